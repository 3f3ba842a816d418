#include "planner_node.h"

#include <diagnostic_msgs/DiagnosticArray.h>
#include <geometry_msgs/Twist.h>
#include <geometry_msgs/TwistStamped.h>
#include <std_msgs/Float64.h>
#include <std_msgs/Int8.h>
#include <tf2/exceptions.h>
#include <tf2_geometry_msgs/tf2_geometry_msgs.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <sstream>

#include "conversions.h"
#include "dqn_dovs/dovs/state.h"
#include "dqn_dovs/planning/route_map.h"
#include "dqn_dovs/sim/map.h"
#include "pipeline_steps.h"
#include "ros_params.h"

namespace dqn_dovs {

namespace {
// Supervisor messages to the ROS log; a throttled key logs at most once per its interval.
class LogSink {
 public:
  void operator()(SupervisorLog level, const std::string& key, const std::string& text, double throttle_s) {
    const double now = ros::WallTime::now().toSec();
    if (throttle_s > 0.0) {
      auto it = last_.find(key);
      if (it != last_.end() && now - it->second < throttle_s) return;
      last_[key] = now;
    }
    if (level == SupervisorLog::kWarn) {
      ROS_WARN("planner: %s", text.c_str());
    } else {
      ROS_INFO("planner: %s", text.c_str());
    }
  }

 private:
  std::map<std::string, double> last_;
};

// The supervisor's parameters over its defaults; SupervisorConfig::validate holds the ranges (and names the field).
SupervisorConfig supervisorConfig(const ros::NodeHandle& pnh, const RobotLimits& limits) {
  SupervisorConfig c;
  c.limits = limits;
  c.max_input_age_s = param<double>(pnh, "max_input_age", c.max_input_age_s);
  c.goal_tolerance_m = param<double>(pnh, "goal_tolerance", c.goal_tolerance_m);
  c.goal_speed_mps = param<double>(pnh, "goal_speed", c.goal_speed_mps);
  c.ramp_rate_hz = param<double>(pnh, "ramp_rate", c.ramp_rate_hz);
  c.deadline_fraction = param<double>(pnh, "deadline_fraction", c.deadline_fraction);
  c.yaw_tolerance_rad = param<double>(pnh, "yaw_tolerance", c.yaw_tolerance_rad);
  c.align_speed = param<double>(pnh, "align_speed", c.align_speed);
  NavigationConfig& n = c.navigation;
  n.progress_timeout_s = param<double>(pnh, "progress_timeout", n.progress_timeout_s);
  n.progress_distance_m = param<double>(pnh, "progress_distance", n.progress_distance_m);
  n.oscillation_timeout_s = param<double>(pnh, "oscillation_timeout", n.oscillation_timeout_s);
  n.oscillation_distance_m = param<double>(pnh, "oscillation_distance", n.oscillation_distance_m);
  n.oscillation_flips = param<int>(pnh, "oscillation_flips", n.oscillation_flips);
  n.stall_command_mps = param<double>(pnh, "stall_command_speed", n.stall_command_mps);
  n.stall_odom_mps = param<double>(pnh, "stall_odom_speed", n.stall_odom_mps);
  n.stall_time_s = param<double>(pnh, "stall_time", n.stall_time_s);
  n.recovery_wait_s = param<double>(pnh, "recovery_wait", n.recovery_wait_s);
  n.recovery_rotate_rad = param<double>(pnh, "recovery_rotate_angle", n.recovery_rotate_rad);
  n.recovery_rotate_speed = param<double>(pnh, "recovery_rotate_speed", n.recovery_rotate_speed);
  n.max_recovery_rounds = param<int>(pnh, "max_recovery_rounds", n.max_recovery_rounds);
  n.allow_reverse = param<bool>(pnh, "allow_reverse", n.allow_reverse);
  n.backoff_distance_m = param<double>(pnh, "backoff_distance", n.backoff_distance_m);
  n.backoff_speed_mps = param<double>(pnh, "backoff_speed", n.backoff_speed_mps);
  if (const std::string e = c.validate(); !e.empty()) throw ParameterError(pnh.resolveName("") + ": " + e);
  return c;
}
}  // namespace

PlannerNode::PlannerNode(ros::NodeHandle nh, ros::NodeHandle pnh)
    : nh_(nh),
      pnh_(pnh),
      limits_(loadRobotLimits(pnh)),
      supervisor_(supervisorConfig(pnh, limits_), LogSink()),
      tf_listener_(tf_buffer_) {
  fixed_frame_ = param<std::string>(pnh_, "fixed_frame", "odom");
  base_frame_ = param<std::string>(pnh_, "base_frame", "base_footprint");
  if (fixed_frame_.empty() || base_frame_.empty()) throw ParameterError("fixed_frame and base_frame must not be empty");
  tf_timeout_s_ = paramInRange(pnh_, "tf_timeout", 0.05, 0.0, 1.0);
  scan_max_nan_fraction_ = paramInRange(pnh_, "scan_max_nan_fraction", 0.5, 0.0, 1.0);
  hooks_.robot_pose = [this](double wait_s) { return robotPose(wait_s); };
  hooks_.space_fault = [this]() -> std::string {
    if (!goal_fault_.empty()) return goal_fault_;
    if (!last_dovs_) return "dovs is stale or missing";
    if (const std::string other = localGoalFault(*last_dovs_); !other.empty()) return other;
    if (network_ && last_dovs_->state.size() != static_cast<size_t>(network_->stateSize()))
      return "dovs state has the wrong size";
    return {};
  };
  hooks_.choose = [this](const Pose2& pose) { return choose(pose); };
  hooks_.remaining = [this](const Pose2& pose) {
    return route_guide_.hasRoute() && route_remaining_m_ >= 0.0 ? route_remaining_m_
                                                                : (pose.position() - *supervisor_.goal()).norm();
  };
  checkRobotDescription(nh_, limits_, base_frame_, param<std::string>(pnh_, "laser_frame", "laser"));
  const std::string model_path = param<std::string>(pnh_, "model_path", "");
  if (model_path.empty()) throw ParameterError("parameter '" + pnh_.resolveName("model_path") + "' is not set");
  {
    // The loader names the field that is wrong inside a weight file; what is wrong with the path itself is
    // said here (a directory, for one, would otherwise surface as a bare stream error).
    std::error_code ec;
    const auto status = std::filesystem::status(model_path, ec);
    const std::string culprit = "model file '" + model_path + "' (parameter '" + pnh_.resolveName("model_path") + "')";
    if (!std::filesystem::exists(status)) throw ParameterError(culprit + " does not exist");
    if (std::filesystem::is_directory(status)) throw ParameterError(culprit + " is a directory, not a weight file");
    if (!std::filesystem::is_regular_file(status)) throw ParameterError(culprit + " is not a regular file");
    if (access(model_path.c_str(), R_OK) != 0) throw ParameterError(culprit + " is not readable");
  }
  statics_ = loadStaticSafetyConfig(pnh_);
  network_ = std::make_unique<QNetwork>(QNetwork::load(model_path));  // throws WeightFileError naming the field
  // At start, against the robot's limits (and any dovs/* given to the planner); each Dovs message carries the
  // normalisation dovs_node really used, checked again before the network runs (chooseAction).
  const StateNormalization expected = stateNormalization(limits_, loadDovsConfig(pnh_));
  std::string mismatch = network_->normalizationMismatch(expected.fields(), 1e-4f);
  if (mismatch.empty()) mismatch = network_->gridChannelsMismatch(expected.grid_channels);
  if (mismatch.empty()) mismatch = network_->previousActionMismatch(expected.previous_action != 0);
  if (mismatch.empty())
    mismatch = network_->tokenLayoutMismatch(expected.wall_rays, expected.person_tokens, expected.route_points);
  if (!mismatch.empty()) {
    throw ParameterError("model '" + model_path +
                         "' was trained with another state normalisation or layout: " + mismatch);
  }

  cmd_pub_ = nh_.advertise<geometry_msgs::Twist>("cmd_vel", 5);
  cmd_stamped_pub_ = nh_.advertise<geometry_msgs::TwistStamped>("planner/cmd_vel_stamped", 50);
  status_pub_ = nh_.advertise<PlannerStatus>("planner/status", 5, true);
  diagnostics_pub_ = nh_.advertise<diagnostic_msgs::DiagnosticArray>("/diagnostics", 5);
  diagnostics_timer_ = nh_.createTimer(ros::Duration(1.0), &PlannerNode::onDiagnostics, this);
  action_pub_ = nh_.advertise<std_msgs::Int8>("planner/action", 5);
  latency_pub_ = nh_.advertise<std_msgs::Float64>("planner/latency", 20);
  dovs_sub_ = nh_.subscribe("dovs", 2, &PlannerNode::onDovs, this, ros::TransportHints().tcpNoDelay());
  odom_sub_ = nh_.subscribe("odom", 10, &PlannerNode::onOdom, this, ros::TransportHints().tcpNoDelay());
  scan_sub_ = nh_.subscribe("scan", 2, &PlannerNode::onScan, this, ros::TransportHints().tcpNoDelay());
  goal_sub_ = nh_.subscribe("move_base_simple/goal", 2, &PlannerNode::onGoal, this);
  cancel_sub_ = nh_.subscribe("planner/cancel", 2, &PlannerNode::onCancel, this);
  safety_sub_ = nh_.subscribe("base_safety", 10, &PlannerNode::onBaseSafety, this, ros::TransportHints().tcpNoDelay());
  local_goal_pub_ = nh_.advertise<geometry_msgs::PoseStamped>("planner/local_goal", 5);
  if (network_->routePoints() > 0) route_ahead_pub_ = nh_.advertise<nav_msgs::Path>("planner/route_ahead", 5);
  use_goal_yaw_ = param<bool>(pnh_, "use_goal_yaw", true);
  action_server_ = std::make_unique<actionlib::SimpleActionServer<move_base_msgs::MoveBaseAction>>(
      nh_, param<std::string>(pnh_, "action_name", "move_base"), false);
  action_server_->registerGoalCallback([this] { onActionGoal(); });
  action_server_->registerPreemptCallback([this] { onActionPreempt(); });
  action_server_->start();
  // Routes: on the occupancy grid of the map topic or of a map file (route/map_file), or a nav_msgs/Path from any
  // global planner on `route` (it replaces ours for the goal it ends at).
  RouteGuideConfig guide;
  guide.lookahead_m = paramInRange(pnh_, "route/lookahead", guide.lookahead_m, 1.0, 8.0);
  guide.replan_off_route_m = paramInRange(pnh_, "route/replan_off_route", guide.replan_off_route_m, 0.2, 10.0);
  guide.obstacle_memory_s = paramInRange(pnh_, "route/obstacle_memory", guide.obstacle_memory_s, 0.0, 3600.0);
  route_guide_.setConfig(guide);
  route_pub_ = nh_.advertise<nav_msgs::Path>("planner/route", 1, true);
  route_config_ = routeConfig();
  const bool route_enabled = param<bool>(pnh_, "route/enabled", true);
  const std::string map_file = param<std::string>(pnh_, "route/map_file", "");
  const std::string map_file_frame = param<std::string>(pnh_, "route/map_frame", "map");
  // dovs.yaml's action shield is dovs_node's; read here too, so that a bad value is refused by both nodes alike.
  (void)loadActionShieldConfig(pnh_);
  // Every parameter is read above: a key under this node that none of them names is a typo (ParameterError).
  refuseUnknownParameters(pnh_);
  if (route_enabled) {
    if (!map_file.empty()) {
      sim::OccupancyMap map;
      try {
        map = sim::loadOccupancyMap(map_file);
      } catch (const std::exception& e) {
        throw ParameterError("route/map_file: " + std::string(e.what()));
      }
      map_frame_ = map_file_frame;
      route_planner_ = std::make_unique<RoutePlanner>(routeGridFromMap(map), route_config_);
      ROS_INFO("planner: routes on '%s' (%d x %d cells of %.3f m) in '%s'", map_file.c_str(), map.width, map.height,
               map.resolution_m, map_frame_.c_str());
    } else {
      map_sub_ = nh_.subscribe("map", 1, &PlannerNode::onMap, this);
    }
    path_sub_ = nh_.subscribe("route", 1, &PlannerNode::onPath, this);
  }
  decide_timer_ = nh_.createTimer(ros::Duration(limits_.dt), &PlannerNode::onDecide, this);
  ramp_timer_ = nh_.createTimer(ros::Duration(1.0 / supervisor_.config().ramp_rate_hz), &PlannerNode::onRamp, this);
  // Runtime tuning (rqt_reconfigure): from the settings loaded above, not the .cfg's defaults.
  reconfigure_server_ = std::make_unique<dynamic_reconfigure::Server<PlannerConfig>>(pnh_);
  reconfigure_server_->updateConfig(reconfigurable());
  reconfigure_server_->setCallback([this](PlannerConfig& c, uint32_t level) { onReconfigure(c, level); });
  reconfigure_route_server_ =
      std::make_unique<dynamic_reconfigure::Server<PlannerRouteConfig>>(ros::NodeHandle(pnh_, "route"));
  reconfigure_route_server_->updateConfig(reconfigurableRoute());
  reconfigure_route_server_->setCallback(
      [this](PlannerRouteConfig& c, uint32_t level) { onReconfigureRoute(c, level); });
  ROS_INFO("planner: model '%s' (%s); control period %.2f s, ramp %.0f Hz", model_path.c_str(),
           network_->metadata().c_str(), limits_.dt, supervisor_.config().ramp_rate_hz);
  publishStatus(ros::Time::now(), 0.0);
}

void PlannerNode::onDovs(const Dovs::ConstPtr& msg) {
  last_dovs_ = msg;
  // Choose the action as soon as the velocity space arrives: the control timer then applies it without
  // running the network, and planner/latency reports how old the scan behind the choice is.
  supervisor_.space(msg->header.stamp.toSec());
  if (supervisor_.hasGoal() && supervisor_.state() != GoalState::kReached && localGoalFault(*msg).empty()) {
    std::string why;
    actionForLastDovs(why);
    if (latency_pub_.getNumSubscribers() > 0) {
      std_msgs::Float64 latency;
      latency.data = (ros::Time::now() - msg->header.stamp).toSec();
      latency_pub_.publish(latency);
    }
  }
}

int PlannerNode::actionForLastDovs(std::string& why) {
  if (chosen_for_ != last_dovs_) {
    // The message's decision fields, copied once per message; every control period until the next one reads them.
    chosen_decision_ = dovsDecisionFromMessage(*last_dovs_);
    chosen_action_ = chooseAction(*network_, chosen_decision_, chosen_why_);
    chosen_for_ = last_dovs_;
  }
  why = chosen_why_;
  return chosen_action_;
}

void PlannerNode::onOdom(const nav_msgs::Odometry::ConstPtr& msg) {
  std::string fault;
  if (!std::isfinite(msg->twist.twist.linear.x) || !std::isfinite(msg->twist.twist.angular.z)) {
    fault = "odom twist has NaN/inf";
  } else if (msg->header.stamp.isZero()) {
    fault = "odom has no stamp";
  }
  supervisor_.odom(msg->header.stamp.toSec(), fault, msg->twist.twist.linear.x);
}

std::string PlannerNode::scanFault(const sensor_msgs::LaserScan& msg) {
  LaserScan2 scan;
  const std::string malformed = laserScanFromMsg(msg, scan);
  if (!malformed.empty()) return malformed;
  if (msg.header.stamp.isZero()) return "scan has no stamp";
  const size_t nan =
      static_cast<size_t>(std::count_if(msg.ranges.begin(), msg.ranges.end(), [](float r) { return std::isnan(r); }));
  if (static_cast<double>(nan) > scan_max_nan_fraction_ * static_cast<double>(msg.ranges.size())) {
    std::ostringstream os;
    os << nan << " of " << msg.ranges.size()
       << " beams are NaN (parameter scan_max_nan_fraction = " << scan_max_nan_fraction_ << ")";
    return os.str();
  }
  std::string tf_error;
  if (!tf_buffer_.canTransform(fixed_frame_, msg.header.frame_id, ros::Time(0), &tf_error)) {
    return "scan frame '" + msg.header.frame_id + "' has no transform to '" + fixed_frame_ + "'";
  }
  return {};
}

void PlannerNode::onScan(const sensor_msgs::LaserScan::ConstPtr& msg) {
  last_scan_ = msg;
  supervisor_.scan(msg->header.stamp.toSec(), scanFault(*msg));
}

void PlannerNode::onGoal(const geometry_msgs::PoseStamped::ConstPtr& msg) {
  if (action_server_->isActive()) {
    action_server_->setPreempted(move_base_msgs::MoveBaseResult(), "replaced by a goal on move_base_simple/goal");
  }
  acceptGoal(*msg, "move_base_simple/goal");
}

void PlannerNode::onActionGoal() {
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

void PlannerNode::onActionPreempt() {
  // actionlib calls this for its current goal handle even when that goal is over (a late cancel): then the goal
  // being pursued (from move_base_simple/goal, say) is not the one cancelled.
  if (!action_server_->isActive()) return;
  supervisor_.cancel();
  dropGoal();
  action_server_->setPreempted(move_base_msgs::MoveBaseResult(), "cancelled");
}

void PlannerNode::dropGoal() {
  goal_.reset();
  local_goals_.clear();
  route_guide_.clear();  // the supervisor counts the rounds of each goal afresh
  route_remaining_m_ = -1.0;
}

std::string PlannerNode::acceptGoal(const geometry_msgs::PoseStamped& goal, const std::string& source) {
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

void PlannerNode::refreshGoal(bool is_new) {
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
    nav_msgs::Path ahead;
    ahead.header.stamp = goal_id_;
    ahead.header.frame_id = fixed_frame_;
    for (const Vec2& p : route_ahead_fixed_) {
      geometry_msgs::PoseStamped ps;
      ps.header = ahead.header;
      ps.pose.position.x = p.x();
      ps.pose.position.y = p.y();
      ps.pose.orientation.w = 1.0;
      ahead.poses.push_back(ps);
    }
    route_ahead_pub_.publish(ahead);
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

std::string PlannerNode::localGoalFault(const Dovs& dovs) const {
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

void PlannerNode::onCancel(const std_msgs::Empty::ConstPtr&) {
  supervisor_.cancel();
  dropGoal();
  if (action_server_->isActive()) {
    action_server_->setPreempted(move_base_msgs::MoveBaseResult(), "cancelled on planner/cancel");
  }
}

void PlannerNode::onBaseSafety(const BaseSafety::ConstPtr& msg) {
  const double now = ros::Time::now().toSec();
  const std::string detail = msg->detail.empty() ? std::string() : " (" + msg->detail + ")";
  supervisor_.contact(now, msg->bumper ? "bumper pressed" + detail : std::string());
  std::string hazard;
  if (msg->cliff) hazard = "cliff sensor sees no floor" + detail;
  if (msg->wheel_drop) hazard = (hazard.empty() ? "" : hazard + "; ") + "wheel drop" + detail;
  supervisor_.baseHazard(now, hazard);
}

RouteConfig PlannerNode::routeConfig() const {
  RouteConfig c;
  c.robot_radius_m = limits_.radius;
  c.inflation_m = param<double>(pnh_, "route/inflation", c.inflation_m);
  c.allow_unknown = param<bool>(pnh_, "route/allow_unknown", c.allow_unknown);
  if (const std::string e = c.validate(); !e.empty()) throw ParameterError(pnh_.resolveName("route") + ": " + e);
  return c;
}

void PlannerNode::onMap(const nav_msgs::OccupancyGrid::ConstPtr& msg) {
  sim::OccupancyMap map;
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

void PlannerNode::onPath(const nav_msgs::Path::ConstPtr& msg) {
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

std::vector<Vec2> PlannerNode::scanPointsInRouteFrame() {
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
  for (size_t k = 0; k < scan.ranges.size(); ++k) {
    const double r = scan.ranges[k];
    if (!std::isfinite(r) || r < scan.range_min || r > scan.range_max) continue;
    const double a = scan.angleOf(k);
    out.push_back(laser.toWorld(Vec2(r * std::cos(a), r * std::sin(a))));
  }
  return out;
}

std::string PlannerNode::planRoute() {
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

void PlannerNode::publishRoute() {
  const Route& route = route_guide_.route();
  nav_msgs::Path path;
  path.header.stamp = ros::Time::now();
  path.header.frame_id = route_frame_;
  for (const Vec2& p : route.points) {
    geometry_msgs::PoseStamped ps;
    ps.header = path.header;
    ps.pose.position.x = p.x();
    ps.pose.position.y = p.y();
    ps.pose.orientation.w = 1.0;
    path.poses.push_back(ps);
  }
  route_pub_.publish(path);
  ROS_INFO("planner: route of %.1f m (%zu points) in '%s'", route.length_m, route.points.size(), route_frame_.c_str());
}

Vec2 PlannerNode::localGoal(const Vec2& goal_fixed) {
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
    for (const Vec2& p : route_guide_.ahead(kRoutePointSpacing_m * network_->routePoints()))
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

void PlannerNode::updateAction(const ros::Time& now) {
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

RobotPoseLookup PlannerNode::robotPose(double wait_s) {
  RobotPoseLookup out;
  geometry_msgs::TransformStamped tf;
  try {
    tf = tf_buffer_.lookupTransform(fixed_frame_, base_frame_, ros::Time(0), ros::Duration(wait_s));
  } catch (const tf2::TransformException& e) {
    out.error = std::string("no transform ") + fixed_frame_ + " <- " + base_frame_ + ": " + e.what();
    return out;
  }
  out.stamp_s = tf.header.stamp.toSec();
  if (!poseFromTransform(tf.transform, out.pose)) {
    out.pose.x = std::numeric_limits<double>::quiet_NaN();  // refused by the supervisor after the stamp checks
  }
  return out;
}

void PlannerNode::checkClock(const ros::Time& now) {
  if (supervisor_.checkClock(now.toSec()) == ClockJump::kBackward) {
    // The supervisor forgot its inputs; the velocity space and the transforms received so far are stamped in the
    // new clock's future too (the transform listener drops its buffer on the jump as well).
    last_dovs_.reset();
    chosen_for_.reset();
    tf_buffer_.clear();
  }
}

Choice PlannerNode::choose(const Pose2& pose) {
  Choice c;
  const Dovs& d = *last_dovs_;
  const int a = actionForLastDovs(c.why);
  if (a < 0) return c;
  c.action = a;
  c.target = limits_.clipToFeasible(choiceVelocity(chosen_decision_, a));
  if (statics_.enabled) {
    // The last line: the target's braking trajectory, from where the robot is now at the speed last sent, must
    // keep clear of the static geometry the Dovs carries; otherwise the nearest velocity whose does.
    const Twist2 current = supervisor_.command();
    Observation now_seen;
    std::string bad = staticFrameFault(d, fixed_frame_);
    if (bad.empty()) bad = staticObservation(chosen_decision_, pose, current, now_seen);
    if (!bad.empty()) {
      c.why = bad;
      return c;
    }
    const StaticScene scene(now_seen, limits_, statics_);
    const Twist2 safe = staticSafeCommand(scene, current, c.target, limits_, statics_);
    if (safe.v != c.target.v || safe.w != c.target.w) {
      ++static_corrections_;
      std::ostringstream os;
      os.precision(3);
      os << "choice " << a << " (" << c.target.v << " m/s, " << c.target.w
         << " rad/s) would brake into static geometry; sent (" << safe.v << ", " << safe.w << ")";
      static_last_ = os.str();
      ROS_WARN_THROTTLE(1.0, "planner: static safety: %s (%u so far)", static_last_.c_str(), static_corrections_);
      c.target = safe;
    }
  }
  return c;
}

void PlannerNode::onDecide(const ros::TimerEvent& event) {
  const ros::Time now = ros::Time::now();
  checkClock(now);
  std::optional<double> lateness;
  if (!event.current_expected.isZero() && !event.last_expected.isZero()) {
    lateness = (event.current_real - event.current_expected).toSec();
  }
  refreshGoal();
  const std::optional<double> goal_distance = supervisor_.controlPeriod(now.toSec(), lateness, hooks_, tf_timeout_s_);
  if (supervisor_.state() == GoalState::kAborted && goal_) dropGoal();
  updateAction(now);
  std_msgs::Int8 a;
  a.data = static_cast<int8_t>(supervisor_.action());
  action_pub_.publish(a);
  publishStatus(now, goal_distance.value_or(-1.0));
}

void PlannerNode::onRamp(const ros::TimerEvent&) {
  const ros::Time now = ros::Time::now();
  checkClock(now);
  const RampCommand r = supervisor_.ramp(now.toSec(), hooks_);
  if (!r.publish) return;
  geometry_msgs::Twist t;
  t.linear.x = r.command.v;
  t.angular.z = r.command.w;
  cmd_pub_.publish(t);
  if (cmd_stamped_pub_.getNumSubscribers() > 0) {
    geometry_msgs::TwistStamped ts;
    ts.header.seq = ++stamped_seq_;  // consecutive: a gap tells the listener a command was lost
    ts.header.stamp = now;
    ts.header.frame_id = base_frame_;
    ts.twist = t;
    cmd_stamped_pub_.publish(ts);
  }
}

void PlannerNode::publishStatus(const ros::Time& now, double goal_distance) {
  PlannerStatus s;
  s.header.stamp = now;
  s.header.frame_id = fixed_frame_;
  s.state = static_cast<uint8_t>(supervisor_.state());
  s.reason = supervisor_.reason().empty() ? goalStateName(supervisor_.state()) : supervisor_.reason();
  s.action = static_cast<int8_t>(supervisor_.action());
  s.goal_distance = goal_distance;
  s.route_remaining = route_guide_.hasRoute() ? route_remaining_m_ : goal_distance;
  s.goal_frame = goal_ ? goal_->header.frame_id : std::string();
  const NavigationMonitor& nav = supervisor_.navigation();
  s.recovery = nav.recovering() ? recoveryStepName(nav.step()) : "";
  s.recovery_rounds = static_cast<uint32_t>(nav.rounds());
  s.last_trigger = nav.lastTrigger();
  s.v = supervisor_.command().v;
  s.w = supervisor_.command().w;
  const SafetyEnvelope& envelope = supervisor_.envelope();
  s.envelope_checks = static_cast<uint32_t>(envelope.checked());
  s.envelope_corrections = static_cast<uint32_t>(envelope.corrected());
  s.envelope_last = envelope.lastCorrection();
  s.static_corrections = static_corrections_;
  s.static_last = static_last_;
  s.control_periods = supervisor_.controlPeriods();
  s.deadline_misses = supervisor_.deadlineMisses();
  s.max_period_lateness = supervisor_.maxLateness_s();
  status_pub_.publish(s);
  last_status_ = s;
}

PlannerConfig PlannerNode::reconfigurable() const {
  const SupervisorConfig& s = supervisor_.config();
  const NavigationConfig& n = s.navigation;
  PlannerConfig c;
  c.goal_tolerance = s.goal_tolerance_m;
  c.goal_speed = s.goal_speed_mps;
  c.use_goal_yaw = use_goal_yaw_;
  c.yaw_tolerance = s.yaw_tolerance_rad;
  c.align_speed = s.align_speed;
  c.progress_timeout = n.progress_timeout_s;
  c.progress_distance = n.progress_distance_m;
  c.oscillation_timeout = n.oscillation_timeout_s;
  c.oscillation_distance = n.oscillation_distance_m;
  c.oscillation_flips = n.oscillation_flips;
  c.stall_command_speed = n.stall_command_mps;
  c.stall_odom_speed = n.stall_odom_mps;
  c.stall_time = n.stall_time_s;
  c.recovery_wait = n.recovery_wait_s;
  c.recovery_rotate_angle = n.recovery_rotate_rad;
  c.recovery_rotate_speed = n.recovery_rotate_speed;
  c.max_recovery_rounds = n.max_recovery_rounds;
  return c;
}

PlannerRouteConfig PlannerNode::reconfigurableRoute() const {
  PlannerRouteConfig c;
  c.lookahead = route_guide_.config().lookahead_m;
  c.replan_off_route = route_guide_.config().replan_off_route_m;
  return c;
}

void PlannerNode::onReconfigureRoute(PlannerRouteConfig& c, uint32_t) {
  RouteGuideConfig guide = route_guide_.config();
  guide.lookahead_m = c.lookahead;
  guide.replan_off_route_m = c.replan_off_route;
  if (const std::string refused = guide.validate(); !refused.empty()) {
    ROS_ERROR("planner: route reconfiguration refused, the settings stay as they were: %s", refused.c_str());
    c = reconfigurableRoute();
    return;
  }
  route_guide_.setConfig(guide);
  ROS_INFO("planner: route reconfigured");
}

void PlannerNode::onReconfigure(PlannerConfig& c, uint32_t) {
  SupervisorConfig s = supervisor_.config();
  NavigationConfig& n = s.navigation;
  s.goal_tolerance_m = c.goal_tolerance;
  s.goal_speed_mps = c.goal_speed;
  s.yaw_tolerance_rad = c.yaw_tolerance;
  s.align_speed = c.align_speed;
  n.progress_timeout_s = c.progress_timeout;
  n.progress_distance_m = c.progress_distance;
  n.oscillation_timeout_s = c.oscillation_timeout;
  n.oscillation_distance_m = c.oscillation_distance;
  n.oscillation_flips = c.oscillation_flips;
  n.stall_command_mps = c.stall_command_speed;
  n.stall_odom_mps = c.stall_odom_speed;
  n.stall_time_s = c.stall_time;
  n.recovery_wait_s = c.recovery_wait;
  n.recovery_rotate_rad = c.recovery_rotate_angle;
  n.recovery_rotate_speed = c.recovery_rotate_speed;
  n.max_recovery_rounds = c.max_recovery_rounds;
  const std::string refused = supervisor_.reconfigure(s);
  if (!refused.empty()) {
    ROS_ERROR("planner: reconfiguration refused, the settings stay as they were: %s", refused.c_str());
    c = reconfigurable();
    return;
  }
  use_goal_yaw_ = c.use_goal_yaw;
  ROS_INFO("planner: reconfigured");
}

void PlannerNode::onDiagnostics(const ros::TimerEvent&) {
  diagnostic_msgs::DiagnosticArray a;
  a.header.stamp = ros::Time::now();
  a.status.push_back(
      plannerDiagnostics(last_status_, last_reported_, ros::this_node::getName() + ": planner", base_frame_));
  diagnostics_pub_.publish(a);
  last_reported_ = last_status_;
}

}  // namespace dqn_dovs
