#include "dqn_dovs/sim/people.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <sstream>

#include "dqn_dovs/common/orca_lp.h"
#include "dqn_dovs/common/random.h"
#include "dqn_dovs/sim/errors.h"

namespace dqn_dovs::sim {

namespace {

bool finitePositive(double x) { return std::isfinite(x) && x > 0.0; }

/// Step length (m) of a person walking at `speed` (m/s): longer strides when faster.
double stepLength(double speed) { return 0.3 + 0.3 * std::min(speed, 1.5); }

/// How much closer to its destination a person must come to count as making progress (PeopleConfig::stall_time_s).
constexpr double kProgressStep_m = 0.1;

/// True when a body of `radius` walking straight from a to b keeps clear of every wall.
bool straightWalkIsClear(const Vec2& a, const Vec2& b, double radius, const std::vector<Segment>& walls) {
  const Segment path{a, b};
  return std::none_of(walls.begin(), walls.end(),
                      [&](const Segment& w) { return segmentSegmentDistance(path, w) < radius; });
}

/// Whether destination k of a person is a waypoint (PersonSpec::pass_through).
bool isWaypoint(const PersonSpec& spec, size_t k) { return !spec.pass_through.empty() && spec.pass_through[k]; }

/// Distance along the ray from `from` in the unit direction `dir` to the first wall, or `reach` when none is nearer.
double rayToWalls(const Vec2& from, const Vec2& dir, double reach, const std::vector<Segment>& walls) {
  double best = reach;
  for (const Segment& w : walls) {
    if (const std::optional<double> t = raySegment(from, dir, w)) best = std::min(best, *t);
  }
  return best;
}

/// A person counts as in a door when its centre is within its radius plus this of the door's wall (and beside the
/// opening): it holds the door until it is out of this band on the other side.
constexpr double kDoorBand_m = 0.3;

}  // namespace

const char* trafficSideName(TrafficSide side) {
  switch (side) {
    case TrafficSide::kNone:
      return "none";
    case TrafficSide::kRight:
      return "right";
    case TrafficSide::kLeft:
      return "left";
  }
  return "?";
}

TrafficSide parseTrafficSide(const std::string& name) {
  for (TrafficSide s : {TrafficSide::kNone, TrafficSide::kRight, TrafficSide::kLeft}) {
    if (name == trafficSideName(s)) return s;
  }
  throw SimConfigError("traffic side '" + name + "' is not one of none, right, left");
}

std::string TrafficRule::validate() const {
  if (side != TrafficSide::kNone && side != TrafficSide::kRight && side != TrafficSide::kLeft) {
    return "traffic rule: unknown side";
  }
  if (!(std::isfinite(strength) && strength >= 0.0 && strength <= 1.0)) {
    std::ostringstream os;
    os << "traffic rule strength " << strength << ": must be in [0, 1]";
    return os.str();
  }
  return "";
}

std::string Door::validate() const {
  std::ostringstream os;
  if (!(center.allFinite() && across.allFinite() && std::abs(across.norm() - 1.0) < 1e-6 && std::isfinite(width_m) &&
        width_m > 0.0)) {
    os << "door at (" << center.x() << ", " << center.y() << "): needs a finite centre, a unit direction across ("
       << across.x() << ", " << across.y() << ") and a width > 0 (" << width_m << ")";
  }
  return os.str();
}

const char* personBehaviorName(PersonBehavior behavior) {
  switch (behavior) {
    case PersonBehavior::kOblivious:
      return "oblivious";
    case PersonBehavior::kImpassive:
      return "impassive";
    case PersonBehavior::kAttentive:
      return "attentive";
  }
  return "?";
}

PeopleMix PeopleMix::parse(const std::string& text) {
  if (text == "headline") return headline();
  PeopleMix m{0.0, 0.0, 0.0};
  bool seen[3] = {false, false, false};
  std::stringstream ss(text);
  std::string item;
  int entries = 0;
  while (std::getline(ss, item, ',')) {
    const size_t eq = item.find('=');
    if (eq == std::string::npos) {
      throw SimConfigError("people mix '" + text + "': '" + item +
                           "' is not BEHAVIOUR=SHARE (or the preset 'headline')");
    }
    const std::string name = item.substr(0, eq), value = item.substr(eq + 1);
    double share = 0.0;
    size_t used = 0;
    try {
      share = std::stod(value, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != value.size() || value.empty() || !std::isfinite(share) || share < 0.0) {
      throw SimConfigError("people mix '" + text + "': the share of '" + name + "' must be a number >= 0, got '" +
                           value + "'");
    }
    int k = -1;
    for (int b = 0; b < 3; ++b) {
      if (name == personBehaviorName(static_cast<PersonBehavior>(b))) k = b;
    }
    if (k < 0) {
      throw SimConfigError("people mix '" + text + "': '" + name + "' is not one of oblivious, impassive, attentive");
    }
    if (seen[k]) throw SimConfigError("people mix '" + text + "': '" + name + "' is given twice");
    seen[k] = true;
    (k == 0 ? m.oblivious : k == 1 ? m.impassive : m.attentive) = share;
    ++entries;
  }
  if (entries == 0) throw SimConfigError("people mix '" + text + "' is empty (e.g. attentive=0.6,oblivious=0.4)");
  const double total = m.attentive + m.impassive + m.oblivious;
  if (!(total > 0.0)) throw SimConfigError("people mix '" + text + "': every share is 0");
  m.attentive /= total;
  m.impassive /= total;
  m.oblivious /= total;
  return m;
}

std::string PeopleMix::str() const {
  std::ostringstream os;
  const double total = attentive + impassive + oblivious;
  for (const auto& [name, share] :
       {std::pair<const char*, double>{"attentive", attentive}, {"impassive", impassive}, {"oblivious", oblivious}}) {
    if (share <= 0.0) continue;
    os << (os.str().empty() ? "" : ",") << name << "=" << share / total;
  }
  return os.str();
}

std::string PeopleMix::validate() const {
  for (const auto& [name, share] :
       {std::pair<const char*, double>{"attentive", attentive}, {"impassive", impassive}, {"oblivious", oblivious}}) {
    if (!(std::isfinite(share) && share >= 0.0)) {
      std::ostringstream os;
      os << "people mix share '" << name << "' = " << share << ": must be finite and >= 0";
      return os.str();
    }
  }
  if (!(attentive + impassive + oblivious > 0.0)) return "people mix: every share is 0";
  return {};
}

PersonBehavior PeopleMix::pick(double u) const {
  const double total = attentive + impassive + oblivious;
  if (u * total < attentive) return PersonBehavior::kAttentive;
  if (u * total < attentive + impassive) return PersonBehavior::kImpassive;
  return PersonBehavior::kOblivious;
}

const char* peopleModelName(PeopleModel model) {
  switch (model) {
    case PeopleModel::kConstant:
      return "constant";
    case PeopleModel::kSocialForce:
      return "social_force";
    case PeopleModel::kOrca:
      return "orca";
  }
  return "?";
}

std::vector<std::string> peopleModelNames() { return {"social_force", "orca", "constant"}; }

PeopleModel parsePeopleModel(const std::string& name) {
  for (PeopleModel m : {PeopleModel::kSocialForce, PeopleModel::kOrca, PeopleModel::kConstant}) {
    if (name == peopleModelName(m)) return m;
  }
  throw SimConfigError("people model '" + name + "' is not one of social_force, orca, constant");
}

std::string PeopleConfig::validate() const {
  std::ostringstream os;
  auto positive = [&](const char* name, double v) {
    if (!finitePositive(v) && os.str().empty()) os << "people parameter '" << name << "' = " << v << ": must be > 0";
  };
  positive("relaxation_time_s", relaxation_time_s);
  positive("person_range_m", person_range_m);
  positive("step_time_s", step_time_s);
  positive("wall_range_m", wall_range_m);
  positive("max_speed_factor", max_speed_factor);
  positive("arrival_radius_m", arrival_radius_m);
  positive("stall_time_s", stall_time_s);
  positive("stall_radius_m", stall_radius_m);
  positive("give_way_s", give_way_s);
  positive("leg_radius_m", leg_radius_m);
  positive("physics_step_s", physics_step_s);
  positive("orca_time_horizon_s", orca_time_horizon_s);
  positive("orca_wall_horizon_s", orca_wall_horizon_s);
  positive("orca_neighbor_dist_m", orca_neighbor_dist_m);
  positive("hip_height_m", hip_height_m);
  if (!os.str().empty()) return os.str();
  for (const auto& [name, v] : {std::pair<const char*, double>{"person_repulsion_mps2", person_repulsion_mps2},
                                {"wall_repulsion_mps2", wall_repulsion_mps2},
                                {"group_attraction_mps2", group_attraction_mps2},
                                {"group_radius_m", group_radius_m},
                                {"hip_half_width_m", hip_half_width_m},
                                {"scan_height_m", scan_height_m}}) {
    if (!(std::isfinite(v) && v >= 0.0)) {
      os << "people parameter '" << name << "' = " << v << ": must be finite and >= 0";
      return os.str();
    }
  }
  if (!(std::isfinite(anisotropy) && anisotropy >= 0.0 && anisotropy <= 1.0)) {
    os << "people parameter 'anisotropy' = " << anisotropy << ": must be in [0, 1]";
    return os.str();
  }
  if (const std::string e = mix.validate(); !e.empty()) return e;
  if (!(std::isfinite(notice_fov_rad) && notice_fov_rad > 0.0 && notice_fov_rad <= 2.0 * 3.141592653589793 + 1e-12)) {
    os << "people parameter 'notice_fov_rad' = " << notice_fov_rad << ": must be in (0, 2 pi]";
  } else if (!(std::isfinite(notice_range_m) && notice_range_m >= 0.0)) {
    os << "people parameter 'notice_range_m' = " << notice_range_m << ": must be finite and >= 0";
  } else if (!(std::isfinite(reaction_min_s) && reaction_min_s >= 0.0 && std::isfinite(reaction_max_s) &&
               reaction_max_s >= reaction_min_s)) {
    os << "people parameters 'reaction_min_s' = " << reaction_min_s << ", 'reaction_max_s' = " << reaction_max_s
       << ": must be finite with 0 <= min <= max";
  } else if (!(std::isfinite(yield_strength_min) && yield_strength_min >= 0.0 && std::isfinite(yield_strength_max) &&
               yield_strength_max >= yield_strength_min)) {
    os << "people parameters 'yield_strength_min' = " << yield_strength_min
       << ", 'yield_strength_max' = " << yield_strength_max << ": must be finite with 0 <= min <= max";
  }
  return os.str();
}

Crowd::Crowd(const std::vector<PersonSpec>& people, const PeopleConfig& config, uint64_t seed, const TrafficRule& rule,
             const std::vector<Door>& doors)
    : config_(config), rule_(rule), doors_(doors), door_state_(doors.size()) {
  if (const std::string e = config_.validate(); !e.empty()) throw SimConfigError(e);
  if (const std::string e = rule_.validate(); !e.empty()) throw SimConfigError(e);
  for (const Door& d : doors_) {
    if (const std::string e = d.validate(); !e.empty()) throw SimConfigError(e);
  }
  // The behaviours' own stream: three draws per person, whatever it draws, so that person i's draws depend only on
  // the seed and i.
  constexpr uint64_t kBehaviorStreamTag = 0xBE4A71C0DE5ULL;
  Rng rng(seed ^ kBehaviorStreamTag);
  const PeopleMix mix = config_.effectiveMix();
  for (size_t i = 0; i < people.size(); ++i) {
    const PersonSpec& s = people[i];
    bool ok = s.position.allFinite() && std::isfinite(s.heading_rad) && finitePositive(s.body_radius_m) &&
              finitePositive(s.preferred_speed_mps) && std::isfinite(s.wait_s) && s.wait_s >= 0.0;
    for (const Vec2& d : s.destinations) ok = ok && d.allFinite();
    if (!ok) {
      throw SimConfigError("person " + std::to_string(i) +
                           ": position, heading, destinations and wait must be finite, radius and speed > 0");
    }
    if (!s.pass_through.empty() && s.pass_through.size() != s.destinations.size()) {
      throw SimConfigError("person " + std::to_string(i) + ": " + std::to_string(s.pass_through.size()) +
                           " pass-through flags for " + std::to_string(s.destinations.size()) + " destinations");
    }
    Person p;
    p.spec = s;
    p.position = s.position;
    p.heading_rad = s.heading_rad;
    if (config_.model == PeopleModel::kConstant || s.destinations.empty()) {
      p.velocity = s.preferred_speed_mps * Vec2(std::cos(s.heading_rad), std::sin(s.heading_rad));
    }
    const double u = rng.uniform01(), reaction = rng.uniform01(), strength = rng.uniform01();
    p.behavior = mix.pick(u);
    p.reaction_s = config_.reaction_min_s + reaction * (config_.reaction_max_s - config_.reaction_min_s);
    p.yield_strength =
        config_.yield_strength_min + strength * (config_.yield_strength_max - config_.yield_strength_min);
    people_.push_back(p);
  }
}

Vec2 Crowd::drive(const Person& p, const std::vector<Segment>& walls) const {
  if (p.waiting_s > 0.0) return Vec2::Zero();
  if (p.spec.destinations.empty()) {
    return p.spec.preferred_speed_mps * Vec2(std::cos(p.spec.heading_rad), std::sin(p.spec.heading_rad));
  }
  const Vec2 to = (p.door_waiting ? p.door_spot : p.spec.destinations[p.destination]) - p.position;
  const double dist = to.norm();
  if (dist < 1e-9) return Vec2::Zero();
  // Slow down over the last half metre so a person stops on the destination instead of overshooting it.
  const Vec2 v = std::min(p.spec.preferred_speed_mps, 2.0 * dist) * to / dist;
  return rule_.active() && !p.door_waiting ? keepToSide(p, v, dist, walls) : v;
}

Vec2 Crowd::keepToSide(const Person& p, const Vec2& v, double dist, const std::vector<Segment>& walls) const {
  const double speed = v.norm();
  if (speed < 1e-9) return v;
  const Vec2 e = v / speed;
  const Vec2 side = rule_.side == TrafficSide::kRight ? Vec2(e.y(), -e.x()) : Vec2(-e.y(), e.x());
  constexpr double reach = TrafficRule::kLaneReach_m;
  const double to_side = rayToWalls(p.position, side, reach, walls);
  if (to_side >= reach) return v;  // no wall on that side: not in a way
  const double to_other = rayToWalls(p.position, -side, reach, walls);
  if (to_other >= reach) return v;
  const double width = to_side + to_other;
  const double lane = std::min(0.5 * width, std::max(p.spec.body_radius_m + 0.15, TrafficRule::kLaneFraction * width));
  // Toward the lane (1 rad of heading per metre off it, at most about 27 deg), fading over the last 1.5 m to the
  // destination. The lane keeps clear of the wall, so the rule never pushes anyone into it.
  const double fade = std::min(1.0, dist / 1.5);
  const double lateral = rule_.strength * fade * std::clamp(to_side - lane, -0.5, 0.5);
  return speed * (e + lateral * side).normalized();
}

void Crowd::updateDoors(double dt, const std::vector<Segment>& walls) {
  for (Person& p : people_) p.door_waiting = false;
  if (doors_.empty() || config_.model == PeopleModel::kConstant) return;
  const size_t count = people_.size();
  std::vector<bool> bound(count, false);
  for (size_t k = 0; k < doors_.size(); ++k) {
    const Door& door = doors_[k];
    DoorState& state = door_state_[k];
    const double half = 0.5 * door.width_m;
    const Vec2 along_door(-door.across.y(), door.across.x());
    auto across = [&](const Vec2& q) { return (q - door.center).dot(door.across); };
    auto sideOf = [](double a) { return a < 0.0 ? -1 : 1; };
    auto inDoor = [&](const Person& p) {
      return std::abs(across(p.position)) < p.spec.body_radius_m + kDoorBand_m &&
             std::abs((p.position - door.center).dot(along_door)) < half + p.spec.body_radius_m;
    };
    // The side (+-1) a person crosses this door from now, 0 when it is not walking through it: its next
    // destination is a waypoint at the door's centre, or its last one was and it is still on the near side.
    auto crossing = [&](const Person& p) -> int {
      const PersonSpec& s = p.spec;
      if (s.destinations.empty() || p.waiting_s > 0.0) return 0;
      if ((p.position - door.center).norm() > Door::kApproach_m) return 0;
      const size_t n = s.destinations.size(), now = p.destination, before = (now + n - 1) % n;
      auto atDoor = [&](size_t j) { return isWaypoint(s, j) && (s.destinations[j] - door.center).norm() < half; };
      Vec2 beyond;
      if (atDoor(now)) {
        beyond = s.destinations[(now + 1) % n];
      } else if (atDoor(before)) {
        beyond = s.destinations[now];
      } else {
        return 0;
      }
      const int from = sideOf(across(p.position)), to = sideOf(across(beyond));
      return from == to ? 0 : from;
    };
    std::vector<int> from(count, 0);
    for (size_t i = 0; i < count; ++i) {
      from[i] = crossing(people_[i]);
      if (from[i] != 0) bound[i] = true;
    }
    // Nearest first, the time waited counting as nearness.
    auto key = [&](size_t i) {
      return (people_[i].position - door.center).norm() - Door::kPatience_mps * people_[i].door_waited_s;
    };
    if (state.holder >= 0) {
      const Person& h = people_[static_cast<size_t>(state.holder)];
      state.held_s += dt;
      if ((from[static_cast<size_t>(state.holder)] == 0 && !inDoor(h)) || state.held_s > Door::kHold_s) {
        state.holder = -1;
      }
    }
    if (state.holder < 0) {
      int best = -1;
      bool best_inside = false;
      for (size_t i = 0; i < count; ++i) {
        if (from[i] == 0) continue;
        const bool inside = inDoor(people_[i]);
        if (best < 0 || (inside && !best_inside) ||
            (inside == best_inside && key(i) < key(static_cast<size_t>(best)))) {
          best = static_cast<int>(i);
          best_inside = inside;
        }
      }
      if (best >= 0) {
        state.holder = best;
        state.from_side = from[static_cast<size_t>(best)];
        state.held_s = 0.0;
        people_[static_cast<size_t>(best)].door_waited_s = 0.0;
      }
    }
    if (state.holder < 0) continue;
    const int group = people_[static_cast<size_t>(state.holder)].spec.group;
    // The others wait, each side in a queue by the same order, beside the door.
    std::vector<size_t> waiting;
    for (size_t i = 0; i < count; ++i) {
      if (from[i] == 0 || static_cast<int>(i) == state.holder) continue;
      if (group >= 0 && people_[i].spec.group == group && from[i] == state.from_side) continue;  // goes with it
      waiting.push_back(i);
    }
    std::stable_sort(waiting.begin(), waiting.end(), [&](size_t a, size_t b) { return key(a) < key(b); });
    int rank[2] = {0, 0};
    for (size_t i : waiting) {
      Person& p = people_[i];
      const int s = from[i];
      const double r = p.spec.body_radius_m;
      const Vec2 facing = -static_cast<double>(s) * door.across;
      const Vec2 right(facing.y(), -facing.x());
      const Vec2 beside = rule_.side == TrafficSide::kLeft ? Vec2(-right) : right;
      const Vec2 back = static_cast<double>(s) * (r + 0.6 + 0.6 * rank[s > 0]) * door.across;
      ++rank[s > 0];
      Vec2 spot = door.center + back + (r + 1.0) * static_cast<double>(s) * door.across;  // on the line, farther
      const Vec2 sides[2] = {beside, -beside};
      for (const Vec2& dir : sides) {
        const Vec2 q = door.center + back + (half + r + 0.25) * dir;
        if (std::all_of(walls.begin(), walls.end(),
                        [&](const Segment& w) { return pointSegmentDistance(q, w) >= r + 0.1; })) {
          spot = q;
          break;
        }
      }
      p.door_waiting = true;
      p.door_spot = spot;
      p.door_waited_s += dt;
    }
  }
  for (size_t i = 0; i < count; ++i) {
    if (!bound[i]) people_[i].door_waited_s = 0.0;
  }
}

void Crowd::step(double dt_s, const std::vector<Segment>& walls, const Circle& robot, const Vec2& robot_velocity) {
  if (!(std::isfinite(dt_s) && dt_s >= 0.0)) throw SimConfigError("Crowd::step: dt_s must be finite and >= 0");
  const int n = std::max(1, static_cast<int>(std::ceil(dt_s / config_.physics_step_s - 1e-9)));
  for (int k = 0; k < n && dt_s > 0.0; ++k) substep(dt_s / n, walls, robot, robot_velocity);
}

void Crowd::notice(double dt, const Circle& robot) {
  for (Person& p : people_) {
    if (p.behavior != PersonBehavior::kAttentive) continue;
    const Vec2 to = robot.center - p.position;
    const double gap = to.norm() - p.spec.body_radius_m - robot.radius;
    if (gap > config_.notice_range_m) {  // out of range: forgotten
      p.noticed = false;
      p.seen_s = 0.0;
      continue;
    }
    if (p.noticed) continue;
    const Vec2 heading(std::cos(p.heading_rad), std::sin(p.heading_rad));
    const double n = to.norm();
    const bool in_view = n < 1e-9 || heading.dot(to / n) >= std::cos(0.5 * config_.notice_fov_rad) - 1e-12;
    p.seen_s = in_view ? p.seen_s + dt : 0.0;
    if (in_view && p.seen_s >= p.reaction_s - 1e-12) p.noticed = true;
  }
}

void Crowd::substep(double dt, const std::vector<Segment>& walls, const Circle& robot, const Vec2& robot_velocity) {
  const size_t count = people_.size();
  notice(dt, robot);
  updateDoors(dt, walls);
  std::vector<Vec2> velocity(count);
  // Group centroids from the states at the start of the step (every person is updated from the same snapshot).
  std::map<int, std::pair<Vec2, int>> groups;
  for (const Person& p : people_) {
    if (p.spec.group < 0) continue;
    auto& g = groups[p.spec.group];
    if (g.second == 0) g.first = Vec2::Zero();
    g.first += p.position;
    ++g.second;
  }
  for (size_t i = 0; i < count; ++i) {
    const Person& p = people_[i];
    if (config_.model == PeopleModel::kConstant) {
      velocity[i] = p.velocity;
      continue;
    }
    if (config_.model == PeopleModel::kOrca) {
      velocity[i] = orcaVelocity(i, dt, walls, robot, robot_velocity);
      continue;
    }
    const Vec2 desired = drive(p, walls);
    Vec2 force = (desired - p.velocity) / config_.relaxation_time_s;
    const Vec2 heading(std::cos(p.heading_rad), std::sin(p.heading_rad));
    // Repulsion from another body (position, radius, velocity): the elliptical potential of Helbing and Molnar,
    // V = A B exp(-(b - R) / B), where b is the semi-minor axis of the ellipse through the person's position with
    // foci at the other's position and where the other will be after step_time_s (so people moving toward each
    // other repel earlier), and R the sum of the radii; the force is -grad V (central differences).
    // Returns the force rather than adding it, so that the robot's can be scaled or turned sideways.
    auto repulsion = [&](const Vec2& other, double other_radius, const Vec2& other_velocity) -> Vec2 {
      const Vec2 step = config_.step_time_s * other_velocity;
      const double s = step.norm(), radii = p.spec.body_radius_m + other_radius;
      auto potential = [&](const Vec2& r) {
        const double a = r.norm() + (r - step).norm();
        const double b = 0.5 * std::sqrt(std::max(0.0, a * a - s * s));
        return config_.person_repulsion_mps2 * config_.person_range_m * std::exp(-(b - radii) / config_.person_range_m);
      };
      const Vec2 r = p.position - other;
      if (r.norm() < 1e-9) return Vec2::Zero();
      constexpr double h = 1e-5;
      const Vec2 f(-(potential(r + Vec2(h, 0)) - potential(r - Vec2(h, 0))) / (2 * h),
                   -(potential(r + Vec2(0, h)) - potential(r - Vec2(0, h))) / (2 * h));
      // Anisotropy: full strength for what lies ahead, lambda for what lies behind.
      const double ahead = -r.normalized().dot(heading);
      const double weight = config_.anisotropy + (1.0 - config_.anisotropy) * 0.5 * (1.0 + ahead);
      return weight * f;
    };
    for (size_t j = 0; j < count; ++j) {
      if (j != i) force += repulsion(people_[j].position, people_[j].spec.body_radius_m, people_[j].velocity);
    }
    if (p.behavior == PersonBehavior::kAttentive && p.noticed) {
      // Gives way as to another person (the robot's motion shapes the ellipse), with its own strength.
      force += p.yield_strength * repulsion(robot.center, robot.radius, robot_velocity);
    } else if (p.behavior == PersonBehavior::kImpassive) {
      // Around the robot as around a still obstacle, and only sideways: the repulsion's whole strength turned
      // across its way, to the side it already is on, so that it steers round and never slows down for it.
      const Vec2 f = repulsion(robot.center, robot.radius, Vec2::Zero());
      const Vec2 along = desired.norm() > 1e-9 ? Vec2(desired.normalized()) : heading;
      const Vec2 left(-along.y(), along.x());
      force += f.norm() * (left.dot(p.position - robot.center) >= 0.0 ? left : Vec2(-left));
    }
    for (const Segment& w : walls) {
      const Vec2 d = p.position - closestPointOnSegment(p.position, w);
      const double dist = d.norm();
      if (dist < 1e-9 || dist > p.spec.body_radius_m + 10.0 * config_.wall_range_m) continue;
      force += config_.wall_repulsion_mps2 * std::exp((p.spec.body_radius_m - dist) / config_.wall_range_m) * d / dist;
    }
    if (p.spec.group >= 0) {
      const auto& g = groups[p.spec.group];
      const Vec2 to = g.first / g.second - p.position;
      const double dist = to.norm();
      if (dist > config_.group_radius_m) {
        force += config_.group_attraction_mps2 * (dist - config_.group_radius_m) * to / dist;
      }
    }
    Vec2 v = p.velocity + dt * force;
    const double limit = config_.max_speed_factor * p.spec.preferred_speed_mps;
    if (v.norm() > limit) v *= limit / v.norm();
    velocity[i] = v;
  }
  for (size_t i = 0; i < count; ++i) {
    Person& p = people_[i];
    Vec2 v = velocity[i];
    Vec2 next = p.position + dt * v;
    // Nobody walks through a wall: a move whose centre would cross one is cancelled, and the velocity keeps only
    // its component along that wall (people slide along walls).
    for (const Segment& w : walls) {
      if (!segmentsCross(p.position, next, w)) continue;
      const Vec2 along = (w.b - w.a).normalized();
      v = v.dot(along) * along;
      next = p.position;
    }
    const double speed = v.norm();
    p.gait_phase_rad = std::fmod(p.gait_phase_rad + kPi * speed * dt / stepLength(speed), kTwoPi);
    p.position = next;
    p.velocity = v;
    if (speed > 0.05) p.heading_rad = std::atan2(v.y(), v.x());
    // Destinations and waits.
    if (p.waiting_s > 0.0) {
      p.waiting_s = std::max(0.0, p.waiting_s - dt);
    } else if (!p.spec.destinations.empty()) {
      const size_t n = p.spec.destinations.size(), following = (p.destination + 1) % n;
      const double distance = (p.spec.destinations[p.destination] - p.position).norm();
      const bool via = isWaypoint(p.spec, p.destination);
      if (p.door_waiting) {  // waiting for a door is not being stalled
        p.closest_m = std::numeric_limits<double>::infinity();
        p.stalled_s = 0.0;
      }
      if (distance < p.closest_m - kProgressStep_m) {
        p.closest_m = distance;
        p.stalled_s = 0.0;
      } else {
        p.stalled_s += dt;
      }
      bool reached =
          distance < config_.arrival_radius_m ||
          (via && straightWalkIsClear(p.position, p.spec.destinations[following], p.spec.body_radius_m, walls));
      bool give_way = false;
      if (!reached && p.stalled_s >= config_.stall_time_s) {
        // Stalled: near a stop, near enough will do (someone stands on it); anywhere else (two people meeting in a
        // door or a narrow corridor) give way for a moment, then try again.
        if (!via && distance <= config_.stall_radius_m) {
          reached = true;
        } else {
          give_way = true;
        }
      }
      const size_t previous = (p.destination + n - 1) % n;
      if (reached) {
        p.destination = following;
        p.waiting_s = via ? 0.0 : p.spec.wait_s;
      } else if (give_way) {
        p.waiting_s = config_.give_way_s;
      } else if (!via && isWaypoint(p.spec, previous) &&
                 !straightWalkIsClear(p.position, p.spec.destinations[p.destination], 0.5 * p.spec.body_radius_m,
                                      walls)) {
        // Pushed off the way through the waypoint (a wall or a door's jamb now stands in the way to the stop):
        // back to the waypoint.
        p.destination = previous;
      } else {
        continue;
      }
      p.closest_m = std::numeric_limits<double>::infinity();
      p.stalled_s = 0.0;
    }
  }
}

Vec2 Crowd::orcaVelocity(size_t i, double dt, const std::vector<Segment>& walls, const Circle& robot,
                         const Vec2& robot_velocity) const {
  const Person& p = people_[i];
  const double r = p.spec.body_radius_m, reach = config_.orca_neighbor_dist_m;
  std::vector<OrcaLine> lines;
  for (const Segment& w : walls) {
    if (pointSegmentDistance(p.position, w) - r < reach) {
      lines.push_back(orcaLineForSegment(p.position, p.velocity, r, w, config_.orca_wall_horizon_s, dt));
    }
  }
  const size_t hard = lines.size();
  for (size_t j = 0; j < people_.size(); ++j) {
    const Person& q = people_[j];
    if (j == i || (q.position - p.position).norm() - r - q.spec.body_radius_m > reach) continue;
    lines.push_back(orcaLineForDisc(p.position, p.velocity, r, q.position, q.velocity, q.spec.body_radius_m,
                                    config_.orca_time_horizon_s, dt, 0.5));
  }
  const bool yields = p.behavior == PersonBehavior::kAttentive && p.noticed;
  if ((yields || p.behavior == PersonBehavior::kImpassive) &&
      (robot.center - p.position).norm() - r - robot.radius < reach) {
    // The robot does not run ORCA with people: whoever sees it takes the whole avoidance. An impassive person
    // avoids it as a still disc (it does not time its way for the robot's motion).
    lines.push_back(orcaLineForDisc(p.position, p.velocity, r, robot.center, yields ? robot_velocity : Vec2::Zero(),
                                    robot.radius, config_.orca_time_horizon_s, dt, 1.0));
  }
  return solveOrcaLp(lines, hard, config_.max_speed_factor * p.spec.preferred_speed_mps, drive(p, walls)).velocity;
}

void Crowd::legsOf(const Person& p, const PeopleConfig& config, Circle& left, Circle& right) {
  const double speed = p.velocity.norm();
  const Vec2 fwd(std::cos(p.heading_rad), std::sin(p.heading_rad)), side(-fwd.y(), fwd.x());
  // Swing amplitude: half a step when walking, fading to legs side by side when standing.
  const double height = std::clamp((config.hip_height_m - config.scan_height_m) / config.hip_height_m, 0.0, 1.0);
  const double swing = 0.5 * stepLength(speed) * height * std::min(1.0, speed / 0.3) * std::sin(p.gait_phase_rad);
  left = {p.position + config.hip_half_width_m * side + swing * fwd, config.leg_radius_m};
  right = {p.position - config.hip_half_width_m * side - swing * fwd, config.leg_radius_m};
}

void Crowd::appendSeen(std::vector<Circle>& out, bool legs) const {
  for (const Person& p : people_) {
    if (!legs) {
      out.push_back({p.position, p.spec.body_radius_m});
      continue;
    }
    Circle l, r;
    legsOf(p, config_, l, r);
    out.push_back(l);
    out.push_back(r);
  }
}

std::vector<Circle> Crowd::bodies() const {
  std::vector<Circle> out;
  appendSeen(out, false);
  return out;
}

std::vector<Circle> Crowd::legs() const {
  std::vector<Circle> out;
  appendSeen(out, true);
  return out;
}

std::vector<MovingObstacle> Crowd::asObstacles() const {
  std::vector<MovingObstacle> out;
  out.reserve(people_.size());
  for (const Person& p : people_) {
    MovingObstacle m;
    m.center = p.position;
    m.radius = p.spec.body_radius_m;
    m.speed = p.velocity.norm();
    m.heading = m.speed > 1e-9 ? std::atan2(p.velocity.y(), p.velocity.x()) : p.heading_rad;
    m.turn_rate = 0.0;
    m.is_static = false;
    out.push_back(m);
  }
  return out;
}

}  // namespace dqn_dovs::sim
