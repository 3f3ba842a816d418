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
#include <geometry_msgs/Twist.h>
#include <gtest/gtest.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <sensor_msgs/LaserScan.h>
#include <tf2_ros/transform_broadcaster.h>

#include <atomic>
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <mutex>
#include <thread>
#include <vector>

#include "dqn_dovs/Dovs.h"
#include "dqn_dovs/PlannerStatus.h"
#include "dqn_dovs/TrackedObstacleArray.h"
#include "dqn_dovs/common/geometry.h"

namespace {

using dqn_dovs::Dovs;
using dqn_dovs::PlannerStatus;
using dqn_dovs::TrackedObstacleArray;

// config/robot.yaml and config/planner.yaml (the .test loads them into the nodes).
constexpr double kVMax = 0.7, kWMax = 3.14159, kAv = 0.5, kAw = 2.0, kDt = 0.2, kMaxInputAge = 0.5;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

struct Command {
  double t;  // receipt time (wall clock, s)
  double v, w;
};

/// The robot and its sensors as the pipeline sees them, at 20 Hz (scan and obstacles at 10 Hz).
class FakeRobot {
 public:
  std::atomic<bool> feed_scan{true}, feed_odom{true}, feed_tf{true}, feed_obstacles{true};

  explicit FakeRobot(ros::NodeHandle& nh)
      : scan_pub_(nh.advertise<sensor_msgs::LaserScan>("scan", 5)),
        odom_pub_(nh.advertise<nav_msgs::Odometry>("odom", 10)),
        obstacles_pub_(nh.advertise<TrackedObstacleArray>("obstacles", 10)),
        cmd_sub_(nh.subscribe("cmd_vel", 200, &FakeRobot::onCmd, this)) {}

  void start() {
    thread_ = std::thread([this] { loop(); });
  }
  void stop() {
    running_ = false;
    if (thread_.joinable()) thread_.join();
  }

  dqn_dovs::Pose2 pose() {
    std::lock_guard<std::mutex> l(mutex_);
    return pose_;
  }
  /// Stamp of the last transform sent: tf can be looked up at any time up to it.
  ros::Time lastTfStamp() {
    std::lock_guard<std::mutex> l(mutex_);
    return last_tf_stamp_;
  }
  std::vector<Command> commands() {
    std::lock_guard<std::mutex> l(mutex_);
    return commands_;
  }
  Command lastCommand() {
    std::lock_guard<std::mutex> l(mutex_);
    return commands_.empty() ? Command{0.0, 0.0, 0.0} : commands_.back();
  }
  void publishOdom(const ros::Time& stamp, double v, double w) {
    nav_msgs::Odometry o;
    o.header.stamp = stamp;
    o.header.frame_id = "odom";
    o.child_frame_id = "base_footprint";
    {
      std::lock_guard<std::mutex> l(mutex_);
      o.pose.pose.position.x = pose_.x;
      o.pose.pose.position.y = pose_.y;
      o.pose.pose.orientation.z = std::sin(pose_.theta / 2.0);
      o.pose.pose.orientation.w = std::cos(pose_.theta / 2.0);
    }
    o.twist.twist.linear.x = v;
    o.twist.twist.angular.z = w;
    odom_pub_.publish(o);
  }
  void publishObstacles(const TrackedObstacleArray& msg) { obstacles_pub_.publish(msg); }
  size_t subscribersReady() {
    return scan_pub_.getNumSubscribers() * odom_pub_.getNumSubscribers() * obstacles_pub_.getNumSubscribers();
  }

  /// One static obstacle far behind the start, so the DOVS always has something to compute.
  static TrackedObstacleArray farObstacles(const ros::Time& stamp) {
    TrackedObstacleArray m;
    m.header.stamp = stamp;
    m.header.frame_id = "odom";
    dqn_dovs::ObstacleTrack o;
    o.id = 1;
    o.center.x = -3.0;
    o.center.y = -3.0;
    o.radius = 0.2;
    o.is_static = true;
    for (int i = 0; i < 5; ++i) o.covariance[static_cast<size_t>(i * 6)] = 0.01;
    m.obstacles.push_back(o);
    return m;
  }

 private:
  void onCmd(const geometry_msgs::Twist::ConstPtr& m) {
    std::lock_guard<std::mutex> l(mutex_);
    commands_.push_back({ros::Time::now().toSec(), m->linear.x, m->angular.z});
    v_ = m->linear.x;
    w_ = m->angular.z;
  }

  void loop() {
    const double period = 0.05;
    ros::WallRate rate(1.0 / period);
    int tick = 0;
    while (running_ && ros::ok()) {
      const ros::Time now = ros::Time::now();
      double v, w;
      dqn_dovs::Pose2 p;
      {
        std::lock_guard<std::mutex> l(mutex_);
        pose_ = dqn_dovs::integrateUnicycle(pose_, v_, w_, period);
        p = pose_;
        v = v_;
        w = w_;
      }
      if (feed_tf) {
        geometry_msgs::TransformStamped t;
        t.header.stamp = now;
        t.header.frame_id = "odom";
        t.child_frame_id = "base_footprint";
        t.transform.translation.x = p.x;
        t.transform.translation.y = p.y;
        t.transform.rotation.z = std::sin(p.theta / 2.0);
        t.transform.rotation.w = std::cos(p.theta / 2.0);
        // The laser sits on the base (its scans must be placeable in the fixed frame, or they are rejected).
        geometry_msgs::TransformStamped laser;
        laser.header.stamp = now;
        laser.header.frame_id = "base_footprint";
        laser.child_frame_id = "laser";
        laser.transform.rotation.w = 1.0;
        tf_.sendTransform({t, laser});
        std::lock_guard<std::mutex> l(mutex_);
        last_tf_stamp_ = now;
      }
      if (feed_odom) publishOdom(now, v, w);
      if (tick % 2 == 0) {
        if (feed_scan) {
          sensor_msgs::LaserScan s;
          s.header.stamp = now;
          s.header.frame_id = "laser";
          s.angle_min = -1.0f;
          s.angle_increment = 0.2f;
          s.angle_max = 1.0f;
          s.range_min = 0.1f;
          s.range_max = 10.0f;
          s.ranges.assign(11, std::numeric_limits<float>::infinity());
          scan_pub_.publish(s);
        }
        if (feed_obstacles) obstacles_pub_.publish(farObstacles(now));
      }
      ++tick;
      rate.sleep();
    }
  }

  ros::Publisher scan_pub_, odom_pub_, obstacles_pub_;
  ros::Subscriber cmd_sub_;
  tf2_ros::TransformBroadcaster tf_;
  std::thread thread_;
  std::atomic<bool> running_{true};
  std::mutex mutex_;
  dqn_dovs::Pose2 pose_{0.0, 0.0, 0.0};
  double v_ = 0.0, w_ = 0.0;
  ros::Time last_tf_stamp_;
  std::vector<Command> commands_;
};

class PlannerWatchdog : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    nh_ = new ros::NodeHandle;
    robot_ = new FakeRobot(*nh_);
    goal_pub_ = new ros::Publisher(nh_->advertise<geometry_msgs::PoseStamped>("move_base_simple/goal", 2));
    status_sub_ = new ros::Subscriber(nh_->subscribe("planner/status", 50, &PlannerWatchdog::onStatus));
    dovs_sub_ = new ros::Subscriber(nh_->subscribe("dovs", 50, &PlannerWatchdog::onDovs));
    spinner_ = new ros::AsyncSpinner(2);
    spinner_->start();
    const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(30.0);
    while (ros::ok() && ros::WallTime::now() < deadline &&
           (robot_->subscribersReady() == 0 || goal_pub_->getNumSubscribers() < 2 || !haveStatus())) {
      ros::WallDuration(0.05).sleep();
    }
    robot_->start();
  }
  static void TearDownTestSuite() {
    robot_->stop();
    spinner_->stop();
    delete spinner_;
    delete dovs_sub_;
    delete status_sub_;
    delete goal_pub_;
    delete robot_;
    delete nh_;
  }

  static bool haveStatus() {
    std::lock_guard<std::mutex> l(mutex_);
    return !statuses_.empty();
  }
  static void onStatus(const PlannerStatus::ConstPtr& m) {
    std::lock_guard<std::mutex> l(mutex_);
    statuses_.push_back(*m);
  }
  static void onDovs(const Dovs::ConstPtr& m) {
    std::lock_guard<std::mutex> l(mutex_);
    dovs_[m->header.stamp] = *m;
  }
  static PlannerStatus lastStatus() {
    std::lock_guard<std::mutex> l(mutex_);
    return statuses_.empty() ? PlannerStatus() : statuses_.back();
  }

  static bool waitFor(const std::function<bool()>& condition, double timeout_s) {
    const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(timeout_s);
    while (ros::ok() && ros::WallTime::now() < deadline) {
      if (condition()) return true;
      ros::WallDuration(0.01).sleep();
    }
    return condition();
  }

  /// A goal `distance` ahead of the robot, in odom.
  static void sendGoalAhead(double distance, const std::string& frame = "odom", double x_override = 0.0,
                            bool use_override = false) {
    const dqn_dovs::Pose2 p = robot_->pose();
    geometry_msgs::PoseStamped g;
    g.header.stamp = ros::Time::now();
    g.header.frame_id = frame;
    g.pose.position.x = use_override ? x_override : p.x + distance * std::cos(p.theta);
    g.pose.position.y = p.y + distance * std::sin(p.theta);
    g.pose.orientation.w = 1.0;
    goal_pub_->publish(g);
  }

  /// Gives a fresh goal 4 m ahead and waits until the robot drives at >= 0.25 m/s.
  static void driveUntilMoving() {
    sendGoalAhead(4.0);
    const bool moving =
        waitFor([] { return lastStatus().state == PlannerStatus::ACTIVE && robot_->lastCommand().v >= 0.25; }, 20.0);
    ASSERT_TRUE(moving) << "the planner does not drive: state " << int(lastStatus().state) << " ("
                        << lastStatus().reason << "), last v " << robot_->lastCommand().v;
  }

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
          const Command c = robot_->lastCommand();
          return c.v == 0.0 && c.w == 0.0;
        },
        allowed_s + 2.0))
        << "cmd_vel never reached zero";
    // The first zero command, and the braking before it.
    const std::vector<Command> cmds = robot_->commands();
    double zero_at = -1.0;
    double max_dv = 0.0, max_dw = 0.0;
    for (size_t i = 1; i < cmds.size(); ++i) {
      // Commands received right after the status may have left before the decision (transport delay).
      if (cmds[i - 1].t < noticed_s + 0.005) continue;
      max_dv = std::max(max_dv, std::abs(cmds[i].v - cmds[i - 1].v));
      max_dw = std::max(max_dw, std::abs(cmds[i].w - cmds[i - 1].w));
      EXPECT_LE(cmds[i].v, cmds[i - 1].v + 1e-9) << "speeding up while stopping";
      if (cmds[i].v == 0.0 && cmds[i].w == 0.0) {
        zero_at = cmds[i].t;
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
    const Command c = robot_->lastCommand();
    EXPECT_EQ(c.v, 0.0);
    EXPECT_EQ(c.w, 0.0);
  }

  static ros::NodeHandle* nh_;
  static FakeRobot* robot_;
  static ros::Publisher* goal_pub_;
  static ros::Subscriber *status_sub_, *dovs_sub_;
  static ros::AsyncSpinner* spinner_;
  static std::mutex mutex_;
  static std::vector<PlannerStatus> statuses_;
  static std::map<ros::Time, Dovs> dovs_;
};

ros::NodeHandle* PlannerWatchdog::nh_ = nullptr;
FakeRobot* PlannerWatchdog::robot_ = nullptr;
ros::Publisher* PlannerWatchdog::goal_pub_ = nullptr;
ros::Subscriber* PlannerWatchdog::status_sub_ = nullptr;
ros::Subscriber* PlannerWatchdog::dovs_sub_ = nullptr;
ros::AsyncSpinner* PlannerWatchdog::spinner_ = nullptr;
std::mutex PlannerWatchdog::mutex_;
std::vector<PlannerStatus> PlannerWatchdog::statuses_;
std::map<ros::Time, Dovs> PlannerWatchdog::dovs_;

// The watchdog fires max_input_age after the last good message, at the next control period at the latest.
constexpr double kNoticeLimit = kMaxInputAge + kDt + 0.15;

TEST_F(PlannerWatchdog, DrivesWhenFed) { driveUntilMoving(); }

TEST_F(PlannerWatchdog, StaleScanStopsTheRobotAndFreshScansResume) {
  driveUntilMoving();
  robot_->feed_scan = false;
  expectStopsInTime(ros::Time::now().toSec(), "scan", kNoticeLimit);
  robot_->feed_scan = true;
  EXPECT_TRUE(
      waitFor([] { return lastStatus().state == PlannerStatus::ACTIVE && robot_->lastCommand().v > 0.05; }, 5.0))
      << "the planner did not resume on fresh scans: " << lastStatus().reason;
}

TEST_F(PlannerWatchdog, StaleOdomStopsTheRobot) {
  driveUntilMoving();
  robot_->feed_odom = false;
  expectStopsInTime(ros::Time::now().toSec(), "odom", kNoticeLimit);
  robot_->feed_odom = true;
  EXPECT_TRUE(waitFor([] { return lastStatus().state == PlannerStatus::ACTIVE; }, 5.0));
}

TEST_F(PlannerWatchdog, NaNGoalIsRejectedAndTheRobotStops) {
  driveUntilMoving();
  sendGoalAhead(0.0, "odom", kNaN, true);
  expectStopsInTime(ros::Time::now().toSec(), "NaN", 0.3);
  EXPECT_NE(lastStatus().reason.find("goal rejected"), std::string::npos) << lastStatus().reason;
}

TEST_F(PlannerWatchdog, GoalInAnUnknownFrameIsRejectedAndTheRobotStops) {
  driveUntilMoving();
  sendGoalAhead(3.0, "no_such_frame");
  // The planner waits up to 0.2 s for the goal's transform before rejecting it.
  expectStopsInTime(ros::Time::now().toSec(), "no_such_frame", 0.5);
}

// Obstacles dovs_node cannot trust are dropped whole: no velocity space is published for them.
TEST_F(PlannerWatchdog, DovsDropsObstaclesWithNaNOrNonPositiveRadius) {
  robot_->feed_obstacles = false;
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
    const ros::Time tf_stamp = robot_->lastTfStamp();
    TrackedObstacleArray bad = FakeRobot::farObstacles(tf_stamp - ros::Duration(0.02));
    c.spoil(bad.obstacles[0]);
    const TrackedObstacleArray marker = FakeRobot::farObstacles(tf_stamp - ros::Duration(0.01));
    robot_->publishObstacles(bad);
    robot_->publishObstacles(marker);
    const bool marker_seen = waitFor(
        [&] {
          std::lock_guard<std::mutex> l(mutex_);
          return dovs_.count(marker.header.stamp) > 0;
        },
        2.0);
    ASSERT_TRUE(marker_seen) << "dovs_node published nothing after obstacles with " << c.what;
    std::lock_guard<std::mutex> l(mutex_);
    EXPECT_EQ(dovs_.count(bad.header.stamp), 0u) << "a velocity space was built from obstacles with " << c.what;
  }
  robot_->feed_obstacles = true;
}

// Uncertain means unsafe: while every obstacles message is unusable the planner gets no velocity space
// and brings the robot to a stop, saying why.
TEST_F(PlannerWatchdog, UnusableObstaclesStopTheRobot) {
  driveUntilMoving();
  robot_->feed_obstacles = false;
  const double cut = ros::Time::now().toSec();
  std::atomic<bool> spoiling{true};
  std::thread spoiler([&] {
    ros::WallRate rate(10.0);
    while (spoiling && ros::ok()) {
      TrackedObstacleArray bad = FakeRobot::farObstacles(robot_->lastTfStamp());
      bad.obstacles[0].radius = kNaN;
      robot_->publishObstacles(bad);
      rate.sleep();
    }
  });
  expectStopsInTime(cut, "dovs", kNoticeLimit);
  spoiling = false;
  spoiler.join();
  robot_->feed_obstacles = true;
}

// An odom velocity outside the robot's limits is clipped into the feasible set before the DOVS uses it.
TEST_F(PlannerWatchdog, DovsClipsOdomVelocityOutsideTheLimits) {
  robot_->feed_odom = false;
  robot_->feed_obstacles = false;
  ros::WallDuration(0.1).sleep();
  const ros::Time tf_stamp = robot_->lastTfStamp();
  robot_->publishOdom(tf_stamp, 2.0, 10.0);
  ros::WallDuration(0.1).sleep();
  const TrackedObstacleArray marker = FakeRobot::farObstacles(tf_stamp - ros::Duration(0.01));
  robot_->publishObstacles(marker);
  Dovs d;
  const bool seen = waitFor(
      [&] {
        std::lock_guard<std::mutex> l(mutex_);
        const auto it = dovs_.find(marker.header.stamp);
        if (it == dovs_.end()) return false;
        d = it->second;
        return true;
      },
      2.0);
  robot_->feed_odom = true;
  robot_->feed_obstacles = true;
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

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_planner_watchdog");
  const int result = RUN_ALL_TESTS();
  ros::shutdown();
  return result;
}
