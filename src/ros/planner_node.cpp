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
  checkRobotDescription(nh_, limits_, base_frame_, param<std::string>(pnh_, "laser_frame", "laser"));
  decision_ = std::make_unique<PlannerDecisionAdapter>(nh_, pnh_, fixed_frame_, limits_, supervisor_);
  hooks_.robot_pose = [this](double wait_s) { return robotPose(wait_s); };
  hooks_.space_fault = [this]() { return decision_->spaceFault(); };
  hooks_.choose = [this](const Pose2& pose) { return decision_->choose(pose); };
  hooks_.remaining = [this](const Pose2& pose) {
    return navigation_->hasRoute() && navigation_->routeRemaining() >= 0.0
               ? navigation_->routeRemaining()
               : (pose.position() - *supervisor_.goal()).norm();
  };

  cmd_pub_ = nh_.advertise<geometry_msgs::Twist>("cmd_vel", 5);
  cmd_stamped_pub_ = nh_.advertise<geometry_msgs::TwistStamped>("planner/cmd_vel_stamped", 50);
  status_pub_ = nh_.advertise<PlannerStatus>("planner/status", 5, true);
  diagnostics_pub_ = nh_.advertise<diagnostic_msgs::DiagnosticArray>("/diagnostics", 5);
  diagnostics_timer_ = nh_.createTimer(ros::Duration(1.0), &PlannerNode::onDiagnostics, this);
  action_pub_ = nh_.advertise<std_msgs::Int8>("planner/action", 5);
  odom_sub_ = nh_.subscribe("odom", 10, &PlannerNode::onOdom, this, ros::TransportHints().tcpNoDelay());
  scan_sub_ = nh_.subscribe("scan", 2, &PlannerNode::onScan, this, ros::TransportHints().tcpNoDelay());
  safety_sub_ = nh_.subscribe("base_safety", 10, &PlannerNode::onBaseSafety, this, ros::TransportHints().tcpNoDelay());
  navigation_ = std::make_unique<PlannerNavigation>(nh_, pnh_, fixed_frame_, base_frame_, limits_,
                                                    decision_->network() ? decision_->network()->routePoints() : 0,
                                                    supervisor_, tf_buffer_);
  // Every parameter is read above: a key under this node that none of them names is a typo (ParameterError).
  refuseUnknownParameters(pnh_);
  decision_->start(*navigation_);
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
  if (decision_->network() != nullptr) {
    ROS_INFO("planner: model '%s' (%s); control period %.2f s, ramp %.0f Hz",
             param<std::string>(pnh_, "model_path", "").c_str(), decision_->network()->metadata().c_str(), limits_.dt,
             supervisor_.config().ramp_rate_hz);
  } else {
    ROS_INFO("planner: %s (decided in dovs_node); control period %.2f s, ramp %.0f Hz", decision_->planner().c_str(),
             limits_.dt, supervisor_.config().ramp_rate_hz);
  }
  publishStatus(ros::Time::now(), 0.0);
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
  navigation_->setLastScan(msg);
  supervisor_.scan(msg->header.stamp.toSec(), scanFault(*msg));
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
    decision_->forget();
    tf_buffer_.clear();
  }
}

void PlannerNode::onDecide(const ros::TimerEvent& event) {
  const ros::Time now = ros::Time::now();
  checkClock(now);
  std::optional<double> lateness;
  if (!event.current_expected.isZero() && !event.last_expected.isZero()) {
    lateness = (event.current_real - event.current_expected).toSec();
  }
  navigation_->refreshGoal();
  const std::optional<double> goal_distance = supervisor_.controlPeriod(now.toSec(), lateness, hooks_, tf_timeout_s_);
  navigation_->afterControlPeriod(now);
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
  s.route_remaining = navigation_->hasRoute() ? navigation_->routeRemaining() : goal_distance;
  s.goal_frame = navigation_->goalFrame();
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
  s.static_corrections = decision_->staticCorrections();
  s.static_last = decision_->staticLast();
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
  c.use_goal_yaw = navigation_->useGoalYaw();
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
  c.lookahead = navigation_->routeGuideConfig().lookahead_m;
  c.replan_off_route = navigation_->routeGuideConfig().replan_off_route_m;
  return c;
}

void PlannerNode::onReconfigureRoute(PlannerRouteConfig& c, uint32_t) {
  RouteGuideConfig guide = navigation_->routeGuideConfig();
  guide.lookahead_m = c.lookahead;
  guide.replan_off_route_m = c.replan_off_route;
  if (const std::string refused = guide.validate(); !refused.empty()) {
    ROS_ERROR("planner: route reconfiguration refused, the settings stay as they were: %s", refused.c_str());
    c = reconfigurableRoute();
    return;
  }
  navigation_->setRouteGuideConfig(guide);
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
  navigation_->setUseGoalYaw(c.use_goal_yaw);
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
