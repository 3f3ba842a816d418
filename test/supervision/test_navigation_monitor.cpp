// Progress, oscillation and stall checks and the recovery rounds they start, without ROS; and the supervisor's
// use of them: the heading at the goal, an abort after the rounds, a bumper contact that drops the command to
// zero at once, a cliff that aborts.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>

#include "dqn_dovs/supervision/navigation_monitor.h"
#include "dqn_dovs/supervision/supervisor.h"

namespace dqn_dovs {
namespace {

NavigationConfig quick() {
  NavigationConfig c;
  c.progress_timeout_s = 5.0;
  c.progress_distance_m = 0.3;
  c.oscillation_timeout_s = 0.0;
  c.stall_time_s = 0.0;
  c.recovery_wait_s = 1.0;
  c.recovery_rotate_rad = 1.0;
  c.recovery_rotate_speed = 1.0;
  c.max_recovery_rounds = 2;
  return c;
}

TEST(NavigationMonitor, ProgressResetsTheTimerAndItsLackTriggers) {
  NavigationMonitor m(quick());
  m.reset(0.0);
  // 0.1 m/s towards the goal: 0.3 m per 3 s, within the 5 s window: never a trigger.
  for (double t = 0.0; t < 20.0; t += 0.2) EXPECT_EQ(m.observe(t, Pose2{}, 10.0 - 0.1 * t, {0.1, 0.0}, 0.1), "") << t;
  // Stuck at 8 m left: a trigger 5 s after the last 0.3 m step gained, not before.
  const double stuck_from = 20.0;
  std::string why;
  double t = stuck_from;
  for (; t < 40.0 && why.empty(); t += 0.2) why = m.observe(t, Pose2{}, 8.0, {0.1, 0.0}, 0.1);
  EXPECT_NE(why.find("no progress"), std::string::npos) << why;
  // The last 0.3 m step was gained at most 3 s (0.3 m at 0.1 m/s) before the robot got stuck.
  EXPECT_GE(t - 0.2, stuck_from + 5.0 - 3.0 - 1e-9);
  EXPECT_LE(t - 0.2, stuck_from + 5.0 + 1e-9);
}

TEST(NavigationMonitor, TheProgressClockCountsDrivingTimeOnly) {
  NavigationMonitor m(quick());  // 0.3 m per 5 s
  m.reset(0.0);
  for (double t = 0.0; t < 3.0; t += 0.2) EXPECT_EQ(m.observe(t, Pose2{}, 8.0, {0.2, 0.0}, 0.2), "") << t;
  // Halted for 30 s (stale input) or a clock jump: no trigger on the first period back ...
  EXPECT_EQ(m.observe(33.0, Pose2{}, 8.0, {0.2, 0.0}, 0.2), "");
  // ... but after 5 s of driving without progress in all (about 2.2 s more).
  std::string why;
  double t = 33.2;
  for (; t < 40.0 && why.empty(); t += 0.2) why = m.observe(t, Pose2{}, 8.0, {0.2, 0.0}, 0.2);
  EXPECT_NE(why.find("no progress"), std::string::npos);
  EXPECT_NEAR(t - 0.2, 35.0, 0.45);
  // A clock that goes back is no trigger either.
  m.reset(0.0);
  for (double s = 0.0; s < 2.0; s += 0.2) m.observe(s, Pose2{}, 8.0, {0.2, 0.0}, 0.2);
  EXPECT_EQ(m.observe(-5.0, Pose2{}, 8.0, {0.2, 0.0}, 0.2), "");
}

TEST(NavigationMonitor, OscillationTriggersOnlyWhenTheRobotStaysPut) {
  NavigationConfig c = quick();
  c.progress_timeout_s = 0.0;
  c.oscillation_timeout_s = 4.0;
  c.oscillation_flips = 4;
  NavigationMonitor m(c);
  m.reset(0.0);
  std::string why;
  // Turning left and right every 0.4 s in place: oscillating once the window is full.
  for (double t = 0.0; t < 6.0 && why.empty(); t += 0.2) {
    why = m.observe(t, Pose2{}, 5.0, {0.0, std::fmod(t, 0.8) < 0.4 ? 1.0 : -1.0}, 0.0);
  }
  EXPECT_NE(why.find("oscillating"), std::string::npos) << why;
  // The same commands while the robot moves away: no trigger.
  m.reset(0.0);
  for (double t = 0.0; t < 10.0; t += 0.2) {
    EXPECT_EQ(m.observe(t, Pose2{0.3 * t, 0.0, 0.0}, 5.0, {0.3, std::fmod(t, 0.8) < 0.4 ? 1.0 : -1.0}, 0.3), "");
  }
}

TEST(NavigationMonitor, StallNeedsTheWholeStallTime) {
  NavigationConfig c = quick();
  c.progress_timeout_s = 0.0;
  c.stall_time_s = 1.0;
  NavigationMonitor m(c);
  m.reset(0.0);
  EXPECT_EQ(m.observe(0.0, Pose2{}, 5.0, {0.2, 0.0}, 0.0), "");
  EXPECT_EQ(m.observe(0.8, Pose2{}, 5.0, {0.2, 0.0}, 0.0), "");
  EXPECT_EQ(m.observe(1.0, Pose2{}, 5.0, {0.2, 0.0}, 0.15), "");  // the wheels turned: the clock restarts
  EXPECT_EQ(m.observe(1.6, Pose2{}, 5.0, {0.2, 0.0}, 0.0), "");
  EXPECT_EQ(m.observe(2.4, Pose2{}, 5.0, {0.2, 0.0}, 0.0), "");
  EXPECT_NE(m.observe(2.6, Pose2{}, 5.0, {0.2, 0.0}, 0.0).find("stalled"), std::string::npos);
  EXPECT_EQ(m.observe(3.0, Pose2{}, 5.0, {0.05, 0.0}, 0.0), "");  // a slow command is no stall
}

TEST(NavigationMonitor, ARoundWaitsThenTurnsThenEnds) {
  NavigationMonitor m(quick());
  RobotLimits limits;
  m.reset(0.0);
  m.startRecovery(10.0, Pose2{}, "no progress");
  ASSERT_TRUE(m.recovering());
  RecoveryCommand r = m.recover(10.0, Pose2{}, limits);
  EXPECT_EQ(r.step, RecoveryStep::kWait);
  EXPECT_EQ(r.target.v, 0.0);
  EXPECT_EQ(r.target.w, 0.0);
  EXPECT_NE(r.reason.find("recovery 1 of 2: wait (no progress)"), std::string::npos) << r.reason;
  r = m.recover(11.1, Pose2{}, limits);
  EXPECT_EQ(r.step, RecoveryStep::kRotate);
  EXPECT_DOUBLE_EQ(r.target.w, 1.0);
  r = m.recover(11.5, Pose2{0.0, 0.0, 0.5}, limits);  // turned 0.5 of 1 rad
  EXPECT_EQ(r.step, RecoveryStep::kRotate);
  r = m.recover(12.1, Pose2{0.0, 0.0, 1.05}, limits);
  EXPECT_EQ(r.step, RecoveryStep::kNone);
  EXPECT_FALSE(r.abort);
  EXPECT_FALSE(m.recovering());
  EXPECT_EQ(m.rounds(), 1);
}

TEST(NavigationMonitor, RoundsWithoutProgressEndInAnAbortProgressResetsThem) {
  NavigationConfig c = quick();
  c.recovery_rotate_rad = 0.0;  // wait only
  NavigationMonitor m(c);
  RobotLimits limits;
  m.reset(0.0);
  for (int round = 1; round <= 2; ++round) {
    m.startRecovery(10.0 * round, Pose2{}, "no progress");
    EXPECT_EQ(m.recover(10.0 * round, Pose2{}, limits).step, RecoveryStep::kWait);
    EXPECT_EQ(m.recover(10.0 * round + 1.5, Pose2{}, limits).step, RecoveryStep::kNone);
  }
  m.startRecovery(40.0, Pose2{}, "no progress: 8 m left");
  const RecoveryCommand r = m.recover(40.0, Pose2{}, limits);
  EXPECT_TRUE(r.abort);
  EXPECT_NE(r.reason.find("gave up after 2 recovery rounds"), std::string::npos) << r.reason;
  EXPECT_NE(r.reason.find("no progress: 8 m left"), std::string::npos) << r.reason;

  // Progress between rounds starts the count afresh.
  m.reset(0.0);
  m.startRecovery(1.0, Pose2{}, "no progress");
  m.recover(3.0, Pose2{}, limits);
  EXPECT_EQ(m.rounds(), 1);
  m.observe(4.0, Pose2{}, 5.0, {0.2, 0.0}, 0.2);
  m.observe(5.0, Pose2{}, 4.0, {0.2, 0.0}, 0.2);
  EXPECT_EQ(m.rounds(), 0);
}

TEST(NavigationMonitor, BackOffOnlyWhenReverseIsAllowed) {
  NavigationConfig c = quick();
  c.recovery_wait_s = 0.0;
  c.recovery_rotate_rad = 0.0;
  c.allow_reverse = true;
  NavigationMonitor m(c);
  RobotLimits limits;
  m.reset(0.0);
  m.startRecovery(1.0, Pose2{}, "bumper pressed");
  RecoveryCommand r = m.recover(1.0, Pose2{}, limits);
  EXPECT_EQ(r.step, RecoveryStep::kBackOff);
  EXPECT_DOUBLE_EQ(r.target.v, -c.backoff_speed_mps);
  r = m.recover(3.0, Pose2{-0.31, 0.0, 0.0}, limits);
  EXPECT_EQ(r.step, RecoveryStep::kNone);
  c.allow_reverse = false;
  NavigationMonitor none(c);
  none.reset(0.0);
  none.startRecovery(1.0, Pose2{}, "bumper pressed");
  EXPECT_FALSE(none.recovering()) << "no step enabled: the round is over at once";
}

TEST(NavigationMonitor, BadConfigurationIsNamed) {
  NavigationConfig c;
  c.progress_distance_m = 0.0;
  EXPECT_NE(c.validate().find("progress_distance"), std::string::npos);
  c = NavigationConfig();
  c.stall_odom_mps = 0.2;
  EXPECT_NE(c.validate().find("stall_odom_speed"), std::string::npos);
  c = NavigationConfig();
  c.max_recovery_rounds = -1;
  EXPECT_THROW(NavigationMonitor{c}, std::invalid_argument);
}

// The supervisor with a robot the test places and a decision that drives at 0.3 m/s.
struct Robot {
  explicit Robot(const SupervisorConfig& c = config()) : supervisor(c) {
    hooks.robot_pose = [this](double) {
      RobotPoseLookup p;
      p.stamp_s = stamp;
      p.pose = pose;
      return p;
    };
    hooks.space_fault = [] { return std::string(); };
    hooks.choose = [](const Pose2&) {
      Choice c;
      c.target = {0.3, 0.0};
      c.action = 1;
      return c;
    };
  }
  static SupervisorConfig config() {
    SupervisorConfig c;
    c.navigation = quick();
    return c;
  }
  void period(double t, double odom_speed = 0.0) {
    stamp = t;
    supervisor.checkClock(t);
    supervisor.scan(t, "");
    supervisor.odom(t, "", odom_speed);
    supervisor.space(t);
    supervisor.controlPeriod(t, 0.0, hooks, 0.0);
    for (int k = 1; k <= 10; ++k) {
      supervisor.checkClock(t + 0.02 * k);
      last = supervisor.ramp(t + 0.02 * k, hooks);
      pose = integrateUnicycle(pose, last.command.v, last.command.w, 0.02);
    }
  }
  Supervisor supervisor;
  DecisionHooks hooks;
  Pose2 pose;
  double stamp = 0.0;
  RampCommand last;
};

TEST(SupervisorNavigation, TurnsToTheGoalHeadingBeforeReached) {
  Robot r;
  r.pose = Pose2{1.95, 0.0, 0.0};
  r.supervisor.newGoal({2.0, 0.0}, 1.5, 0.0);
  double t = 0.0;
  for (; t < 10.0 && r.supervisor.state() != GoalState::kReached; t += 0.2) {
    r.period(t);
    if (r.supervisor.aligning()) {
      EXPECT_EQ(r.supervisor.target().v, 0.0);
    }
  }
  ASSERT_EQ(r.supervisor.state(), GoalState::kReached);
  EXPECT_LT(std::abs(normalizeAngle(r.pose.theta - 1.5)), r.supervisor.config().yaw_tolerance_rad + 0.05);
  // Without a heading, reached at once.
  Robot plain;
  plain.pose = Pose2{1.95, 0.0, 0.0};
  plain.supervisor.newGoal({2.0, 0.0}, std::nullopt, 0.0);
  plain.period(0.0);
  EXPECT_EQ(plain.supervisor.state(), GoalState::kReached);
}

TEST(SupervisorNavigation, NoProgressEndsInAnAbortWithTheReason) {
  Robot r;
  r.hooks.remaining = [](const Pose2&) { return 8.0; };  // a route that never gets shorter
  r.supervisor.newGoal({10.0, 0.0}, std::nullopt, 0.0);
  for (double t = 0.0; t < 60.0 && r.supervisor.state() != GoalState::kAborted; t += 0.2) r.period(t, 0.3);
  ASSERT_EQ(r.supervisor.state(), GoalState::kAborted);
  EXPECT_NE(r.supervisor.reason().find("gave up after 2 recovery rounds"), std::string::npos) << r.supervisor.reason();
  EXPECT_FALSE(r.supervisor.hasGoal());
  r.period(61.0);
  EXPECT_EQ(r.supervisor.target().v, 0.0);
}

TEST(SupervisorNavigation, BumperDropsTheCommandAtOnceAndHoldsUntilReleased) {
  Robot r;
  r.supervisor.newGoal({10.0, 0.0}, std::nullopt, 0.0);
  for (double t = 0.0; t < 2.0; t += 0.2) r.period(t, 0.3);
  ASSERT_GT(r.supervisor.command().v, 0.25);
  r.supervisor.contact(2.0, "bumper pressed");
  const RampCommand next = r.supervisor.ramp(2.01, r.hooks);
  EXPECT_TRUE(next.publish);
  EXPECT_EQ(next.command.v, 0.0) << "zero at once, not along the deceleration ramp";
  // The round (wait 1 s, turn 1 rad) runs; then the robot holds still while the bumper is pressed.
  for (double t = 2.2; t < 8.0; t += 0.2) r.period(t);
  EXPECT_EQ(r.supervisor.target().v, 0.0);
  EXPECT_NE(r.supervisor.reason().find("bumper pressed"), std::string::npos) << r.supervisor.reason();
  r.supervisor.contact(8.0, "");
  for (double t = 8.0; t < 9.0; t += 0.2) r.period(t, 0.3);
  EXPECT_GT(r.supervisor.command().v, 0.0) << "driving again after the release";
}

TEST(SupervisorNavigation, BackOffWithReverseAllowedIsStraightSlowAndWithinTheLimits) {
  SupervisorConfig c = Robot::config();
  c.navigation.recovery_wait_s = 0.0;
  c.navigation.recovery_rotate_rad = 0.0;
  c.navigation.allow_reverse = true;
  c.navigation.backoff_speed_mps = 0.1;
  c.navigation.backoff_distance_m = 0.3;
  Robot r(c);
  r.supervisor.newGoal({10.0, 0.0}, std::nullopt, 0.0);
  for (double t = 0.0; t < 1.0; t += 0.2) r.period(t, 0.3);
  r.supervisor.contact(1.0, "bumper pressed");
  r.supervisor.contact(1.05, "");  // released at once: the round backs off
  double most_reverse = 0.0;
  Twist2 previous;  // the contact dropped the command to zero at once
  for (double t = 1.2; t < 6.0; t += 0.2) {
    r.period(t);
    most_reverse = std::min(most_reverse, r.supervisor.command().v);
    if (r.supervisor.command().v < 0.0) {
      EXPECT_EQ(r.supervisor.command().w, 0.0);
    }
    EXPECT_LE(std::abs(r.supervisor.command().v - previous.v), c.limits.a_v * 0.2 + 1e-9);
    previous = r.supervisor.command();
  }
  EXPECT_LT(most_reverse, -0.05) << "no back-off";
  EXPECT_GE(most_reverse, -0.1 - 1e-9);
  EXPECT_EQ(r.supervisor.envelope().corrected(), 0u) << r.supervisor.envelope().lastCorrection();
  // Without allow_reverse the same contact never reverses.
  Robot plain;
  plain.supervisor.newGoal({10.0, 0.0}, std::nullopt, 0.0);
  for (double t = 0.0; t < 1.0; t += 0.2) plain.period(t, 0.3);
  plain.supervisor.contact(1.0, "bumper pressed");
  plain.supervisor.contact(1.05, "");
  for (double t = 1.2; t < 6.0; t += 0.2) {
    plain.period(t);
    EXPECT_GE(plain.supervisor.command().v, 0.0);
  }
}

TEST(SupervisorNavigation, ReconfigureChangesTheChecksButNeverTheLimits) {
  Robot r;
  SupervisorConfig c = r.supervisor.config();
  c.goal_tolerance_m = 0.3;
  c.navigation.max_recovery_rounds = 5;
  EXPECT_EQ(r.supervisor.reconfigure(c), "");
  EXPECT_EQ(r.supervisor.config().goal_tolerance_m, 0.3);
  EXPECT_EQ(r.supervisor.navigation().config().max_recovery_rounds, 5);
  SupervisorConfig faster = r.supervisor.config();
  faster.limits.v_max = 1.5;
  EXPECT_NE(r.supervisor.reconfigure(faster).find("fixed at start"), std::string::npos);
  EXPECT_EQ(r.supervisor.config().limits.v_max, RobotLimits().v_max);
  SupervisorConfig reverse = r.supervisor.config();
  reverse.navigation.allow_reverse = true;
  EXPECT_NE(r.supervisor.reconfigure(reverse).find("fixed at start"), std::string::npos);
  SupervisorConfig bad = r.supervisor.config();
  bad.yaw_tolerance_rad = 0.0;
  EXPECT_NE(r.supervisor.reconfigure(bad).find("yaw_tolerance"), std::string::npos);
  EXPECT_EQ(r.supervisor.config().yaw_tolerance_rad, SupervisorConfig().yaw_tolerance_rad);
}

TEST(SupervisorNavigation, CliffAbortsAndNothingDrivesUntilItClears) {
  Robot r;
  r.supervisor.newGoal({10.0, 0.0}, std::nullopt, 0.0);
  for (double t = 0.0; t < 1.0; t += 0.2) r.period(t, 0.3);
  r.supervisor.baseHazard(1.0, "cliff sensor sees no floor");
  EXPECT_EQ(r.supervisor.ramp(1.01, r.hooks).command.v, 0.0);
  EXPECT_EQ(r.supervisor.state(), GoalState::kAborted);
  EXPECT_EQ(r.supervisor.reason(), "cliff sensor sees no floor");
  r.supervisor.newGoal({10.0, 0.0}, std::nullopt, 1.2);
  r.period(1.2);
  EXPECT_EQ(r.supervisor.state(), GoalState::kStopped);
  EXPECT_NE(r.supervisor.reason().find("cliff"), std::string::npos);
  r.supervisor.baseHazard(1.4, "");
  r.period(1.4, 0.0);
  EXPECT_EQ(r.supervisor.state(), GoalState::kActive);
}

}  // namespace
}  // namespace dqn_dovs
