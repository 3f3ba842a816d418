// ROS wrapper of the DOVS: tracked obstacles + robot state (tf, odom) + goal -> Dovs message, the
// network state, and an image of the velocity space for rviz.
#pragma once

#include <geometry_msgs/PoseStamped.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <std_msgs/Int8.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <optional>
#include <string>

#include "dqn_dovs/TrackedObstacleArray.h"
#include "dqn_dovs/dovs/actions.h"
#include "dqn_dovs/dovs/dovs.h"
#include "dqn_dovs/dovs/state.h"
#include "dqn_dovs/policy/action_shield.h"

namespace dqn_dovs {

class DovsNode {
 public:
  /// Reads and validates parameters (throws ParameterError naming the culprit), then subscribes.
  DovsNode(ros::NodeHandle nh, ros::NodeHandle pnh);

 private:
  void onObstacles(const TrackedObstacleArray::ConstPtr& msg);
  void onOdom(const nav_msgs::Odometry::ConstPtr& msg);
  void onGoal(const geometry_msgs::PoseStamped::ConstPtr& msg);
  void onChosenAction(const std_msgs::Int8::ConstPtr& msg);

  ros::NodeHandle nh_, pnh_;
  std::string fixed_frame_, base_frame_;
  double max_input_age_s_ = 0.5, tf_timeout_s_ = 0.05;
  int image_size_px_ = 400;
  RobotLimits limits_;
  DovsBuilder builder_;
  StateNormalization normalization_;
  ActionShieldConfig shield_;
  VelocitySpace dovs_;

  std::optional<Vec2> goal_;  // in fixed_frame_
  nav_msgs::Odometry last_odom_;
  bool have_odom_ = false;
  int chosen_action_ = -1;

  tf2_ros::Buffer tf_buffer_;
  tf2_ros::TransformListener tf_listener_;
  ros::Subscriber obstacles_sub_, odom_sub_, goal_sub_, action_sub_;
  ros::Publisher dovs_pub_, image_pub_;
};

}  // namespace dqn_dovs
