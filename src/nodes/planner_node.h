// ROS wrapper of the DQN-DOVS planner: Dovs -> one of the 8 actions per control period -> cmd_vel ramp.
// Owns the goal life cycle (new goal, cancel, reached), the watchdog that stops the robot on stale or bad
// input, missing tf, a clock jump or a planner error, and the safety envelope every cmd_vel passes through.
#pragma once

#include <geometry_msgs/PoseStamped.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <sensor_msgs/LaserScan.h>
#include <std_msgs/Empty.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <memory>
#include <optional>
#include <string>

#include "dqn_dovs/Dovs.h"
#include "dqn_dovs/PlannerStatus.h"
#include "dqn_dovs/qnetwork.h"
#include "dqn_dovs/robot_model.h"
#include "dqn_dovs/safety_envelope.h"
#include "dqn_dovs/static_safety.h"

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
  void onDecide(const ros::TimerEvent& event);  // once per control period
  void onRamp(const ros::TimerEvent& event);    // >= 20 Hz command ramp
  /// Picks the target velocity for the next period; returns why it must stop instead (empty when fine).
  std::string decide(const ros::Time& now, std::optional<double>& goal_distance);
  /// Why the inputs cannot be trusted now ("" when they can): a clock jump not yet recovered from, a rejected
  /// scan or odom, stale / missing / future-stamped scan, odom, dovs or robot transform. Waits up to tf_wait_s
  /// for the transform; fills `pose` (robot in the fixed frame) when given and the inputs are good.
  std::string inputFault(const ros::Time& now, double tf_wait_s, Pose2* pose);
  /// Detects the clock jumping backwards or forwards (sim time reset, bag loop, a stalled process) since the
  /// last call; a jump latches a stop until the robot is at rest and the inputs are fresh again.
  void checkClock(const ros::Time& now);
  /// Why a scan is unusable for driving ("" when usable): malformed, wrong size, too many NaN beams, a frame
  /// tf does not know.
  std::string scanFault(const sensor_msgs::LaserScan& msg);
  /// Brakes to zero (within the limits) because of `reason`; warns (throttled) when the reason is new.
  void halt(const std::string& reason);
  /// The network's action for last_dovs_ (computed once per message); -1 with `why` when there is none.
  int actionForLastDovs(std::string& why);
  void stop(const std::string& reason);
  void publishStatus(const ros::Time& now, double goal_distance);

  ros::NodeHandle nh_, pnh_;
  std::string fixed_frame_, base_frame_;
  RobotLimits limits_;
  StaticSafetyConfig statics_;
  uint32_t static_corrections_ = 0;
  std::string static_last_;
  double max_input_age_s_ = 0.5, goal_tolerance_m_ = 0.15, goal_speed_mps_ = 0.2, ramp_rate_hz_ = 50.0;
  double tf_timeout_s_ = 0.05, scan_max_nan_fraction_ = 0.5, deadline_fraction_ = 0.5;
  std::unique_ptr<QNetwork> network_;

  uint8_t state_ = PlannerStatus::IDLE;
  std::string reason_;
  int action_ = -1;
  std::optional<Vec2> goal_;  // fixed frame
  Dovs::ConstPtr last_dovs_;
  Dovs::ConstPtr chosen_for_;  // the message chosen_action_ / chosen_why_ belong to
  int chosen_action_ = -1;
  std::string chosen_why_;
  ros::Time last_odom_stamp_, last_scan_stamp_;
  bool have_odom_ = false, have_scan_ = false;
  std::string scan_fault_, odom_fault_;  // why the last scan / odom was rejected ("" when it was good)
  ros::Time last_clock_;                 // node clock at the previous checkClock()
  std::string clock_fault_;              // a clock jump not yet recovered from
  Twist2 target_;   // velocity to reach by the end of the current period
  Twist2 command_;  // last published command (the ramp's state)
  int idle_zero_messages_ = 0;

  // Safety envelope of the published stream (checked just before every cmd_vel).
  SafetyEnvelope envelope_;
  ros::Time last_publish_;  // node clock at the last cmd_vel
  uint32_t stamped_seq_ = 0;  // planner/cmd_vel_stamped sequence
  // Control-period deadlines: a period whose decision started more than deadline_fraction_ * dt late.
  uint32_t control_periods_ = 0, deadline_misses_ = 0;
  double max_lateness_s_ = 0.0;

  tf2_ros::Buffer tf_buffer_;
  tf2_ros::TransformListener tf_listener_;
  ros::Subscriber dovs_sub_, odom_sub_, scan_sub_, goal_sub_, cancel_sub_;
  ros::Publisher cmd_pub_, cmd_stamped_pub_, status_pub_, action_pub_, latency_pub_;
  ros::Timer decide_timer_, ramp_timer_;
};

}  // namespace dqn_dovs
