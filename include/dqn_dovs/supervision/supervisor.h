// The planner's supervision, ROS-free: the goal life cycle (idle -> active -> reached, stopped with a reason), the
// input watchdog (stale, missing, rejected or future-stamped scan, odom, velocity space and robot pose), the latch
// after a clock jump, the command ramp within the acceleration limits through the safety envelope, and the
// deadline accounting of the control periods. planner_node is its adapter: it turns messages, tf lookups and
// timer events into the calls below and publishes what they return; the decision itself (network, shield
// escape, static last line) is handed in as a callback. Times are seconds of the node's clock.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>

#include "dqn_dovs/common/robot_model.h"
#include "dqn_dovs/common/types.h"
#include "dqn_dovs/supervision/navigation_monitor.h"
#include "dqn_dovs/supervision/safety_envelope.h"

namespace dqn_dovs {

/// The goal life cycle (the values of dqn_dovs/PlannerStatus's state constants).
enum class GoalState : uint8_t { kIdle = 0, kActive = 1, kReached = 2, kStopped = 3, kAborted = 4 };
const char* goalStateName(GoalState s);

struct SupervisorConfig {
  RobotLimits limits;
  double max_input_age_s = 0.5;     ///< inputs older (or stamped further in the future) than this are stale
  double goal_tolerance_m = 0.15;   ///< closer than this to the goal: brake and hold
  double goal_speed_mps = 0.2;      ///< ... and reached once the command is slower than this
  double ramp_rate_hz = 50.0;       ///< command ramp rate
  double deadline_fraction = 0.5;   ///< a control period starting later than this fraction of dt misses its deadline
  double yaw_tolerance_rad = 0.15;  ///< a goal with a heading: turn in place on it until within this
  double align_speed = 1.0;         ///< rad/s, fastest turn while aligning (clipped to w_max)
  NavigationConfig navigation;      ///< progress, oscillation and stall checks; recovery
  std::string validate() const;
};

/// Where the robot is, as the adapter found it (tf): `error` non-empty when there is no pose.
struct RobotPoseLookup {
  std::string error;
  double stamp_s = 0.0;  ///< the pose's stamp
  Pose2 pose;            ///< may be non-finite: the supervisor refuses it
};

/// The decision for one control period, made by the adapter for the robot at the given pose.
struct Choice {
  std::string why;  ///< non-empty: no decision (the robot halts with this reason)
  Twist2 target;    ///< velocity to reach by the end of the period
  int action = -1;  ///< 0..7, 8 for the shield's escape, -1 none
};

/// What the adapter plugs in: the robot pose lookup (waiting up to wait_s), whether the latest velocity space
/// can be decided on ("" when it can), the decision itself, and the way left to the goal from a pose (a route's
/// remaining length; unset: the straight-line distance), which the progress check watches.
struct DecisionHooks {
  std::function<RobotPoseLookup(double wait_s)> robot_pose;
  std::function<std::string()> space_fault;
  std::function<Choice(const Pose2& pose)> choose;
  std::function<double(const Pose2& pose)> remaining;
};

/// Messages for the adapter's log: level, text, and the minimum interval between two messages of that key (0: always).
enum class SupervisorLog { kInfo, kWarn };
using SupervisorLogSink =
    std::function<void(SupervisorLog level, const std::string& key, const std::string& text, double throttle_s)>;

/// A clock step seen by checkClock().
enum class ClockJump { kNone, kForward, kBackward };

/// One command of the ramp: what to publish (when `publish`), and whether the envelope corrected it.
struct RampCommand {
  bool publish = false;
  Twist2 command;
  bool corrected = false;
};

class Supervisor {
 public:
  /// Throws std::invalid_argument naming the field of a bad configuration.
  explicit Supervisor(const SupervisorConfig& config, SupervisorLogSink log = {});

  // --- the goal life cycle --------------------------------------------------------------------------------------
  /// A new goal (fixed frame; with a final heading when `yaw` is set) replaces the previous one: active, with
  /// fresh progress windows and no recovery.
  void newGoal(const Vec2& goal, std::optional<double> yaw = std::nullopt, double now_s = 0.0);
  /// The same goal seen again in the fixed frame (the adapter re-transforms it every control period: localisation
  /// moves the map against odom); the life cycle is untouched.
  void moveGoal(const Vec2& goal, std::optional<double> yaw);
  /// The goal given up: no goal, aborted with `reason` (the adapter's action server reports it).
  void abort(const std::string& reason);
  /// A goal that could not be accepted (NaN, no transform): no goal, stopped with `reason`.
  void rejectGoal(const std::string& reason);
  /// Cancel: no goal, stopped.
  void cancel();

  // --- inputs ---------------------------------------------------------------------------------------------------
  /// A scan stamped stamp_s; `fault` non-empty when it is unusable (the robot then halts at once while active).
  void scan(double stamp_s, const std::string& fault);
  /// An odometry message; `fault` non-empty when it is unusable; `speed_mps` the linear speed it measured.
  void odom(double stamp_s, const std::string& fault, double speed_mps = 0.0);
  /// The base touched something (bumper), `what` non-empty, or the contact ended (""): at the onset the command
  /// drops to zero at once (the ramp does not decelerate into the contact) and, while a goal is pursued, a round of
  /// recovery starts; after the round, the robot holds still until the contact ends.
  void contact(double now_s, const std::string& what);
  /// A hazard under the base (cliff, wheel drop), `what` non-empty, or its end (""): at the onset the command drops
  /// to zero at once and the goal is aborted; while it lasts nothing drives.
  void baseHazard(double now_s, const std::string& what);
  /// A velocity space stamped stamp_s arrived.
  void space(double stamp_s);

  /// Watches the node clock: a backward step (more than 10 ms) or a forward one longer than max_input_age_s
  /// latches a stop until the robot is at rest with fresh input. After a backward jump every input received so far
  /// is forgotten (the adapter forgets its own: the last velocity space, the tf buffer).
  ClockJump checkClock(double now_s);

  /// Why the inputs cannot be trusted at now_s ("" when they can); fills `pose` when they can.
  std::string inputFault(double now_s, const DecisionHooks& hooks, double tf_wait_s, Pose2* pose);

  // --- the two timers -------------------------------------------------------------------------------------------
  /// Once per control period: the deadline (lateness_s of this period's start, when known), then the decision
  /// while a goal is pursued or the robot is stopped with a goal (resuming when the inputs are good again).
  /// Returns the goal distance when it was measured.
  std::optional<double> controlPeriod(double now_s, std::optional<double> lateness_s, const DecisionHooks& hooks,
                                      double tf_wait_s);
  /// At the ramp rate: the watchdog (without waiting for tf), then the next command towards the target within
  /// the acceleration limits through the safety envelope; stopped and idle, a few zeros and then nothing.
  RampCommand ramp(double now_s, const DecisionHooks& hooks);

  // --- state ----------------------------------------------------------------------------------------------------
  GoalState state() const { return state_; }
  const std::string& reason() const { return reason_; }
  bool hasGoal() const { return goal_.has_value(); }
  const std::optional<Vec2>& goal() const { return goal_; }
  int action() const { return action_; }
  const Twist2& target() const { return target_; }
  const Twist2& command() const { return command_; }
  const std::string& clockFault() const { return clock_fault_; }
  const SafetyEnvelope& envelope() const { return envelope_; }
  uint32_t controlPeriods() const { return control_periods_; }
  uint32_t deadlineMisses() const { return deadline_misses_; }
  double maxLateness_s() const { return max_lateness_s_; }
  const SupervisorConfig& config() const { return config_; }
  /// New settings while running: the goal tolerances, the heading and the navigation checks. The robot's limits,
  /// the input ages, the ramp rate, the deadline fraction and allow_reverse are fixed at construction (they bound
  /// what the envelope admits); a change to them, or a configuration validate() refuses, is refused with the
  /// reason ("" when applied).
  std::string reconfigure(const SupervisorConfig& config);
  const NavigationMonitor& navigation() const { return navigation_; }
  /// True while turning in place on the goal towards its heading.
  bool aligning() const { return aligning_; }

  /// The longest step one command may take credit for (a pause never licenses a larger jump than a_v times it).
  static constexpr double kMaxRampStepS = 0.1;
  /// A clock that goes back by more than this between two checks has jumped.
  static constexpr double kBackwardJumpS = 0.01;

 private:
  void stop(const std::string& reason);
  void halt(const std::string& reason);
  void emergencyZero();
  /// The next ramp command from `last` towards the target within the acceleration limits over dt (straight
  /// reverse for a back-off when navigation.allow_reverse).
  Twist2 rampStep(const Twist2& last, double dt) const;
  /// The target on the goal: brake, then turn to the heading; reached once slow and aligned.
  void onGoal(const Pose2& pose, double goal_distance);
  std::string decide(double now_s, const DecisionHooks& hooks, double tf_wait_s, std::optional<double>& goal_distance);
  void log(SupervisorLog level, const std::string& key, const std::string& text, double throttle_s = 0.0) const;

  SupervisorConfig config_;
  SupervisorLogSink log_;
  GoalState state_ = GoalState::kIdle;
  std::string reason_;
  std::optional<Vec2> goal_;
  std::optional<double> goal_yaw_;
  bool aligning_ = false;
  NavigationMonitor navigation_;
  double odom_speed_mps_ = 0.0;
  std::string hazard_, contact_;
  bool emergency_ = false;
  int action_ = -1;
  Twist2 target_, command_;
  double last_scan_s_ = 0.0, last_odom_s_ = 0.0, last_space_s_ = 0.0;
  bool have_scan_ = false, have_odom_ = false, have_space_ = false;
  std::string scan_fault_, odom_fault_, clock_fault_;
  std::optional<double> last_clock_s_, last_publish_s_;
  int idle_zero_messages_ = 0;
  SafetyEnvelope envelope_;
  uint32_t control_periods_ = 0, deadline_misses_ = 0;
  double max_lateness_s_ = 0.0;
};

}  // namespace dqn_dovs
