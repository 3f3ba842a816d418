#include "dqn_dovs/sim/worlds.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <sstream>

#include "dqn_dovs/common/random.h"

namespace dqn_dovs::sim {

namespace {

/// An axis-aligned free rectangle of the walkable area and the region it belongs to (a room, a corridor arm).
struct Rect {
  double x0, y0, x1, y1;
  int region;
  double area() const { return (x1 - x0) * (y1 - y0); }
  bool contains(const Vec2& p, double margin) const {
    return p.x() >= x0 + margin && p.x() <= x1 - margin && p.y() >= y0 + margin && p.y() <= y1 - margin;
  }
};

/// The static layout of one world: where one may stand, the walls, the furniture, and the hub every route
/// between two regions passes (a door, a junction's centre).
struct Layout {
  std::vector<Rect> free;
  std::vector<Segment> walls;
  std::vector<std::vector<Vec2>> furniture;  // closed polygons
  Vec2 hub = Vec2::Zero();
  double bound_half = 4.0;  // the square room holding everything
  double arm_m = 0.0;       // corridor: half its length; junction: an arm's length from the centre
  bool tee = false;         // junction: a T (three arms) rather than an L
};

/// Stops lie within this of a corridor's or an arm's end (at most a quarter of the corridor's length).
constexpr double kEndZone_m = 2.0;
/// Doorway stops keep this far from the wall with the door.
constexpr double kDoorwayStopOff_m = 1.0;
/// stopPlace: a room where a stop may be anywhere.
constexpr int kAnywhere = -2;

void addPolyline(std::vector<Segment>& walls, const std::vector<Vec2>& points, bool closed) {
  for (size_t i = 0; i + 1 < points.size(); ++i) walls.push_back({points[i], points[i + 1]});
  if (closed && points.size() > 2) walls.push_back({points.back(), points.front()});
}

bool insidePolygon(const std::vector<Vec2>& poly, const Vec2& p) {
  bool inside = false;
  for (size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++) {
    const Vec2 &a = poly[i], &b = poly[j];
    if ((a.y() > p.y()) != (b.y() > p.y()) && p.x() < (b.x() - a.x()) * (p.y() - a.y()) / (b.y() - a.y()) + a.x())
      inside = !inside;
  }
  return inside;
}

class Builder {
 public:
  Builder(const WorldFamilyConfig& c, uint64_t seed) : c_(c), rng_(seed), seed_(seed) {}

  [[noreturn]] void fail(const std::string& what) const {
    std::ostringstream os;
    os << "world generator '" << worldFamilyName(c_.family) << "' (seed " << seed_ << "): " << what << " after "
       << c_.max_attempts << " attempts";
    throw ScenarioError(os.str());
  }

  int regionOf(const Vec2& p) const {
    for (const Rect& r : layout_.free) {
      if (r.contains(p, 0.0)) return r.region;
    }
    return -1;
  }

  /// True when a disc of radius `margin` at p lies in the walkable area, off every wall and piece of furniture.
  bool free(const Vec2& p, double margin) const {
    if (std::none_of(layout_.free.begin(), layout_.free.end(), [&](const Rect& r) { return r.contains(p, margin); }))
      return false;
    for (const Segment& w : layout_.walls) {
      if (pointSegmentDistance(p, w) < margin) return false;
    }
    for (const auto& poly : layout_.furniture) {
      if (insidePolygon(poly, p)) return false;
    }
    return true;
  }

  /// A free point for a disc of radius `margin`, accepted by `ok`; throws ScenarioError naming `what` after
  /// max_attempts draws.
  template <class Ok>
  Vec2 sample(double margin, Ok ok, const std::string& what) {
    if (const std::optional<Vec2> p = trySample(margin, ok, c_.max_attempts)) return *p;
    fail("no free place for " + what);
  }

  /// The same within `attempts` draws, or nothing.
  template <class Ok>
  std::optional<Vec2> trySample(double margin, Ok ok, int attempts) {
    double total = 0.0;
    for (const Rect& r : layout_.free) total += r.area();
    for (int attempt = 0; attempt < attempts; ++attempt) {
      double pick = rng_.uniform(0.0, total);
      const Rect* rect = &layout_.free.back();
      for (const Rect& r : layout_.free) {
        if (pick < r.area()) {
          rect = &r;
          break;
        }
        pick -= r.area();
      }
      const Vec2 p(rng_.uniform(rect->x0, rect->x1), rng_.uniform(rect->y0, rect->y1));
      if (free(p, margin) && ok(p)) return p;
    }
    return std::nullopt;
  }

  /// The robot's start and goal, each uniform in its own box, clear of walls.
  void startAndGoal(Scenario& s, const Rect& start_box, const Rect& goal_box) {
    auto inBox = [&](const Rect& box, const char* what) {
      for (int attempt = 0; attempt < c_.max_attempts; ++attempt) {
        const Vec2 p(rng_.uniform(box.x0, box.x1), rng_.uniform(box.y0, box.y1));
        if (free(p, c_.room.robot_radius_m + 0.1)) return p;
      }
      fail(std::string("no free place for the robot's ") + what);
    };
    const Vec2 start = inBox(start_box, "start"), goal = inBox(goal_box, "goal");
    s.robot_start = {start.x(), start.y(), std::atan2(goal.y() - start.y(), goal.x() - start.x())};
    s.goal = goal;
  }

  void addFurniture(Scenario& s) {
    const int count = static_cast<int>(rng_.uniformInt(c_.furniture_min, c_.furniture_max));
    const Vec2 start = s.robot_start.position();
    for (int i = 0; i < count; ++i) {
      const double kind = rng_.uniform01();
      if (kind < 0.3) {  // a chair: a small static disc
        const double r = rng_.uniform(0.2, 0.25);
        const Vec2 p = sample(
            r + 0.05,
            [&](const Vec2& q) {
              if ((q - start).norm() < c_.start_goal_clearance_m + r ||
                  (q - s.goal).norm() < c_.start_goal_clearance_m + r)
                return false;
              return std::all_of(s.obstacles.begin(), s.obstacles.end(),
                                 [&](const MovingObstacle& o) { return (o.center - q).norm() > o.radius + r + 0.3; });
            },
            "a chair");
        MovingObstacle o;
        o.center = p;
        o.radius = r;
        o.is_static = true;
        s.obstacles.push_back(o);
        continue;
      }
      // A table (square) or a shelf (long and narrow), turned at random.
      const bool table = kind < 0.7;
      const double w = table ? rng_.uniform(0.6, 1.0) : rng_.uniform(1.2, 1.8);
      const double d = table ? w : rng_.uniform(0.35, 0.45);
      const double yaw = rng_.uniform(-kPi, kPi);
      const double reach = 0.5 * std::hypot(w, d);
      const Vec2 p = sample(
          reach,
          [&](const Vec2& q) {
            if ((q - start).norm() < c_.start_goal_clearance_m + reach ||
                (q - s.goal).norm() < c_.start_goal_clearance_m + reach)
              return false;
            return std::all_of(s.obstacles.begin(), s.obstacles.end(),
                               [&](const MovingObstacle& o) { return (o.center - q).norm() > o.radius + reach + 0.3; });
          },
          table ? "a table" : "a shelf");
      const Pose2 pose{p.x(), p.y(), yaw};
      std::vector<Vec2> poly = {pose.toWorld({-w / 2, -d / 2}), pose.toWorld({w / 2, -d / 2}),
                                pose.toWorld({w / 2, d / 2}), pose.toWorld({-w / 2, d / 2})};
      addPolyline(layout_.walls, poly, true);
      layout_.furniture.push_back(poly);
    }
  }

  /// People with plans: positions clear of the robot, destinations far enough apart, hubs between regions.
  void addPeople(Scenario& s) {
    const Vec2 start = s.robot_start.position();
    for (int i = 0; i < c_.people; ++i) {
      PersonSpec p;
      p.body_radius_m = rng_.uniform(c_.person_radius_min_m, c_.person_radius_max_m);
      p.preferred_speed_mps = rng_.uniform(c_.person_speed_min_mps, c_.person_speed_max_mps);
      p.wait_s = rng_.uniform(0.0, c_.wait_max_s);
      const bool join = !s.people.empty() && rng_.uniform01() < c_.group_probability;
      const PersonSpec* leader = join ? &s.people.back() : nullptr;
      const double r = p.body_radius_m;
      auto clear = [&](const Vec2& q) {
        if ((q - start).norm() < c_.start_goal_clearance_m + 0.5 + r) return false;
        // A group member stands near its leader and can walk straight to the leader's first stop.
        if (leader != nullptr && ((q - leader->position).norm() > 1.2 || !reachable(q, leader->destinations.front())))
          return false;
        for (const PersonSpec& o : s.people) {
          if ((o.position - q).norm() < o.body_radius_m + r + 0.1) return false;
        }
        return std::all_of(s.obstacles.begin(), s.obstacles.end(),
                           [&](const MovingObstacle& o) { return (o.center - q).norm() > o.radius + r + 0.1; });
      };
      // A group member that finds no place beside its leader walks alone. A person placed where furniture boxes
      // it in (no stop reachable in a straight line) is placed again.
      constexpr int kPlacements = 20;
      for (int placement = 0;; ++placement) {
        std::optional<Vec2> place = trySample(r + 0.1, clear, c_.max_attempts);
        if (!place && leader != nullptr) {
          leader = nullptr;
          place = trySample(r + 0.1, clear, c_.max_attempts);
        }
        if (!place) fail("no free place for person " + std::to_string(i));
        p.position = *place;
        if (leader != nullptr) {
          p.group = leader->group >= 0 ? leader->group : static_cast<int>(s.people.size()) - 1;
          s.people.back().group = p.group;
          p.preferred_speed_mps = leader->preferred_speed_mps;
          p.destinations = leader->destinations;
          p.pass_through = leader->pass_through;
          p.wait_s = leader->wait_s;
          break;
        }
        const std::vector<Vec2> stops = reachableStops(p.position, r);
        if (!stops.empty()) {
          route(p.position, stops, p);
          break;
        }
        if (placement + 1 == kPlacements) {
          fail("no destination reachable from person " + std::to_string(i) + " in " + std::to_string(kPlacements) +
               " placements");
        }
      }
      const Vec2 first = p.destinations.front() - p.position;
      p.heading_rad = std::atan2(first.y(), first.x());
      s.people.push_back(p);
    }
  }

  /// Where the family puts its stops (natural destinations): the corridor's end (0 west, 1 east) or the junction's
  /// arm end (0 west, 1 east, 2 north) a point lies in, within kEndZone_m of it; the doorway's room (0 west, 1 east),
  /// kDoorwayStopOff_m off the wall with the door; -1 where no stop goes; kAnywhere in the crowd and clutter rooms.
  /// Consecutive stops lie in different places, so people walk a corridor's length, from arm to arm and through the
  /// door.
  int stopPlace(const Vec2& q) const {
    const double zone = std::min(kEndZone_m, 0.5 * layout_.arm_m);
    switch (c_.family) {
      case WorldFamily::kCorridor:
        return q.x() <= -layout_.arm_m + zone ? 0 : q.x() >= layout_.arm_m - zone ? 1 : -1;
      case WorldFamily::kJunction:
        if (q.x() <= -layout_.arm_m + zone) return 0;
        if (layout_.tee && q.x() >= layout_.arm_m - zone) return 1;
        return q.y() >= layout_.arm_m - zone ? 2 : -1;
      case WorldFamily::kDoorway:
        return std::abs(q.x()) < kDoorwayStopOff_m ? -1 : q.x() < 0.0 ? 0 : 1;
      default:
        return kAnywhere;
    }
  }

  /// Whether q may follow `last` as a stop (stopPlace).
  bool stopMayFollow(const Vec2& last, const Vec2& q) const {
    const int place = stopPlace(q);
    return place == kAnywhere || (place >= 0 && place != stopPlace(last));
  }

  /// Up to four stops for a person of radius r at `from`: far enough, where the family puts them (stopPlace), and
  /// reachable in a straight line (through the hub between regions); the last stop also leads back to the first.
  /// Where furniture leaves no such place, half the distance will do; empty when none is reachable (the person is
  /// boxed in).
  std::vector<Vec2> reachableStops(const Vec2& from, double r) {
    std::vector<Vec2> stops;
    Vec2 last = from;
    for (int k = 0; k < 4; ++k) {
      auto stop = [&](double min_distance) {
        return trySample(
            r + 0.15,
            [&](const Vec2& q) {
              return (q - last).norm() >= min_distance && stopMayFollow(last, q) && reachable(last, q) &&
                     (k < 3 || (reachable(q, stops.front()) && stopMayFollow(q, stops.front())));
            },
            c_.max_attempts);
      };
      std::optional<Vec2> q = stop(c_.destination_min_distance_m);
      if (!q) q = stop(0.5 * c_.destination_min_distance_m);
      if (!q) break;
      last = *q;
      stops.push_back(last);
    }
    while (stops.size() > 1 &&
           (!reachable(stops.back(), stops.front()) || !stopMayFollow(stops.back(), stops.front()))) {
      stops.pop_back();
    }
    return stops;
  }

  /// True when the straight walk from a to b (through the hub when they lie in different regions) crosses no wall.
  bool reachable(const Vec2& a, const Vec2& b) const {
    auto clear = [&](const Vec2& p, const Vec2& q) {
      return std::none_of(layout_.walls.begin(), layout_.walls.end(),
                          [&](const Segment& w) { return segmentsCross(p, q, w); });
    };
    if (regionOf(a) == regionOf(b)) return clear(a, b);
    return clear(a, layout_.hub) && clear(layout_.hub, b);
  }

  /// The person's destinations: the stops with the hub inserted, as a waypoint passed on the way, wherever
  /// consecutive stops (cyclically, and from `from`) change region.
  void route(const Vec2& from, const std::vector<Vec2>& stops, PersonSpec& person) const {
    person.destinations.clear();
    person.pass_through.clear();
    auto add = [&](const Vec2& q, bool hub) {
      person.destinations.push_back(q);
      person.pass_through.push_back(hub);
    };
    int region = regionOf(from);
    for (const Vec2& q : stops) {
      const int next = regionOf(q);
      if (next != region) add(layout_.hub, true);
      add(q, false);
      region = next;
    }
    if (regionOf(stops.front()) != region) add(layout_.hub, true);
    if (std::none_of(person.pass_through.begin(), person.pass_through.end(), [](bool hub) { return hub; })) {
      person.pass_through.clear();  // one room: no waypoints
    }
  }

  Scenario build() {
    Scenario s;
    s.name = std::string(worldFamilyName(c_.family)) + "/seed=" + std::to_string(seed_);
    const double W = rng_.uniform(c_.corridor_width_min_m, c_.corridor_width_max_m);
    const double L = c_.corridor_length_m;
    switch (c_.family) {
      case WorldFamily::kRoom:
        break;  // handled by generateWorld
      case WorldFamily::kCrowd:
      case WorldFamily::kClutter: {
        const double h = c_.room.room_half_size_m;
        layout_.bound_half = h;
        layout_.free = {{-h, -h, h, h, 0}};
        startAndGoal(s, {-h + 0.5, -h + 1.0, -h + 0.9, h - 1.0, 0}, {h - 0.9, -h + 1.0, h - 0.5, h - 1.0, 0});
        if (c_.family == WorldFamily::kClutter) addFurniture(s);
        break;
      }
      case WorldFamily::kCorridor: {
        layout_.bound_half = L / 2 + 0.5;
        layout_.arm_m = L / 2;
        layout_.free = {{-L / 2, -W / 2, L / 2, W / 2, 0}};
        addPolyline(layout_.walls, {{-L / 2, -W / 2}, {L / 2, -W / 2}, {L / 2, W / 2}, {-L / 2, W / 2}}, true);
        startAndGoal(s, {-L / 2 + 0.5, -W / 2 + 0.5, -L / 2 + 0.9, W / 2 - 0.5, 0},
                     {L / 2 - 0.9, -W / 2 + 0.5, L / 2 - 0.5, W / 2 - 0.5, 0});
        break;
      }
      case WorldFamily::kDoorway: {
        const double door = rng_.uniform(c_.door_width_min_m, c_.door_width_max_m);
        const double door_y = rng_.uniform(-1.5, 1.5);
        layout_.bound_half = 6.5;
        layout_.free = {{-6, -3, 0, 3, 0}, {0, -3, 6, 3, 1}};
        addPolyline(layout_.walls, {{-6, -3}, {6, -3}, {6, 3}, {-6, 3}}, true);
        layout_.walls.push_back({Vec2(0, -3), Vec2(0, door_y - door / 2)});
        layout_.walls.push_back({Vec2(0, door_y + door / 2), Vec2(0, 3)});
        layout_.hub = Vec2(0.0, door_y);
        s.doors.push_back(Door{Vec2(0.0, door_y), Vec2(1.0, 0.0), door});
        startAndGoal(s, {-5.4, -2.4, -3.0, 2.4, 0}, {3.0, -2.4, 5.4, 2.4, 1});
        break;
      }
      case WorldFamily::kJunction: {
        const double a = L / 2;  // arm length from the centre
        const bool tee = rng_.uniform01() < 0.5;
        const double right = tee ? a : W / 2;
        layout_.bound_half = a + 0.5;
        layout_.arm_m = a;
        layout_.tee = tee;
        layout_.free = {{-a, -W / 2, right, W / 2, 0}, {-W / 2, W / 2, W / 2, a, 1}};
        // Outline counter-clockwise: bottom wall, right end, the top wall up the branch and back, left end.
        addPolyline(layout_.walls,
                    {{-a, -W / 2},
                     {right, -W / 2},
                     {right, W / 2},
                     {W / 2, W / 2},
                     {W / 2, a},
                     {-W / 2, a},
                     {-W / 2, W / 2},
                     {-a, W / 2}},
                    true);
        layout_.hub = Vec2::Zero();
        startAndGoal(s, {-a + 0.5, -W / 2 + 0.5, -a + 0.9, W / 2 - 0.5, 0},
                     {-W / 2 + 0.5, a - 0.9, W / 2 - 0.5, a - 0.5, 1});
        break;
      }
    }
    // Keep to a side where there are ways between walls and doors (corridors, junction arms, the doorway's door);
    // the open rooms have no lanes to keep.
    if (c_.family == WorldFamily::kCorridor || c_.family == WorldFamily::kDoorway ||
        c_.family == WorldFamily::kJunction) {
      s.traffic = {c_.traffic_side, c_.traffic_strength};
    }
    addPeople(s);
    s.room_half_size_m = layout_.bound_half;
    // The square room is the building's outer boundary; the walls inside it (the family's own, furniture) are
    // static segments. The crowd and clutter rooms are that square itself.
    s.static_segments = layout_.walls;
    return s;
  }

 private:
  const WorldFamilyConfig& c_;
  Rng rng_;
  uint64_t seed_;
  Layout layout_;
};

}  // namespace

const char* worldFamilyName(WorldFamily family) {
  switch (family) {
    case WorldFamily::kRoom:
      return "room";
    case WorldFamily::kCrowd:
      return "crowd";
    case WorldFamily::kCorridor:
      return "corridor";
    case WorldFamily::kDoorway:
      return "doorway";
    case WorldFamily::kClutter:
      return "clutter";
    case WorldFamily::kJunction:
      return "junction";
  }
  return "?";
}

std::vector<std::string> worldFamilyNames() { return {"room", "crowd", "corridor", "doorway", "clutter", "junction"}; }

WorldFamily parseWorldFamily(const std::string& name) {
  for (WorldFamily f : {WorldFamily::kRoom, WorldFamily::kCrowd, WorldFamily::kCorridor, WorldFamily::kDoorway,
                        WorldFamily::kClutter, WorldFamily::kJunction}) {
    if (name == worldFamilyName(f)) return f;
  }
  std::string known;
  for (const std::string& n : worldFamilyNames()) known += (known.empty() ? "" : ", ") + n;
  throw SimConfigError("world family '" + name + "' is not one of " + known);
}

std::string WorldFamilyConfig::validate() const {
  std::ostringstream os;
  auto range = [&](const char* name, double lo, double hi, double min_allowed) {
    if (!os.str().empty()) return;
    if (!(std::isfinite(lo) && std::isfinite(hi) && lo >= min_allowed && hi >= lo)) {
      os << "world parameters '" << name << "' [" << lo << ", " << hi << "]: need " << min_allowed
         << " <= min <= max, finite";
    }
  };
  if (people < 0 || people > 200) os << "world parameter 'people' = " << people << ": must be in [0, 200]";
  range("person_radius", person_radius_min_m, person_radius_max_m, 0.05);
  range("person_speed", person_speed_min_mps, person_speed_max_mps, 0.05);
  range("corridor_width", corridor_width_min_m, corridor_width_max_m, 1.0);
  range("door_width", door_width_min_m, door_width_max_m, 0.6);
  range("furniture", furniture_min, furniture_max, 0.0);
  range("wait", 0.0, wait_max_s, 0.0);
  range("destination_min_distance", destination_min_distance_m, destination_min_distance_m, 0.0);
  range("start_goal_clearance", start_goal_clearance_m, start_goal_clearance_m, 0.0);
  if (os.str().empty() && !(corridor_length_m >= 4.0 && corridor_length_m <= 100.0)) {
    os << "world parameter 'corridor_length_m' = " << corridor_length_m << ": must be in [4, 100]";
  }
  if (os.str().empty() && !(group_probability >= 0.0 && group_probability <= 1.0)) {
    os << "world parameter 'group_probability' = " << group_probability << ": must be in [0, 1]";
  }
  if (os.str().empty() && max_attempts < 1) os << "world parameter 'max_attempts' must be >= 1";
  if (os.str().empty()) {
    const std::string e = TrafficRule{traffic_side, traffic_strength}.validate();
    if (!e.empty()) os << "world parameter 'traffic': " << e;
  }
  if (os.str().empty()) {
    const std::string e = room.validate();
    if (!e.empty()) os << "world parameter 'room': " << e;
  }
  return os.str();
}

Scenario generateWorld(const WorldFamilyConfig& config, uint64_t seed) {
  if (const std::string e = config.validate(); !e.empty()) throw SimConfigError(e);
  if (config.family == WorldFamily::kRoom) {
    GeneratorConfig g = config.room;
    g.obstacle_count_min = g.obstacle_count_max = config.people;
    Scenario s = generateScenario(g, seed);
    s.name = "room/seed=" + std::to_string(seed);
    return s;
  }
  return Builder(config, seed).build();
}

}  // namespace dqn_dovs::sim
