// ORCA (Optimal Reciprocal Collision Avoidance, van den Berg et al. 2011) as two baseline planners: one for a
// holonomic robot without acceleration limits (how the paper ran the CrowdNav baselines) and one mapped to the
// differential-drive (v, w) inside the dynamic window. The obstacles of this project never react to the robot, so
// the robot takes the whole avoidance effort on itself (responsibility 1 instead of ORCA's 1/2). ROS-free.
// Formulation, parameters and execution: docs/planners.md.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "dqn_dovs/common/orca_lp.h"
#include "dqn_dovs/planning/planner.h"

namespace dqn_dovs {

/// Parameters shared by both ORCA planners. Defaults live here only.
struct OrcaConfig {
  /// Time horizon of the velocity obstacles of disc obstacles, s: velocities that would bring the robot into
  /// contact within this time are forbidden. Longer is safer but more conservative.
  double time_horizon_s = 2.0;
  /// Time horizon of the velocity obstacles of wall segments, s (walls never move, so a shorter horizon lets the
  /// robot drive along them).
  double obstacle_time_horizon_s = 1.0;
  /// Disc obstacles whose surface is farther than this from the robot's surface are ignored, m.
  double neighbor_dist_m = 4.0;
  /// At most this many disc obstacles (the closest ones) give constraints.
  int max_neighbors = 10;
  /// Added to the sum of radii of every robot-obstacle pair and to the robot radius against walls, m.
  double safety_margin_m = 0.05;
  /// Preferred speed toward the goal, m/s; capped by the robot's v_max.
  double preferred_speed_mps = 0.7;
  /// The preferred speed shrinks to distance / arrival_time_s near the goal, so the robot lands on it and stops.
  double arrival_time_s = 0.6;
  /// Inside this distance to the goal the preferred velocity is zero, m (the episode's 0.15 m tolerance).
  double goal_tolerance_m = 0.12;
  /// The preferred velocity is turned counter-clockwise by this angle, rad. A velocity obstacle straight ahead
  /// on the goal line is symmetric, and ORCA's closest-velocity rule then only slows the robot down in front of it
  /// (a standstill); the small bias picks a side, as the perturbed preferred velocities of ORCA simulations do.
  double symmetry_breaking_rad = 0.05;
  /// Time step used when the robot already overlaps an obstacle (inflated by the margin): the constraint then
  /// asks to leave the overlap within this time, s. The control period is the natural value.
  double collision_time_step_s = 0.2;
  /// Seed of the random constraint order of the linear program (randomised incremental algorithm).
  uint64_t lp_seed = 1;

  // Differential-drive mapping (orca_diffdrive only).
  /// The (v, w) candidates are the dynamic window sampled on a (2 n + 1) x (2 n + 1) grid of its rhombus
  /// coordinates, keeping |a| + |b| <= 1 and the feasible ones; n = this value.
  int window_samples = 10;
  /// A candidate (v, w) is held this long and its end position compared with where the ORCA velocity leads in
  /// the same time, s. Longer than the control period so that turning toward a sideways ORCA velocity pays off.
  double tracking_time_s = 0.8;
  /// The mapping compares a point this far ahead of the axle (an effective centre) rather than the axle itself:
  /// its target is the axle's target plus this distance along the ORCA velocity, so that the heading counts too
  /// and a robot at rest turns toward an ORCA velocity behind it instead of waiting, m.
  double effective_centre_distance_m = 0.2;
  /// Extra radius of the robot for orca_diffdrive, m: a differential drive only approximates the ORCA velocity
  /// (NH-ORCA's tracking error bound), so it keeps this much more distance.
  double diffdrive_extra_radius_m = 0.1;
  /// orca_diffdrive braking rule: the preferred speed never exceeds sqrt(2 * braking_fraction * a_v * d_goal),
  /// so that the robot can stop on the goal with its real deceleration.
  double braking_fraction = 0.7;

  /// Empty when consistent, otherwise a message naming the offending field and why.
  std::string validate() const;
};

/// The differential-drive mapping of a holonomic velocity: among the dynamic-window samples of `current` (the
/// (2 n + 1) x (2 n + 1) rhombus grid, n = window_samples, feasible ones only), the (v, w) that brings the
/// effective centre (the point effective_centre_m ahead of the axle) closest, after tracking_time_s, to
/// pose + velocity * tracking_time_s + effective_centre_m * (unit velocity; the current heading when the velocity
/// is zero). Falls back to decelerationCommand when no sample is feasible or the input is not finite.
Twist2 mapVelocityToWindow(const Pose2& pose, const Twist2& current, const Vec2& velocity, const RobotLimits& limits,
                           int window_samples, double tracking_time_s, double effective_centre_m);

/// Shared machinery of both ORCA planners: neighbour selection, constraint lines, preferred velocity, LP.
class OrcaCore {
 public:
  /// Throws PlannerError when config.validate() fails.
  explicit OrcaCore(const OrcaConfig& config);
  void reset();

  struct Solution {
    Vec2 velocity = Vec2::Zero();   ///< the ORCA velocity (fixed frame)
    Vec2 preferred = Vec2::Zero();  ///< the preferred velocity it was computed from
    bool feasible = true;
    int constraints = 0;   ///< number of ORCA lines
    bool at_goal = false;  ///< within goal_tolerance_m of the goal
  };

  /// ORCA velocity for a robot at `position` moving at `velocity` (fixed frame), radius `robot_radius_m`, speed
  /// limit `max_speed`, toward the observation's goal with preferred speed capped at `speed_cap`.
  Solution solve(const Observation& obs, const Vec2& position, const Vec2& velocity, double robot_radius_m,
                 double max_speed, double speed_cap);

  const OrcaConfig& config() const { return config_; }

 private:
  OrcaConfig config_;
  std::mt19937_64 rng_;
  std::vector<OrcaLine> lines_;
};

/// ORCA for a holonomic robot without acceleration limits. The decision carries the ORCA velocity in
/// PlannerDecision::holonomic_velocity (executed by Episode::stepDecision); `command` holds the same velocity
/// mapped to the dynamic window as orca_diffdrive does, for callers that drive a differential robot.
class OrcaHolonomicPlanner : public Planner {
 public:
  /// Throws PlannerError when config.validate() fails.
  explicit OrcaHolonomicPlanner(const OrcaConfig& config = OrcaConfig());
  std::string name() const override { return "orca_holonomic"; }
  void reset() override;
  /// Throws PlannerError when input.observation is null or the pose, twist or goal is not finite.
  PlannerDecision decide(const PlannerInput& input) override;
  const OrcaConfig& config() const { return core_.config(); }

 private:
  OrcaCore core_;
};

/// ORCA mapped to a differential drive: the ORCA velocity u is computed for the robot's real velocity (heading
/// times v) with the radius enlarged by diffdrive_extra_radius_m, then the command is the dynamic-window sample
/// (v, w) whose effective centre after tracking_time_s is closest to where u leads it (mapVelocityToWindow).
class OrcaDiffDrivePlanner : public Planner {
 public:
  /// Throws PlannerError when config.validate() fails.
  explicit OrcaDiffDrivePlanner(const OrcaConfig& config = OrcaConfig());
  std::string name() const override { return "orca_diffdrive"; }
  void reset() override;
  /// Throws PlannerError when input.observation is null or the pose, twist or goal is not finite. The command
  /// always lies in the dynamic window and the feasible set.
  PlannerDecision decide(const PlannerInput& input) override;
  const OrcaConfig& config() const { return core_.config(); }

 private:
  OrcaCore core_;
};

/// Factories for the planner registry (default configuration).
std::unique_ptr<Planner> makeOrcaHolonomicPlanner();
std::unique_ptr<Planner> makeOrcaDiffDrivePlanner();

}  // namespace dqn_dovs
