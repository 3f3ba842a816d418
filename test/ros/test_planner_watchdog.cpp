// Node-level test of dovs_node + planner_node (shipped model and configs) against stale input and bad
// goals and obstacles. The test node plays the robot: it integrates cmd_vel into a pose and publishes
// tf (odom -> base_footprint), odom, scan stamps and tracked obstacles, and can stop any of them.
//   - the robot drives when fed; when the scans (or odom) stop, cmd_vel reaches zero within
//     max(v / a_v, |w| / a_w) + 0.2 s of the planner noticing, never braking harder than the limits, and
//     planner/status says STOPPED naming the stale input; fresh input resumes the drive;
//   - a goal with NaN or in an unknown frame is rejected with a message naming it and the robot stops;
//   - obstacles with NaN fields or a non-positive radius make dovs_node publish nothing (uncertain is
//     unsafe: the planner then stops on a stale DOVS); an odom velocity outside the limits is clipped.
#include <geometry_msgs/PoseStamped.h>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <sensor_msgs/Image.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "dqn_dovs/Dovs.h"
#include "dqn_dovs/PlannerStatus.h"
#include "dqn_dovs/TrackedObstacleArray.h"
#include "fake_robot.h"

namespace {

using dqn_dovs::Dovs;
using dqn_dovs::PlannerStatus;
using dqn_dovs::TrackedObstacleArray;
using namespace dqn_dovs::test;

class PlannerWatchdog : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    FakeRobotOptions options;
    options.scan = narrowScan();  // the planner only watches the scans' stamps and validity
    options.publish_obstacles = true;
    h_ = new RobotHarness(options);
    dovs_ = new TopicLog<Dovs>(h_->nh, "dovs", 50);
    h_->waitUntilReady(1, 30.0);
    h_->robot.start();
  }
  static void TearDownTestSuite() {
    h_->stop();
    delete dovs_;
    delete h_;
  }

  static FakeRobot& robot() { return h_->robot; }
  static PlannerStatus lastStatus() { return h_->lastStatus(); }
  static void sendGoal(const geometry_msgs::PoseStamped& g) { h_->goal_pub.publish(g); }

  /// Gives a fresh goal 4 m ahead and waits until the robot drives at >= 0.25 m/s.
  static void driveUntilMoving() { h_->driveUntilMoving(4.0, 0.25, 20.0); }

  /// After something went stale at `cut_s` (wall clock): the planner says STOPPED with a reason containing
  /// `culprit`, then cmd_vel ramps to zero within the limits and in time.
  static void expectStopsInTime(double cut_s, const std::string& culprit, double notice_limit_s) {
    PlannerStatus stopped;
    const bool said = waitFor(
        [&] {
          stopped = lastStatus();
          return stopped.state == PlannerStatus::STOPPED;
        },
        notice_limit_s + 1.0);
    ASSERT_TRUE(said) << "planner/status never said STOPPED; last reason: " << stopped.reason;
    EXPECT_NE(stopped.reason.find(culprit), std::string::npos)
        << "the reason '" << stopped.reason << "' does not name '" << culprit << "'";
    const double noticed_s = stopped.header.stamp.toSec();
    EXPECT_LE(noticed_s - cut_s, notice_limit_s) << "the watchdog took too long to notice";
    const double allowed_s = std::max(std::abs(stopped.v) / kAv, std::abs(stopped.w) / kAw) + 0.2;
    ASSERT_TRUE(waitFor(
        [] {
          const Command c = robot().lastCommand();
          return c.v == 0.0 && c.w == 0.0;
        },
        allowed_s + 2.0))
        << "cmd_vel never reached zero";
    // The first zero command, and the braking before it.
    const std::vector<Command> cmds = robot().commands();
    double zero_at = -1.0;
    double max_dv = 0.0, max_dw = 0.0;
    for (size_t i = 1; i < cmds.size(); ++i) {
      // Commands received right after the status may have left before the decision (transport delay).
      if (cmds[i - 1].wall < noticed_s + 0.005) continue;
      max_dv = std::max(max_dv, std::abs(cmds[i].v - cmds[i - 1].v));
      max_dw = std::max(max_dw, std::abs(cmds[i].w - cmds[i - 1].w));
      EXPECT_LE(cmds[i].v, cmds[i - 1].v + 1e-9) << "speeding up while stopping";
      if (cmds[i].v == 0.0 && cmds[i].w == 0.0) {
        zero_at = cmds[i].wall;
        break;
      }
    }
    ASSERT_GT(zero_at, 0.0);
    EXPECT_LE(zero_at - noticed_s, allowed_s)
        << "stopping from v = " << stopped.v << " m/s, w = " << stopped.w << " rad/s took too long";
    // Never harder than the limits: the ramp caps one step at 0.1 s.
    EXPECT_LE(max_dv, kAv * 0.1 + 1e-9);
    EXPECT_LE(max_dw, kAw * 0.1 + 1e-9);
    // And it stays stopped.
    ros::WallDuration(0.3).sleep();
    const Command c = robot().lastCommand();
    EXPECT_EQ(c.v, 0.0);
    EXPECT_EQ(c.w, 0.0);
  }

  static inline RobotHarness* h_ = nullptr;
  static inline TopicLog<Dovs>* dovs_ = nullptr;
};

// The watchdog fires max_input_age after the last good message, at the next control period at the latest.
constexpr double kNoticeLimit = kMaxInputAge + kPlannerPeriod + 0.15;

TEST_F(PlannerWatchdog, DrivesWhenFed) { driveUntilMoving(); }

// dovs/image (image_transport, raw) is drawn while someone watches: the velocity space at image_size pixels.
TEST_F(PlannerWatchdog, TheVelocitySpaceImageComesWhenSubscribed) {
  driveUntilMoving();
  TopicLog<sensor_msgs::Image> images(h_->nh, "dovs/image", 2, 1);
  ASSERT_TRUE(waitFor([&] { return images.any(); }, 5.0)) << "no dovs/image while subscribed";
  const sensor_msgs::Image image = images.last();
  EXPECT_EQ(image.width, 400u);
  EXPECT_EQ(image.height, 400u);
  EXPECT_EQ(image.encoding, "bgr8");
  EXPECT_EQ(image.data.size(), static_cast<size_t>(image.step) * image.height);
}

TEST_F(PlannerWatchdog, StaleScanStopsTheRobotAndFreshScansResume) {
  driveUntilMoving();
  robot().feed_scan = false;
  expectStopsInTime(ros::Time::now().toSec(), "scan", kNoticeLimit);
  robot().feed_scan = true;
  EXPECT_TRUE(
      waitFor([] { return lastStatus().state == PlannerStatus::ACTIVE && robot().lastCommand().v > 0.05; }, 5.0))
      << "the planner did not resume on fresh scans: " << lastStatus().reason;
}

TEST_F(PlannerWatchdog, StaleOdomStopsTheRobot) {
  driveUntilMoving();
  robot().feed_odom = false;
  expectStopsInTime(ros::Time::now().toSec(), "odom", kNoticeLimit);
  robot().feed_odom = true;
  EXPECT_TRUE(waitFor([] { return lastStatus().state == PlannerStatus::ACTIVE; }, 5.0));
}

TEST_F(PlannerWatchdog, NaNGoalIsRejectedAndTheRobotStops) {
  driveUntilMoving();
  geometry_msgs::PoseStamped nan_goal = h_->goalAhead(0.0);
  nan_goal.pose.position.x = kNaN;
  sendGoal(nan_goal);
  expectStopsInTime(ros::Time::now().toSec(), "NaN", 0.3);
  EXPECT_NE(lastStatus().reason.find("goal rejected"), std::string::npos) << lastStatus().reason;
}

TEST_F(PlannerWatchdog, GoalInAnUnknownFrameIsRejectedAndTheRobotStops) {
  driveUntilMoving();
  sendGoal(h_->goalAhead(3.0, "no_such_frame"));
  // The planner waits up to 0.2 s for the goal's transform before rejecting it.
  expectStopsInTime(ros::Time::now().toSec(), "no_such_frame", 0.5);
}

// Obstacles dovs_node cannot trust are dropped whole: no velocity space is published for them.
TEST_F(PlannerWatchdog, DovsDropsObstaclesWithNaNOrNonPositiveRadius) {
  robot().feed_obstacles = false;
  ros::WallDuration(0.15).sleep();
  struct Case {
    std::string what;
    std::function<void(dqn_dovs::ObstacleTrack&)> spoil;
  };
  const std::vector<Case> cases = {
      {"NaN radius", [](dqn_dovs::ObstacleTrack& o) { o.radius = kNaN; }},
      {"zero radius", [](dqn_dovs::ObstacleTrack& o) { o.radius = 0.0; }},
      {"negative radius", [](dqn_dovs::ObstacleTrack& o) { o.radius = -0.2; }},
      {"NaN centre", [](dqn_dovs::ObstacleTrack& o) { o.center.x = kNaN; }},
      {"inf speed", [](dqn_dovs::ObstacleTrack& o) { o.speed = std::numeric_limits<double>::infinity(); }},
  };
  for (const Case& c : cases) {
    // Stamps just before the last transform: tf2 can interpolate there.
    const ros::Time tf_stamp = robot().lastTfStamp();
    TrackedObstacleArray bad = farObstacles(tf_stamp - ros::Duration(0.02));
    c.spoil(bad.obstacles[0]);
    const TrackedObstacleArray marker = farObstacles(tf_stamp - ros::Duration(0.01));
    robot().publishObstacles(bad);
    robot().publishObstacles(marker);
    const bool marker_seen = waitFor([&] { return dovs_->find(marker.header.stamp).has_value(); }, 2.0);
    ASSERT_TRUE(marker_seen) << "dovs_node published nothing after obstacles with " << c.what;
    EXPECT_FALSE(dovs_->find(bad.header.stamp).has_value())
        << "a velocity space was built from obstacles with " << c.what;
  }
  robot().feed_obstacles = true;
}

// Uncertain means unsafe: while every obstacles message is unusable the planner gets no velocity space
// and brings the robot to a stop, saying why.
TEST_F(PlannerWatchdog, UnusableObstaclesStopTheRobot) {
  driveUntilMoving();
  robot().feed_obstacles = false;
  const double cut = ros::Time::now().toSec();
  std::atomic<bool> spoiling{true};
  std::thread spoiler([&] {
    ros::WallRate rate(10.0);
    while (spoiling && ros::ok()) {
      TrackedObstacleArray bad = farObstacles(robot().lastTfStamp());
      bad.obstacles[0].radius = kNaN;
      robot().publishObstacles(bad);
      rate.sleep();
    }
  });
  expectStopsInTime(cut, "dovs", kNoticeLimit);
  spoiling = false;
  spoiler.join();
  robot().feed_obstacles = true;
}

// An odom velocity outside the robot's limits is clipped into the feasible set before the DOVS uses it.
TEST_F(PlannerWatchdog, DovsClipsOdomVelocityOutsideTheLimits) {
  robot().feed_odom = false;
  robot().feed_obstacles = false;
  ros::WallDuration(0.1).sleep();
  const ros::Time tf_stamp = robot().lastTfStamp();
  robot().publishOdom(tf_stamp, 2.0, 10.0);
  ros::WallDuration(0.1).sleep();
  const TrackedObstacleArray marker = farObstacles(tf_stamp - ros::Duration(0.01));
  robot().publishObstacles(marker);
  Dovs d;
  const bool seen = waitFor(
      [&] {
        const std::optional<Dovs> found = dovs_->find(marker.header.stamp);
        if (found) d = *found;
        return found.has_value();
      },
      2.0);
  robot().feed_odom = true;
  robot().feed_obstacles = true;
  ASSERT_TRUE(seen) << "dovs_node published nothing for an odom velocity outside the limits";
  EXPECT_LE(d.v, kVMax + 1e-9);
  EXPECT_GE(d.v, 0.0);
  EXPECT_LE(std::abs(d.w), kWMax * (1.0 - d.v / kVMax) + 1e-6) << "(v, w) outside the kinematic triangle";
  for (size_t i = 0; i < d.action_v.size(); ++i) {
    if (!d.action_valid[i]) continue;
    EXPECT_LE(d.action_v[i], kVMax + 1e-9) << "action " << i;
    EXPECT_LE(std::abs(d.action_w[i]), kWMax + 1e-6) << "action " << i;
  }
}

}  // namespace

int main(int argc, char** argv) { return runRostestNode(argc, argv, "test_planner_watchdog"); }
