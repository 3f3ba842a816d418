#include "dqn_dovs/supervision/navigation_monitor.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "dqn_dovs/common/geometry.h"

namespace dqn_dovs {

const char* recoveryStepName(RecoveryStep s) {
  switch (s) {
    case RecoveryStep::kNone:
      return "none";
    case RecoveryStep::kWait:
      return "wait";
    case RecoveryStep::kRotate:
      return "rotate in place";
    case RecoveryStep::kBackOff:
      return "back off";
  }
  return "unknown";
}

std::string NavigationConfig::validate() const {
  std::ostringstream os;
  auto in = [](double x, double lo, double hi) { return std::isfinite(x) && x >= lo && x <= hi; };
  if (!in(progress_timeout_s, 0.0, 600.0)) {
    os << "progress_timeout = " << progress_timeout_s << " s is outside [0, 600]";
  } else if (!in(progress_distance_m, 0.01, 10.0)) {
    os << "progress_distance = " << progress_distance_m << " m is outside [0.01, 10]";
  } else if (!in(oscillation_timeout_s, 0.0, 600.0)) {
    os << "oscillation_timeout = " << oscillation_timeout_s << " s is outside [0, 600]";
  } else if (!in(oscillation_distance_m, 0.01, 10.0)) {
    os << "oscillation_distance = " << oscillation_distance_m << " m is outside [0.01, 10]";
  } else if (oscillation_flips < 1 || oscillation_flips > 1000) {
    os << "oscillation_flips = " << oscillation_flips << " is outside [1, 1000]";
  } else if (!in(stall_command_mps, 0.0, 10.0) || !in(stall_odom_mps, 0.0, 10.0) ||
             stall_odom_mps >= stall_command_mps) {
    os << "stall_odom_speed = " << stall_odom_mps << " m/s must be below stall_command_speed = " << stall_command_mps
       << " m/s (both in [0, 10])";
  } else if (!in(stall_time_s, 0.0, 60.0)) {
    os << "stall_time = " << stall_time_s << " s is outside [0, 60]";
  } else if (!in(recovery_wait_s, 0.0, 120.0)) {
    os << "recovery_wait = " << recovery_wait_s << " s is outside [0, 120]";
  } else if (!in(recovery_rotate_rad, 0.0, 4.0 * kPi)) {
    os << "recovery_rotate_angle = " << recovery_rotate_rad << " rad is outside [0, 4 pi]";
  } else if (!in(recovery_rotate_speed, 0.05, 10.0)) {
    os << "recovery_rotate_speed = " << recovery_rotate_speed << " rad/s is outside [0.05, 10]";
  } else if (!in(backoff_distance_m, 0.0, 2.0)) {
    os << "backoff_distance = " << backoff_distance_m << " m is outside [0, 2]";
  } else if (!in(backoff_speed_mps, 0.02, 0.5)) {
    os << "backoff_speed = " << backoff_speed_mps << " m/s is outside [0.02, 0.5]";
  } else if (max_recovery_rounds < 0 || max_recovery_rounds > 100) {
    os << "max_recovery_rounds = " << max_recovery_rounds << " is outside [0, 100]";
  }
  return os.str();
}

namespace {
const NavigationConfig& checked(const NavigationConfig& c) {
  if (const std::string e = c.validate(); !e.empty()) throw std::invalid_argument("navigation: " + e);
  return c;
}
int sign(double x, double dead_band) { return x > dead_band ? 1 : (x < -dead_band ? -1 : 0); }
}  // namespace

NavigationMonitor::NavigationMonitor(const NavigationConfig& config) : config_(checked(config)) {}

void NavigationMonitor::setConfig(const NavigationConfig& config) { config_ = checked(config); }

void NavigationMonitor::reset(double now_s) {
  have_progress_ = false;
  progress_since_s_ = now_s;
  window_.clear();
  stall_since_s_ = -1.0;
  contact_.clear();
  step_ = RecoveryStep::kNone;
  rounds_ = 0;
  progressed_since_round_ = true;
  last_trigger_.clear();
}

void NavigationMonitor::restartWindows(double now_s, double remaining_m) {
  best_remaining_m_ = remaining_m;
  progress_since_s_ = now_s;
  last_observe_s_ = now_s;
  have_progress_ = true;
  window_.clear();
  stall_since_s_ = -1.0;
}

std::string NavigationMonitor::observe(double now_s, const Pose2& pose, double remaining_m, const Twist2& command,
                                       double odom_speed_mps) {
  if (!have_progress_) restartWindows(now_s, remaining_m);
  const double gap = now_s - last_observe_s_;
  if (gap < 0.0 || gap > kMaxObserveGapS) {
    // Not driving in between (halted on stale input, recovering, on the goal) or the clock jumped: the windows
    // measure driving time, so the progress clock resumes where it stopped and the other windows start afresh.
    progress_since_s_ = now_s - std::max(0.0, last_observe_s_ - progress_since_s_);
    window_.clear();
    stall_since_s_ = -1.0;
  }
  last_observe_s_ = now_s;
  std::ostringstream why;
  why.precision(3);
  // Progress: the way left must shrink by progress_distance_m per progress_timeout_s.
  if (remaining_m <= best_remaining_m_ - config_.progress_distance_m) {
    best_remaining_m_ = remaining_m;
    progress_since_s_ = now_s;
    rounds_ = 0;  // progress between rounds: the next trigger starts a fresh count
  } else if (config_.progress_timeout_s > 0.0 && now_s - progress_since_s_ >= config_.progress_timeout_s) {
    why << "no progress: " << remaining_m << " m left, not " << config_.progress_distance_m << " m closer in "
        << config_.progress_timeout_s << " s";
  }
  // Oscillation: sign changes of the command while the robot stays near where it was.
  if (why.str().empty() && config_.oscillation_timeout_s > 0.0) {
    window_.push_back({now_s, pose.position(), sign(command.v, 0.02), sign(command.w, 0.1)});
    while (!window_.empty() && now_s - window_.front().t > config_.oscillation_timeout_s) window_.pop_front();
    int flips = 0, last_v = 0, last_w = 0;
    double reach = 0.0;
    for (const Sample& s : window_) {
      if (s.v_sign != 0) flips += (last_v != 0 && s.v_sign != last_v), last_v = s.v_sign;
      if (s.w_sign != 0) flips += (last_w != 0 && s.w_sign != last_w), last_w = s.w_sign;
      reach = std::max(reach, (s.position - window_.front().position).norm());
    }
    const bool full = now_s - window_.front().t >= 0.9 * config_.oscillation_timeout_s;
    if (full && flips >= config_.oscillation_flips && reach < config_.oscillation_distance_m) {
      why << "oscillating: " << flips << " reversals of the command within " << reach << " m in "
          << config_.oscillation_timeout_s << " s";
    }
  }
  // Stall: the command asks for speed the wheels do not deliver.
  if (why.str().empty() && config_.stall_time_s > 0.0) {
    if (std::abs(command.v) > config_.stall_command_mps && std::abs(odom_speed_mps) < config_.stall_odom_mps) {
      if (stall_since_s_ < 0.0) stall_since_s_ = now_s;
      if (now_s - stall_since_s_ >= config_.stall_time_s) {
        why << "stalled: commanded " << command.v << " m/s, odometry " << odom_speed_mps << " m/s for "
            << now_s - stall_since_s_ << " s";
      }
    } else {
      stall_since_s_ = -1.0;
    }
  }
  if (!why.str().empty()) last_trigger_ = why.str();
  return why.str();
}

void NavigationMonitor::contact(double /*now_s*/, const std::string& what) {
  contact_ = what;
  last_trigger_ = what;
}

std::string NavigationMonitor::takeContact() {
  std::string c;
  c.swap(contact_);
  return c;
}

void NavigationMonitor::startRecovery(double now_s, const Pose2& pose, const std::string& reason) {
  last_trigger_ = reason;
  if (rounds_ >= config_.max_recovery_rounds) {
    step_ = RecoveryStep::kNone;
    rounds_ = config_.max_recovery_rounds + 1;  // recover() aborts
    return;
  }
  ++rounds_;
  step_ = RecoveryStep::kNone;
  nextStep(now_s, pose);
}

void NavigationMonitor::nextStep(double now_s, const Pose2& pose) {
  // wait -> rotate -> back off (when allowed), skipping the steps configured away.
  const RecoveryStep order[] = {RecoveryStep::kWait, RecoveryStep::kRotate, RecoveryStep::kBackOff};
  auto enabled = [&](RecoveryStep s) {
    switch (s) {
      case RecoveryStep::kWait:
        return config_.recovery_wait_s > 0.0;
      case RecoveryStep::kRotate:
        return config_.recovery_rotate_rad > 0.0;
      case RecoveryStep::kBackOff:
        return config_.allow_reverse && config_.backoff_distance_m > 0.0;
      case RecoveryStep::kNone:
        break;
    }
    return false;
  };
  size_t i = 0;
  if (step_ != RecoveryStep::kNone) {
    while (i < 3 && order[i] != step_) ++i;
    ++i;
  }
  while (i < 3 && !enabled(order[i])) ++i;
  step_ = i < 3 ? order[i] : RecoveryStep::kNone;
  step_since_s_ = now_s;
  step_start_ = pose.position();
  last_theta_ = pose.theta;
  turned_rad_ = 0.0;
  if (step_ == RecoveryStep::kNone) have_progress_ = false;  // the round is over: fresh windows when driving again
}

RecoveryCommand NavigationMonitor::recover(double now_s, const Pose2& pose, const RobotLimits& limits) {
  RecoveryCommand out;
  if (rounds_ > config_.max_recovery_rounds) {
    std::ostringstream os;
    os << "gave up after " << config_.max_recovery_rounds << " recovery round"
       << (config_.max_recovery_rounds == 1 ? "" : "s") << " without progress; last: " << last_trigger_;
    out.abort = true;
    out.reason = os.str();
    return out;
  }
  // Each step ends on its own measure, or after a time limit it cannot need more than (a blocked turn or
  // back-off must not hold the round forever).
  for (int guard = 0; guard < 4 && step_ != RecoveryStep::kNone; ++guard) {
    const double elapsed = now_s - step_since_s_;
    bool done = false;
    switch (step_) {
      case RecoveryStep::kWait:
        done = elapsed >= config_.recovery_wait_s;
        break;
      case RecoveryStep::kRotate: {
        turned_rad_ += std::abs(normalizeAngle(pose.theta - last_theta_));
        last_theta_ = pose.theta;
        const double speed = std::min(config_.recovery_rotate_speed, limits.w_max);
        done = turned_rad_ >= config_.recovery_rotate_rad || elapsed > 3.0 * config_.recovery_rotate_rad / speed + 5.0;
        break;
      }
      case RecoveryStep::kBackOff:
        done = (pose.position() - step_start_).norm() >= config_.backoff_distance_m ||
               elapsed > 3.0 * config_.backoff_distance_m / config_.backoff_speed_mps + 5.0;
        break;
      case RecoveryStep::kNone:
        break;
    }
    if (!done) break;
    nextStep(now_s, pose);
  }
  out.step = step_;
  switch (step_) {
    case RecoveryStep::kRotate:
      out.target = {0.0, std::min(config_.recovery_rotate_speed, limits.w_max)};
      break;
    case RecoveryStep::kBackOff:
      out.target = {-config_.backoff_speed_mps, 0.0};
      break;
    default:
      break;
  }
  std::ostringstream os;
  os << "recovery " << rounds_ << " of " << config_.max_recovery_rounds << ": " << recoveryStepName(step_) << " ("
     << last_trigger_ << ")";
  out.reason = os.str();
  return out;
}

}  // namespace dqn_dovs
