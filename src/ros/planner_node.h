// ROS adapter of the DQN-DOVS planner: Dovs -> one of the 8 actions per control period -> cmd_vel ramp. This class is
// the supervision adapter: the goal life cycle, the watchdog that stops the robot on stale or bad input, missing tf, a
// clock jump or a planner error, the ramp and the safety envelope every cmd_vel passes through live in the ROS-free
// Supervisor (include/dqn_dovs/supervision/supervisor.h), and this class turns odom, scans, base safety, tf and
// timers into its calls, publishes the commands, the status and the diagnostics, and runs the runtime tuning. Where
// the robot goes is PlannerNavigation's (goals, the move_base action, routes); what it does on each velocity space is
// PlannerDecisionAdapter's (the network and the static last line).
#pragma once

#include <dynamic_reconfigure/server.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <sensor_msgs/LaserScan.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <memory>
#include <string>

#include "dqn_dovs/BaseSafety.h"
#include "dqn_dovs/PlannerConfig.h"
#include "dqn_dovs/PlannerRouteConfig.h"
#include "dqn_dovs/PlannerStatus.h"
#include "dqn_dovs/common/robot_model.h"
#include "dqn_dovs/supervision/supervisor.h"
#include "planner_decision.h"
#include "planner_navigation.h"

namespace dqn_dovs {

class PlannerNode {
 public:
  /// Loads the model and validates parameters; throws (ParameterError, WeightFileError) naming the culprit.
  PlannerNode(ros::NodeHandle nh, ros::NodeHandle pnh);

 private:
  void onOdom(const nav_msgs::Odometry::ConstPtr& msg);
  void onScan(const sensor_msgs::LaserScan::ConstPtr& msg);
  void onBaseSafety(const BaseSafety::ConstPtr& msg);
  void onDecide(const ros::TimerEvent& event);  // once per control period
  void onRamp(const ros::TimerEvent& event);    // >= 20 Hz command ramp
  /// The supervisor's clock check; after a backward jump the last velocity space and the tf buffer are dropped.
  void checkClock(const ros::Time& now);
  /// The robot in the fixed frame from tf, waiting up to wait_s (the supervisor checks its age and finiteness).
  RobotPoseLookup robotPose(double wait_s);
  /// Why a scan is unusable for driving ("" when usable): malformed, wrong size, too many NaN beams, a frame
  /// tf does not know.
  std::string scanFault(const sensor_msgs::LaserScan& msg);
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
  double tf_timeout_s_ = 0.05, scan_max_nan_fraction_ = 0.5;
  // Goal life cycle, input watchdog, clock-jump latch, ramp through the safety envelope, deadlines (ROS-free).
  Supervisor supervisor_;
  DecisionHooks hooks_;
  uint32_t stamped_seq_ = 0;  // planner/cmd_vel_stamped sequence

  tf2_ros::Buffer tf_buffer_;
  tf2_ros::TransformListener tf_listener_;
  std::unique_ptr<PlannerDecisionAdapter> decision_;
  std::unique_ptr<PlannerNavigation> navigation_;
  ros::Subscriber odom_sub_, scan_sub_, safety_sub_;
  ros::Publisher cmd_pub_, cmd_stamped_pub_, status_pub_, action_pub_, diagnostics_pub_;
  ros::Timer decide_timer_, ramp_timer_, diagnostics_timer_;
  std::unique_ptr<dynamic_reconfigure::Server<PlannerConfig>> reconfigure_server_;
  std::unique_ptr<dynamic_reconfigure::Server<PlannerRouteConfig>> reconfigure_route_server_;
  PlannerStatus last_status_, last_reported_;
};

}  // namespace dqn_dovs
