#include "dovs_node.h"

#include <cv_bridge/cv_bridge.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/image_encodings.h>
#include <tf2/exceptions.h>
#include <tf2_geometry_msgs/tf2_geometry_msgs.h>

#include <boost/make_shared.hpp>
#include <cmath>
#include <limits>
#include <utility>

#include "conversions.h"
#include "dqn_dovs/Dovs.h"
#include "dqn_dovs/maps/occupancy_map.h"
#include "dqn_dovs/render/dovs_render.h"
#include "pipeline_steps.h"
#include "ros_params.h"

namespace dqn_dovs {

DovsNode::DovsNode(ros::NodeHandle nh, ros::NodeHandle pnh)
    : nh_(nh),
      pnh_(pnh),
      limits_(loadRobotLimits(pnh)),
      builder_(limits_, loadDovsConfig(pnh)),
      tf_waiter_(tf_buffer_),
      tf_listener_(tf_buffer_),
      image_transport_(nh) {
  fixed_frame_ = param<std::string>(pnh_, "fixed_frame", "odom");
  base_frame_ = param<std::string>(pnh_, "base_frame", "base_footprint");
  if (fixed_frame_.empty() || base_frame_.empty()) throw ParameterError("fixed_frame and base_frame must not be empty");
  max_input_age_s_ = paramInRange(pnh_, "max_input_age", 0.5, 0.05, 5.0);
  tf_timeout_s_ = paramInRange(pnh_, "tf_timeout", 0.05, 0.0, 1.0);
  image_size_px_ = static_cast<int>(paramInRange(pnh_, "image_size", 400, 100, 2000));
  checkRobotDescription(nh_, limits_, base_frame_, param<std::string>(pnh_, "laser_frame", "laser"));
  normalization_ = stateNormalization(limits_, builder_.config());
  shield_ = loadActionShieldConfig(pnh_);
  if (const std::string file = param<std::string>(pnh_, "people_predictor", ""); !file.empty()) {
    try {
      predicted_arcs_ =
          std::make_unique<PredictedArcs>(std::make_shared<const PeoplePredictor>(PeoplePredictor::load(file)));
    } catch (const PeoplePredictorError& e) {
      throw ParameterError(std::string("people_predictor: ") + e.what());
    }
    ROS_INFO("dovs: moving tracks take the arcs of the learned prediction in '%s'", file.c_str());
  }

  dovs_pub_ = nh_.advertise<Dovs>("dovs", 5);
  image_pub_ = image_transport_.advertise("dovs/image", 2);
  obstacles_sub_ = nh_.subscribe("obstacles", 5, &DovsNode::onObstacles, this, ros::TransportHints().tcpNoDelay());
  odom_sub_ = nh_.subscribe("odom", 10, &DovsNode::onOdom, this, ros::TransportHints().tcpNoDelay());
  goal_sub_ = nh_.subscribe("move_base_simple/goal", 2, &DovsNode::onGoal, this);
  action_sub_ = nh_.subscribe("planner/action", 2, &DovsNode::onChosenAction, this);
  use_map_ = param<bool>(pnh_, "use_map", false);
  map_range_m_ = paramInRange(pnh_, "map_range", 4.0, 0.5, 50.0);
  map_unknown_is_occupied_ = param<bool>(pnh_, "map_unknown_is_occupied", false);
  planner_name_ = param<std::string>(pnh_, "planner", "dqn_dovs");
  if (const std::string why = robotPlannerFault(planner_name_); !why.empty()) {
    throw ParameterError("parameter '" + pnh_.resolveName("planner") + "': " + why);
  }
  if (planner_name_ != "dqn_dovs") {
    planner_ = makePlanner(planner_name_, "", &shield_, &normalization_);  // the registry's, as the evaluation's
    ROS_INFO("dovs: %s decides on each velocity space (the Dovs message carries its command)", planner_name_.c_str());
  }
  // Every parameter is read above: a key under this node that none of them names is a typo (ParameterError).
  refuseUnknownParameters(pnh_);
  if (use_map_) map_sub_ = nh_.subscribe("map", 1, &DovsNode::onMap, this);
  if (normalization_.route_points > 0)
    route_ahead_sub_ = nh_.subscribe("planner/route_ahead", 2, &DovsNode::onRouteAhead, this);
  ROS_INFO("dovs: robot frame '%s' in '%s', %d trajectories, horizon %.1f s", base_frame_.c_str(), fixed_frame_.c_str(),
           builder_.config().num_trajectories, builder_.config().time_horizon_s);
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
  const bool same_goal = goal_ && goal_stamp_ == msg->header.stamp;
  goal_ = Vec2(in_fixed.pose.position.x, in_fixed.pose.position.y);
  goal_stamp_ = msg->header.stamp;
  // The planner republishes its goal every control period (re-transformed, or the next point of a route) with
  // the stamp it gave the goal: only a new stamp is a new goal worth a log line.
  if (!same_goal && planner_) planner_->reset();
  if (same_goal) {
    ROS_DEBUG("dovs: goal moved to (%.2f, %.2f) in '%s'", goal_->x(), goal_->y(), fixed_frame_.c_str());
  } else {
    ROS_INFO("dovs: goal (%.2f, %.2f) in '%s'", goal_->x(), goal_->y(), fixed_frame_.c_str());
  }
}

void DovsNode::onRouteAhead(const nav_msgs::Path::ConstPtr& msg) {
  if (msg->header.frame_id != fixed_frame_ && !msg->poses.empty()) {
    ROS_ERROR_THROTTLE(2.0, "dovs: planner/route_ahead ignored: in frame '%s', expected the fixed frame '%s'",
                       msg->header.frame_id.c_str(), fixed_frame_.c_str());
    return;
  }
  std::vector<Vec2> points;
  if (const std::string why = pathPointsFromMsg(*msg, points); !why.empty()) {
    ROS_ERROR_THROTTLE(2.0, "dovs: planner/route_ahead ignored: %s", why.c_str());
    return;
  }
  route_ahead_ = std::move(points);
  route_ahead_stamp_ = msg->header.stamp;
}

void DovsNode::onMap(const nav_msgs::OccupancyGrid::ConstPtr& msg) {
  std::vector<Segment> walls;
  const std::string error = mapWallsFromMsg(*msg, map_unknown_is_occupied_, walls);
  if (!error.empty()) {
    ROS_ERROR("dovs: map ignored (the previous one, if any, is kept): %s", error.c_str());
    return;
  }
  map_walls_ = std::move(walls);
  map_frame_ = msg->header.frame_id;
  ROS_INFO("dovs: map of %u x %u cells at %.3f m in '%s': %zu wall segments", msg->info.width, msg->info.height,
           msg->info.resolution, map_frame_.c_str(), map_walls_.size());
}

void DovsNode::addMapWalls(TrackedObstacleArray& obstacles, const Pose2& robot, const ros::Time& stamp) {
  if (map_walls_.empty()) return;
  Pose2 map_in_fixed;
  const std::string why = tf_waiter_.lookupPose(fixed_frame_, map_frame_, stamp, tf_timeout_s_, map_in_fixed);
  if (!why.empty()) {
    ROS_WARN_THROTTLE(2.0, "dovs: map walls left out: %s (the obstacles' stamp)", why.c_str());
    return;
  }
  dqn_dovs::addMapWalls(map_walls_, map_in_fixed, robot, map_range_m_, obstacles);
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
  Pose2 robot_pose;
  const std::string why =
      tf_waiter_.lookupPose(fixed_frame_, base_frame_, msg->header.stamp, tf_timeout_s_, robot_pose);
  if (!why.empty()) {
    ROS_WARN_THROTTLE(2.0, "dovs: not publishing: %s (the obstacles' stamp)", why.c_str());
    return;
  }
  const Twist2 odom_twist{last_odom_.twist.twist.linear.x, last_odom_.twist.twist.angular.z};
  if (!limits_.feasible(odom_twist, 0.05 * limits_.v_max)) {
    ROS_WARN_THROTTLE(2.0, "dovs: odom velocity (%.2f m/s, %.2f rad/s) is outside the robot limits; clipped",
                      odom_twist.v, odom_twist.w);
  }
  // The map's walls join the scan's (a copy of the message only when there are any to add).
  TrackedObstacleArray with_map;
  const TrackedObstacleArray* obstacles = msg.get();
  if (use_map_ && !map_walls_.empty()) {
    with_map = *msg;
    addMapWalls(with_map, robot_pose, msg->header.stamp);
    obstacles = &with_map;
  }
  DovsStep step;
  try {
    const std::string obstacle_error = buildDovsStep(
        *obstacles, robot_pose, odom_twist, goal_, limits_, normalization_, shield_, base_frame_, builder_, dovs_, step,
        predicted_arcs_.get(), &track_history_, route_ahead_stamp_ == goal_stamp_ ? &route_ahead_ : nullptr);
    if (!obstacle_error.empty()) {
      ROS_WARN_THROTTLE(2.0, "dovs: obstacles dropped: %s; not publishing", obstacle_error.c_str());
      return;
    }
  } catch (const std::exception& e) {
    ROS_ERROR_THROTTLE(2.0, "dovs: cannot build the velocity space: %s", e.what());
    return;
  }
  step.msg.planner = planner_name_;
  if (planner_ && goal_) {
    PlannerInput input;
    input.observation = &step.observation;
    input.dovs = &dovs_;
    input.actions = &step.actions;
    input.limits = limits_;
    try {
      const PlannerDecision d = planner_->decide(input);
      step.msg.planner_v = d.command.v;
      step.msg.planner_w = d.command.w;
      step.msg.planner_action = static_cast<int8_t>(d.action);
      step.msg.planner_note = d.note;
    } catch (const std::exception& e) {  // planner_node halts on a non-finite command, with the note as the reason
      step.msg.planner_v = step.msg.planner_w = std::numeric_limits<double>::quiet_NaN();
      step.msg.planner_action = -1;
      step.msg.planner_note = std::string("planner error: ") + e.what();
    }
  }
  // The goal it was built for: the planner acts only on velocity spaces of its own goal.
  step.msg.goal_stamp = goal_stamp_;
  step.msg.goal_x = goal_ ? goal_->x() : 0.0;
  step.msg.goal_y = goal_ ? goal_->y() : 0.0;
  // Published as a shared pointer: a planner nodelet in the same manager gets this very message, not a copy.
  const Dovs::ConstPtr shared = boost::make_shared<Dovs>(std::move(step.msg));
  const Dovs& out = *shared;
  dovs_pub_.publish(shared);

  if (image_pub_.getNumSubscribers() > 0) {
    const cv::Mat image = renderDovs(dovs_, step.actions, step.observation.robot_twist, chosen_action_, image_size_px_);
    cv_bridge::CvImage bridge(out.header, sensor_msgs::image_encodings::BGR8, image);
    image_pub_.publish(bridge.toImageMsg());
  }
}

}  // namespace dqn_dovs
