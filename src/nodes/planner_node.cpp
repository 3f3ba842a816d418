#include "planner_node.h"

#include <geometry_msgs/Twist.h>
#include <std_msgs/Float64.h>
#include <std_msgs/Int8.h>
#include <tf2/exceptions.h>
#include <tf2_geometry_msgs/tf2_geometry_msgs.h>

#include <cmath>

#include "conversions.h"
#include "dqn_dovs/state.h"
#include "pipeline_steps.h"
#include "ros_params.h"

namespace dqn_dovs {

namespace {
const char* stateName(uint8_t s) {
  switch (s) {
    case PlannerStatus::IDLE: return "idle";
    case PlannerStatus::ACTIVE: return "active";
    case PlannerStatus::REACHED: return "reached";
    case PlannerStatus::STOPPED: return "stopped";
  }
  return "unknown";
}
}  // namespace

PlannerNode::PlannerNode(ros::NodeHandle nh, ros::NodeHandle pnh)
    : nh_(nh), pnh_(pnh), limits_(loadRobotLimits(pnh)), tf_listener_(tf_buffer_) {
  fixed_frame_ = param<std::string>(pnh_, "fixed_frame", "odom");
  base_frame_ = param<std::string>(pnh_, "base_frame", "base_footprint");
  if (fixed_frame_.empty() || base_frame_.empty()) throw ParameterError("fixed_frame and base_frame must not be empty");
  max_input_age_s_ = paramInRange(pnh_, "max_input_age", 0.5, 0.05, 5.0);
  goal_tolerance_m_ = paramInRange(pnh_, "goal_tolerance", 0.15, 0.01, 2.0);
  goal_speed_mps_ = paramInRange(pnh_, "goal_speed", 0.2, 0.01, limits_.v_max);
  ramp_rate_hz_ = paramInRange(pnh_, "ramp_rate", 50.0, 20.0, 500.0);
  tf_timeout_s_ = paramInRange(pnh_, "tf_timeout", 0.05, 0.0, 1.0);
  checkRobotDescription(nh_, limits_, base_frame_, param<std::string>(pnh_, "laser_frame", "laser"));
  const std::string model_path = param<std::string>(pnh_, "model_path", "");
  if (model_path.empty()) throw ParameterError("parameter '" + pnh_.resolveName("model_path") + "' is not set");
  network_ = std::make_unique<QNetwork>(QNetwork::load(model_path));  // throws WeightFileError naming the field
  StateNormalization expected;
  expected.v_scale_mps = static_cast<float>(limits_.v_max);
  expected.w_scale_rps = static_cast<float>(limits_.w_max);
  const std::string mismatch = network_->normalizationMismatch(expected.fields(), 1e-4f);
  if (!mismatch.empty()) {
    throw ParameterError("model '" + model_path + "' was trained with another state normalisation: " + mismatch);
  }

  cmd_pub_ = nh_.advertise<geometry_msgs::Twist>("cmd_vel", 5);
  status_pub_ = nh_.advertise<PlannerStatus>("planner/status", 5, true);
  action_pub_ = nh_.advertise<std_msgs::Int8>("planner/action", 5);
  latency_pub_ = nh_.advertise<std_msgs::Float64>("planner/latency", 20);
  dovs_sub_ = nh_.subscribe("dovs", 2, &PlannerNode::onDovs, this, ros::TransportHints().tcpNoDelay());
  odom_sub_ = nh_.subscribe("odom", 10, &PlannerNode::onOdom, this, ros::TransportHints().tcpNoDelay());
  scan_sub_ = nh_.subscribe("scan", 2, &PlannerNode::onScan, this, ros::TransportHints().tcpNoDelay());
  goal_sub_ = nh_.subscribe("move_base_simple/goal", 2, &PlannerNode::onGoal, this);
  cancel_sub_ = nh_.subscribe("planner/cancel", 2, &PlannerNode::onCancel, this);
  decide_timer_ = nh_.createTimer(ros::Duration(limits_.dt), &PlannerNode::onDecide, this);
  ramp_timer_ = nh_.createTimer(ros::Duration(1.0 / ramp_rate_hz_), &PlannerNode::onRamp, this);
  ROS_INFO("planner: model '%s' (%s); control period %.2f s, ramp %.0f Hz", model_path.c_str(),
           network_->metadata().substr(0, 80).c_str(), limits_.dt, ramp_rate_hz_);
  publishStatus(ros::Time::now(), 0.0);
}

void PlannerNode::onDovs(const Dovs::ConstPtr& msg) {
  last_dovs_ = msg;
  // Choose the action as soon as the velocity space arrives: the control timer then applies it without
  // running the network, and planner/latency reports how old the scan behind the choice is.
  if (goal_ && state_ != PlannerStatus::REACHED && msg->has_goal) {
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
    chosen_action_ = chooseAction(*network_, *last_dovs_, chosen_why_);
    chosen_for_ = last_dovs_;
  }
  why = chosen_why_;
  return chosen_action_;
}

void PlannerNode::onOdom(const nav_msgs::Odometry::ConstPtr& msg) {
  last_odom_stamp_ = msg->header.stamp;
  have_odom_ = true;
}

void PlannerNode::onScan(const sensor_msgs::LaserScan::ConstPtr& msg) {
  last_scan_stamp_ = msg->header.stamp;
  have_scan_ = true;
}

void PlannerNode::onGoal(const geometry_msgs::PoseStamped::ConstPtr& msg) {
  if (!std::isfinite(msg->pose.position.x) || !std::isfinite(msg->pose.position.y)) {
    stop("goal rejected: its position has NaN/inf");
    goal_.reset();
    return;
  }
  geometry_msgs::PoseStamped in_fixed;
  try {
    geometry_msgs::PoseStamped latest = *msg;
    latest.header.stamp = ros::Time(0);
    in_fixed = tf_buffer_.transform(latest, fixed_frame_, ros::Duration(0.2));
  } catch (const tf2::TransformException& e) {
    goal_.reset();
    stop("goal rejected: no transform from '" + msg->header.frame_id + "' to '" + fixed_frame_ + "': " + e.what());
    return;
  }
  goal_ = Vec2(in_fixed.pose.position.x, in_fixed.pose.position.y);  // a new goal cancels the previous one
  state_ = PlannerStatus::ACTIVE;
  reason_.clear();
  ROS_INFO("planner: new goal (%.2f, %.2f) in '%s'", goal_->x(), goal_->y(), fixed_frame_.c_str());
}

void PlannerNode::onCancel(const std_msgs::Empty::ConstPtr&) {
  goal_.reset();
  stop("goal cancelled");
}

void PlannerNode::stop(const std::string& reason) {
  target_ = Twist2{};
  action_ = -1;
  if (state_ != PlannerStatus::STOPPED || reason_ != reason) ROS_WARN("planner: stopping: %s", reason.c_str());
  state_ = PlannerStatus::STOPPED;
  reason_ = reason;
}

std::string PlannerNode::decide(const ros::Time& now, std::optional<double>& goal_distance) {
  auto age = [&](const ros::Time& t) { return (now - t).toSec(); };
  if (!have_scan_ || age(last_scan_stamp_) > max_input_age_s_) return "scan is stale or missing";
  if (!have_odom_ || age(last_odom_stamp_) > max_input_age_s_) return "odom is stale or missing";
  if (!last_dovs_ || age(last_dovs_->header.stamp) > max_input_age_s_) return "dovs is stale or missing";
  if (age(last_dovs_->header.stamp) < -max_input_age_s_) return "dovs is stamped in the future (time jumped back?)";

  geometry_msgs::TransformStamped tf;
  try {
    tf = tf_buffer_.lookupTransform(fixed_frame_, base_frame_, ros::Time(0), ros::Duration(tf_timeout_s_));
  } catch (const tf2::TransformException& e) {
    return std::string("no transform ") + fixed_frame_ + " <- " + base_frame_ + ": " + e.what();
  }
  if (age(tf.header.stamp) > max_input_age_s_) return "robot transform is stale";
  Pose2 pose;
  if (!poseFromTransform(tf.transform, pose)) return "robot transform has NaN/inf";
  goal_distance = (pose.position() - *goal_).norm();

  const Dovs& d = *last_dovs_;
  if (!d.has_goal) return "dovs has no goal yet";
  if (d.state.size() != static_cast<size_t>(QNetwork::kStateSize)) return "dovs state has the wrong size";
  if (*goal_distance < goal_tolerance_m_) {
    // On the goal: brake to a stop within the limits and hold.
    target_ = Twist2{};
    action_ = -1;
    if (std::abs(command_.v) < goal_speed_mps_ && state_ == PlannerStatus::ACTIVE) {
      state_ = PlannerStatus::REACHED;
      reason_ = "goal reached";
      ROS_INFO("planner: goal reached (%.2f m)", *goal_distance);
    }
    return {};
  }
  std::string why;
  const int a = actionForLastDovs(why);
  if (a < 0) return why;
  action_ = a;
  target_ = limits_.clipToFeasible({d.action_v[static_cast<size_t>(a)], d.action_w[static_cast<size_t>(a)]});
  return {};
}

void PlannerNode::onDecide(const ros::TimerEvent&) {
  const ros::Time now = ros::Time::now();
  std::optional<double> goal_distance;
  if (!goal_ || state_ == PlannerStatus::IDLE) {
    target_ = Twist2{};
  } else if (state_ == PlannerStatus::REACHED) {
    target_ = Twist2{};  // hold on the goal until a new goal comes
  } else if (state_ == PlannerStatus::ACTIVE || (state_ == PlannerStatus::STOPPED && goal_)) {
    const std::string why = decide(now, goal_distance);
    if (!why.empty()) {
      ROS_WARN_THROTTLE(1.0, "planner: %s; decelerating to zero", why.c_str());
      target_ = Twist2{};
      action_ = -1;
      state_ = PlannerStatus::STOPPED;
      reason_ = why;
    } else if (state_ == PlannerStatus::STOPPED) {
      ROS_INFO("planner: inputs are fresh again; resuming");
      state_ = PlannerStatus::ACTIVE;
      reason_.clear();
    }
  }
  std_msgs::Int8 a;
  a.data = static_cast<int8_t>(action_);
  action_pub_.publish(a);
  publishStatus(now, goal_distance.value_or(-1.0));
}

void PlannerNode::onRamp(const ros::TimerEvent& event) {
  const double dt = event.last_real.isZero() ? 1.0 / ramp_rate_hz_
                                             : std::clamp((event.current_real - event.last_real).toSec(), 0.0, 0.1);
  command_ = applyAccelerationLimits(command_, target_, limits_, dt);
  const bool still = command_.v == 0.0 && command_.w == 0.0;
  idle_zero_messages_ = still ? idle_zero_messages_ + 1 : 0;
  // Keep publishing while moving or active; once stopped and idle, send a few zeros and go quiet so that
  // other sources (teleop) can drive the base.
  if (state_ == PlannerStatus::ACTIVE || !still || idle_zero_messages_ <= 10) {
    geometry_msgs::Twist t;
    t.linear.x = command_.v;
    t.angular.z = command_.w;
    cmd_pub_.publish(t);
  }
}

void PlannerNode::publishStatus(const ros::Time& now, double goal_distance) {
  PlannerStatus s;
  s.header.stamp = now;
  s.header.frame_id = fixed_frame_;
  s.state = state_;
  s.reason = reason_.empty() ? stateName(state_) : reason_;
  s.action = static_cast<int8_t>(action_);
  s.goal_distance = goal_distance;
  s.v = command_.v;
  s.w = command_.w;
  status_pub_.publish(s);
}

}  // namespace dqn_dovs
