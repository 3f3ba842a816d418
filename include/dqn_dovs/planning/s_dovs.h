// S-DOVS: the strategy-based planner on the Dynamic Object Velocity Space (the paper's main baseline).
// Strategies, the order they are tried in and every constant are documented in docs/planners.md. ROS-free.
#pragma once

#include <string>
#include <vector>

#include "dqn_dovs/planning/planner.h"
#include "dqn_dovs/policy/static_safety.h"

namespace dqn_dovs {

/// Parameters of the S-DOVS planner. Defaults live here only.
struct SDovsConfig {
  /// The dynamic window is sampled on a grid of (2 n + 1) x (2 n + 1) points of its rhombus coordinates
  /// (a, b) = ((v' - v) / dv, (w' - w) / dw), keeping |a| + |b| <= 1 and the feasible ones; n = this value.
  int window_samples = 10;
  /// The goal counts as reached closer than this: the robot only brakes there, m (the episode's 0.15 m).
  double goal_tolerance_m = 0.15;
  /// Braking rule: the speed may not exceed sqrt(arrival_speed^2 + 2 * braking_fraction * a_v * (d -
  /// arrival_distance)), so that the robot crosses into the goal tolerance below the success speed. Speed at the
  /// arrival distance, m/s.
  double arrival_speed_mps = 0.15;
  /// Braking rule: distance to the goal at which the speed must be down to arrival_speed_mps, m.
  double arrival_distance_m = 0.12;
  /// Braking rule: fraction of a_v planned for braking; the rest absorbs the one-period delay of the commands.
  double braking_fraction = 0.8;
  /// Strategy (a) "goal" applies only while the goal's bearing is within this angle of the heading: beyond it the
  /// circle through the goal is a long detour and the turn-first options of the time-to-goal heuristic win, rad.
  double direct_goal_angle_rad = 0.8;
  /// Strategy (a): the goal line counts as free when every sample from the lowest speed of the window up to the
  /// goal speed is free; samples are this far apart in v, m/s.
  double goal_line_step_mps = 0.02;
  /// Strategy (c) "escape" starts when fewer than this fraction of the window samples are free.
  double escape_free_fraction = 0.08;
  /// Strategy (b): targets keep this far in speed from the edges of the free interval they are taken from
  /// (when the interval is wide enough), so that tracking noise does not put them in the DOV at once, m/s.
  double target_speed_margin_mps = 0.05;
  /// Time-to-goal heuristic: a target velocity is held for at most this long before the robot is assumed to
  /// head straight for the goal, s.
  double lookahead_s = 3.0;
  /// Time step of the forward roll-outs (time-to-goal heuristic and escape time to collision), s.
  double rollout_step_s = 0.1;
  /// Time-to-goal heuristic: after the held velocity, the rest of the way is costed as distance / v_max plus
  /// this factor times |heading error| / w_max (turning while slow costs more than the bare turn time).
  double turn_cost_factor = 1.5;
  /// Roll-outs and the clearance penalty inflate obstacles like the DOVS does: (r + robot radius) * this.
  double safety_factor = 1.1;
  /// Clearance (surface to surface, true radii) below which a target is penalised, m.
  double comfort_clearance_m = 0.3;
  /// Penalty per metre of clearance missing below comfort_clearance_m, s/m.
  double clearance_penalty_s_per_m = 4.0;
  /// Escape roll-outs look this far ahead for the first collision, s.
  double escape_horizon_s = 3.0;
  /// A window sample counts as robustly free when it is free and so are its neighbours this far away in v ...
  double robust_dv_mps = 0.03;
  /// ... and in w (rad/s). Robustly free samples are preferred: tracker noise then rarely makes them unsafe.
  double robust_dw_rps = 0.15;
  /// The static braking rule (static_safety.h) every command passes last: a command whose braking trajectory
  /// reaches static geometry is replaced by the nearest statically safe velocity of the window.
  StaticSafetyConfig statics;

  /// Empty when consistent, otherwise a message naming the offending field and why.
  std::string validate() const;
};

/// Strategy-based planner on the DOVS. Each decision: (d) brake on the goal; (c) escape when nearly the whole
/// window is unsafe; (a) head to the goal along the goal line, as fast as is free and still allows stopping on
/// the goal; (b) otherwise pick a free target velocity anywhere in the DOVS - passing in front of an obstacle
/// (above its DOV band), behind it (below), or around - by a time-to-goal heuristic; then step to the free window
/// sample closest to the target.
class SDovsPlanner : public Planner {
 public:
  /// Throws PlannerError when config.validate() fails.
  explicit SDovsPlanner(const SDovsConfig& config = SDovsConfig());

  std::string name() const override { return "s_dovs"; }
  void reset() override {}
  /// Throws PlannerError when input.observation or input.dovs is null or the robot pose, twist or goal is not
  /// finite. The returned command always lies in the dynamic window and the feasible set; it is free in the DOVS
  /// whenever any window sample is.
  PlannerDecision decide(const PlannerInput& input) override;

  const SDovsConfig& config() const { return config_; }

  /// Braking rule: the largest speed that still allows stopping on a goal d_goal_m away (see SDovsConfig).
  double brakingSpeedCap(double d_goal_m, const RobotLimits& limits) const;

  /// The dynamic-window samples of `current` (feasible only), in a fixed order.
  std::vector<Twist2> windowSamples(const Twist2& current, const RobotLimits& limits) const;

 private:
  PlannerDecision plan(const PlannerInput& input) const;  // the strategies, before the static rule
  SDovsConfig config_;
};

}  // namespace dqn_dovs
