#include "dqn_dovs/sim/world.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <unordered_map>

namespace dqn_dovs::sim {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
// Keeps the lidar's noise stream unrelated to any other stream seeded from the same user seed.
constexpr uint64_t kLidarStreamTag = 0x6C69646172ULL;
constexpr uint64_t kOdometryStreamTag = 0x6F646F6DULL;
// A single step is never cut into more sub-steps than this, whatever the speeds (guards absurd inputs).
constexpr int kMaxSubsteps = 100000;

std::string bad(const char* field, double value, const std::string& why) {
  std::ostringstream os;
  os << "world parameter '" << field << "' = " << value << ": " << why;
  return os.str();
}

// Signed distance of a disc centre past the border line of one wall: >= 0 means the disc is at (or over) the
// line where it must turn around. Walls: 0 = +x, 1 = -x, 2 = +y, 3 = -y.
inline double pastBorder(const Vec2& c, int wall, double limit) {
  const double coord = wall < 2 ? c.x() : c.y();
  const double sign = (wall % 2 == 0) ? 1.0 : -1.0;
  return sign * coord - limit;
}

// Component of the direction of travel along wall's outward normal.
inline double outwardComponent(double heading, double speed, int wall) {
  const double d = wall < 2 ? std::cos(heading) : std::sin(heading);
  const double sign = (wall % 2 == 0) ? 1.0 : -1.0;
  return sign * d * (speed < 0.0 ? -1.0 : 1.0);
}

void checkScenario(const Scenario& s) {
  auto fail = [&](const std::string& why) { throw ScenarioError("scenario '" + s.name + "': " + why); };
  const double half = s.room_half_size_m;
  if (!(std::isfinite(half) && half > 0.0)) fail("room_half_size_m must be finite and > 0");
  if (!s.robot_start.isFinite()) fail("robot start pose is not finite");
  if (!s.goal.allFinite()) fail("goal is not finite");
  if (!(std::abs(s.robot_start.x) < half && std::abs(s.robot_start.y) < half)) {
    std::ostringstream os;
    os << "robot start (" << s.robot_start.x << ", " << s.robot_start.y << ") is outside the room (walls at +-" << half
       << " m)";
    fail(os.str());
  }
  for (size_t i = 0; i < s.obstacles.size(); ++i) {
    const MovingObstacle& o = s.obstacles[i];
    if (!(o.center.allFinite() && std::isfinite(o.heading) && std::isfinite(o.speed) && std::isfinite(o.turn_rate))) {
      fail("obstacle " + std::to_string(i) + " has a non-finite centre, heading, speed or turn rate");
    }
    if (!(std::isfinite(o.radius) && o.radius > 0.0)) {
      fail("obstacle " + std::to_string(i) + " radius must be finite and > 0");
    }
  }
  for (size_t i = 0; i < s.static_segments.size(); ++i) {
    if (!(s.static_segments[i].a.allFinite() && s.static_segments[i].b.allFinite())) {
      fail("static segment " + std::to_string(i) + " is not finite");
    }
  }
  for (size_t i = 0; i < s.people.size(); ++i) {
    const Vec2& p = s.people[i].position;
    if (!(p.allFinite() && std::abs(p.x()) < s.room_half_size_m && std::abs(p.y()) < s.room_half_size_m)) {
      fail("person " + std::to_string(i) + " does not start inside the room");
    }
  }
}

const WorldConfig& validated(const WorldConfig& config) {
  const std::string error = config.validate();
  if (!error.empty()) throw SimConfigError(error);
  return config;
}

}  // namespace

std::string WorldConfig::validate() const {
  const std::string robot_error = robot.validate();
  if (!robot_error.empty()) return "world parameter 'robot': " + robot_error;
  if (!(std::isfinite(physics_step_s) && physics_step_s > 0.0 && physics_step_s <= 1.0)) {
    return bad("physics_step_s", physics_step_s, "must be in (0, 1] s");
  }
  if (!(std::isfinite(max_substep_travel_m) && max_substep_travel_m > 0.0)) {
    return bad("max_substep_travel_m", max_substep_travel_m, "must be finite and > 0 m");
  }
  const std::string lidar_error = lidar.validate();
  if (!lidar_error.empty()) return "world parameter 'lidar': " + lidar_error;
  if (const std::string e = people.validate(); !e.empty()) return "world parameter 'people': " + e;
  if (const std::string e = odometry.validate(); !e.empty()) return "world parameter 'odometry': " + e;
  if (!(std::isfinite(wall_thickness_m) && wall_thickness_m >= 0.0 && wall_thickness_m <= 1.0)) {
    return bad("wall_thickness_m", wall_thickness_m, "must be in [0, 1] m");
  }
  if (!(std::isfinite(border_turn_rate_rps) && border_turn_rate_rps > 0.0)) {
    return bad("border_turn_rate_rps", border_turn_rate_rps, "must be finite and > 0 rad/s");
  }
  if (!(std::isfinite(border_margin_m) && border_margin_m >= 0.0)) {
    return bad("border_margin_m", border_margin_m, "must be finite and >= 0 m");
  }
  return {};
}

OdometryConfig OdometryConfig::level(const std::string& name) {
  if (name == "none") return {};
  if (name == "low") return {0.01, 0.02, 0.005, 0.02};
  if (name == "high") return {0.03, 0.05, 0.02, 0.05};
  throw SimConfigError("odometry noise level '" + name + "' is not one of none, low, high");
}

std::string OdometryConfig::validate() const {
  for (const auto& [name, v] : {std::pair<const char*, double>{"speed_scale_std", speed_scale_std},
                                {"turn_scale_std", turn_scale_std},
                                {"turn_bias_std_rps", turn_bias_std_rps},
                                {"step_noise_std", step_noise_std}}) {
    if (!(std::isfinite(v) && v >= 0.0 && v < 0.5)) return bad(name, v, "must be in [0, 0.5)");
  }
  return {};
}

World::World(const Scenario& scenario, const WorldConfig& config, uint64_t seed)
    : config_(validated(config)), lidar_(config.lidar, mixSeed(seed ^ kLidarStreamTag)) {
  reset(scenario, seed);
}

void World::reset(const Scenario& scenario, uint64_t seed) {
  checkScenario(scenario);
  scenario_ = scenario;
  lidar_.reseed(mixSeed(seed ^ kLidarStreamTag));
  time_s_ = 0.0;
  robot_pose_ = scenario.robot_start;
  robot_pose_.theta = normalizeAngle(robot_pose_.theta);
  odom_pose_ = robot_pose_;
  if (config_.odometry.enabled()) {
    // A stream of its own: the LIDAR's noise stays the same with or without odometry errors.
    odom_rng_.reseed(mixSeed(seed ^ kOdometryStreamTag));
    odom_speed_scale_ = 1.0 + config_.odometry.speed_scale_std * odom_rng_.normal();
    odom_turn_scale_ = 1.0 + config_.odometry.turn_scale_std * odom_rng_.normal();
    odom_turn_bias_rps_ = config_.odometry.turn_bias_std_rps * odom_rng_.normal();
  }
  robot_twist_ = {};
  robot_stopped_ = false;
  collision_ = {};
  last_moving_s_ = -std::numeric_limits<double>::infinity();
  obstacles_.clear();
  obstacles_.reserve(scenario.obstacles.size());
  for (const MovingObstacle& m : scenario.obstacles) {
    SimObstacle o;
    o.body = m;
    if (o.body.is_static) {
      o.body.speed = 0.0;
      o.body.turn_rate = 0.0;
    }
    o.turn_direction = o.body.turn_rate < 0.0 ? -1.0 : 1.0;
    obstacles_.push_back(o);
  }
  try {
    crowd_ = Crowd(scenario.people, config_.people, seed, scenario.traffic, scenario.doors);
  } catch (const SimConfigError& e) {
    throw ScenarioError("scenario '" + scenario.name + "': " + e.what());
  }
  shadow_crowd_ = config_.shadow_people ? crowd_ : Crowd();
  const double h = scenario.room_half_size_m;
  walls_ = {
      {Vec2(-h, -h), Vec2(h, -h)}, {Vec2(h, -h), Vec2(h, h)}, {Vec2(h, h), Vec2(-h, h)}, {Vec2(-h, h), Vec2(-h, -h)}};
  walls_.insert(walls_.end(), scenario.static_segments.begin(), scenario.static_segments.end());
  lidar_scene_.room_half_size_m = h;
  lidar_scene_.segments = scenario.static_segments;
  lidar_scene_.discs.clear();
  if (config_.wall_thickness_m > 0.0) addWallEndFaces();
  checkCollision();  // a start pose inside an obstacle is a collision at t = 0
  if (collided() && config_.stop_on_collision) robot_stopped_ = true;
}

void World::addWallEndFaces() {
  // A wall's end that touches no other wall (within kJoin) is free: the scanner sees its end face there. The walls
  // are bucketed by the grid cells their bounding boxes cover, so each end is tested only against the walls near it
  // (a map's outlines are thousands of short pieces).
  constexpr double kJoin = 0.01, kCell = 0.5;
  auto cellOf = [](double v) { return static_cast<int64_t>(std::floor(v / kCell)); };
  auto key = [](int64_t i, int64_t j) {
    return (static_cast<uint64_t>(i) << 32) ^ static_cast<uint64_t>(static_cast<uint32_t>(j));
  };
  std::unordered_map<uint64_t, std::vector<size_t>> cells;
  std::vector<size_t> long_walls;  // spanning more than 50 cells: tested against every end instead
  for (size_t j = 0; j < walls_.size(); ++j) {
    const Segment& w = walls_[j];
    if (!w.a.allFinite() || !w.b.allFinite()) continue;
    const Vec2 lo = w.a.cwiseMin(w.b) - Vec2::Constant(kJoin), hi = w.a.cwiseMax(w.b) + Vec2::Constant(kJoin);
    if ((hi - lo).maxCoeff() > 50.0 * kCell) {
      long_walls.push_back(j);
      continue;
    }
    for (int64_t i = cellOf(lo.x()); i <= cellOf(hi.x()); ++i) {
      for (int64_t k = cellOf(lo.y()); k <= cellOf(hi.y()); ++k) cells[key(i, k)].push_back(j);
    }
  }
  const std::vector<size_t> none;
  auto bucket = [&](uint64_t k) -> const std::vector<size_t>& {
    const auto it = cells.find(k);
    return it == cells.end() ? none : it->second;
  };
  const std::vector<Segment>& segments = scenario_.static_segments;
  for (size_t k = 0; k < segments.size(); ++k) {
    const Segment& s = segments[k];
    const double length = (s.b - s.a).norm();
    if (!(length > 0.0) || !std::isfinite(length)) continue;
    const Vec2 across = 0.5 * config_.wall_thickness_m * Vec2(-(s.b - s.a).y(), (s.b - s.a).x()) / length;
    const size_t self = 4 + k;  // walls_: the room's four, then the scenario's segments
    for (const Vec2& end : {s.a, s.b}) {
      auto touches = [&](const std::vector<size_t>& list) {
        return std::any_of(list.begin(), list.end(),
                           [&](size_t j) { return j != self && pointSegmentDistance(end, walls_[j]) < kJoin; });
      };
      const bool joined = touches(long_walls) || touches(bucket(key(cellOf(end.x()), cellOf(end.y()))));
      if (!joined) lidar_scene_.segments.push_back({end - across, end + across});
    }
  }
}

double World::borderEventTime(const SimObstacle& o, double dt_s) const {
  const MovingObstacle& b = o.body;
  const double limit = scenario_.room_half_size_m - config_.border_margin_m - b.radius;
  const Pose2 p0{b.center.x(), b.center.y(), b.heading};
  const Pose2 p1 = integrateUnicycle(p0, b.speed, b.turn_rate, dt_s);
  double best = -1.0;
  for (int wall = 0; wall < 4; ++wall) {
    const double f0 = pastBorder(p0.position(), wall, limit);
    const double f1 = pastBorder(p1.position(), wall, limit);
    double t = -1.0;
    if (f0 >= 0.0) {
      // Already at the line (it just turned there, or started there): only motion out of the room counts.
      if (outwardComponent(p0.theta, b.speed, wall) > 0.0 && b.speed != 0.0) {
        t = 0.0;
      } else if (f1 >= 0.0 && outwardComponent(p1.theta, b.speed, wall) > 0.0 && b.speed != 0.0) {
        t = dt_s;  // curved back outward while still past the line; sub-steps are short enough for this
      }
    } else if (f1 >= 0.0) {
      // Crossing inside this interval: bisect to the last instant still inside the line.
      double lo = 0.0, hi = dt_s;
      for (int it = 0; it < 40; ++it) {
        const double mid = 0.5 * (lo + hi);
        const Pose2 pm = integrateUnicycle(p0, b.speed, b.turn_rate, mid);
        (pastBorder(pm.position(), wall, limit) >= 0.0 ? hi : lo) = mid;
      }
      t = lo;
    }
    if (t >= 0.0 && (best < 0.0 || t < best)) best = t;
  }
  return best;
}

void World::startBorderTurn(SimObstacle& o) const {
  MovingObstacle& b = o.body;
  const double limit = scenario_.room_half_size_m - config_.border_margin_m - b.radius;
  o.motion = ObstacleMotion::kTurningAtBorder;
  o.turn_direction = b.turn_rate < 0.0 ? -1.0 : 1.0;
  o.turn_remaining_rad = kPi;
  o.border_turns += 1;
  // In a corner the reversed heading can still point out through the other wall, which would trigger another
  // turn at once and trap the obstacle; there it turns to face the room centre instead.
  const double reversed = normalizeAngle(b.heading + kPi);
  bool reversed_escapes = true;
  for (int wall = 0; wall < 4; ++wall) {
    if (pastBorder(b.center, wall, limit) >= -1e-6 && outwardComponent(reversed, b.speed, wall) > 1e-9) {
      reversed_escapes = false;
    }
  }
  if (!reversed_escapes) {
    const double to_centre = std::atan2(-b.center.y(), -b.center.x());
    const double diff = angleDiff(b.speed < 0.0 ? normalizeAngle(to_centre + kPi) : to_centre, b.heading);
    o.turn_direction = diff < 0.0 ? -1.0 : 1.0;
    o.turn_remaining_rad = std::abs(diff);
  }
}

void World::advanceObstacle(SimObstacle& o, double dt_s) const {
  MovingObstacle& b = o.body;
  if (b.is_static || (b.speed == 0.0 && b.turn_rate == 0.0)) return;
  double left = dt_s;
  // Each pass either finishes the interval or ends a phase; a handful of phases per sub-step is the most a
  // real motion can produce, the cap only protects against degenerate inputs.
  for (int phase = 0; phase < 8 && left > 0.0; ++phase) {
    if (o.motion == ObstacleMotion::kTurningAtBorder) {
      const double rate = config_.border_turn_rate_rps;
      if (rate * left < o.turn_remaining_rad) {
        b.heading = normalizeAngle(b.heading + o.turn_direction * rate * left);
        o.turn_remaining_rad -= rate * left;
        return;
      }
      b.heading = normalizeAngle(b.heading + o.turn_direction * o.turn_remaining_rad);
      left -= o.turn_remaining_rad / rate;
      o.turn_remaining_rad = 0.0;
      o.motion = ObstacleMotion::kMoving;
      continue;
    }
    const double t_event = borderEventTime(o, left);
    const double t_move = t_event >= 0.0 ? t_event : left;
    const Pose2 p = integrateUnicycle({b.center.x(), b.center.y(), b.heading}, b.speed, b.turn_rate, t_move);
    b.center = p.position();
    b.heading = p.theta;
    left -= t_move;
    if (t_event < 0.0) return;
    startBorderTurn(o);
  }
}

bool World::checkCollision() {
  const Vec2 p = robot_pose_.position();
  const double r = config_.robot.radius;
  // The first contact's record: what, when, and the motion of both sides (who hit whom, evaluation/eval.h).
  auto record = [&](CollisionInfo::Kind kind, int index, bool still, const Vec2& toward, const Vec2& other_velocity) {
    if (collided()) return;
    CollisionInfo c;
    c.kind = kind;
    c.index = index;
    c.time_s = time_s_;
    c.robot_speed_mps = std::abs(robot_twist_.v);
    c.static_contact = still;
    c.robot_velocity = robot_twist_.v * Vec2(std::cos(robot_pose_.theta), std::sin(robot_pose_.theta));
    c.other_velocity = other_velocity;
    c.normal = toward.norm() > 1e-12 ? Vec2(toward.normalized()) : Vec2::Zero();
    c.robot_rest_s = c.robot_speed_mps >= kRobotRestSpeedMps ? 0.0 : time_s_ - last_moving_s_;
    collision_ = c;
  };
  for (size_t i = 0; i < obstacles_.size(); ++i) {
    const MovingObstacle& b = obstacles_[i].body;
    if ((b.center - p).norm() < r + b.radius) {
      const bool still = b.is_static || (b.speed == 0.0 && b.turn_rate == 0.0);
      record(CollisionInfo::Kind::kObstacle, static_cast<int>(i), still, b.center - p,
             still ? Vec2(Vec2::Zero()) : Vec2(b.speed * Vec2(std::cos(b.heading), std::sin(b.heading))));
      return true;
    }
  }
  const std::vector<Person>& people = crowd_.people();
  for (size_t j = 0; j < people.size(); ++j) {
    if ((people[j].position - p).norm() < r + people[j].spec.body_radius_m) {
      // A person standing still (waiting) counts as static: driving into them was avoidable.
      const bool still = people[j].velocity.norm() < 1e-3;
      record(CollisionInfo::Kind::kObstacle, static_cast<int>(obstacles_.size() + j), still, people[j].position - p,
             people[j].velocity);
      return true;
    }
  }
  for (size_t i = 0; i < walls_.size(); ++i) {
    if (pointSegmentDistance(p, walls_[i]) < r) {
      record(CollisionInfo::Kind::kWall, static_cast<int>(i), true, closestPointOnSegment(p, walls_[i]) - p,
             Vec2::Zero());
      return true;
    }
  }
  // A robot centre outside the room (possible only after tunnelling through a wall) is also a collision.
  const double h = scenario_.room_half_size_m;
  if (!(std::abs(p.x()) < h && std::abs(p.y()) < h)) {
    record(CollisionInfo::Kind::kWall, 0, true, -p, Vec2::Zero());
    return true;
  }
  return false;
}

void World::step(const Twist2& cmd, double dt_s) {
  if (!(std::isfinite(dt_s) && dt_s >= 0.0)) {
    std::ostringstream os;
    os << "World::step: dt_s = " << dt_s << " must be finite and >= 0 s";
    throw SimConfigError(os.str());
  }
  if (dt_s == 0.0) return;
  const Twist2 command = robot_stopped_ ? Twist2{} : cmd;
  if (!config_.ramp_velocity) {
    robot_twist_ = robot_stopped_ ? Twist2{} : applyAccelerationLimits(robot_twist_, command, config_.robot, dt_s);
  }

  const double fastest_obstacle = fastestObstacleSpeed();
  const double robot_speed =
      config_.ramp_velocity ? std::max(std::abs(robot_twist_.v), std::abs(command.v)) : std::abs(robot_twist_.v);
  const double relative_speed = std::min(robot_speed, config_.robot.v_max) + fastest_obstacle;
  double h = config_.physics_step_s;
  if (relative_speed > 0.0) h = std::min(h, config_.max_substep_travel_m / relative_speed);
  const int n = static_cast<int>(std::min<double>(kMaxSubsteps, std::max(1.0, std::ceil(dt_s / h - 1e-9))));
  const double sub_dt = dt_s / n;

  for (int k = 0; k < n; ++k) {
    if (config_.ramp_velocity && !robot_stopped_) {
      robot_twist_ = applyAccelerationLimits(robot_twist_, command, config_.robot, sub_dt);
    }
    const Pose2 previous = robot_pose_, previous_odom = odom_pose_;
    robot_pose_ = integrateUnicycle(robot_pose_, robot_twist_.v, robot_twist_.w, sub_dt);
    stepOdometry(sub_dt);
    for (SimObstacle& o : obstacles_) advanceObstacle(o, sub_dt);
    stepPeople(sub_dt);
    time_s_ += sub_dt;
    if (std::abs(robot_twist_.v) >= kRobotRestSpeedMps) last_moving_s_ = time_s_;
    if (checkCollision() && config_.stop_on_collision && !robot_stopped_) {
      robot_pose_ = previous;
      odom_pose_ = previous_odom;
      robot_twist_ = {};
      robot_stopped_ = true;
    }
  }
}

// Holonomic mode: the robot translates at a fixed-frame velocity instead of following the unicycle model. The
// sub-stepping and collision handling mirror step() so that both modes are judged by the same physics.
void World::stepHolonomic(const Vec2& velocity, double dt_s) {
  if (!(std::isfinite(dt_s) && dt_s >= 0.0)) {
    std::ostringstream os;
    os << "World::stepHolonomic: dt_s = " << dt_s << " must be finite and >= 0 s";
    throw SimConfigError(os.str());
  }
  if (dt_s == 0.0) return;
  Vec2 u = velocity.allFinite()
               ? velocity
               : Vec2(robot_twist_.v * std::cos(robot_pose_.theta), robot_twist_.v * std::sin(robot_pose_.theta));
  if (robot_stopped_) u.setZero();
  const double speed = u.norm();
  if (speed > config_.robot.v_max) u *= config_.robot.v_max / speed;
  const double held_speed = std::min(speed, config_.robot.v_max);
  if (held_speed > 1e-9) robot_pose_.theta = std::atan2(u.y(), u.x());
  robot_twist_ = Twist2{held_speed, 0.0};

  const double fastest_obstacle = fastestObstacleSpeed();
  double h = config_.physics_step_s;
  const double relative_speed = held_speed + fastest_obstacle;
  if (relative_speed > 0.0) h = std::min(h, config_.max_substep_travel_m / relative_speed);
  const int n = static_cast<int>(std::min<double>(kMaxSubsteps, std::max(1.0, std::ceil(dt_s / h - 1e-9))));
  const double sub_dt = dt_s / n;
  for (int k = 0; k < n; ++k) {
    const Pose2 previous = robot_pose_;
    if (!robot_stopped_) {
      robot_pose_.x += u.x() * sub_dt;
      robot_pose_.y += u.y() * sub_dt;
    }
    odom_pose_ = robot_pose_;  // the holonomic baseline runs without wheel odometry (and is judged by the truth)
    for (SimObstacle& o : obstacles_) advanceObstacle(o, sub_dt);
    stepPeople(sub_dt);
    time_s_ += sub_dt;
    if (std::abs(robot_twist_.v) >= kRobotRestSpeedMps) last_moving_s_ = time_s_;
    if (checkCollision() && config_.stop_on_collision && !robot_stopped_) {
      robot_pose_ = previous;
      odom_pose_ = previous;
      robot_twist_ = {};
      robot_stopped_ = true;
    }
  }
}

double World::fastestObstacleSpeed() const {
  double fastest = 0.0;
  for (const SimObstacle& o : obstacles_) fastest = std::max(fastest, std::abs(o.body.speed));
  for (const Person& p : crowd_.people()) {
    fastest = std::max(fastest, config_.people.max_speed_factor * p.spec.preferred_speed_mps);
  }
  return fastest;
}

void World::stepOdometry(double dt_s) {
  if (!config_.odometry.enabled()) {
    odom_pose_ = robot_pose_;
    return;
  }
  const double slip = 1.0 + config_.odometry.step_noise_std * odom_rng_.normal();
  odom_pose_ = integrateUnicycle(
      odom_pose_, robot_twist_.v * odom_speed_scale_ * slip,
      robot_twist_.w * odom_turn_scale_ + (robot_twist_.v != 0.0 || robot_twist_.w != 0.0 ? odom_turn_bias_rps_ : 0.0),
      dt_s);
}

void World::stepPeople(double dt_s) {
  if (crowd_.people().empty()) return;
  const Vec2 robot_velocity = robot_twist_.v * Vec2(std::cos(robot_pose_.theta), std::sin(robot_pose_.theta));
  crowd_.step(dt_s, walls_, Circle{robot_pose_.position(), config_.robot.radius}, robot_velocity);
  // The shadow's robot is a point far outside every world: out of anyone's notice range.
  if (config_.shadow_people) shadow_crowd_.step(dt_s, walls_, Circle{Vec2(1.0e6, 1.0e6), 0.0}, Vec2::Zero());
}

std::vector<MovingObstacle> World::groundTruthObstacles() const {
  std::vector<MovingObstacle> out;
  out.reserve(obstacles_.size() + crowd_.people().size());
  for (const SimObstacle& o : obstacles_) {
    MovingObstacle m = o.body;
    if (o.motion == ObstacleMotion::kTurningAtBorder) {
      m.speed = 0.0;
      m.turn_rate = o.turn_direction * config_.border_turn_rate_rps;
    }
    out.push_back(m);
  }
  for (const MovingObstacle& m : crowd_.asObstacles()) out.push_back(m);
  return out;
}

double World::minClearance_m() const {
  const Vec2 p = robot_pose_.position();
  const double r = config_.robot.radius;
  double best = kInf;
  for (const SimObstacle& o : obstacles_) best = std::min(best, (o.body.center - p).norm() - o.body.radius - r);
  for (const Person& q : crowd_.people()) best = std::min(best, (q.position - p).norm() - q.spec.body_radius_m - r);
  // The room walls as a signed distance, so that a robot that went through a wall reads as overlapping.
  const double h = scenario_.room_half_size_m;
  best = std::min(best, std::min(h - std::abs(p.x()), h - std::abs(p.y())) - r);
  for (size_t i = 4; i < walls_.size(); ++i) best = std::min(best, pointSegmentDistance(p, walls_[i]) - r);
  return best;
}

void World::scanInto(LaserScan2& out) {
  lidar_scene_.discs.resize(obstacles_.size());
  for (size_t i = 0; i < obstacles_.size(); ++i) {
    lidar_scene_.discs[i] = Circle{obstacles_[i].body.center, obstacles_[i].body.radius};
  }
  crowd_.appendSeen(lidar_scene_.discs, config_.scan_legs);
  lidar_.scanInto(laserPose(), lidar_scene_, time_s_, out);
}

LaserScan2 World::scan() {
  LaserScan2 out;
  scanInto(out);
  return out;
}

}  // namespace dqn_dovs::sim
