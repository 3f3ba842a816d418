#include "dovs_node.h"

#include <cv_bridge/cv_bridge.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/image_encodings.h>
#include <tf2/exceptions.h>
#include <tf2_geometry_msgs/tf2_geometry_msgs.h>

#include <cmath>

#include "conversions.h"
#include "dqn_dovs/Dovs.h"
#include "dqn_dovs/dovs_render.h"
#include "pipeline_steps.h"
#include "ros_params.h"

namespace dqn_dovs {

DovsConfig loadDovsConfig(const ros::NodeHandle& pnh) {
  DovsConfig c;
  c.obstacle_range_m = param<double>(pnh, "dovs/obstacle_range", c.obstacle_range_m);
  c.safety_factor = param<double>(pnh, "dovs/safety_factor", c.safety_factor);
  c.num_trajectories = param<int>(pnh, "dovs/num_trajectories", c.num_trajectories);
  c.time_horizon_s = param<double>(pnh, "dovs/time_horizon", c.time_horizon_s);
  c.static_reaction_time_s = param<double>(pnh, "dovs/static_reaction_time", c.static_reaction_time_s);
  c.static_margin_m = param<double>(pnh, "dovs/static_margin", c.static_margin_m);
  const std::string error = c.validate();
  if (!error.empty()) throw ParameterError(pnh.resolveName("dovs") + ": " + error);
  return c;
}

ActionShieldConfig loadActionShieldConfig(const ros::NodeHandle& pnh) {
  ActionShieldConfig c;
  c.enabled = param<bool>(pnh, "action_shield/enabled", c.enabled);
  c.robust_dv_mps = param<double>(pnh, "action_shield/robust_dv", c.robust_dv_mps);
  c.robust_dw_rps = param<double>(pnh, "action_shield/robust_dw", c.robust_dw_rps);
  c.last_resort_horizon_s = param<double>(pnh, "action_shield/last_resort_horizon", c.last_resort_horizon_s);
  c.last_resort_step_s = param<double>(pnh, "action_shield/last_resort_step", c.last_resort_step_s);
  c.last_resort_tolerance_s = param<double>(pnh, "action_shield/last_resort_tolerance", c.last_resort_tolerance_s);
  c.last_resort_clearance_tolerance_m =
      param<double>(pnh, "action_shield/last_resort_clearance_tolerance", c.last_resort_clearance_tolerance_m);
  c.escape_enabled = param<bool>(pnh, "action_shield/escape", c.escape_enabled);
  c.escape_window_samples = param<int>(pnh, "action_shield/escape_window_samples", c.escape_window_samples);
  c.passive_escape = param<bool>(pnh, "action_shield/passive_escape", c.passive_escape);
  c.passive_actions = param<bool>(pnh, "action_shield/passive_actions", c.passive_actions);
  c.rest_speed_mps = param<double>(pnh, "action_shield/rest_speed", c.rest_speed_mps);
  c.dodge_advantage_s = param<double>(pnh, "action_shield/dodge_advantage", c.dodge_advantage_s);
  c.slowest_contact = param<bool>(pnh, "action_shield/slowest_contact", c.slowest_contact);
  c.passive_margin_m = param<double>(pnh, "action_shield/passive_margin", c.passive_margin_m);
  c.passive_margin_growth_mps = param<double>(pnh, "action_shield/passive_margin_growth", c.passive_margin_growth_mps);
  c.statics = loadStaticSafetyConfig(pnh);
  const std::string error = c.validate();
  if (!error.empty()) throw ParameterError(pnh.resolveName("action_shield") + ": " + error);
  return c;
}

DovsNode::DovsNode(ros::NodeHandle nh, ros::NodeHandle pnh)
    : nh_(nh),
      pnh_(pnh),
      limits_(loadRobotLimits(pnh)),
      builder_(limits_, loadDovsConfig(pnh)),
      tf_listener_(tf_buffer_) {
  fixed_frame_ = param<std::string>(pnh_, "fixed_frame", "odom");
  base_frame_ = param<std::string>(pnh_, "base_frame", "base_footprint");
  if (fixed_frame_.empty() || base_frame_.empty()) throw ParameterError("fixed_frame and base_frame must not be empty");
  max_input_age_s_ = paramInRange(pnh_, "max_input_age", 0.5, 0.05, 5.0);
  tf_timeout_s_ = paramInRange(pnh_, "tf_timeout", 0.05, 0.0, 1.0);
  image_size_px_ = static_cast<int>(paramInRange(pnh_, "image_size", 400, 100, 2000));
  checkRobotDescription(nh_, limits_, base_frame_, param<std::string>(pnh_, "laser_frame", "laser"));
  normalization_ = dovsStateNormalization(limits_, builder_.config());
  shield_ = loadActionShieldConfig(pnh_);

  dovs_pub_ = nh_.advertise<Dovs>("dovs", 5);
  image_pub_ = nh_.advertise<sensor_msgs::Image>("dovs/image", 2);
  obstacles_sub_ = nh_.subscribe("obstacles", 5, &DovsNode::onObstacles, this, ros::TransportHints().tcpNoDelay());
  odom_sub_ = nh_.subscribe("odom", 10, &DovsNode::onOdom, this, ros::TransportHints().tcpNoDelay());
  goal_sub_ = nh_.subscribe("move_base_simple/goal", 2, &DovsNode::onGoal, this);
  action_sub_ = nh_.subscribe("planner/action", 2, &DovsNode::onChosenAction, this);
  ROS_INFO("dovs: robot frame '%s' in '%s', %d trajectories, horizon %.1f s", base_frame_.c_str(),
           fixed_frame_.c_str(), builder_.config().num_trajectories, builder_.config().time_horizon_s);
}

void DovsNode::onOdom(const nav_msgs::Odometry::ConstPtr& msg) {
  if (!std::isfinite(msg->twist.twist.linear.x) || !std::isfinite(msg->twist.twist.angular.z)) {
    ROS_WARN_THROTTLE(2.0, "dovs: odom twist has NaN/inf; ignored");
    return;
  }
  last_odom_ = *msg;
  have_odom_ = true;
}

void DovsNode::onChosenAction(const std_msgs::Int8::ConstPtr& msg) {
  // 0-7 an action; 8 (the shield's escape) and -1 mark none of the 8 in the image.
  chosen_action_ = msg->data >= 0 && msg->data < kNumActions ? msg->data : -1;
}

void DovsNode::onGoal(const geometry_msgs::PoseStamped::ConstPtr& msg) {
  if (!std::isfinite(msg->pose.position.x) || !std::isfinite(msg->pose.position.y)) {
    ROS_ERROR("dovs: goal ignored: its position has NaN/inf");
    return;
  }
  if (msg->header.frame_id.empty()) {
    ROS_ERROR("dovs: goal ignored: empty header.frame_id");
    return;
  }
  geometry_msgs::PoseStamped in_fixed;
  try {
    // Latest transform: a goal is a place, not an instant.
    geometry_msgs::PoseStamped latest = *msg;
    latest.header.stamp = ros::Time(0);
    in_fixed = tf_buffer_.transform(latest, fixed_frame_, ros::Duration(0.2));
  } catch (const tf2::TransformException& e) {
    ROS_ERROR("dovs: goal ignored: no transform from '%s' to '%s': %s", msg->header.frame_id.c_str(),
              fixed_frame_.c_str(), e.what());
    return;
  }
  goal_ = Vec2(in_fixed.pose.position.x, in_fixed.pose.position.y);
  ROS_INFO("dovs: goal (%.2f, %.2f) in '%s'", goal_->x(), goal_->y(), fixed_frame_.c_str());
}

void DovsNode::onObstacles(const TrackedObstacleArray::ConstPtr& msg) {
  if (msg->header.frame_id != fixed_frame_) {
    ROS_WARN_THROTTLE(2.0, "dovs: obstacles in frame '%s', expected the fixed frame '%s'; dropped",
                      msg->header.frame_id.c_str(), fixed_frame_.c_str());
    return;
  }
  if (!have_odom_) {
    ROS_WARN_THROTTLE(2.0, "dovs: no odom yet; cannot build the velocity space");
    return;
  }
  const double odom_age = (msg->header.stamp - last_odom_.header.stamp).toSec();
  if (std::abs(odom_age) > max_input_age_s_) {
    ROS_WARN_THROTTLE(2.0, "dovs: odom is %.2f s away from the obstacles' stamp (limit %.2f s); not publishing",
                      odom_age, max_input_age_s_);
    return;
  }
  geometry_msgs::TransformStamped tf;
  try {
    tf = tf_buffer_.lookupTransform(fixed_frame_, base_frame_, msg->header.stamp, ros::Duration(tf_timeout_s_));
  } catch (const tf2::TransformException& e) {
    ROS_WARN_THROTTLE(2.0, "dovs: no transform %s <- %s at the obstacles' stamp: %s", fixed_frame_.c_str(),
                      base_frame_.c_str(), e.what());
    return;
  }
  Pose2 robot_pose;
  if (!poseFromTransform(tf.transform, robot_pose)) {
    ROS_WARN_THROTTLE(2.0, "dovs: robot transform has NaN/inf; not publishing");
    return;
  }
  const Twist2 odom_twist{last_odom_.twist.twist.linear.x, last_odom_.twist.twist.angular.z};
  if (!limits_.feasible(odom_twist, 0.05 * limits_.v_max)) {
    ROS_WARN_THROTTLE(2.0, "dovs: odom velocity (%.2f m/s, %.2f rad/s) is outside the robot limits; clipped",
                      odom_twist.v, odom_twist.w);
  }
  DovsStep step;
  try {
    const std::string obstacle_error = buildDovsStep(*msg, robot_pose, odom_twist, goal_, limits_, normalization_,
                                                     shield_, base_frame_, builder_, dovs_, step);
    if (!obstacle_error.empty()) {
      ROS_WARN_THROTTLE(2.0, "dovs: obstacles dropped: %s; not publishing", obstacle_error.c_str());
      return;
    }
  } catch (const std::exception& e) {
    ROS_ERROR_THROTTLE(2.0, "dovs: cannot build the velocity space: %s", e.what());
    return;
  }
  const Dovs& out = step.msg;
  dovs_pub_.publish(out);

  if (image_pub_.getNumSubscribers() > 0) {
    const cv::Mat image = renderDovs(dovs_, step.actions, step.observation.robot_twist, chosen_action_, image_size_px_);
    cv_bridge::CvImage bridge(out.header, sensor_msgs::image_encodings::BGR8, image);
    image_pub_.publish(bridge.toImageMsg());
  }
}

}  // namespace dqn_dovs
