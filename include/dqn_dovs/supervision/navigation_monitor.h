// Progress, oscillation and stall checks for one goal, and the recovery behaviours they start (ROS-free).
//
// While the robot drives to a goal the monitor is shown, once per control period, where the robot is, how much of
// the way is left (route length or straight-line distance), the command last sent and the speed odometry
// measures. It reports a trigger when
//   - no progress: the way left has not shrunk by progress_distance_m within progress_timeout_s;
//   - oscillation: within oscillation_timeout_s the robot stayed within oscillation_distance_m of where it was while
//     the commanded turn rate or speed changed sign at least oscillation_flips times;
//   - stall: the command asked for more than stall_command_mps while odometry measured less than stall_odom_mps for
//     stall_time_s (wheels blocked, a caster stuck on a threshold);
//   - the base reported a bumper contact (the adapter calls contact()).
// A trigger starts one round of recovery: wait (people may walk away), rotate in place once (the tracker sees all
// around and drops what is no longer there), and, when allow_reverse, back off slowly. The round ends and the
// robot drives again; after max_recovery_rounds rounds without progress between them the goal is aborted with
// the triggers' reasons. Recovery commands are targets for the command ramp, which keeps them within the
// acceleration limits and the safety envelope.
#pragma once

#include <deque>
#include <string>

#include "dqn_dovs/common/robot_model.h"
#include "dqn_dovs/common/types.h"

namespace dqn_dovs {

struct NavigationConfig {
  double progress_timeout_s = 20.0;     ///< s without progress_distance_m of progress: a trigger (0: off)
  double progress_distance_m = 0.3;     ///< m of the way left that must be gained per progress_timeout_s
  double oscillation_timeout_s = 10.0;  ///< s window of the oscillation check (0: off)
  double oscillation_distance_m = 0.3;  ///< m the robot must move away within the window
  int oscillation_flips = 4;            ///< sign changes of the commanded v or w within the window that count
  double stall_command_mps = 0.08;      ///< commanded speed above this (below a_v dt: see config/planner.yaml) ...
  double stall_odom_mps = 0.02;         ///< ... with odometry below this ...
  double stall_time_s = 1.0;            ///< ... for this long: stalled (0: off)
  double recovery_wait_s = 3.0;         ///< s of waiting at rest (0: skip)
  double recovery_rotate_rad = 6.2832;  ///< angle turned in place (0: skip)
  double recovery_rotate_speed = 0.8;   ///< rad/s, clipped to w_max
  bool allow_reverse = false;           ///< back off as the last recovery step
  double backoff_distance_m = 0.3;      ///< m backed off
  double backoff_speed_mps = 0.1;       ///< m/s while backing off
  int max_recovery_rounds = 2;          ///< rounds without progress between them before the goal is aborted
  /// Why the configuration is unusable ("" when it is), naming the field.
  std::string validate() const;
};

/// What a recovery step is doing.
enum class RecoveryStep { kNone, kWait, kRotate, kBackOff };
const char* recoveryStepName(RecoveryStep s);

/// One control period of recovery: the target to ramp to, or the end of the round / the goal.
struct RecoveryCommand {
  RecoveryStep step = RecoveryStep::kNone;  ///< kNone: the round is over, drive again (or abort when `abort`)
  Twist2 target;
  bool abort = false;  ///< give the goal up; `reason` says why
  std::string reason;
};

class NavigationMonitor {
 public:
  /// Throws std::invalid_argument naming the field of a bad configuration.
  explicit NavigationMonitor(const NavigationConfig& config = {});

  /// A new goal: forgets every window, every round and any recovery in progress.
  void reset(double now_s);

  /// One control period while driving (not recovering): the checks above. Returns the trigger's reason, "" when
  /// none. `remaining_m` is the way left to the goal; `command` the command last sent; `odom_speed_mps` the
  /// measured linear speed. The windows count driving time: a gap of more than kMaxObserveGapS since the last
  /// call (the robot halted on stale input, or the clock jumped) pauses the progress clock and restarts the others.
  std::string observe(double now_s, const Pose2& pose, double remaining_m, const Twist2& command,
                      double odom_speed_mps);

  /// A bumper contact (or a stall) the adapter saw: a trigger now, whatever the windows say.
  void contact(double now_s, const std::string& what);

  /// Starts a round of recovery for `reason` at `pose` (observe() or contact() said so). When the rounds are used
  /// up, the next recover() aborts.
  void startRecovery(double now_s, const Pose2& pose, const std::string& reason);

  /// One control period of recovery at `pose`, `limits` bounding the rotation and back-off speeds.
  RecoveryCommand recover(double now_s, const Pose2& pose, const RobotLimits& limits);

  bool recovering() const { return step_ != RecoveryStep::kNone; }
  RecoveryStep step() const { return step_; }
  int rounds() const { return rounds_; }
  /// The reason of the last trigger ("" when none since the goal began).
  const std::string& lastTrigger() const { return last_trigger_; }
  /// A pending contact trigger, taken by the adapter (cleared on read).
  std::string takeContact();
  const NavigationConfig& config() const { return config_; }
  /// Longest pause between two observe() calls that still counts as driving on, s.
  static constexpr double kMaxObserveGapS = 1.0;
  /// New settings while running (windows, rounds and any recovery in progress are kept); throws
  /// std::invalid_argument naming the field of a bad configuration, leaving the old one.
  void setConfig(const NavigationConfig& config);

 private:
  struct Sample {
    double t;
    Vec2 position;
    int v_sign, w_sign;
  };
  void nextStep(double now_s, const Pose2& pose);
  void restartWindows(double now_s, double remaining_m);

  NavigationConfig config_;
  // Progress: the best way left so far and when it was last improved by progress_distance_m.
  double best_remaining_m_ = 0.0, progress_since_s_ = 0.0, last_observe_s_ = 0.0;
  bool have_progress_ = false;
  std::deque<Sample> window_;  // oscillation window
  double stall_since_s_ = -1.0;
  std::string contact_;
  // Recovery state.
  RecoveryStep step_ = RecoveryStep::kNone;
  double step_since_s_ = 0.0, turned_rad_ = 0.0, last_theta_ = 0.0;
  Vec2 step_start_ = Vec2::Zero();
  int rounds_ = 0;
  bool progressed_since_round_ = true;
  std::string last_trigger_;
};

}  // namespace dqn_dovs
