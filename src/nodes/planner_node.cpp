#include "planner_node.h"

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
#include <sstream>

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

// The longest time step one command may take credit for: a pause between two commands (a stalled node, a
// forward clock jump) never licenses a larger jump of the command than a_v * kMaxRampStepS.
constexpr double kMaxRampStepS = 0.1;
// A clock that goes back by more than this between two checks has jumped (smaller steps: time adjustment).
constexpr double kBackwardJumpS = 0.01;
}  // namespace

PlannerNode::PlannerNode(ros::NodeHandle nh, ros::NodeHandle pnh)
    : nh_(nh), pnh_(pnh), limits_(loadRobotLimits(pnh)), envelope_(limits_, kMaxRampStepS), tf_listener_(tf_buffer_) {
  fixed_frame_ = param<std::string>(pnh_, "fixed_frame", "odom");
  base_frame_ = param<std::string>(pnh_, "base_frame", "base_footprint");
  if (fixed_frame_.empty() || base_frame_.empty()) throw ParameterError("fixed_frame and base_frame must not be empty");
  max_input_age_s_ = paramInRange(pnh_, "max_input_age", 0.5, 0.05, 5.0);
  goal_tolerance_m_ = paramInRange(pnh_, "goal_tolerance", 0.15, 0.01, 2.0);
  goal_speed_mps_ = paramInRange(pnh_, "goal_speed", 0.2, 0.01, limits_.v_max);
  ramp_rate_hz_ = paramInRange(pnh_, "ramp_rate", 50.0, 20.0, 500.0);
  tf_timeout_s_ = paramInRange(pnh_, "tf_timeout", 0.05, 0.0, 1.0);
  scan_max_nan_fraction_ = paramInRange(pnh_, "scan_max_nan_fraction", 0.5, 0.0, 1.0);
  deadline_fraction_ = paramInRange(pnh_, "deadline_fraction", 0.5, 0.05, 10.0);
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
  StateNormalization expected;
  expected.v_scale_mps = static_cast<float>(limits_.v_max);
  expected.w_scale_rps = static_cast<float>(limits_.w_max);
  const std::string mismatch = network_->normalizationMismatch(expected.fields(), 1e-4f);
  if (!mismatch.empty()) {
    throw ParameterError("model '" + model_path + "' was trained with another state normalisation: " + mismatch);
  }

  cmd_pub_ = nh_.advertise<geometry_msgs::Twist>("cmd_vel", 5);
  cmd_stamped_pub_ = nh_.advertise<geometry_msgs::TwistStamped>("planner/cmd_vel_stamped", 50);
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
  if (!std::isfinite(msg->twist.twist.linear.x) || !std::isfinite(msg->twist.twist.angular.z)) {
    odom_fault_ = "odom twist has NaN/inf";
    return;
  }
  if (msg->header.stamp.isZero()) {
    odom_fault_ = "odom has no stamp";
    return;
  }
  odom_fault_.clear();
  last_odom_stamp_ = msg->header.stamp;
  have_odom_ = true;
}

std::string PlannerNode::scanFault(const sensor_msgs::LaserScan& msg) {
  LaserScan2 scan;
  const std::string malformed = laserScanFromMsg(msg, scan);
  if (!malformed.empty()) return malformed;
  if (msg.header.stamp.isZero()) return "scan has no stamp";
  const size_t nan = static_cast<size_t>(std::count_if(msg.ranges.begin(), msg.ranges.end(),
                                                       [](float r) { return std::isnan(r); }));
  if (static_cast<double>(nan) > scan_max_nan_fraction_ * static_cast<double>(msg.ranges.size())) {
    std::ostringstream os;
    os << nan << " of " << msg.ranges.size() << " beams are NaN (parameter scan_max_nan_fraction = "
       << scan_max_nan_fraction_ << ")";
    return os.str();
  }
  std::string tf_error;
  if (!tf_buffer_.canTransform(fixed_frame_, msg.header.frame_id, ros::Time(0), &tf_error)) {
    return "scan frame '" + msg.header.frame_id + "' has no transform to '" + fixed_frame_ + "'";
  }
  return {};
}

void PlannerNode::onScan(const sensor_msgs::LaserScan::ConstPtr& msg) {
  const std::string fault = scanFault(*msg);
  if (!fault.empty()) {
    // A scan the robot cannot see with: stop now rather than when the last good scan grows stale.
    scan_fault_ = fault;
    if (goal_ && state_ == PlannerStatus::ACTIVE) halt("scan rejected: " + fault);
    return;
  }
  scan_fault_.clear();
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

void PlannerNode::halt(const std::string& reason) {
  target_ = Twist2{};
  action_ = -1;
  if (state_ != PlannerStatus::STOPPED || reason_ != reason) {
    ROS_WARN_THROTTLE(1.0, "planner: %s; decelerating to zero", reason.c_str());
  }
  state_ = PlannerStatus::STOPPED;
  reason_ = reason;
}

void PlannerNode::checkClock(const ros::Time& now) {
  if (!last_clock_.isZero() && !now.isZero()) {
    const double step = (now - last_clock_).toSec();
    if (step < -kBackwardJumpS || step > max_input_age_s_) {
      std::ostringstream os;
      os.precision(3);
      os << "clock jumped " << (step < 0.0 ? "backwards" : "forwards") << " by " << std::abs(step)
         << " s (or the node was stalled that long); stopping until at rest with fresh input";
      clock_fault_ = os.str();
      ROS_WARN("planner: %s", clock_fault_.c_str());
      if (step < 0.0) {
        // Everything received so far is stamped in the new clock's future: forget it, and wait for input
        // stamped after the jump (the transform listener drops its buffer on the jump too).
        have_scan_ = have_odom_ = false;
        last_dovs_.reset();
        chosen_for_.reset();
        tf_buffer_.clear();
      }
    }
  }
  if (!now.isZero()) last_clock_ = now;
}

std::string PlannerNode::inputFault(const ros::Time& now, double tf_wait_s, Pose2* pose) {
  auto age = [&](const ros::Time& t) { return (now - t).toSec(); };
  auto fault = [&]() -> std::string {
    if (!scan_fault_.empty()) return "scan rejected: " + scan_fault_;
    if (!have_scan_ || age(last_scan_stamp_) > max_input_age_s_) return "scan is stale or missing";
    if (age(last_scan_stamp_) < -max_input_age_s_) return "scan is stamped in the future (clock jumped back?)";
    if (!odom_fault_.empty()) return "odom rejected: " + odom_fault_;
    if (!have_odom_ || age(last_odom_stamp_) > max_input_age_s_) return "odom is stale or missing";
    if (age(last_odom_stamp_) < -max_input_age_s_) return "odom is stamped in the future (clock jumped back?)";
    if (!last_dovs_ || age(last_dovs_->header.stamp) > max_input_age_s_) return "dovs is stale or missing";
    if (age(last_dovs_->header.stamp) < -max_input_age_s_) return "dovs is stamped in the future (time jumped back?)";
    geometry_msgs::TransformStamped tf;
    try {
      tf = tf_buffer_.lookupTransform(fixed_frame_, base_frame_, ros::Time(0), ros::Duration(tf_wait_s));
    } catch (const tf2::TransformException& e) {
      return std::string("no transform ") + fixed_frame_ + " <- " + base_frame_ + ": " + e.what();
    }
    if (age(tf.header.stamp) > max_input_age_s_) return "robot transform is stale";
    if (age(tf.header.stamp) < -max_input_age_s_) return "robot transform is stamped in the future";
    Pose2 p;
    if (!poseFromTransform(tf.transform, p)) return "robot transform has NaN/inf";
    if (pose) *pose = p;
    return {};
  };
  const std::string why = fault();
  if (!clock_fault_.empty()) {
    const bool at_rest = command_.v == 0.0 && command_.w == 0.0;
    if (!why.empty() || !at_rest) return clock_fault_;
    ROS_INFO("planner: at rest after the clock jump and the inputs are fresh again");
    clock_fault_.clear();
  }
  return why;
}

std::string PlannerNode::decide(const ros::Time& now, std::optional<double>& goal_distance) {
  Pose2 pose;
  const std::string fault = inputFault(now, tf_timeout_s_, &pose);
  if (!fault.empty()) return fault;
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
  target_ = limits_.clipToFeasible(choiceVelocity(d, a));
  if (statics_.enabled) {
    // The last line: the target's braking trajectory, from where the robot is now at the speed last sent, must
    // keep clear of the static geometry the Dovs carries; otherwise the nearest velocity whose does.
    Observation now_seen;
    const std::string bad = staticObservationFromDovs(d, fixed_frame_, pose, command_, now_seen);
    if (!bad.empty()) return bad;
    const StaticScene scene(now_seen, limits_, statics_);
    const Twist2 safe = staticSafeCommand(scene, command_, target_, limits_, statics_);
    if (safe.v != target_.v || safe.w != target_.w) {
      ++static_corrections_;
      std::ostringstream os;
      os.precision(3);
      os << "choice " << a << " (" << target_.v << " m/s, " << target_.w << " rad/s) would brake into static geometry; sent ("
         << safe.v << ", " << safe.w << ")";
      static_last_ = os.str();
      ROS_WARN_THROTTLE(1.0, "planner: static safety: %s (%u so far)", static_last_.c_str(), static_corrections_);
      target_ = safe;
    }
  }
  return {};
}

void PlannerNode::onDecide(const ros::TimerEvent& event) {
  const ros::Time now = ros::Time::now();
  checkClock(now);
  if (!event.current_expected.isZero() && !event.last_expected.isZero() && clock_fault_.empty()) {
    // Deadline: the decision of this period started late by more than deadline_fraction of the period.
    const double late = (event.current_real - event.current_expected).toSec();
    ++control_periods_;
    max_lateness_s_ = std::max(max_lateness_s_, late);
    if (late > deadline_fraction_ * limits_.dt) {
      ++deadline_misses_;
      ROS_WARN_THROTTLE(5.0, "planner: control period started %.3f s late (%u of %u periods late so far)", late,
                        deadline_misses_, control_periods_);
    }
  }
  std::optional<double> goal_distance;
  if (!goal_ || state_ == PlannerStatus::IDLE) {
    target_ = Twist2{};
  } else if (state_ == PlannerStatus::REACHED) {
    target_ = Twist2{};  // hold on the goal until a new goal comes
  } else if (state_ == PlannerStatus::ACTIVE || (state_ == PlannerStatus::STOPPED && goal_)) {
    const std::string why = decide(now, goal_distance);
    if (!why.empty()) {
      halt(why);
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

void PlannerNode::onRamp(const ros::TimerEvent&) {
  const ros::Time now = ros::Time::now();
  checkClock(now);
  // The watchdog runs at the ramp rate: a fault stops the ramp's climb within one ramp step, not at the
  // next control period.
  if (goal_ && state_ == PlannerStatus::ACTIVE) {
    const std::string why = inputFault(now, 0.0, nullptr);
    if (!why.empty()) halt(why);
  }
  // The time this command may take credit for: the node clock since the last published command (0 when the
  // clock went backwards), capped.
  const double dt = last_publish_.isZero() ? 1.0 / ramp_rate_hz_
                                           : std::clamp((now - last_publish_).toSec(), 0.0, kMaxRampStepS);
  const Twist2 ramp = applyAccelerationLimits(envelope_.last(), target_, limits_, dt);
  const bool still = ramp.v == 0.0 && ramp.w == 0.0;
  idle_zero_messages_ = still ? idle_zero_messages_ + 1 : 0;
  // Keep publishing while moving or active; once stopped and idle, send a few zeros and go quiet so that
  // other sources (teleop) can drive the base.
  if (state_ == PlannerStatus::ACTIVE || !still || idle_zero_messages_ <= 10) {
    // The safety envelope: the last check before the command leaves (feasible, within the acceleration
    // limits of the previous command over the real elapsed time, finite); a violation is corrected.
    const EnvelopeResult checked = envelope_.filter(ramp, dt);
    if (checked.modified()) {
      ROS_WARN_THROTTLE(1.0, "planner: cmd_vel outside the safety envelope (%llu so far): %s",
                        static_cast<unsigned long long>(envelope_.corrected()), envelope_.lastCorrection().c_str());
    }
    command_ = checked.command;
    geometry_msgs::Twist t;
    t.linear.x = command_.v;
    t.angular.z = command_.w;
    cmd_pub_.publish(t);
    if (cmd_stamped_pub_.getNumSubscribers() > 0) {
      geometry_msgs::TwistStamped ts;
      ts.header.seq = ++stamped_seq_;  // consecutive: a gap tells the listener a command was lost
      ts.header.stamp = now;
      ts.header.frame_id = base_frame_;
      ts.twist = t;
      cmd_stamped_pub_.publish(ts);
    }
    last_publish_ = now;
  } else {
    command_ = ramp;
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
  s.envelope_checks = static_cast<uint32_t>(envelope_.checked());
  s.envelope_corrections = static_cast<uint32_t>(envelope_.corrected());
  s.envelope_last = envelope_.lastCorrection();
  s.static_corrections = static_corrections_;
  s.static_last = static_last_;
  s.control_periods = control_periods_;
  s.deadline_misses = deadline_misses_;
  s.max_period_lateness = max_lateness_s_;
  status_pub_.publish(s);
}

}  // namespace dqn_dovs
