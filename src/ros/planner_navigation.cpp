#include "planner_navigation.h"

#include <tf2/exceptions.h>
#include <tf2_geometry_msgs/tf2_geometry_msgs.h>

#include <cmath>

#include "conversions.h"
#include "dqn_dovs/dovs/state.h"
#include "dqn_dovs/maps/occupancy_map.h"
#include "dqn_dovs/planning/route_map.h"
#include "pipeline_steps.h"
#include "ros_params.h"

namespace dqn_dovs {

PlannerNavigation::PlannerNavigation(ros::NodeHandle nh, ros::NodeHandle pnh, const std::string& fixed_frame,
                                     const std::string& base_frame, const RobotLimits& limits, int route_points,
                                     Supervisor& supervisor, tf2_ros::Buffer& tf_buffer)
    : nh_(nh),
      pnh_(pnh),
      fixed_frame_(fixed_frame),
      base_frame_(base_frame),
      route_points_(route_points),
      supervisor_(supervisor),
      tf_buffer_(tf_buffer) {
  use_goal_yaw_ = param<bool>(pnh_, "use_goal_yaw", true);
  const std::string action_name = param<std::string>(pnh_, "action_name", "move_base");
  // Routes: on the occupancy grid of the map topic or of a map file (route/map_file), or a nav_msgs/Path from any
  // global planner on `route` (it replaces ours for the goal it ends at).
  RouteGuideConfig guide;
  guide.lookahead_m = paramInRange(pnh_, "route/lookahead", guide.lookahead_m, 1.0, 8.0);
  guide.replan_off_route_m = paramInRange(pnh_, "route/replan_off_route", guide.replan_off_route_m, 0.2, 10.0);
  guide.obstacle_memory_s = paramInRange(pnh_, "route/obstacle_memory", guide.obstacle_memory_s, 0.0, 3600.0);
  route_guide_.setConfig(guide);
  route_config_.robot_radius_m = limits.radius;
  route_config_.inflation_m = param<double>(pnh_, "route/inflation", route_config_.inflation_m);
  route_config_.allow_unknown = param<bool>(pnh_, "route/allow_unknown", route_config_.allow_unknown);
  if (const std::string e = route_config_.validate(); !e.empty()) {
    throw ParameterError(pnh_.resolveName("route") + ": " + e);
  }
  const bool route_enabled = param<bool>(pnh_, "route/enabled", true);
  const std::string map_file = param<std::string>(pnh_, "route/map_file", "");
  const std::string map_file_frame = param<std::string>(pnh_, "route/map_frame", "map");
  if (route_enabled && !map_file.empty()) {
    OccupancyMap map;
    try {
      map = loadOccupancyMap(map_file);
    } catch (const std::exception& e) {
      throw ParameterError("route/map_file: " + std::string(e.what()));
    }
    map_frame_ = map_file_frame;
    route_planner_ = std::make_unique<RoutePlanner>(routeGridFromMap(map), route_config_);
    ROS_INFO("planner: routes on '%s' (%d x %d cells of %.3f m) in '%s'", map_file.c_str(), map.width, map.height,
             map.resolution_m, map_frame_.c_str());
  }

  goal_sub_ = nh_.subscribe("move_base_simple/goal", 2, &PlannerNavigation::onGoal, this);
  cancel_sub_ = nh_.subscribe("planner/cancel", 2, &PlannerNavigation::onCancel, this);
  local_goal_pub_ = nh_.advertise<geometry_msgs::PoseStamped>("planner/local_goal", 5);
  if (route_points_ > 0) route_ahead_pub_ = nh_.advertise<nav_msgs::Path>("planner/route_ahead", 5);
  route_pub_ = nh_.advertise<nav_msgs::Path>("planner/route", 1, true);
  if (route_enabled) {
    if (map_file.empty()) map_sub_ = nh_.subscribe("map", 1, &PlannerNavigation::onMap, this);
    path_sub_ = nh_.subscribe("route", 1, &PlannerNavigation::onPath, this);
  }
  action_server_ =
      std::make_unique<actionlib::SimpleActionServer<move_base_msgs::MoveBaseAction>>(nh_, action_name, false);
  action_server_->registerGoalCallback([this] { onActionGoal(); });
  action_server_->registerPreemptCallback([this] { onActionPreempt(); });
  action_server_->start();
}

void PlannerNavigation::afterControlPeriod(const ros::Time& now) {
  if (supervisor_.state() == GoalState::kAborted && goal_) dropGoal();
  updateAction(now);
}

void PlannerNavigation::onGoal(const geometry_msgs::PoseStamped::ConstPtr& msg) {
  if (action_server_->isActive()) {
    action_server_->setPreempted(move_base_msgs::MoveBaseResult(), "replaced by a goal on move_base_simple/goal");
  }
  acceptGoal(*msg, "move_base_simple/goal");
}

void PlannerNavigation::onActionGoal() {
  const move_base_msgs::MoveBaseGoal::ConstPtr goal = action_server_->acceptNewGoal();
  if (!goal) return;
  if (action_server_->isPreemptRequested()) {
    // Cancelled before it could start.
    action_server_->setPreempted(move_base_msgs::MoveBaseResult(), "cancelled before it started");
    return;
  }
  const std::string refused = acceptGoal(goal->target_pose, "move_base action");
  if (!refused.empty()) action_server_->setAborted(move_base_msgs::MoveBaseResult(), refused);
}

void PlannerNavigation::onActionPreempt() {
  // actionlib calls this for its current goal handle even when that goal is over (a late cancel): then the goal
  // being pursued (from move_base_simple/goal, say) is not the one cancelled.
  if (!action_server_->isActive()) return;
  supervisor_.cancel();
  dropGoal();
  action_server_->setPreempted(move_base_msgs::MoveBaseResult(), "cancelled");
}

void PlannerNavigation::dropGoal() {
  goal_.reset();
  local_goals_.clear();
  route_guide_.clear();  // the supervisor counts the rounds of each goal afresh
  route_remaining_m_ = -1.0;
}

std::string PlannerNavigation::acceptGoal(const geometry_msgs::PoseStamped& goal, const std::string& source) {
  dropGoal();
  const auto& p = goal.pose.position;
  const auto& q = goal.pose.orientation;
  std::string refused;
  if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(q.x) || !std::isfinite(q.y) || !std::isfinite(q.z) ||
      !std::isfinite(q.w)) {
    refused = "goal rejected: its pose has NaN/inf";
  } else if (goal.header.frame_id.empty()) {
    refused = "goal rejected: empty header.frame_id";
  } else if (std::string tf_error; !tf_buffer_.canTransform(fixed_frame_, goal.header.frame_id, ros::Time(0),
                                                            ros::Duration(0.2), &tf_error)) {
    refused = "goal rejected: no transform from '" + goal.header.frame_id + "' to '" + fixed_frame_ + "': " + tf_error;
  }
  if (!refused.empty()) {
    supervisor_.rejectGoal(refused);
    return refused;
  }
  goal_ = goal;
  // The stamp that names this goal on planner/local_goal and in the Dovs built for it: the goal's own stamp (a
  // dovs_node fed the same goal directly agrees), made unique when two goals carry the same one.
  ros::Time id = goal.header.stamp;
  if (id == goal_id_) id += ros::Duration(0, 1000);
  goal_id_ = id;
  goal_fault_.clear();
  refreshGoal(true);
  if (!goal_fault_.empty()) {
    supervisor_.rejectGoal(goal_fault_);
    dropGoal();
    return goal_fault_;
  }
  if (const std::string no_route = planRoute(); !no_route.empty()) {
    supervisor_.rejectGoal(no_route);
    dropGoal();
    return no_route;
  }
  const Vec2 fixed = *supervisor_.goal();
  ROS_INFO("planner: new goal from %s: (%.2f, %.2f) in '%s' = (%.2f, %.2f) in '%s'%s", source.c_str(), p.x, p.y,
           goal.header.frame_id.c_str(), fixed.x(), fixed.y(), fixed_frame_.c_str(),
           use_goal_yaw_ ? ", with its heading" : "");
  return {};
}

void PlannerNavigation::refreshGoal(bool is_new) {
  if (!goal_) return;
  geometry_msgs::PoseStamped in_fixed;
  try {
    // The latest transform: a goal is a place, not an instant; where the map lies in odom changes with every
    // localisation update.
    geometry_msgs::PoseStamped latest = *goal_;
    latest.header.stamp = ros::Time(0);
    in_fixed = tf_buffer_.transform(latest, fixed_frame_);
  } catch (const tf2::TransformException& e) {
    goal_fault_ =
        "no transform from the goal's frame '" + goal_->header.frame_id + "' to '" + fixed_frame_ + "': " + e.what();
    return;
  }
  goal_fault_.clear();
  const Vec2 goal(in_fixed.pose.position.x, in_fixed.pose.position.y);
  std::optional<double> yaw;
  const auto& q = in_fixed.pose.orientation;
  const double qn = std::sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w);
  if (use_goal_yaw_ && qn > 1e-6) yaw = std::atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z));
  if (is_new) {
    supervisor_.newGoal(goal, yaw, ros::Time::now().toSec());
  } else {
    supervisor_.moveGoal(goal, yaw);
  }
  // dovs_node builds the velocity space for this point (remapped to planner/local_goal by pipeline.launch).
  route_ahead_fixed_.clear();
  const Vec2 target = is_new ? goal : localGoal(goal);
  if (route_ahead_pub_) {  // before the local goal: dovs_node takes the route ahead published under its stamp
    std_msgs::Header header;
    header.stamp = goal_id_;
    header.frame_id = fixed_frame_;
    route_ahead_pub_.publish(pathToMsg(route_ahead_fixed_, header));
  }
  geometry_msgs::PoseStamped local;
  local.header.stamp = goal_id_;
  local.header.frame_id = fixed_frame_;
  local.pose.position.x = target.x();
  local.pose.position.y = target.y();
  local.pose.orientation.w = 1.0;
  local_goal_pub_.publish(local);
  const double now = ros::Time::now().toSec();
  local_goals_.emplace_back(now, target);
  while (local_goals_.size() > 1 && now - local_goals_.front().first > 1.0) local_goals_.pop_front();
}

std::string PlannerNavigation::localGoalFault(const Dovs& dovs) const {
  if (local_goals_.empty()) return "no goal";
  std::string fault;
  // Built for one of the recent local goals, under the id this node gave the goal or (a dovs_node fed the goal
  // directly, not planner/local_goal) under the goal's own stamp.
  const double own_stamp = goal_ ? goal_->header.stamp.toSec() : goal_id_.toSec();
  for (auto it = local_goals_.rbegin(); it != local_goals_.rend(); ++it) {
    for (const double stamp : {goal_id_.toSec(), own_stamp}) {
      const std::string f = dovsGoalFault(dovs, stamp, it->second);
      if (f.empty()) return {};
      if (fault.empty()) fault = f;
    }
  }
  return fault;
}

void PlannerNavigation::onCancel(const std_msgs::Empty::ConstPtr&) {
  supervisor_.cancel();
  dropGoal();
  if (action_server_->isActive()) {
    action_server_->setPreempted(move_base_msgs::MoveBaseResult(), "cancelled on planner/cancel");
  }
}

void PlannerNavigation::onMap(const nav_msgs::OccupancyGrid::ConstPtr& msg) {
  OccupancyMap map;
  std::string error = occupancyMapFromMsg(*msg, map);
  if (error.empty() && msg->header.frame_id.empty()) error = "empty header.frame_id";
  if (!error.empty()) {
    ROS_ERROR("planner: map ignored (the previous one, if any, is kept): %s", error.c_str());
    return;
  }
  try {
    route_planner_ = std::make_unique<RoutePlanner>(routeGridFromMap(map), route_config_);
  } catch (const std::exception& e) {
    ROS_ERROR("planner: map ignored (the previous one, if any, is kept): %s", e.what());
    return;
  }
  map_frame_ = msg->header.frame_id;
  ROS_INFO("planner: routes on the map (%d x %d cells of %.3f m) in '%s'", map.width, map.height, map.resolution_m,
           map_frame_.c_str());
  if (goal_ && supervisor_.state() != GoalState::kReached && (!route_guide_.hasRoute() || route_guide_.planned())) {
    if (const std::string why = planRoute(); !why.empty()) ROS_WARN("planner: %s", why.c_str());
  }
}

void PlannerNavigation::onPath(const nav_msgs::Path::ConstPtr& msg) {
  if (!goal_) {
    ROS_WARN("planner: route ignored: there is no goal to follow it to");
    return;
  }
  if (msg->header.frame_id.empty() || msg->poses.empty()) {
    ROS_ERROR("planner: route ignored: %s", msg->poses.empty() ? "it has no poses" : "empty header.frame_id");
    return;
  }
  std::vector<Vec2> points;
  points.reserve(msg->poses.size());
  for (const auto& p : msg->poses) points.emplace_back(p.pose.position.x, p.pose.position.y);
  Route route = routeFromPoints(std::move(points));
  if (!route.found) {
    ROS_ERROR("planner: route ignored: %s", route.why.c_str());
    return;
  }
  // It must lead to the goal being pursued.
  try {
    geometry_msgs::PoseStamped latest = *goal_;
    latest.header.stamp = ros::Time(0);
    const geometry_msgs::PoseStamped end = tf_buffer_.transform(latest, msg->header.frame_id);
    const double miss = (route.points.back() - Vec2(end.pose.position.x, end.pose.position.y)).norm();
    if (miss > 0.5) {
      ROS_ERROR("planner: route ignored: it ends %.2f m from the goal", miss);
      return;
    }
  } catch (const tf2::TransformException& e) {
    ROS_ERROR("planner: route ignored: no transform from the goal's frame to '%s': %s", msg->header.frame_id.c_str(),
              e.what());
    return;
  }
  route_guide_.follow(std::move(route));
  route_frame_ = msg->header.frame_id;
  route_pub_.publish(*msg);
  ROS_INFO("planner: following a route of %zu points, %.1f m, from the route topic", route_guide_.route().points.size(),
           route_guide_.route().length_m);
}

std::vector<Vec2> PlannerNavigation::scanPointsInRouteFrame() {
  std::vector<Vec2> out;
  if (!last_scan_) return out;
  LaserScan2 scan;
  if (!laserScanFromMsg(*last_scan_, scan).empty()) return out;
  geometry_msgs::TransformStamped tf;
  try {
    tf = tf_buffer_.lookupTransform(route_frame_, last_scan_->header.frame_id, ros::Time(0));
  } catch (const tf2::TransformException&) {
    return out;
  }
  Pose2 laser;
  if (!poseFromTransform(tf.transform, laser)) return out;
  return scan.returnsIn(laser);
}

std::string PlannerNavigation::planRoute() {
  if (!route_planner_ || !goal_) return {};
  Vec2 start, goal;
  try {
    geometry_msgs::PoseStamped latest = *goal_;
    latest.header.stamp = ros::Time(0);
    const geometry_msgs::PoseStamped g = tf_buffer_.transform(latest, map_frame_, ros::Duration(0.2));
    goal = Vec2(g.pose.position.x, g.pose.position.y);
    const geometry_msgs::TransformStamped robot =
        tf_buffer_.lookupTransform(map_frame_, base_frame_, ros::Time(0), ros::Duration(0.2));
    start = Vec2(robot.transform.translation.x, robot.transform.translation.y);
  } catch (const tf2::TransformException& e) {
    return "no route: the map's frame '" + map_frame_ + "' cannot be related to the goal and the robot: " + e.what();
  }
  if (std::string why = route_guide_.plan(*route_planner_, start, goal, ros::Time::now().toSec()); !why.empty()) {
    return why;
  }
  route_frame_ = map_frame_;
  publishRoute();
  return {};
}

void PlannerNavigation::publishRoute() {
  const Route& route = route_guide_.route();
  std_msgs::Header header;
  header.stamp = ros::Time::now();
  header.frame_id = route_frame_;
  route_pub_.publish(pathToMsg(route.points, header));
  ROS_INFO("planner: route of %.1f m (%zu points) in '%s'", route.length_m, route.points.size(), route_frame_.c_str());
}

Vec2 PlannerNavigation::localGoal(const Vec2& goal_fixed) {
  route_remaining_m_ = -1.0;
  if (!route_guide_.hasRoute()) return goal_fixed;
  geometry_msgs::TransformStamped to_route, to_fixed;
  Pose2 robot_in_route, route_in_fixed;
  try {
    to_route = tf_buffer_.lookupTransform(route_frame_, base_frame_, ros::Time(0));
    to_fixed = tf_buffer_.lookupTransform(fixed_frame_, route_frame_, ros::Time(0));
  } catch (const tf2::TransformException&) {
    return goal_fixed;  // the supervisor halts on the robot transform; the goal itself meanwhile
  }
  if (!poseFromTransform(to_route.transform, robot_in_route) ||
      !poseFromTransform(to_fixed.transform, route_in_fixed)) {
    return goal_fixed;
  }
  // The subgoal and the replanning (off the route, after a recovery round, blocked ahead by what the laser sees),
  // as the evaluation decides them. Only a route planned on the map in force is planned again.
  const RoutePlanner* planner = route_frame_ == map_frame_ ? route_planner_.get() : nullptr;
  const RouteGuidance g = route_guide_.update(
      planner, robot_in_route.position(), route_in_fixed.inverse().toWorld(goal_fixed), ros::Time::now().toSec(),
      supervisor_.navigation().rounds(), [this]() { return scanPointsInRouteFrame(); });
  route_remaining_m_ = g.remaining_m;
  if (route_ahead_pub_) {
    for (const Vec2& p : route_guide_.ahead(kRoutePointSpacing_m * route_points_))
      route_ahead_fixed_.push_back(route_in_fixed.toWorld(p));
  }
  if (g.replan != RouteReplan::kNone) {
    ++route_replans_;
    if (g.replan == RouteReplan::kBlocked) {
      ROS_INFO("planner: the route is blocked ahead; planning again around what the laser sees");
    }
    if (g.replanned) {
      publishRoute();
    } else {
      ROS_WARN_THROTTLE(2.0, "planner: replanning failed, keeping the route: %s", g.replan_error.c_str());
    }
  }
  return g.final_goal ? goal_fixed : route_in_fixed.toWorld(g.local_goal);
}

void PlannerNavigation::updateAction(const ros::Time& now) {
  if (!action_server_->isActive()) return;
  switch (supervisor_.state()) {
    case GoalState::kReached:
      action_server_->setSucceeded(move_base_msgs::MoveBaseResult(), supervisor_.reason());
      return;
    case GoalState::kAborted:
      action_server_->setAborted(move_base_msgs::MoveBaseResult(), supervisor_.reason());
      return;
    case GoalState::kIdle:
      action_server_->setAborted(move_base_msgs::MoveBaseResult(), "the planner has no goal");
      return;
    case GoalState::kStopped:
      if (!supervisor_.hasGoal()) {
        action_server_->setAborted(move_base_msgs::MoveBaseResult(), supervisor_.reason());
        return;
      }
      break;
    case GoalState::kActive:
      break;
  }
  // Feedback: where the robot is, in the goal's frame.
  if (!goal_) return;
  try {
    const geometry_msgs::TransformStamped tf =
        tf_buffer_.lookupTransform(goal_->header.frame_id, base_frame_, ros::Time(0));
    move_base_msgs::MoveBaseFeedback feedback;
    feedback.base_position.header.stamp = now;
    feedback.base_position.header.frame_id = goal_->header.frame_id;
    feedback.base_position.pose.position.x = tf.transform.translation.x;
    feedback.base_position.pose.position.y = tf.transform.translation.y;
    feedback.base_position.pose.position.z = tf.transform.translation.z;
    feedback.base_position.pose.orientation = tf.transform.rotation;
    action_server_->publishFeedback(feedback);
  } catch (const tf2::TransformException&) {
    // No pose in the goal's frame now: the supervisor already halts on the missing transform.
  }
}

}  // namespace dqn_dovs
