// Fault injection into the running pipeline (obstacle_tracker_node + dovs_node + planner_node, shipped
// configs and model) in simulated time. This node owns /clock and plays the robot: it integrates cmd_vel into
// a pose and publishes tf (odom -> base_footprint -> laser), odom and full 360-beam LaserScans that go
// through the real tracker. Each case drives the robot, injects one fault and MEASURES the time from the
// fault to the first cmd_vel with v == 0 and w == 0:
//     stop time <= max(v / a_v, |w| / a_w) + 0.2 s   (v, w: the command at the fault),
// every command in between decelerates (v and |w| never grow), planner/status names the culprit, every node
// stays up (required="true" in the .test), and the pipeline drives again once the fault is gone.
// Faults: scans with NaN beams, inf fields, no ranges, a wrong number of ranges, an unknown frame; the clock
// jumping backwards and forwards; the robot transform missing; odom with stale stamps. The fault instant of a
// missing input is when it becomes stale (its last message + max_input_age); of everything else, the first
// faulty message. The last case checks the whole published command stream (planner/cmd_vel_stamped, which
// carries the publish stamps the planner's safety envelope used) against the envelope.
#include <geometry_msgs/TwistStamped.h>
#include <gtest/gtest.h>
#include <ros/ros.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <string>
#include <vector>

#include "dqn_dovs/Dovs.h"
#include "dqn_dovs/PlannerStatus.h"
#include "dqn_dovs/TrackedObstacleArray.h"
#include "fake_robot.h"

namespace {

using dqn_dovs::PlannerStatus;
using namespace dqn_dovs::test;

// Commands received this soon after the fault may have left the planner before it saw the fault.
constexpr double kGrace = 0.03;

/// One measured stop, for the summary (and bench/results/faults.json).
struct StopFigure {
  std::string fault;
  double v = 0.0, w = 0.0;  // command at the fault
  double stop_s = -1.0;     // fault -> first zero command
  double bound_s = 0.0;     // max(v / a_v, |w| / a_w) + 0.2
  std::string reason;       // planner/status
};

class PipelineFaults : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    h_ = new RobotHarness(FakeRobotOptions{}, /*sim_clock=*/true, /*spinner_threads=*/3);
    obstacles_ = new TopicLog<dqn_dovs::TrackedObstacleArray>(h_->nh, "obstacles", 50, 1);
    dovs_ = new TopicLog<dqn_dovs::Dovs>(h_->nh, "dovs", 50, 1);
    stamped_ = new TopicLog<geometry_msgs::TwistStamped>(h_->nh, "planner/cmd_vel_stamped", 5000);
    h_->robot.start();
    h_->waitUntilReady(2, 60.0);
  }
  static void TearDownTestSuite() {
    writeFigures();
    h_->stop();
    delete stamped_;
    delete dovs_;
    delete obstacles_;
    delete h_;
  }

  static FakeRobot& robot() { return h_->robot; }
  static PlannerStatus lastStatus() { return h_->lastStatus(); }

  /// A fresh goal 5 m ahead; waits until the robot drives at >= 0.4 m/s.
  static void driveUntilMoving() { h_->driveUntilMoving(5.0, 0.4, 25.0); }

  /// Measures the stop after a fault at `fault_wall` (wall clock): time to the first zero command, braking
  /// only, planner/status STOPPED naming one of `culprits`.
  static StopFigure expectStop(const std::string& name, double fault_wall, const std::vector<std::string>& culprits,
                               bool expect_hold = true) {
    StopFigure f;
    f.fault = name;
    const bool zero = waitFor(
        [&] {
          const Command c = robot().lastCommand();
          return c.wall > fault_wall && c.v == 0.0 && c.w == 0.0;
        },
        8.0);
    EXPECT_TRUE(zero) << name << ": cmd_vel never reached zero; last v " << robot().lastCommand().v << ", status '"
                      << lastStatus().reason << "'";
    const std::vector<Command> cmds = robot().commands();
    // The command in force at the fault, and the first zero after it.
    size_t i0 = 0;
    for (size_t i = 0; i < cmds.size(); ++i) {
      if (cmds[i].wall <= fault_wall) i0 = i;
    }
    f.v = cmds.empty() ? 0.0 : cmds[i0].v;
    f.w = cmds.empty() ? 0.0 : cmds[i0].w;
    f.bound_s = std::max(f.v / kAv, std::abs(f.w) / kAw) + 0.2;
    int increases = 0;
    for (size_t i = i0 + 1; i < cmds.size(); ++i) {
      if (cmds[i].wall > fault_wall + kGrace) {
        if (cmds[i].v > cmds[i - 1].v + 1e-9 || std::abs(cmds[i].w) > std::abs(cmds[i - 1].w) + 1e-9) ++increases;
      } else {
        // In flight when the fault came: at most one ramp step up.
        EXPECT_LE(cmds[i].v - cmds[i - 1].v, kAv * kMaxRampStep + 1e-9) << name;
      }
      if (cmds[i].v == 0.0 && cmds[i].w == 0.0) {
        f.stop_s = cmds[i].wall - fault_wall;
        break;
      }
    }
    EXPECT_EQ(increases, 0) << name << ": the command grew while stopping";
    EXPECT_GE(f.stop_s, 0.0) << name;
    EXPECT_LE(f.stop_s, f.bound_s) << name << ": stopping from v = " << f.v << " m/s, w = " << f.w
                                   << " rad/s took too long";
    EXPECT_GE(f.v, 0.35) << name << ": the robot was not moving at the fault; the case proves nothing";
    // planner/status: STOPPED with the culprit named, after the fault.
    for (const auto& s : h_->status.entries()) {
      if (s.wall < fault_wall || s.msg.state != PlannerStatus::STOPPED) continue;
      for (const std::string& c : culprits) {
        if (s.msg.reason.find(c) != std::string::npos) f.reason = s.msg.reason;
      }
      if (!f.reason.empty()) break;
    }
    EXPECT_FALSE(f.reason.empty()) << name << ": planner/status never said STOPPED naming '" << culprits.front()
                                   << "'; last reason '" << lastStatus().reason << "'";
    if (expect_hold) {
      // It stays stopped while the fault lasts.
      ros::WallDuration(0.4).sleep();
      const Command c = robot().lastCommand();
      EXPECT_EQ(c.v, 0.0) << name;
      EXPECT_EQ(c.w, 0.0) << name;
    }
    std::cout << "[fault] " << std::left << std::setw(22) << name << " v " << std::fixed << std::setprecision(3) << f.v
              << " m/s, w " << f.w << " rad/s: zero after " << f.stop_s << " s (bound " << f.bound_s
              << " s); status: " << f.reason << std::endl;
    figures_.push_back(f);
    return f;
  }

  /// The fault is gone: every node is still up and publishing, and the robot drives again.
  static void expectRecovery(const std::string& name) {
    const double t = wallNow();
    EXPECT_TRUE(waitFor([&] { return obstacles_->lastWall() > t && dovs_->lastWall() > t; }, 5.0))
        << name << ": the tracker or dovs_node stopped publishing";
    EXPECT_TRUE(
        waitFor([] { return lastStatus().state == PlannerStatus::ACTIVE && robot().lastCommand().v > 0.05; }, 10.0))
        << name << ": the planner does not drive again: '" << lastStatus().reason << "'";
  }

  static void scanCase(const std::string& name, ScanFault fault, const std::vector<std::string>& culprits) {
    driveUntilMoving();
    if (HasFatalFailure()) return;
    robot().armFaultClocks();
    robot().scan_fault = fault;
    ASSERT_TRUE(waitFor([] { return robot().firstFaultyScanWall() > 0.0; }, 1.0));
    expectStop(name, robot().firstFaultyScanWall(), culprits);
    robot().scan_fault = ScanFault::kNone;
    expectRecovery(name);
  }

  static void writeFigures() {
    std::string path;
    ros::NodeHandle("~").param<std::string>("results", path, "");
    if (path.empty()) return;
    std::error_code ec;
    std::filesystem::create_directories(std::filesystem::path(path).parent_path(), ec);
    std::ofstream out(path);
    if (!out) return;
    out << "{\n  \"what\": \"fault -> first zero cmd_vel, measured in test/ros/test_pipeline_faults.cpp\",\n"
        << "  \"faults\": [\n";
    for (size_t i = 0; i < figures_.size(); ++i) {
      const StopFigure& f = figures_[i];
      std::string reason;
      for (char c : f.reason) reason += (c == '"' || c == '\\') ? '\'' : c;
      out << "    {\"fault\": \"" << f.fault << "\", \"v\": " << f.v << ", \"w\": " << f.w
          << ", \"stop_s\": " << f.stop_s << ", \"bound_s\": " << f.bound_s << ", \"reason\": \"" << reason << "\"}"
          << (i + 1 < figures_.size() ? "," : "") << "\n";
    }
    out << "  ]\n}\n";
  }

  static inline RobotHarness* h_ = nullptr;
  static inline TopicLog<dqn_dovs::TrackedObstacleArray>* obstacles_ = nullptr;
  static inline TopicLog<dqn_dovs::Dovs>* dovs_ = nullptr;
  static inline TopicLog<geometry_msgs::TwistStamped>* stamped_ = nullptr;
  static inline std::vector<StopFigure> figures_;
};

// The harness: fed properly, the pipeline drives (without this every "it stopped" below could be vacuous).
TEST_F(PipelineFaults, DrivesWhenFed) {
  driveUntilMoving();
  EXPECT_EQ(lastStatus().state, PlannerStatus::ACTIVE);
}

TEST_F(PipelineFaults, ScanWithNaNBeamsStopsTheRobot) { scanCase("scan NaN beams", ScanFault::kNaN, {"NaN"}); }

TEST_F(PipelineFaults, ScanWithInfFieldStopsTheRobot) {
  scanCase("scan inf field", ScanFault::kInfField, {"not finite"});
}

TEST_F(PipelineFaults, EmptyScanStopsTheRobot) { scanCase("scan empty", ScanFault::kEmpty, {"no ranges"}); }

TEST_F(PipelineFaults, WrongSizeScanStopsTheRobot) {
  scanCase("scan wrong size", ScanFault::kWrongSize, {"100 ranges"});
}

TEST_F(PipelineFaults, ScanInUnknownFrameStopsTheRobot) {
  scanCase("scan unknown frame", ScanFault::kUnknownFrame, {"no_such_laser"});
}

// Sim time reset / a looping bag: everything received so far is stamped in the new clock's future.
TEST_F(PipelineFaults, ClockJumpingBackwardsStopsTheRobotThenItResumes) {
  driveUntilMoving();
  if (HasFatalFailure()) return;
  const double at = h_->clock->jump(-30.0);
  expectStop("clock jumps back 30 s", at, {"clock jumped backwards"}, false);
  expectRecovery("clock jumps back 30 s");
}

TEST_F(PipelineFaults, ClockJumpingForwardsStopsTheRobotThenItResumes) {
  driveUntilMoving();
  if (HasFatalFailure()) return;
  const double at = h_->clock->jump(30.0);
  expectStop("clock jumps ahead 30 s", at, {"clock jumped forwards"}, false);
  expectRecovery("clock jumps ahead 30 s");
}

// The robot transform stops: it is stale max_input_age after the last one. The tracker and dovs_node
// starve at the same time, so the first stale input the planner names may be the dovs.
TEST_F(PipelineFaults, MissingRobotTransformStopsTheRobot) {
  driveUntilMoving();
  if (HasFatalFailure()) return;
  robot().feed_tf = false;
  ros::WallDuration(0.06).sleep();
  const double stale_at = robot().lastTfWall() + kMaxInputAge;
  expectStop("tf missing", stale_at, {"transform", "dovs"});
  robot().feed_tf = true;
  expectRecovery("tf missing");
}

// Odom keeps coming, but stamped 1.5 s in the past (a driver with a stuck clock): stale at once.
TEST_F(PipelineFaults, OdomWithStaleStampsStopsTheRobot) {
  driveUntilMoving();
  if (HasFatalFailure()) return;
  robot().armFaultClocks();
  robot().odom_lag_s = 1.5;
  ASSERT_TRUE(waitFor([] { return robot().firstLaggedOdomWall() > 0.0; }, 1.0));
  expectStop("odom stale stamps", robot().firstLaggedOdomWall(), {"odom"});
  robot().odom_lag_s = 0.0;
  expectRecovery("odom stale stamps");
}

// Every command the planner published during all of the above (faults, clock jumps included) against the
// safety envelope, with the publish stamps it used: feasible, finite, and within a_v * dt, a_w * dt of the
// previous command (dt = the stamps' difference, 0 when the clock went back, capped at 0.1 s). The envelope
// never had to correct the planner's own ramp.
TEST_F(PipelineFaults, PublishedStreamStaysInsideTheSafetyEnvelope) {
  struct Stamped {
    ros::Time stamp;
    uint32_t seq;
    double v, w;
  };
  std::vector<Stamped> s;
  for (const auto& e : stamped_->entries()) {
    s.push_back({e.msg.header.stamp, e.msg.header.seq, e.msg.twist.linear.x, e.msg.twist.angular.z});
  }
  ASSERT_GT(s.size(), 500u) << "too few stamped commands to judge";
  size_t pairs = 0, gaps = 0, outside = 0;
  for (size_t i = 0; i < s.size(); ++i) {
    const double v = s[i].v, w = s[i].w;
    const bool feasible = std::isfinite(v) && std::isfinite(w) && v >= -1e-9 && v <= kVMax + 1e-9 &&
                          std::abs(w) <= kWMax * (1.0 - v / kVMax) + 1e-9;
    if (!feasible) ++outside;
    EXPECT_TRUE(feasible) << "command " << i << " (" << v << ", " << w << ") is outside the feasible set";
    if (i == 0) continue;
    if (s[i].seq != s[i - 1].seq + 1) {
      ++gaps;  // a message was lost on the way: the two are not consecutive commands
      continue;
    }
    ++pairs;
    const double dt = std::clamp((s[i].stamp - s[i - 1].stamp).toSec(), 0.0, kMaxRampStep);
    const bool accel_ok = std::abs(v - s[i - 1].v) <= kAv * dt + 1e-9 && std::abs(w - s[i - 1].w) <= kAw * dt + 1e-9;
    if (!accel_ok) ++outside;
    EXPECT_TRUE(accel_ok) << "command " << i << ": (" << s[i - 1].v << ", " << s[i - 1].w << ") -> (" << v << ", " << w
                          << ") in " << dt << " s";
  }
  EXPECT_GT(pairs, 500u);
  EXPECT_LT(gaps, s.size() / 100 + 1) << "too many lost stamped commands";
  const PlannerStatus st = lastStatus();
  EXPECT_GT(st.envelope_checks, 500u);
  EXPECT_EQ(st.envelope_corrections, 0u) << "the ramp produced a command outside the envelope: " << st.envelope_last;
  std::cout << "[envelope] " << s.size() << " commands, " << pairs << " consecutive pairs checked, " << outside
            << " outside; planner: " << st.envelope_checks << " checks, " << st.envelope_corrections << " corrections"
            << std::endl;
}

}  // namespace

int main(int argc, char** argv) { return runRostestNode(argc, argv, "test_pipeline_faults"); }
