// ROS adapter of the DQN-DOVS planner: Dovs -> one of the 8 actions per control period -> cmd_vel ramp. The goal
// life cycle, the watchdog that stops the robot on stale or bad input, missing tf, a clock jump or a planner error,
// the ramp and the safety envelope every cmd_vel passes through live in the ROS-free Supervisor
// (include/dqn_dovs/supervision/supervisor.h); this class turns messages, tf and timers into its calls.
#pragma once

#include <actionlib/server/simple_action_server.h>
#include <dynamic_reconfigure/server.h>
#include <geometry_msgs/PoseStamped.h>
#include <move_base_msgs/MoveBaseAction.h>
#include <nav_msgs/OccupancyGrid.h>
#include <nav_msgs/Odometry.h>
#include <nav_msgs/Path.h>
#include <ros/ros.h>
#include <sensor_msgs/LaserScan.h>
#include <std_msgs/Empty.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <deque>
#include <memory>
#include <optional>
#include <string>
#include <utility>

#include "dqn_dovs/BaseSafety.h"
#include "dqn_dovs/Dovs.h"
#include "dqn_dovs/PlannerConfig.h"
#include "dqn_dovs/PlannerRouteConfig.h"
#include "dqn_dovs/PlannerStatus.h"
#include "dqn_dovs/common/robot_model.h"
#include "dqn_dovs/planning/route.h"
#include "dqn_dovs/policy/dovs_decision.h"
#include "dqn_dovs/policy/qnetwork.h"
#include "dqn_dovs/policy/static_safety.h"
#include "dqn_dovs/supervision/safety_envelope.h"
#include "dqn_dovs/supervision/supervisor.h"

namespace dqn_dovs {

class PlannerNode {
 public:
  /// Loads the model and validates parameters; throws (ParameterError, WeightFileError) naming the culprit.
  PlannerNode(ros::NodeHandle nh, ros::NodeHandle pnh);

 private:
  void onDovs(const Dovs::ConstPtr& msg);
  void onOdom(const nav_msgs::Odometry::ConstPtr& msg);
  void onScan(const sensor_msgs::LaserScan::ConstPtr& msg);
  void onGoal(const geometry_msgs::PoseStamped::ConstPtr& msg);
  void onCancel(const std_msgs::Empty::ConstPtr& msg);
  void onActionGoal();     // move_base action: a new goal (it preempts the one before)
  void onActionPreempt();  // move_base action: the client cancelled
  void onBaseSafety(const BaseSafety::ConstPtr& msg);
  void onMap(const nav_msgs::OccupancyGrid::ConstPtr& msg);
  void onPath(const nav_msgs::Path::ConstPtr& msg);
  /// Plans the route to the goal on the map (route_planner_), from the robot, around the obstacle points the laser
  /// found on routes to this goal within route/obstacle_memory s (route_guide_); "" when planned (or there is no
  /// map: the goal is driven at straight), else why there is no route.
  std::string planRoute();
  /// Publishes route_guide_'s route on planner/route and logs it.
  void publishRoute();
  /// The point the velocity space is built for now: route_guide_'s subgoal on the route (its frame converted to
  /// the fixed frame), or the goal itself; replans as route_guide_ decides; sets route_remaining_m_.
  Vec2 localGoal(const Vec2& goal_fixed);
  /// The route planner's settings: robot/radius and route/* parameters.
  RouteConfig routeConfig() const;
  RouteConfig route_config_;  ///< route/inflation, route/allow_unknown and the robot radius, read once at start
  /// The last scan's returns in the route's frame (obstacles the map does not have), empty when tf cannot place it.
  std::vector<Vec2> scanPointsInRouteFrame();
  /// Accepts `goal` (any frame tf knows) as the goal; `source` names where it came from for the log. Returns why
  /// it was refused ("" when accepted); a refused goal leaves the robot stopped with that reason.
  std::string acceptGoal(const geometry_msgs::PoseStamped& goal, const std::string& source);
  /// Every control period: the goal re-transformed from its own frame into the fixed frame (localisation moves
  /// the map against odom), handed to the supervisor (as a new goal when `is_new`) and published on planner/local_goal
  /// for dovs_node.
  void refreshGoal(bool is_new = false);
  /// Forgets the goal, its local goals and its route (cancelled, aborted, replaced).
  void dropGoal();
  /// Why `dovs` was not built for the current goal ("" when it was built for one of its recent local goals).
  std::string localGoalFault(const Dovs& dovs) const;
  /// The action's feedback, and its end when the goal was reached, aborted or dropped.
  void updateAction(const ros::Time& now);
  void onDecide(const ros::TimerEvent& event);  // once per control period
  void onRamp(const ros::TimerEvent& event);    // >= 20 Hz command ramp
  /// The supervisor's clock check; after a backward jump the last velocity space and the tf buffer are dropped.
  void checkClock(const ros::Time& now);
  /// The robot in the fixed frame from tf, waiting up to wait_s (the supervisor checks its age and finiteness).
  RobotPoseLookup robotPose(double wait_s);
  /// The decision for the robot at `pose`: the network's action or the shield's escape from the last Dovs, then
  /// the static last line against the geometry the Dovs carries.
  Choice choose(const Pose2& pose);
  /// Why a scan is unusable for driving ("" when usable): malformed, wrong size, too many NaN beams, a frame
  /// tf does not know.
  std::string scanFault(const sensor_msgs::LaserScan& msg);
  /// The network's action for last_dovs_ (computed once per message); -1 with `why` when there is none.
  int actionForLastDovs(std::string& why);
  void publishStatus(const ros::Time& now, double goal_distance);
  void onDiagnostics(const ros::TimerEvent& event);  // 1 Hz: /diagnostics from the last status
  /// dynamic_reconfigure: applies `config` (cfg/Planner.cfg), or puts the settings in force back into it with
  /// the reason in the log when the supervisor refuses them.
  void onReconfigure(PlannerConfig& config, uint32_t level);
  /// The settings in force, as cfg/Planner.cfg names them.
  PlannerConfig reconfigurable() const;
  /// The same for route/* (cfg/PlannerRoute.cfg, on the `route` namespace: route/lookahead, route/replan_off_route).
  void onReconfigureRoute(PlannerRouteConfig& config, uint32_t level);
  PlannerRouteConfig reconfigurableRoute() const;

  ros::NodeHandle nh_, pnh_;
  std::string fixed_frame_, base_frame_;
  RobotLimits limits_;
  StaticSafetyConfig statics_;
  uint32_t static_corrections_ = 0;
  std::string static_last_;
  double tf_timeout_s_ = 0.05, scan_max_nan_fraction_ = 0.5;
  std::unique_ptr<QNetwork> network_;
  // Goal life cycle, input watchdog, clock-jump latch, ramp through the safety envelope, deadlines (ROS-free).
  Supervisor supervisor_;
  DecisionHooks hooks_;

  Dovs::ConstPtr last_dovs_;
  // The goal as it was given (its own frame) and the stamp that names it on planner/local_goal and in the Dovs
  // messages built for it; goal_fault_ says why it cannot be placed in the fixed frame now ("" when it can).
  std::optional<geometry_msgs::PoseStamped> goal_;
  ros::Time goal_id_;
  std::string goal_fault_;
  bool use_goal_yaw_ = true;
  // The route to the goal (route_frame_): planned on the map, or taken from a nav_msgs/Path; none: straight at it.
  // route_guide_ holds it and decides the subgoal and the replanning, as the evaluation's Episode does.
  std::unique_ptr<RoutePlanner> route_planner_;
  std::string map_frame_, route_frame_;
  RouteGuide route_guide_;
  double route_remaining_m_ = -1.0;
  int route_replans_ = 0;
  sensor_msgs::LaserScan::ConstPtr last_scan_;
  // The local goals published for the current goal over the last second (ROS time, position in the fixed frame):
  // a Dovs built for none of them is not used.
  std::deque<std::pair<double, Vec2>> local_goals_;
  std::unique_ptr<actionlib::SimpleActionServer<move_base_msgs::MoveBaseAction>> action_server_;
  Dovs::ConstPtr chosen_for_;     // the message chosen_decision_, chosen_action_ and chosen_why_ belong to
  DovsDecision chosen_decision_;  // its decision fields (state, actions, escape, static geometry)
  int chosen_action_ = -1;
  std::string chosen_why_;
  uint32_t stamped_seq_ = 0;  // planner/cmd_vel_stamped sequence

  tf2_ros::Buffer tf_buffer_;
  tf2_ros::TransformListener tf_listener_;
  ros::Subscriber dovs_sub_, odom_sub_, scan_sub_, goal_sub_, cancel_sub_, safety_sub_, map_sub_, path_sub_;
  ros::Publisher cmd_pub_, cmd_stamped_pub_, status_pub_, action_pub_, latency_pub_, local_goal_pub_, route_pub_;
  // planner/route_ahead: the route's next metres (fixed frame) beside each local goal, for a network with route
  // points (dovs_node puts them in the state); empty without a route.
  ros::Publisher route_ahead_pub_;
  std::vector<Vec2> route_ahead_fixed_;
  ros::Timer decide_timer_, ramp_timer_, diagnostics_timer_;
  ros::Publisher diagnostics_pub_;
  std::unique_ptr<dynamic_reconfigure::Server<PlannerConfig>> reconfigure_server_;
  std::unique_ptr<dynamic_reconfigure::Server<PlannerRouteConfig>> reconfigure_route_server_;
  PlannerStatus last_status_, last_reported_;
};

}  // namespace dqn_dovs
