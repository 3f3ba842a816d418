#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>

#include "dqn_dovs/common/random.h"
#include "dqn_dovs/sim/scenario.h"

namespace dqn_dovs::sim {
namespace {

std::string bad(const char* field, double value, const std::string& why) {
  std::ostringstream os;
  os << "scenario generator parameter '" << field << "' = " << value << ": " << why;
  return os.str();
}

bool positiveFinite(double x) { return std::isfinite(x) && x > 0.0; }

/// Whether `o`, moving on its own (v, w) arc from its start, comes within `clearance` (centre to centre) of `robot`
/// in the first `horizon_s` seconds, while its centre stays inside the room (0.05 s steps).
bool reachesStart(const MovingObstacle& o, const Vec2& robot, double clearance, double horizon_s, double room_half) {
  constexpr double kStep = 0.05;
  const double inside = room_half - o.radius;
  for (double t = 0.0; t <= horizon_s + 1e-9; t += kStep) {
    const Vec2 p = integrateUnicycle({o.center.x(), o.center.y(), o.heading}, o.speed, o.turn_rate, t).position();
    if (std::abs(p.x()) > inside || std::abs(p.y()) > inside) return false;
    if ((p - robot).norm() < clearance) return true;
  }
  return false;
}

}  // namespace

std::string GeneratorConfig::validate() const {
  if (!positiveFinite(room_half_size_m)) return bad("room_half_size_m", room_half_size_m, "must be finite and > 0 (m)");
  if (!positiveFinite(spawn_half_size_m) || spawn_half_size_m >= room_half_size_m) {
    return bad("spawn_half_size_m", spawn_half_size_m, "must be > 0 and < room_half_size_m (m)");
  }
  if (!(std::isfinite(goal_distance_min_m) && goal_distance_min_m >= 0.0)) {
    return bad("goal_distance_min_m", goal_distance_min_m, "must be finite and >= 0 (m)");
  }
  const double diagonal = 2.0 * std::sqrt(2.0) * spawn_half_size_m;
  if (goal_distance_min_m >= diagonal) {
    return bad("goal_distance_min_m", goal_distance_min_m,
               "must be below the spawn square's diagonal " + std::to_string(diagonal) + " m");
  }
  if (std::isnan(goal_distance_max_m) || goal_distance_max_m < goal_distance_min_m || goal_distance_max_m <= 0.0) {
    return bad("goal_distance_max_m", goal_distance_max_m, "must be > 0 and >= goal_distance_min_m (m; +inf = any)");
  }
  if (!(std::isfinite(min_separation_m) && min_separation_m >= 0.0)) {
    return bad("min_separation_m", min_separation_m, "must be finite and >= 0 (m)");
  }
  if (!positiveFinite(robot_radius_m)) return bad("robot_radius_m", robot_radius_m, "must be finite and > 0 (m)");
  if (obstacle_count_min < 0) return bad("obstacle_count_min", obstacle_count_min, "must be >= 0");
  if (obstacle_count_max < obstacle_count_min) {
    return bad("obstacle_count_max", obstacle_count_max, "must be >= obstacle_count_min");
  }
  if (obstacle_count_max > 1000) return bad("obstacle_count_max", obstacle_count_max, "must be <= 1000");
  if (!(dynamic_fraction >= 0.0 && dynamic_fraction <= 1.0)) {
    return bad("dynamic_fraction", dynamic_fraction, "must be in [0, 1]");
  }
  if (!(std::isfinite(speed_min_mps) && speed_min_mps >= 0.0)) {
    return bad("speed_min_mps", speed_min_mps, "must be finite and >= 0 (m/s)");
  }
  if (!(std::isfinite(speed_max_mps) && speed_max_mps >= speed_min_mps)) {
    return bad("speed_max_mps", speed_max_mps, "must be finite and >= speed_min_mps (m/s)");
  }
  if (!(std::isfinite(turn_rate_max_rps) && turn_rate_max_rps >= 0.0)) {
    return bad("turn_rate_max_rps", turn_rate_max_rps, "must be finite and >= 0 (rad/s)");
  }
  if (!positiveFinite(radius_min_m)) return bad("radius_min_m", radius_min_m, "must be finite and > 0 (m)");
  if (!(std::isfinite(radius_max_m) && radius_max_m >= radius_min_m && radius_max_m < spawn_half_size_m)) {
    return bad("radius_max_m", radius_max_m, "must be >= radius_min_m and < spawn_half_size_m (m)");
  }
  if (max_attempts < 1) return bad("max_attempts", max_attempts, "must be >= 1");
  if (!(std::isfinite(start_clear_s) && start_clear_s >= 0.0 && start_clear_s <= 60.0)) {
    return bad("start_clear_s", start_clear_s, "must be in [0, 60] (s)");
  }
  if (!(std::isfinite(start_clear_margin_m) && start_clear_margin_m >= 0.0)) {
    return bad("start_clear_margin_m", start_clear_margin_m, "must be finite and >= 0 (m)");
  }
  return {};
}

Scenario generateScenario(const GeneratorConfig& config, uint64_t seed) {
  const std::string error = config.validate();
  if (!error.empty()) throw ScenarioError(error);

  Rng rng(seed);
  const double h = config.spawn_half_size_m;
  Scenario s;
  s.name = "generated/seed=" + std::to_string(seed);
  s.room_half_size_m = config.room_half_size_m;
  s.robot_start.x = rng.uniform(-h, h);
  s.robot_start.y = rng.uniform(-h, h);
  s.robot_start.theta = config.random_robot_heading ? rng.uniform(-kPi, kPi) : 0.0;
  const Vec2 robot = s.robot_start.position();

  const double goal_min = std::max(config.goal_distance_min_m, config.min_separation_m);
  bool placed = false;
  for (int attempt = 0; attempt < config.max_attempts && !placed; ++attempt) {
    const Vec2 g(rng.uniform(-h, h), rng.uniform(-h, h));
    const double d = (g - robot).norm();
    if (d >= goal_min && d <= config.goal_distance_max_m) {
      s.goal = g;
      placed = true;
    }
  }
  if (!placed) {
    std::ostringstream os;
    os << "scenario generator (seed " << seed << "): no goal at " << config.goal_distance_min_m << ".."
       << config.goal_distance_max_m << " m from the robot at (" << robot.x() << ", " << robot.y()
       << ") inside the spawn square after " << config.max_attempts << " attempts";
    throw ScenarioError(os.str());
  }

  const int count = config.obstacle_type == ObstacleType::kNone
                        ? 0
                        : static_cast<int>(rng.uniformInt(config.obstacle_count_min, config.obstacle_count_max));
  s.obstacles.reserve(static_cast<size_t>(count));
  for (int i = 0; i < count; ++i) {
    MovingObstacle o;
    for (int clear_attempt = 0;; ++clear_attempt) {
      o.radius = rng.uniform(config.radius_min_m, config.radius_max_m);
      placed = false;
      for (int attempt = 0; attempt < config.max_attempts && !placed; ++attempt) {
        const Vec2 c(rng.uniform(-h, h), rng.uniform(-h, h));
        // The goal keeps a robot-sized clearance so that a static obstacle can never cover it.
        bool ok = (c - robot).norm() >= std::max(config.min_separation_m, config.robot_radius_m + o.radius) &&
                  (c - s.goal).norm() >= std::max(config.min_separation_m, config.robot_radius_m + o.radius);
        for (size_t j = 0; ok && j < s.obstacles.size(); ++j) {
          const MovingObstacle& other = s.obstacles[j];
          ok = (c - other.center).norm() >= std::max(config.min_separation_m, o.radius + other.radius);
        }
        if (ok) {
          o.center = c;
          placed = true;
        }
      }
      if (!placed) {
        std::ostringstream os;
        os << "scenario generator (seed " << seed << "): could not place obstacle " << i + 1 << " of " << count
           << " with " << config.min_separation_m << " m separation after " << config.max_attempts
           << " attempts (too many obstacles for the spawn square?)";
        throw ScenarioError(os.str());
      }
      // Every draw happens whatever the obstacle type, so the positions of a seed do not depend on the type.
      o.heading = rng.uniform(-kPi, kPi);
      const double speed = rng.uniform(config.speed_min_mps, config.speed_max_mps);
      const double turn_rate = rng.uniform(-config.turn_rate_max_rps, config.turn_rate_max_rps);
      const double moving_draw = rng.uniform01();
      bool moving = false;
      switch (config.obstacle_type) {
        case ObstacleType::kNone:
        case ObstacleType::kStatic:
          moving = false;
          break;
        case ObstacleType::kDynamic:
          moving = true;
          break;
        case ObstacleType::kBoth:
          moving = moving_draw < config.dynamic_fraction;
          break;
      }
      o.speed = moving ? speed : 0.0;
      o.turn_rate = moving ? turn_rate : 0.0;
      o.is_static = !moving;
      if (config.start_clear_s <= 0.0 || !moving ||
          !reachesStart(o, robot, config.robot_radius_m + o.radius + config.start_clear_margin_m, config.start_clear_s,
                        config.room_half_size_m)) {
        break;
      }
      if (clear_attempt + 1 >= config.max_attempts) {
        std::ostringstream os;
        os << "scenario generator (seed " << seed << "): obstacle " << i + 1 << " of " << count
           << " reaches the robot's start within start_clear_s = " << config.start_clear_s << " s on every one of "
           << config.max_attempts << " draws";
        throw ScenarioError(os.str());
      }
    }
    s.obstacles.push_back(o);
  }
  return s;
}

}  // namespace dqn_dovs::sim
