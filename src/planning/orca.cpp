#include "dqn_dovs/planning/orca.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <utility>

namespace dqn_dovs {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

inline Vec2 rotate(const Vec2& v, double angle) {
  const double c = std::cos(angle), s = std::sin(angle);
  return {c * v.x() - s * v.y(), s * v.x() + c * v.y()};
}

std::string bad(const char* field, double value, const std::string& why) {
  std::ostringstream os;
  os << "orca parameter '" << field << "' = " << value << ": " << why;
  return os.str();
}

}  // namespace

std::string OrcaConfig::validate() const {
  if (!(std::isfinite(time_horizon_s) && time_horizon_s > 0.0))
    return bad("time_horizon_s", time_horizon_s, "must be > 0 s");
  if (!(std::isfinite(obstacle_time_horizon_s) && obstacle_time_horizon_s > 0.0)) {
    return bad("obstacle_time_horizon_s", obstacle_time_horizon_s, "must be > 0 s");
  }
  if (!(std::isfinite(neighbor_dist_m) && neighbor_dist_m > 0.0))
    return bad("neighbor_dist_m", neighbor_dist_m, "must be > 0 m");
  if (max_neighbors < 1) return bad("max_neighbors", max_neighbors, "must be >= 1");
  if (!(std::isfinite(safety_margin_m) && safety_margin_m >= 0.0))
    return bad("safety_margin_m", safety_margin_m, "must be >= 0 m");
  if (!(std::isfinite(preferred_speed_mps) && preferred_speed_mps > 0.0)) {
    return bad("preferred_speed_mps", preferred_speed_mps, "must be > 0 m/s");
  }
  if (!(std::isfinite(arrival_time_s) && arrival_time_s > 0.0))
    return bad("arrival_time_s", arrival_time_s, "must be > 0 s");
  if (!(std::isfinite(goal_tolerance_m) && goal_tolerance_m >= 0.0))
    return bad("goal_tolerance_m", goal_tolerance_m, "must be >= 0 m");
  if (!(std::isfinite(collision_time_step_s) && collision_time_step_s > 0.0)) {
    return bad("collision_time_step_s", collision_time_step_s, "must be > 0 s");
  }
  if (!(std::isfinite(symmetry_breaking_rad) && std::abs(symmetry_breaking_rad) <= 0.5)) {
    return bad("symmetry_breaking_rad", symmetry_breaking_rad, "must be in [-0.5, 0.5] rad");
  }
  if (window_samples < 1 || window_samples > 100) return bad("window_samples", window_samples, "must be in [1, 100]");
  if (!(std::isfinite(tracking_time_s) && tracking_time_s > 0.0))
    return bad("tracking_time_s", tracking_time_s, "must be > 0 s");
  if (!(std::isfinite(effective_centre_distance_m) && effective_centre_distance_m >= 0.0)) {
    return bad("effective_centre_distance_m", effective_centre_distance_m, "must be >= 0 m");
  }
  if (!(std::isfinite(diffdrive_extra_radius_m) && diffdrive_extra_radius_m >= 0.0)) {
    return bad("diffdrive_extra_radius_m", diffdrive_extra_radius_m, "must be >= 0 m");
  }
  if (!(std::isfinite(braking_fraction) && braking_fraction > 0.0 && braking_fraction <= 1.0)) {
    return bad("braking_fraction", braking_fraction, "must be in (0, 1]");
  }
  return {};
}

Twist2 mapVelocityToWindow(const Pose2& pose, const Twist2& current, const Vec2& velocity, const RobotLimits& limits,
                           int window_samples, double tracking_time_s, double effective_centre_m) {
  if (!pose.isFinite() || !velocity.allFinite() || !std::isfinite(current.v) || !std::isfinite(current.w) ||
      !std::isfinite(effective_centre_m)) {
    return decelerationCommand(current, limits);
  }
  const double speed = velocity.norm();
  const Vec2 direction = speed > 1e-9 ? Vec2(velocity / speed) : Vec2(std::cos(pose.theta), std::sin(pose.theta));
  const Vec2 wanted = pose.position() + velocity * tracking_time_s + effective_centre_m * direction;
  const int n = window_samples;
  double best = kInf;
  Twist2 best_twist = decelerationCommand(current, limits);
  for (int i = -n; i <= n; ++i) {
    for (int j = -n; j <= n; ++j) {
      if (std::abs(i) + std::abs(j) > n) continue;
      const Twist2 t{current.v + limits.dv() * i / n, current.w + limits.dw() * j / n};
      if (!limits.feasible(t)) continue;
      const Pose2 end = integrateUnicycle(pose, t.v, t.w, tracking_time_s);
      const Vec2 reached = end.position() + effective_centre_m * Vec2(std::cos(end.theta), std::sin(end.theta));
      // The tiny turn-rate term breaks ties toward driving straight (e.g. when the robot must stop).
      const double cost = (reached - wanted).squaredNorm() + 1e-9 * t.w * t.w;
      if (cost < best) {
        best = cost;
        best_twist = t;
      }
    }
  }
  return best_twist;
}

OrcaCore::OrcaCore(const OrcaConfig& config) : config_(config), rng_(config.lp_seed) {
  const std::string error = config_.validate();
  if (!error.empty()) throw PlannerError(error);
}

void OrcaCore::reset() { rng_.seed(config_.lp_seed); }

OrcaCore::Solution OrcaCore::solve(const Observation& obs, const Vec2& position, const Vec2& velocity,
                                   double robot_radius_m, double max_speed, double speed_cap) {
  Solution sol;
  const Vec2 to_goal = obs.goal - position;
  const double d_goal = to_goal.norm();
  sol.at_goal = d_goal < config_.goal_tolerance_m;
  if (!sol.at_goal) {
    const double speed = std::min({config_.preferred_speed_mps, max_speed, speed_cap, d_goal / config_.arrival_time_s});
    sol.preferred = rotate(to_goal / d_goal, config_.symmetry_breaking_rad) * std::max(0.0, speed);
  }

  lines_.clear();
  const double step = config_.collision_time_step_s;
  const double robot_r = robot_radius_m + config_.safety_margin_m;
  // Walls first: they are the hard constraints of the program.
  const double wall_reach = max_speed * config_.obstacle_time_horizon_s + robot_r;
  for (const Segment& s : obs.segments) {
    if (!(s.a.allFinite() && s.b.allFinite())) continue;
    if (pointSegmentDistance(position, s) > wall_reach) continue;
    lines_.push_back(orcaLineForSegment(position, velocity, robot_r, s, config_.obstacle_time_horizon_s, step));
  }
  const size_t num_hard = lines_.size();

  std::vector<std::pair<double, size_t>> neighbours;
  for (size_t i = 0; i < obs.obstacles.size(); ++i) {
    const MovingObstacle& o = obs.obstacles[i];
    if (!(o.center.allFinite() && std::isfinite(o.radius) && std::isfinite(o.speed) && std::isfinite(o.heading)))
      continue;
    const double gap = (o.center - position).norm() - o.radius - robot_radius_m;
    if (gap <= config_.neighbor_dist_m) neighbours.emplace_back(gap, i);
  }
  std::sort(neighbours.begin(), neighbours.end());
  if (neighbours.size() > static_cast<size_t>(config_.max_neighbors)) neighbours.resize(config_.max_neighbors);
  for (const auto& entry : neighbours) {
    const MovingObstacle& o = obs.obstacles[entry.second];
    const double speed = o.is_static ? 0.0 : o.speed;
    const Vec2 o_velocity(speed * std::cos(o.heading), speed * std::sin(o.heading));
    lines_.push_back(orcaLineForDisc(position, velocity, robot_r, o.center, o_velocity, std::max(0.0, o.radius),
                                     config_.time_horizon_s, step));
  }
  sol.constraints = static_cast<int>(lines_.size());
  const OrcaLpResult lp = solveOrcaLp(lines_, num_hard, max_speed, sol.preferred, &rng_);
  sol.velocity = lp.velocity;
  sol.feasible = lp.feasible;
  return sol;
}

namespace {

void checkInput(const PlannerInput& input, const char* planner) {
  if (input.observation == nullptr) throw PlannerError(std::string(planner) + ": the observation is missing");
  const Observation& o = *input.observation;
  if (!o.robot_pose.isFinite() || !std::isfinite(o.robot_twist.v) || !std::isfinite(o.robot_twist.w) ||
      !o.goal.allFinite()) {
    throw PlannerError(std::string(planner) + ": the robot pose, twist or goal is not finite");
  }
}

Vec2 headingVelocity(const Observation& o) {
  return o.robot_twist.v * Vec2(std::cos(o.robot_pose.theta), std::sin(o.robot_pose.theta));
}

std::string noteOf(const OrcaCore::Solution& s) {
  if (s.at_goal) return "stop_on_goal";
  return s.feasible ? "orca" : "orca_least_violation";
}

}  // namespace

OrcaHolonomicPlanner::OrcaHolonomicPlanner(const OrcaConfig& config) : core_(config) {}

void OrcaHolonomicPlanner::reset() { core_.reset(); }

PlannerDecision OrcaHolonomicPlanner::decide(const PlannerInput& input) {
  checkInput(input, "orca_holonomic");
  const Observation& o = *input.observation;
  const RobotLimits& limits = input.limits;
  const OrcaCore::Solution s =
      core_.solve(o, o.robot_pose.position(), headingVelocity(o), limits.radius, limits.v_max, limits.v_max);
  PlannerDecision d;
  d.holonomic_velocity = s.velocity;
  d.command = mapVelocityToWindow(o.robot_pose, o.robot_twist, s.velocity, limits, core_.config().window_samples,
                                  core_.config().tracking_time_s, core_.config().effective_centre_distance_m);
  d.note = noteOf(s);
  return d;
}

OrcaDiffDrivePlanner::OrcaDiffDrivePlanner(const OrcaConfig& config) : core_(config) {}

void OrcaDiffDrivePlanner::reset() { core_.reset(); }

PlannerDecision OrcaDiffDrivePlanner::decide(const PlannerInput& input) {
  checkInput(input, "orca_diffdrive");
  const Observation& o = *input.observation;
  const RobotLimits& limits = input.limits;
  const OrcaConfig& c = core_.config();
  const double d_goal = (o.goal - o.robot_pose.position()).norm();
  const double braking_cap =
      std::sqrt(2.0 * c.braking_fraction * limits.a_v * std::max(0.0, d_goal - c.goal_tolerance_m));
  const OrcaCore::Solution s = core_.solve(o, o.robot_pose.position(), headingVelocity(o),
                                           limits.radius + c.diffdrive_extra_radius_m, limits.v_max, braking_cap);
  PlannerDecision d;
  d.command = mapVelocityToWindow(o.robot_pose, o.robot_twist, s.velocity, limits, c.window_samples, c.tracking_time_s,
                                  c.effective_centre_distance_m);
  d.note = noteOf(s);
  return d;
}

std::unique_ptr<Planner> makeOrcaHolonomicPlanner() { return std::make_unique<OrcaHolonomicPlanner>(); }
std::unique_ptr<Planner> makeOrcaDiffDrivePlanner() { return std::make_unique<OrcaDiffDrivePlanner>(); }

}  // namespace dqn_dovs
