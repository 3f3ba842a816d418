#include "dqn_dovs/supervision/supervisor.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace dqn_dovs {

const char* goalStateName(GoalState s) {
  switch (s) {
    case GoalState::kIdle:
      return "idle";
    case GoalState::kActive:
      return "active";
    case GoalState::kReached:
      return "reached";
    case GoalState::kStopped:
      return "stopped";
    case GoalState::kAborted:
      return "aborted";
  }
  return "unknown";
}

std::string SupervisorConfig::validate() const {
  std::ostringstream os;
  auto in = [](double x, double lo, double hi) { return std::isfinite(x) && x >= lo && x <= hi; };
  if (const std::string e = limits.validate(); !e.empty()) {
    os << "robot: " << e;
  } else if (!in(max_input_age_s, 0.05, 5.0)) {
    os << "max_input_age = " << max_input_age_s << " s is outside [0.05, 5]";
  } else if (!in(goal_tolerance_m, 0.01, 2.0)) {
    os << "goal_tolerance = " << goal_tolerance_m << " m is outside [0.01, 2]";
  } else if (!in(goal_speed_mps, 0.01, limits.v_max)) {
    os << "goal_speed = " << goal_speed_mps << " m/s is outside [0.01, v_max]";
  } else if (!in(ramp_rate_hz, 20.0, 500.0)) {
    os << "ramp_rate = " << ramp_rate_hz << " Hz is outside [20, 500]";
  } else if (!in(deadline_fraction, 0.05, 10.0)) {
    os << "deadline_fraction = " << deadline_fraction << " is outside [0.05, 10]";
  } else if (!in(yaw_tolerance_rad, 0.01, kPi)) {
    os << "yaw_tolerance = " << yaw_tolerance_rad << " rad is outside [0.01, pi]";
  } else if (!in(align_speed, 0.05, 10.0)) {
    os << "align_speed = " << align_speed << " rad/s is outside [0.05, 10]";
  } else if (const std::string e = navigation.validate(); !e.empty()) {
    os << e;
  }
  return os.str();
}

namespace {
const SupervisorConfig& checked(const SupervisorConfig& c) {
  if (const std::string e = c.validate(); !e.empty()) throw std::invalid_argument("supervisor: " + e);
  return c;
}
}  // namespace

Supervisor::Supervisor(const SupervisorConfig& config, SupervisorLogSink log)
    : config_(checked(config)),
      log_(std::move(log)),
      navigation_(config.navigation),
      envelope_(config.limits, kMaxRampStepS,
                config.navigation.allow_reverse ? config.navigation.backoff_speed_mps : 0.0) {}

void Supervisor::log(SupervisorLog level, const std::string& key, const std::string& text, double throttle_s) const {
  if (log_) log_(level, key, text, throttle_s);
}

std::string Supervisor::reconfigure(const SupervisorConfig& c) {
  if (const std::string e = c.validate(); !e.empty()) return e;
  const RobotLimits& a = c.limits;
  const RobotLimits& b = config_.limits;
  const bool same_limits = a.v_max == b.v_max && a.w_max == b.w_max && a.a_v == b.a_v && a.a_w == b.a_w &&
                           a.dt == b.dt && a.radius == b.radius;
  if (!same_limits || c.max_input_age_s != config_.max_input_age_s || c.ramp_rate_hz != config_.ramp_rate_hz ||
      c.deadline_fraction != config_.deadline_fraction ||
      c.navigation.allow_reverse != config_.navigation.allow_reverse ||
      c.navigation.backoff_speed_mps != config_.navigation.backoff_speed_mps) {
    return "the robot's limits, max_input_age, ramp_rate, deadline_fraction, allow_reverse and backoff_speed are "
           "fixed at start";
  }
  navigation_.setConfig(c.navigation);
  config_ = c;
  log(SupervisorLog::kInfo, "reconfigure", "new settings applied");
  return {};
}

void Supervisor::newGoal(const Vec2& goal, std::optional<double> yaw, double now_s) {
  goal_ = goal;  // a new goal cancels the previous one
  goal_yaw_ = yaw;
  aligning_ = false;
  navigation_.reset(now_s);
  state_ = GoalState::kActive;
  reason_.clear();
}

void Supervisor::moveGoal(const Vec2& goal, std::optional<double> yaw) {
  if (!goal_) return;
  goal_ = goal;
  goal_yaw_ = yaw;
}

void Supervisor::abort(const std::string& reason) {
  goal_.reset();
  target_ = Twist2{};
  action_ = -1;
  aligning_ = false;
  log(SupervisorLog::kWarn, "abort", "goal aborted: " + reason);
  state_ = GoalState::kAborted;
  reason_ = reason;
}

void Supervisor::emergencyZero() {
  target_ = Twist2{};
  action_ = -1;
  emergency_ = true;  // the next ramp command is zero, whatever the deceleration limit says
}

void Supervisor::contact(double now_s, const std::string& what) {
  if (what == contact_) return;
  const bool onset = contact_.empty();
  contact_ = what;
  if (what.empty()) {
    log(SupervisorLog::kInfo, "contact", "contact ended");
    return;
  }
  if (!onset) return;
  log(SupervisorLog::kWarn, "contact", what + ": stopping at once");
  emergencyZero();
  if (goal_ && (state_ == GoalState::kActive || state_ == GoalState::kStopped)) navigation_.contact(now_s, what);
}

void Supervisor::baseHazard(double /*now_s*/, const std::string& what) {
  if (what == hazard_) return;
  if (what.empty()) {
    log(SupervisorLog::kInfo, "hazard", "base hazard cleared (" + hazard_ + ")");
    hazard_.clear();
    return;
  }
  hazard_ = what;
  emergencyZero();
  if (goal_ && state_ != GoalState::kReached) {
    abort(what);
  } else {
    log(SupervisorLog::kWarn, "hazard", what + ": stopping at once");
  }
}

void Supervisor::rejectGoal(const std::string& reason) {
  goal_.reset();
  stop(reason);
}

void Supervisor::cancel() {
  goal_.reset();
  stop("goal cancelled");
}

void Supervisor::stop(const std::string& reason) {
  target_ = Twist2{};
  action_ = -1;
  if (state_ != GoalState::kStopped || reason_ != reason) log(SupervisorLog::kWarn, "stop", "stopping: " + reason);
  state_ = GoalState::kStopped;
  reason_ = reason;
}

void Supervisor::halt(const std::string& reason) {
  target_ = Twist2{};
  action_ = -1;
  if (state_ != GoalState::kStopped || reason_ != reason) {
    log(SupervisorLog::kWarn, "halt", reason + "; decelerating to zero", 1.0);
  }
  state_ = GoalState::kStopped;
  reason_ = reason;
}

void Supervisor::scan(double stamp_s, const std::string& fault) {
  if (!fault.empty()) {
    // A scan the robot cannot see with: stop now rather than when the last good scan grows stale.
    scan_fault_ = fault;
    if (goal_ && state_ == GoalState::kActive) halt("scan rejected: " + fault);
    return;
  }
  scan_fault_.clear();
  last_scan_s_ = stamp_s;
  have_scan_ = true;
}

void Supervisor::odom(double stamp_s, const std::string& fault, double speed_mps) {
  if (!fault.empty()) {
    odom_fault_ = fault;
    return;
  }
  odom_fault_.clear();
  odom_speed_mps_ = speed_mps;
  last_odom_s_ = stamp_s;
  have_odom_ = true;
}

void Supervisor::space(double stamp_s) {
  last_space_s_ = stamp_s;
  have_space_ = true;
}

ClockJump Supervisor::checkClock(double now_s) {
  ClockJump jump = ClockJump::kNone;
  if (last_clock_s_ && now_s != 0.0) {
    const double step = now_s - *last_clock_s_;
    if (step < -kBackwardJumpS || step > config_.max_input_age_s) {
      std::ostringstream os;
      os.precision(3);
      os << "clock jumped " << (step < 0.0 ? "backwards" : "forwards") << " by " << std::abs(step)
         << " s (or the node was stalled that long); stopping until at rest with fresh input";
      clock_fault_ = os.str();
      log(SupervisorLog::kWarn, "clock", clock_fault_);
      jump = step < 0.0 ? ClockJump::kBackward : ClockJump::kForward;
      if (step < 0.0) {
        // Everything received so far is stamped in the new clock's future: forget it, and wait for input
        // stamped after the jump.
        have_scan_ = have_odom_ = have_space_ = false;
      }
    }
  }
  if (now_s != 0.0) last_clock_s_ = now_s;
  return jump;
}

std::string Supervisor::inputFault(double now_s, const DecisionHooks& hooks, double tf_wait_s, Pose2* pose) {
  const double max_age = config_.max_input_age_s;
  auto age = [&](double t) { return now_s - t; };
  auto fault = [&]() -> std::string {
    if (!hazard_.empty()) return "base hazard: " + hazard_;
    if (!scan_fault_.empty()) return "scan rejected: " + scan_fault_;
    if (!have_scan_ || age(last_scan_s_) > max_age) return "scan is stale or missing";
    if (age(last_scan_s_) < -max_age) return "scan is stamped in the future (clock jumped back?)";
    if (!odom_fault_.empty()) return "odom rejected: " + odom_fault_;
    if (!have_odom_ || age(last_odom_s_) > max_age) return "odom is stale or missing";
    if (age(last_odom_s_) < -max_age) return "odom is stamped in the future (clock jumped back?)";
    if (!have_space_ || age(last_space_s_) > max_age) return "dovs is stale or missing";
    if (age(last_space_s_) < -max_age) return "dovs is stamped in the future (time jumped back?)";
    if (!hooks.robot_pose) return "no robot pose lookup";
    const RobotPoseLookup p = hooks.robot_pose(tf_wait_s);
    if (!p.error.empty()) return p.error;
    if (age(p.stamp_s) > max_age) return "robot transform is stale";
    if (age(p.stamp_s) < -max_age) return "robot transform is stamped in the future";
    if (!p.pose.position().allFinite() || !std::isfinite(p.pose.theta)) return "robot transform has NaN/inf";
    if (pose) *pose = p.pose;
    return {};
  };
  const std::string why = fault();
  if (!clock_fault_.empty()) {
    const bool at_rest = command_.v == 0.0 && command_.w == 0.0;
    if (!why.empty() || !at_rest) return clock_fault_;
    log(SupervisorLog::kInfo, "clock", "at rest after the clock jump and the inputs are fresh again");
    clock_fault_.clear();
  }
  return why;
}

void Supervisor::onGoal(const Pose2& pose, double goal_distance) {
  target_ = Twist2{};
  action_ = -1;
  if (std::abs(command_.v) >= config_.goal_speed_mps || state_ != GoalState::kActive) return;  // braking first
  if (goal_yaw_) {
    // Turn in place to the goal's heading, no faster than lets the turn stop on it within the angular
    // acceleration limit and one control period.
    const double error = normalizeAngle(*goal_yaw_ - pose.theta);
    if (std::abs(error) > config_.yaw_tolerance_rad) {
      const double a = 0.5 * config_.limits.a_w;
      const double speed = std::min({config_.align_speed, config_.limits.w_max, std::sqrt(2.0 * a * std::abs(error)),
                                     std::abs(error) / config_.limits.dt});
      target_ = {0.0, std::copysign(speed, error)};
      if (!aligning_) log(SupervisorLog::kInfo, "goal", "on the goal; turning to its heading");
      aligning_ = true;
      reason_ = "aligning to the goal's heading";
      return;
    }
    if (std::abs(command_.w) >= 0.1) return;  // aligned: let the turn stop
  }
  aligning_ = false;
  state_ = GoalState::kReached;
  reason_ = "goal reached";
  std::ostringstream os;
  os.precision(3);
  os << "goal reached (" << goal_distance << " m";
  if (goal_yaw_) os << ", heading within " << std::abs(normalizeAngle(*goal_yaw_ - pose.theta)) << " rad";
  os << ")";
  log(SupervisorLog::kInfo, "goal", os.str());
}

std::string Supervisor::decide(double now_s, const DecisionHooks& hooks, double tf_wait_s,
                               std::optional<double>& goal_distance) {
  Pose2 pose;
  const std::string fault = inputFault(now_s, hooks, tf_wait_s, &pose);
  if (!fault.empty()) return fault;
  goal_distance = (pose.position() - *goal_).norm();
  if (const std::string contact = navigation_.takeContact(); !contact.empty()) {
    navigation_.startRecovery(now_s, pose, contact);
  }
  if (navigation_.recovering() || navigation_.rounds() > config_.navigation.max_recovery_rounds) {
    // Recovery drives without the velocity space: waiting and turning in place keep a round robot where it is.
    const RecoveryCommand r = navigation_.recover(now_s, pose, config_.limits);
    if (r.abort) {
      abort(r.reason);
      return {};
    }
    if (r.step != RecoveryStep::kNone) {
      target_ = r.target;
      action_ = -1;
      if (reason_ != r.reason) log(SupervisorLog::kWarn, "recovery", r.reason);
      reason_ = r.reason;
      return {};
    }
    log(SupervisorLog::kInfo, "recovery", "recovery round over; driving again");
    reason_.clear();
  }
  if (!contact_.empty()) return contact_ + ": holding still until the contact ends";
  if (*goal_distance < config_.goal_tolerance_m || aligning_) {
    onGoal(pose, *goal_distance);
    return {};
  }
  if (hooks.space_fault) {
    if (const std::string why = hooks.space_fault(); !why.empty()) return why;
  }
  if (!hooks.choose) return "no decision";
  const Choice c = hooks.choose(pose);
  if (!c.why.empty()) return c.why;
  action_ = c.action;
  target_ = c.target;
  const double remaining = hooks.remaining ? hooks.remaining(pose) : *goal_distance;
  if (const std::string trigger = navigation_.observe(now_s, pose, remaining, command_, odom_speed_mps_);
      !trigger.empty()) {
    log(SupervisorLog::kWarn, "trigger", trigger + "; starting recovery");
    navigation_.startRecovery(now_s, pose, trigger);
    if (navigation_.recovering()) {
      target_ = Twist2{};
      action_ = -1;
    }
  }
  return {};
}

std::optional<double> Supervisor::controlPeriod(double now_s, std::optional<double> lateness_s,
                                                const DecisionHooks& hooks, double tf_wait_s) {
  if (lateness_s && clock_fault_.empty()) {
    // Deadline: the decision of this period started late by more than deadline_fraction of the period.
    ++control_periods_;
    max_lateness_s_ = std::max(max_lateness_s_, *lateness_s);
    if (*lateness_s > config_.deadline_fraction * config_.limits.dt) {
      ++deadline_misses_;
      std::ostringstream os;
      os.precision(3);
      os << "control period started " << *lateness_s << " s late (" << deadline_misses_ << " of " << control_periods_
         << " periods late so far)";
      log(SupervisorLog::kWarn, "deadline", os.str(), 5.0);
    }
  }
  std::optional<double> goal_distance;
  if (!goal_ || state_ == GoalState::kIdle) {
    target_ = Twist2{};
  } else if (state_ == GoalState::kReached || state_ == GoalState::kAborted) {
    target_ = Twist2{};  // hold on the goal (or where it was given up) until a new goal comes
  } else if (state_ == GoalState::kActive || state_ == GoalState::kStopped) {
    const std::string why = decide(now_s, hooks, tf_wait_s, goal_distance);
    if (!why.empty()) {
      halt(why);
    } else if (state_ == GoalState::kStopped) {
      log(SupervisorLog::kInfo, "resume", "inputs are fresh again; resuming");
      state_ = GoalState::kActive;
      if (!navigation_.recovering()) reason_.clear();
    }
  }
  return goal_distance;
}

Twist2 Supervisor::rampStep(const Twist2& last, double dt) const {
  const double reverse = config_.navigation.allow_reverse ? config_.navigation.backoff_speed_mps : 0.0;
  if (reverse <= 0.0 || (target_.v >= 0.0 && last.v >= 0.0)) {
    return applyAccelerationLimits(last, target_, config_.limits, dt);
  }
  // Into, during or out of a back-off: straight only, so the turn rate goes to zero first (at rest meanwhile).
  const double max_dv = config_.limits.a_v * dt, max_dw = config_.limits.a_w * dt;
  Twist2 next;
  next.w = last.w + std::clamp(-last.w, -max_dw, max_dw);
  const double v_goal = next.w != 0.0 ? std::max(0.0, target_.v) : target_.v;
  next.v = std::clamp(last.v + std::clamp(v_goal - last.v, -max_dv, max_dv), -reverse, config_.limits.v_max);
  if (next.v > 0.0 && next.w != 0.0) return applyAccelerationLimits(last, target_, config_.limits, dt);
  return next;
}

RampCommand Supervisor::ramp(double now_s, const DecisionHooks& hooks) {
  // The watchdog runs at the ramp rate: a fault stops the ramp's climb within one ramp step, not at the next
  // control period.
  if (goal_ && state_ == GoalState::kActive) {
    const std::string why = inputFault(now_s, hooks, 0.0, nullptr);
    if (!why.empty()) halt(why);
  }
  // The time this command may take credit for: the node clock since the last published command (0 when the
  // clock went backwards), capped.
  const double dt =
      !last_publish_s_ ? 1.0 / config_.ramp_rate_hz : std::clamp(now_s - *last_publish_s_, 0.0, kMaxRampStepS);
  if (emergency_) {
    // A contact or a hazard under the base: zero now. The base cannot follow the deceleration limit into an
    // obstacle it touches; the envelope checks the commands after this one from rest.
    emergency_ = false;
    envelope_.restartFrom(Twist2{});
    command_ = Twist2{};
    last_publish_s_ = now_s;
    idle_zero_messages_ = 0;
    RampCommand out;
    out.publish = true;
    return out;
  }
  const Twist2 next = rampStep(envelope_.last(), dt);
  const bool still = next.v == 0.0 && next.w == 0.0;
  idle_zero_messages_ = still ? idle_zero_messages_ + 1 : 0;
  RampCommand out;
  // Keep publishing while moving or active; once stopped and idle, send a few zeros and go quiet so that other
  // sources (teleop) can drive the base.
  if (state_ == GoalState::kActive || !still || idle_zero_messages_ <= 10) {
    // The safety envelope: the last check before the command leaves (feasible, within the acceleration limits of
    // the previous command over the real elapsed time, finite); a violation is corrected.
    const EnvelopeResult checked = envelope_.filter(next, dt);
    if (checked.modified()) {
      std::ostringstream os;
      os << "cmd_vel outside the safety envelope (" << envelope_.corrected()
         << " so far): " << envelope_.lastCorrection();
      log(SupervisorLog::kWarn, "envelope", os.str(), 1.0);
    }
    command_ = checked.command;
    last_publish_s_ = now_s;
    out.publish = true;
    out.command = command_;
    out.corrected = checked.modified();
  } else {
    command_ = next;
    out.command = command_;
  }
  return out;
}

}  // namespace dqn_dovs
