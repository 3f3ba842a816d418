// DWA, the Dynamic Window Approach (Fox, Burgard and Thrun 1997), as a baseline planner: velocities sampled in
// the dynamic window, each held and simulated forward against the obstacles predicted on their own constant
// (v, w), kept when the robot can still brake before any predicted contact, and scored by goal progress, heading,
// clearance and speed. Parameter names follow ROS's dwa_local_planner where they mean the same. ROS-free.
// Formulation and parameters: docs/planners.md.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "dqn_dovs/planning/planner.h"

namespace dqn_dovs {

/// Parameters of the DWA planner. Defaults live here only.
struct DwaConfig {
  /// Number of linear-speed samples across the dynamic window (dwa_local_planner `vx_samples`).
  int vx_samples = 8;
  /// Number of turn-rate samples at each linear speed, across the window's width there (`vth_samples`).
  int vth_samples = 15;
  /// Each sample is held and simulated forward for this long, s (`sim_time`).
  double sim_time_s = 2.0;
  /// Largest distance the robot, plus the fastest obstacle, moves between two checked points of a
  /// simulated trajectory, m (`sim_granularity`).
  double sim_granularity_m = 0.025;
  /// Largest heading change between two checked points, rad (`angular_sim_granularity`).
  double angular_sim_granularity_rad = 0.1;
  /// Weight of the goal distance of the trajectory's forward point, per metre (`goal_distance_bias`). As in
  /// dwa_local_planner, the distance is measured on a grid by a wavefront from the goal around the static
  /// obstacles and walls (a navigation function), not in a straight line: a straight-line goal term traps DWA in
  /// front of any obstacle on the goal line. There is no global path here, so `path_distance_bias` has no
  /// counterpart: the navigation function plays the role of the path.
  double goal_distance_bias = 1.0;
  /// Weight of Fox's heading term: |angle between the end pose's heading and the navigation function's descent
  /// direction at the end position| / pi (toward the goal itself once in its cell).
  double heading_bias = 0.2;
  /// Cell size of the navigation-function grid, m.
  double grid_resolution_m = 0.1;
  /// The grid covers the bounding box of the robot and the goal grown by this much on every side, m.
  double grid_margin_m = 2.0;
  /// Obstacles slower than this enter the navigation function as static (the others only enter the forward
  /// simulation, since they will not be where they are now), m/s.
  double static_speed_mps = 0.1;
  /// Weight of the clearance term (`occdist_scale`): 0 beyond inflation_radius_m of clearance, rising to 1 at
  /// safety_margin_m, and 1 for a trajectory with a predicted contact that braking avoids. The level the goal
  /// position itself has (a goal near a wall) is subtracted, so that the term never keeps the robot off its goal.
  double occdist_scale = 0.3;
  /// Clearance (surface to surface) below which the clearance term grows, m (the costmap inflation radius).
  double inflation_radius_m = 0.3;
  /// Weight of Fox's velocity term: |v_ref - v| / v_max, with v_ref the fastest speed that still stops on the goal.
  double speed_bias = 0.4;
  /// The goal distance is measured from the point this far ahead of the end pose (`forward_point_distance`), or
  /// from the goal's distance ahead when that is shorter; it rewards ending the trajectory facing the goal, m.
  double forward_point_distance_m = 0.325;
  /// A simulated trajectory whose clearance drops below this is in contact, m.
  double safety_margin_m = 0.05;
  /// Fox's admissibility (`stop_time_buffer`), s: a sample with a predicted contact is kept only when the robot,
  /// holding it for this long and then braking at a_v along the same arc, stops without contact with the
  /// predicted obstacles. Against static obstacles this is Fox's v^2 / (2 a_v) + v * buffer <= distance to contact.
  double stop_time_buffer_s = 0.2;
  /// true: obstacles move on their own constant (v, w) during the forward simulation; false: they are frozen
  /// where they are now, as on the costmap of dwa_local_planner.
  bool predict_obstacles = true;
  /// Inside this distance to the goal the robot brakes to a stop, m (`xy_goal_tolerance`; the episode's is 0.15).
  double goal_tolerance_m = 0.12;
  /// Braking rule: speeds above sqrt(2 * braking_fraction * a_v * (d_goal - goal_tolerance_m)) are not sampled
  /// (unless the window holds nothing slower), so the robot stops on the goal with its real deceleration.
  double braking_fraction = 0.7;

  /// Empty when consistent, otherwise a message naming the offending field and why.
  std::string validate() const;
};

/// One simulated sample, as DwaPlanner scores it.
struct DwaTrajectory {
  Twist2 velocity;
  bool admissible = false;        ///< no predicted contact, or the robot can still brake to a stop without one
  bool contact = false;           ///< a contact is predicted within sim_time_s
  double contact_distance_m = 0;  ///< arc length to the first predicted contact (when contact)
  double contact_time_s = 0;      ///< time of the first predicted contact (+inf without contact)
  double min_clearance_m = 0;     ///< smallest clearance up to the end or the contact
  double cost = 0;                ///< weighted sum of the four terms (lower is better)
};

/// Grid distance to the goal around static obstacles and walls (dwa_local_planner's goal distance map): a
/// Dijkstra wavefront on 8-connected cells from the goal's cell. Cells whose centre is closer than the robot
/// radius to a wall segment, or closer than the sum of radii to a static disc, are blocked.
class DwaNavigationGrid {
 public:
  DwaNavigationGrid(const Observation& obs, const RobotLimits& limits, const DwaConfig& config);
  /// Path distance from p to the goal, m: the value of p's cell plus the straight distance to the cell centre;
  /// for a point off the grid or in a blocked or unreachable cell, the straight distance to the goal plus a
  /// penalty of the grid's diagonal (so that such points always rank behind reachable ones).
  double distance(const Vec2& p) const;
  /// Unit direction of steepest descent of the distance at p (toward the goal in its own cell and off the grid).
  Vec2 descent(const Vec2& p) const;
  bool reachable(const Vec2& p) const;

 private:
  long cellOf(const Vec2& p) const;
  Vec2 centreOf(long cell) const;

  Vec2 origin_ = Vec2::Zero();
  Vec2 goal_ = Vec2::Zero();
  double resolution_ = 0.1;
  long cols_ = 0, rows_ = 0;
  std::vector<double> value_;
};

class DwaPlanner : public Planner {
 public:
  /// Throws PlannerError when config.validate() fails.
  explicit DwaPlanner(const DwaConfig& config = DwaConfig());

  std::string name() const override { return "dwa"; }
  void reset() override {}
  /// Throws PlannerError when input.observation is null or the pose, twist or goal is not finite. The command
  /// always lies in the dynamic window and the feasible set. With no admissible sample it is the sample whose
  /// predicted contact comes latest (the note says `no_admissible_velocity`).
  PlannerDecision decide(const PlannerInput& input) override;

  /// Every sample of the window around the observation's twist, simulated and scored (the decision's candidates).
  std::vector<DwaTrajectory> evaluate(const Observation& obs, const RobotLimits& limits) const;

  const DwaConfig& config() const { return config_; }

 private:
  DwaTrajectory simulate(const Observation& obs, const RobotLimits& limits, const Twist2& velocity,
                         const std::vector<size_t>& nearby, double v_ref, const DwaNavigationGrid& grid,
                         double clearance_floor) const;

  DwaConfig config_;
};

/// Factory for the planner registry (default configuration).
std::unique_ptr<Planner> makeDwaPlanner();

}  // namespace dqn_dovs
