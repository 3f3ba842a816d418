// planner_node's navigation: where the robot is asked to go and how it gets there. The goals (the move_base action,
// move_base_simple/goal, planner/cancel), the goal re-placed in the fixed frame every control period, the route to it
// (planned on the map or taken from a nav_msgs/Path, followed and planned again by the ROS-free RouteGuide as the
// evaluation's Episode follows it) and the local goal (and route ahead) published for dovs_node. The goal life cycle
// itself is the Supervisor's; this class tells it about goals and reads its state for the action's result.
#pragma once

#include <actionlib/server/simple_action_server.h>
#include <geometry_msgs/PoseStamped.h>
#include <move_base_msgs/MoveBaseAction.h>
#include <nav_msgs/OccupancyGrid.h>
#include <nav_msgs/Path.h>
#include <ros/ros.h>
#include <sensor_msgs/LaserScan.h>
#include <std_msgs/Empty.h>
#include <tf2_ros/buffer.h>

#include <deque>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "dqn_dovs/Dovs.h"
#include "dqn_dovs/common/robot_model.h"
#include "dqn_dovs/planning/route.h"
#include "dqn_dovs/supervision/supervisor.h"

namespace dqn_dovs {

class PlannerNavigation {
 public:
  /// Reads use_goal_yaw, action_name and route/* (ParameterError naming the culprit), loads route/map_file, then
  /// advertises, subscribes and starts the action server. `route_points`: the network's route points (it publishes
  /// planner/route_ahead when there are any).
  PlannerNavigation(ros::NodeHandle nh, ros::NodeHandle pnh, const std::string& fixed_frame,
                    const std::string& base_frame, const RobotLimits& limits, int route_points, Supervisor& supervisor,
                    tf2_ros::Buffer& tf_buffer);

  /// Every control period, before the supervisor's: the goal re-placed in the fixed frame (localisation moves the map
  /// against odom), handed to the supervisor and published on planner/local_goal (and planner/route_ahead).
  void refreshGoal(bool is_new = false);
  /// Every control period, after the supervisor's: an aborted goal is forgotten; the action's feedback, or its end.
  void afterControlPeriod(const ros::Time& now);

  /// The last scan (the laser's returns tell the route guide a route is blocked).
  void setLastScan(const sensor_msgs::LaserScan::ConstPtr& scan) { last_scan_ = scan; }

  /// Why `dovs` was not built for the current goal ("" when it was built for one of its recent local goals).
  std::string localGoalFault(const Dovs& dovs) const;
  /// Why the goal cannot be placed in the fixed frame now ("" when it can).
  const std::string& goalFault() const { return goal_fault_; }
  bool hasGoal() const { return goal_.has_value(); }
  /// The goal's own frame ("" without a goal).
  std::string goalFrame() const { return goal_ ? goal_->header.frame_id : std::string(); }
  /// Whether a route is followed, and its length left to the goal (m; -1 before the first control period of a
  /// route).
  bool hasRoute() const { return route_guide_.hasRoute(); }
  double routeRemaining() const { return route_remaining_m_; }

  bool useGoalYaw() const { return use_goal_yaw_; }
  void setUseGoalYaw(bool on) { use_goal_yaw_ = on; }
  const RouteGuideConfig& routeGuideConfig() const { return route_guide_.config(); }
  /// Throws RouteError naming the field when `config` is not valid (the settings in force stay).
  void setRouteGuideConfig(const RouteGuideConfig& config) { route_guide_.setConfig(config); }

 private:
  void onGoal(const geometry_msgs::PoseStamped::ConstPtr& msg);
  void onCancel(const std_msgs::Empty::ConstPtr& msg);
  void onActionGoal();     // move_base action: a new goal (it preempts the one before)
  void onActionPreempt();  // move_base action: the client cancelled
  void onMap(const nav_msgs::OccupancyGrid::ConstPtr& msg);
  void onPath(const nav_msgs::Path::ConstPtr& msg);
  /// Accepts `goal` (any frame tf knows) as the goal; `source` names where it came from for the log. Returns why
  /// it was refused ("" when accepted); a refused goal leaves the robot stopped with that reason.
  std::string acceptGoal(const geometry_msgs::PoseStamped& goal, const std::string& source);
  /// Forgets the goal, its local goals and its route (cancelled, aborted, replaced).
  void dropGoal();
  /// Plans the route to the goal on the map (route_planner_), from the robot, around the obstacle points the laser
  /// found on routes to this goal within route/obstacle_memory s (route_guide_); "" when planned (or there is no
  /// map: the goal is driven at straight), else why there is no route.
  std::string planRoute();
  /// Publishes route_guide_'s route on planner/route and logs it.
  void publishRoute();
  /// The point the velocity space is built for now: route_guide_'s subgoal on the route (its frame converted to
  /// the fixed frame), or the goal itself; replans as route_guide_ decides; sets route_remaining_m_ and the route
  /// ahead.
  Vec2 localGoal(const Vec2& goal_fixed);
  /// The last scan's returns in the route's frame (obstacles the map does not have), empty when tf cannot place it.
  std::vector<Vec2> scanPointsInRouteFrame();
  /// The action's feedback, and its end when the goal was reached, aborted or dropped.
  void updateAction(const ros::Time& now);

  ros::NodeHandle nh_, pnh_;
  std::string fixed_frame_, base_frame_;
  int route_points_ = 0;
  Supervisor& supervisor_;
  tf2_ros::Buffer& tf_buffer_;
  bool use_goal_yaw_ = true;

  // The goal as it was given (its own frame) and the stamp that names it on planner/local_goal and in the Dovs
  // messages built for it; goal_fault_ says why it cannot be placed in the fixed frame now ("" when it can).
  std::optional<geometry_msgs::PoseStamped> goal_;
  ros::Time goal_id_;
  std::string goal_fault_;
  // The local goals published for the current goal over the last second (ROS time, position in the fixed frame):
  // a Dovs built for none of them is not used.
  std::deque<std::pair<double, Vec2>> local_goals_;

  // The route to the goal (route_frame_): planned on the map, or taken from a nav_msgs/Path; none: straight at it.
  // route_guide_ holds it and decides the subgoal and the replanning, as the evaluation's Episode does.
  RouteConfig route_config_;  ///< route/inflation, route/allow_unknown and the robot radius, read once at start
  std::unique_ptr<RoutePlanner> route_planner_;
  std::string map_frame_, route_frame_;
  RouteGuide route_guide_;
  double route_remaining_m_ = -1.0;
  int route_replans_ = 0;
  std::vector<Vec2> route_ahead_fixed_;  ///< the route's next metres (fixed frame), for planner/route_ahead
  sensor_msgs::LaserScan::ConstPtr last_scan_;

  std::unique_ptr<actionlib::SimpleActionServer<move_base_msgs::MoveBaseAction>> action_server_;
  ros::Subscriber goal_sub_, cancel_sub_, map_sub_, path_sub_;
  ros::Publisher local_goal_pub_, route_pub_;
  // planner/route_ahead: the route's next metres (fixed frame) beside each local goal, for a network with route
  // points (dovs_node puts them in the state); empty without a route.
  ros::Publisher route_ahead_pub_;
};

}  // namespace dqn_dovs
