// The planner's supervision without ROS: every transition of the goal life cycle, the input watchdog (each input
// stale, missing, rejected, future-stamped), the clock-jump latch, the ramp within the acceleration limits and
// the idle silence, and the deadline accounting.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "dqn_dovs/supervision/supervisor.h"

namespace dqn_dovs {
namespace {

// A robot whose inputs the test sets: fresh scan, odom and velocity space at time t, pose at the origin, and a
// decision that drives at 0.5 m/s.
struct Rig {
  Rig()
      : supervisor(config(), [this](SupervisorLog, const std::string& key, const std::string& text, double) {
          logs.push_back(key + ": " + text);
        }) {
    hooks.robot_pose = [this](double) {
      RobotPoseLookup p;
      p.error = pose_error;
      p.stamp_s = pose_stamp;
      p.pose = pose;
      return p;
    };
    hooks.space_fault = [this] { return space_fault; };
    hooks.choose = [this](const Pose2&) { return choice; };
    choice.target = {0.5, 0.0};
    choice.action = 1;
  }
  static SupervisorConfig config() {
    SupervisorConfig c;
    c.ramp_rate_hz = 50.0;
    return c;
  }
  void feed(double t) {
    supervisor.scan(t, "");
    supervisor.odom(t, "");
    supervisor.space(t);
    pose_stamp = t;
  }
  // The control period at t after fresh input, then the ramp for one period.
  void period(double t) {
    supervisor.checkClock(t);
    feed(t);
    supervisor.controlPeriod(t, 0.0, hooks, 0.0);
    for (int k = 1; k <= 10; ++k) {
      supervisor.checkClock(t + 0.02 * k);
      supervisor.ramp(t + 0.02 * k, hooks);
    }
  }

  Supervisor supervisor;
  DecisionHooks hooks;
  std::vector<std::string> logs;
  std::string pose_error, space_fault;
  double pose_stamp = 0.0;
  Pose2 pose;
  Choice choice;
};

TEST(Supervisor, GoalLifeCycle) {
  Rig r;
  EXPECT_EQ(r.supervisor.state(), GoalState::kIdle);
  r.period(1.0);  // no goal: nothing decided, zero target
  EXPECT_EQ(r.supervisor.state(), GoalState::kIdle);
  EXPECT_EQ(r.supervisor.target().v, 0.0);

  r.supervisor.newGoal({3.0, 0.0});
  EXPECT_EQ(r.supervisor.state(), GoalState::kActive);
  r.period(1.2);
  EXPECT_EQ(r.supervisor.action(), 1);
  EXPECT_EQ(r.supervisor.target().v, 0.5);
  EXPECT_GT(r.supervisor.command().v, 0.0);

  // A planner error halts with its reason; good again, it resumes.
  r.choice.why = "planner error: every action is masked";
  r.period(1.4);
  EXPECT_EQ(r.supervisor.state(), GoalState::kStopped);
  EXPECT_EQ(r.supervisor.reason(), "planner error: every action is masked");
  EXPECT_EQ(r.supervisor.target().v, 0.0);
  EXPECT_EQ(r.supervisor.action(), -1);
  r.choice.why.clear();
  r.period(1.6);
  EXPECT_EQ(r.supervisor.state(), GoalState::kActive);
  EXPECT_EQ(r.supervisor.reason(), "");

  // A velocity space that cannot be decided on halts too.
  r.space_fault = "dovs has no goal yet";
  r.period(1.8);
  EXPECT_EQ(r.supervisor.reason(), "dovs has no goal yet");
  r.space_fault.clear();
  r.period(2.0);
  EXPECT_EQ(r.supervisor.state(), GoalState::kActive);

  // On the goal: braking, and reached once slower than goal_speed; held until a new goal.
  r.pose = Pose2{2.9, 0.0, 0.0};
  double t = 2.2;
  for (; t < 5.0 && r.supervisor.state() != GoalState::kReached; t += 0.2) r.period(t);
  EXPECT_EQ(r.supervisor.state(), GoalState::kReached);
  EXPECT_EQ(r.supervisor.reason(), "goal reached");
  EXPECT_LT(std::abs(r.supervisor.command().v), 0.2);
  r.pose = Pose2{};  // pushed off the goal: still holding
  r.period(t);
  EXPECT_EQ(r.supervisor.state(), GoalState::kReached);
  EXPECT_EQ(r.supervisor.target().v, 0.0);

  // Cancel and rejected goals stop with their reasons and leave no goal.
  r.supervisor.newGoal({3.0, 0.0});
  r.supervisor.cancel();
  EXPECT_EQ(r.supervisor.state(), GoalState::kStopped);
  EXPECT_EQ(r.supervisor.reason(), "goal cancelled");
  EXPECT_FALSE(r.supervisor.hasGoal());
  r.period(t + 0.2);  // no goal: stays stopped, zero target
  EXPECT_EQ(r.supervisor.state(), GoalState::kStopped);
  r.supervisor.rejectGoal("goal rejected: its position has NaN/inf");
  EXPECT_EQ(r.supervisor.reason(), "goal rejected: its position has NaN/inf");
  EXPECT_FALSE(r.supervisor.hasGoal());
  EXPECT_EQ(std::string(goalStateName(GoalState::kStopped)), "stopped");
}

TEST(Supervisor, WatchdogNamesEachInputFault) {
  struct Case {
    const char* expected;
    std::function<void(Rig&, double)> spoil;
  };
  const std::vector<Case> cases = {
      {"scan is stale or missing", [](Rig& r, double t) { r.supervisor.scan(t - 1.0, ""); }},
      {"scan is stamped in the future", [](Rig& r, double t) { r.supervisor.scan(t + 1.0, ""); }},
      {"odom rejected: odom twist has NaN/inf",
       [](Rig& r, double t) { r.supervisor.odom(t, "odom twist has NaN/inf"); }},
      {"odom is stale or missing", [](Rig& r, double t) { r.supervisor.odom(t - 0.6, ""); }},
      {"odom is stamped in the future", [](Rig& r, double t) { r.supervisor.odom(t + 0.6, ""); }},
      {"dovs is stale or missing", [](Rig& r, double t) { r.supervisor.space(t - 0.6); }},
      {"dovs is stamped in the future", [](Rig& r, double t) { r.supervisor.space(t + 0.6); }},
      {"no transform odom <- base_footprint",
       [](Rig& r, double) { r.pose_error = "no transform odom <- base_footprint"; }},
      {"robot transform is stale", [](Rig& r, double t) { r.pose_stamp = t - 0.6; }},
      {"robot transform is stamped in the future", [](Rig& r, double t) { r.pose_stamp = t + 0.6; }},
      {"robot transform has NaN/inf", [](Rig& r, double) { r.pose.theta = std::numeric_limits<double>::quiet_NaN(); }},
  };
  for (const Case& c : cases) {
    Rig r;
    r.supervisor.newGoal({3.0, 0.0});
    r.period(1.0);
    ASSERT_EQ(r.supervisor.state(), GoalState::kActive) << c.expected;
    r.supervisor.checkClock(1.2);
    r.feed(1.2);
    c.spoil(r, 1.2);
    r.supervisor.controlPeriod(1.2, 0.0, r.hooks, 0.0);
    EXPECT_EQ(r.supervisor.state(), GoalState::kStopped) << c.expected;
    EXPECT_EQ(r.supervisor.reason().rfind(c.expected, 0), 0u) << r.supervisor.reason();
    EXPECT_EQ(r.supervisor.target().v, 0.0);
  }
  // A rejected scan halts at once (not at the next period), while active.
  Rig r;
  r.supervisor.newGoal({3.0, 0.0});
  r.period(1.0);
  r.supervisor.scan(1.1, "3 of 4 beams are NaN");
  EXPECT_EQ(r.supervisor.state(), GoalState::kStopped);
  EXPECT_EQ(r.supervisor.reason(), "scan rejected: 3 of 4 beams are NaN");
  // The ramp's watchdog: a stale input halts within one ramp step.
  Rig q;
  q.supervisor.newGoal({3.0, 0.0});
  q.period(1.0);
  q.supervisor.ramp(1.0 + 0.6, q.hooks);
  EXPECT_EQ(q.supervisor.state(), GoalState::kStopped);
  EXPECT_EQ(q.supervisor.reason(), "scan is stale or missing");
}

TEST(Supervisor, ClockJumpsLatchAStopUntilAtRestWithFreshInput) {
  for (const double jump : {-5.0, +2.0}) {
    Rig r;
    r.supervisor.newGoal({3.0, 0.0});
    for (double t = 10.0; t < 11.0; t += 0.2) r.period(t);
    ASSERT_GT(r.supervisor.command().v, 0.1);
    const double t = 11.0 + jump;
    EXPECT_EQ(r.supervisor.checkClock(t), jump < 0 ? ClockJump::kBackward : ClockJump::kForward);
    EXPECT_NE(r.supervisor.clockFault().find(jump < 0 ? "backwards" : "forwards"), std::string::npos);
    // Fresh input, but still moving: the latch holds and the robot brakes.
    r.feed(t);
    r.supervisor.controlPeriod(t, 0.0, r.hooks, 0.0);
    EXPECT_EQ(r.supervisor.state(), GoalState::kStopped);
    EXPECT_EQ(r.supervisor.reason(), r.supervisor.clockFault());
    double now = t;
    for (int k = 0; k < 200 && (r.supervisor.command().v != 0.0 || r.supervisor.command().w != 0.0); ++k) {
      now += 0.02;
      r.supervisor.checkClock(now);
      r.supervisor.ramp(now, r.hooks);
    }
    ASSERT_EQ(r.supervisor.command().v, 0.0);
    // At rest with fresh input: the latch clears and the robot resumes.
    r.supervisor.checkClock(now + 0.02);
    r.feed(now + 0.02);
    r.supervisor.controlPeriod(now + 0.02, 0.0, r.hooks, 0.0);
    EXPECT_EQ(r.supervisor.clockFault(), "");
    EXPECT_EQ(r.supervisor.state(), GoalState::kActive);
  }
  // After a backward jump the inputs received before it are forgotten.
  Rig r;
  r.supervisor.newGoal({3.0, 0.0});
  r.period(10.0);
  r.supervisor.checkClock(5.0);
  r.supervisor.controlPeriod(5.0, 0.0, r.hooks, 0.0);
  EXPECT_EQ(r.supervisor.state(), GoalState::kStopped);
  EXPECT_EQ(r.supervisor.inputFault(5.0, r.hooks, 0.0, nullptr), r.supervisor.clockFault());
  // Small steps are time adjustment, not jumps.
  EXPECT_EQ(r.supervisor.checkClock(5.0 - 0.005), ClockJump::kNone);
}

TEST(Supervisor, RampKeepsTheLimitsAndGoesQuietWhenIdle) {
  Rig r;
  r.supervisor.newGoal({3.0, 0.0});
  r.supervisor.checkClock(1.0);
  r.feed(1.0);
  r.supervisor.controlPeriod(1.0, 0.0, r.hooks, 0.0);
  const RobotLimits limits;
  Twist2 previous{};
  double t = 1.0;
  for (int k = 0; k < 10; ++k) {
    t += 0.02;
    const RampCommand c = r.supervisor.ramp(t, r.hooks);
    ASSERT_TRUE(c.publish);
    EXPECT_LE(c.command.v - previous.v, limits.a_v * 0.02 + 1e-9);
    previous = c.command;
  }
  EXPECT_NEAR(previous.v, limits.a_v * 0.2, 1e-9);  // one period of acceleration towards 0.5 m/s
  // A long pause licenses no larger step than kMaxRampStepS.
  r.feed(t + 1.0);
  const RampCommand after_pause = r.supervisor.ramp(t + 0.3, r.hooks);
  EXPECT_LE(after_pause.command.v - previous.v, limits.a_v * Supervisor::kMaxRampStepS + 1e-9);
  EXPECT_EQ(r.supervisor.envelope().corrected(), 0u);
  // Cancelled: brakes to zero, sends a few zeros, then nothing (other sources may drive the base).
  r.supervisor.cancel();
  int published = 0, zeros = 0;
  for (int k = 0; k < 100; ++k) {
    t += 0.02;
    const RampCommand c = r.supervisor.ramp(t, r.hooks);
    if (c.publish) {
      ++published;
      zeros += c.command.v == 0.0 && c.command.w == 0.0;
    }
  }
  EXPECT_EQ(zeros, 10);
  EXPECT_LT(published, 100);
  EXPECT_EQ(r.supervisor.command().v, 0.0);
}

TEST(Supervisor, DeadlinesAreCountedOutsideClockFaults) {
  Rig r;
  r.supervisor.checkClock(1.0);
  r.supervisor.controlPeriod(1.0, 0.01, r.hooks, 0.0);
  r.supervisor.controlPeriod(1.2, 0.15, r.hooks, 0.0);          // more than half of the 0.2 s period late
  r.supervisor.controlPeriod(1.4, std::nullopt, r.hooks, 0.0);  // unknown: not counted
  EXPECT_EQ(r.supervisor.controlPeriods(), 2u);
  EXPECT_EQ(r.supervisor.deadlineMisses(), 1u);
  EXPECT_DOUBLE_EQ(r.supervisor.maxLateness_s(), 0.15);
  bool logged = false;
  for (const std::string& l : r.logs)
    logged = logged || l.rfind("deadline: control period started 0.15 s late", 0) == 0;
  EXPECT_TRUE(logged);
  r.supervisor.checkClock(1.4);
  r.supervisor.checkClock(9.0);  // a forward jump: periods are not counted until it is recovered from
  r.supervisor.controlPeriod(9.0, 0.5, r.hooks, 0.0);
  EXPECT_EQ(r.supervisor.controlPeriods(), 2u);
}

TEST(Supervisor, BadConfigurationIsNamed) {
  SupervisorConfig c;
  c.ramp_rate_hz = 5.0;
  try {
    Supervisor s(c);
    FAIL() << "accepted ramp_rate 5";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("ramp_rate"), std::string::npos) << e.what();
  }
  c = SupervisorConfig{};
  c.limits.a_v = 0.0;
  EXPECT_THROW(Supervisor{c}, std::invalid_argument);
}

}  // namespace
}  // namespace dqn_dovs
