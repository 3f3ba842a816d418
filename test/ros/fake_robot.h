// The fake robot the node-level tests (test/ros/test_*.cpp, each its own rostest node) drive the pipeline
// with, header-only: include it as "fake_robot.h" from a test in this folder.
//
// What it plays (FakeRobot): a unicycle that integrates the cmd_vel it receives into a pose, and its sensors:
//   - tf odom -> base_footprint (the pose) and base_footprint -> laser (identity), at rate_hz (20 Hz);
//   - odom (pose and the commanded velocity), at rate_hz;
//   - a LaserScan in "laser" every scan_every-th tick (10 Hz): all beams non-returns, shaped by ScanShape
//     (narrowScan: 11 beams over +-1 rad; fullTurnScan: 360 beams over a full turn, as the tracker wants);
//   - with publish_obstacles, tracked obstacles (farObstacles: one static disc far behind the start) with the
//     scans, in place of a tracker.
// Every stamp comes from its clock: ros::Time::now(), or a SimClock the test owns (simulated time on /clock,
// 1:1 with the wall clock, that can be made to jump). Every received command is recorded with its wall time.
// Switches (atomics, flipped from the test while the robot runs):
//   feed_tf (odom -> base_footprint only; the laser stays on the base), feed_odom, feed_scan, feed_obstacles
//   stop that input; scan_fault spoils every scan (ScanFault); odom_lag_s stamps odom that far in the past;
//   stuck blocks the wheels (the pose holds, odom says zero speed); setWalls puts walls into the scans.
//   firstFaultyScanWall / firstLaggedOdomWall say when the first spoiled message left (armFaultClocks resets).
// Around it: TopicLog (what a topic published, with receipt wall times), RobotHarness (node handle, robot,
// goal publisher, planner/status log, spinner: what a test fixture sets up), waitFor, runRostestNode, and the
// shipped robot limits (config/robot.yaml, config/planner.yaml).
#pragma once

#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/Twist.h>
#include <gtest/gtest.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Clock.h>
#include <sensor_msgs/LaserScan.h>
#include <tf2_ros/transform_broadcaster.h>

#include <atomic>
#include <cmath>
#include <deque>
#include <functional>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "dqn_dovs/Dovs.h"
#include "dqn_dovs/PlannerStatus.h"
#include "dqn_dovs/TrackedObstacleArray.h"
#include "dqn_dovs/common/geometry.h"

namespace dqn_dovs::test {

// config/robot.yaml and config/planner.yaml (the .test files load them into the nodes).
inline constexpr double kVMax = 0.7, kWMax = 3.14159, kAv = 0.5, kAw = 2.0;
inline constexpr double kPlannerPeriod = 0.2, kMaxInputAge = 0.5;
inline constexpr double kMaxRampStep = 0.1;  // planner_node: the longest step one command may take credit for
inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

inline double wallNow() { return ros::WallTime::now().toSec(); }

/// Polls `condition` until it holds or `timeout_s` of wall time pass; its value at the end.
inline bool waitFor(const std::function<bool()>& condition, double timeout_s, double poll_s = 0.005) {
  const double deadline = wallNow() + timeout_s;
  while (ros::ok() && wallNow() < deadline) {
    if (condition()) return true;
    ros::WallDuration(poll_s).sleep();
  }
  return condition();
}

/// The transform parent -> child of a child frame at pose `p` in the parent's plane.
inline geometry_msgs::TransformStamped planarTransform(const ros::Time& stamp, const std::string& parent,
                                                       const std::string& child, const Pose2& p) {
  geometry_msgs::TransformStamped t;
  t.header.stamp = stamp;
  t.header.frame_id = parent;
  t.child_frame_id = child;
  t.transform.translation.x = p.x;
  t.transform.translation.y = p.y;
  t.transform.rotation.z = std::sin(p.theta / 2.0);
  t.transform.rotation.w = std::cos(p.theta / 2.0);
  return t;
}

/// The transform odom -> base_footprint of a robot at pose `p`.
inline geometry_msgs::TransformStamped baseInOdom(const ros::Time& stamp, const Pose2& p) {
  return planarTransform(stamp, "odom", "base_footprint", p);
}

/// A robot standing at the odom origin at `stamp`: tf odom -> base_footprint (identity) and its odom message.
inline void publishStandingRobot(tf2_ros::TransformBroadcaster& tf, ros::Publisher& odom, const ros::Time& stamp) {
  tf.sendTransform(baseInOdom(stamp, Pose2{}));
  nav_msgs::Odometry o;
  o.header.stamp = stamp;
  o.header.frame_id = "odom";
  o.child_frame_id = "base_footprint";
  o.pose.pose.orientation.w = 1.0;
  odom.publish(o);
}

/// main() of a rostest node.
inline int runRostestNode(int argc, char** argv, const std::string& name) {
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, name);
  const int result = RUN_ALL_TESTS();
  ros::shutdown();
  return result;
}

/// A command as the robot received it.
struct Command {
  double wall;  // receipt (wall clock, s)
  double v, w;
};

/// The beams of a scan; angle_max = angle_min + (beams - 1) * angle_increment.
struct ScanShape {
  int beams;
  float angle_min, angle_increment;
  float range_min, range_max;
  float scan_time;
};
/// 11 beams over +-1 rad: enough for a planner that only watches the scans' stamps and validity.
inline ScanShape narrowScan() { return {11, -1.0f, 0.2f, 0.1f, 10.0f, 0.0f}; }
/// 360 beams over a full turn, 0.05-10 m, at `scan_time` s per scan: what the tracker sees from a real LIDAR.
inline ScanShape fullTurnScan(double scan_time = 0.1) {
  const int beams = 360;
  return {beams, static_cast<float>(-M_PI),    static_cast<float>(2.0 * M_PI / beams), 0.05f,
          10.0f, static_cast<float>(scan_time)};
}

/// A scan of open space (every beam a non-return).
inline sensor_msgs::LaserScan makeScan(const ros::Time& stamp, const ScanShape& shape,
                                       const std::string& frame = "laser") {
  sensor_msgs::LaserScan s;
  s.header.stamp = stamp;
  s.header.frame_id = frame;
  s.angle_min = shape.angle_min;
  s.angle_increment = shape.angle_increment;
  s.angle_max = static_cast<float>(s.angle_min + (shape.beams - 1) * s.angle_increment);
  s.range_min = shape.range_min;
  s.range_max = shape.range_max;
  s.scan_time = shape.scan_time;
  s.ranges.assign(static_cast<size_t>(shape.beams), std::numeric_limits<float>::infinity());
  return s;
}

/// How a scan is spoiled.
enum class ScanFault { kNone, kNaN, kInfField, kEmpty, kWrongSize, kUnknownFrame };

inline void spoilScan(sensor_msgs::LaserScan& s, ScanFault fault) {
  switch (fault) {
    case ScanFault::kNone:
      break;
    case ScanFault::kNaN:
      s.ranges.assign(s.ranges.size(), std::numeric_limits<float>::quiet_NaN());
      break;
    case ScanFault::kInfField:
      s.angle_increment = std::numeric_limits<float>::infinity();
      break;
    case ScanFault::kEmpty:
      s.ranges.clear();
      break;
    case ScanFault::kWrongSize:
      s.ranges.resize(100);
      break;
    case ScanFault::kUnknownFrame:
      s.header.frame_id = "no_such_laser";
      break;
  }
}

/// One static obstacle far behind the start (in odom), so the DOVS always has something to compute.
inline TrackedObstacleArray farObstacles(const ros::Time& stamp) {
  TrackedObstacleArray m;
  m.header.stamp = stamp;
  m.header.frame_id = "odom";
  ObstacleTrack o;
  o.id = 1;
  o.center.x = -3.0;
  o.center.y = -3.0;
  o.radius = 0.2;
  o.is_static = true;
  for (int i = 0; i < 5; ++i) o.covariance[static_cast<size_t>(i * 6)] = 0.01;
  m.obstacles.push_back(o);
  return m;
}

/// Simulated time the test owns: published on /clock at `rate_hz`, 1:1 with the wall clock from `base_s`
/// (far from 0, so a backwards jump stays positive), plus the jumps injected so far.
class SimClock {
 public:
  explicit SimClock(ros::NodeHandle& nh, double base_s = 1000.0, double rate_hz = 200.0)
      : pub_(nh.advertise<rosgraph_msgs::Clock>("/clock", 20)), base_s_(base_s), rate_hz_(rate_hz), wall0_(wallNow()) {}
  ~SimClock() { stop(); }

  void start() {
    thread_ = std::thread([this] {
      ros::WallRate rate(rate_hz_);
      while (running_ && ros::ok()) {
        rosgraph_msgs::Clock c;
        c.clock = now();
        pub_.publish(c);
        rate.sleep();
      }
    });
  }
  void stop() {
    running_ = false;
    if (thread_.joinable()) thread_.join();
  }

  ros::Time now() {
    std::lock_guard<std::mutex> l(mutex_);
    return ros::Time(base_s_ + (wallNow() - wall0_) + offset_);
  }
  /// Makes the clock jump by `s` seconds; returns the wall time of the jump.
  double jump(double s) {
    std::lock_guard<std::mutex> l(mutex_);
    offset_ += s;
    return wallNow();
  }

 private:
  ros::Publisher pub_;
  double base_s_, rate_hz_, wall0_, offset_ = 0.0;
  std::mutex mutex_;
  std::thread thread_;
  std::atomic<bool> running_{true};
};

struct FakeRobotOptions {
  double rate_hz = 20.0;  // tf and odom
  int scan_every = 2;     // scans (and obstacles) every scan_every-th tick
  ScanShape scan = fullTurnScan();
  bool publish_obstacles = false;    // tracked obstacles on `obstacles` (no tracker in the test)
  std::function<ros::Time()> clock;  // the stamps; empty: ros::Time::now()
};

/// The robot and its sensors as the pipeline sees them (see the top of this file).
class FakeRobot {
 public:
  std::atomic<bool> feed_tf{true}, feed_odom{true}, feed_scan{true}, feed_obstacles{true};
  std::atomic<ScanFault> scan_fault{ScanFault::kNone};
  std::atomic<double> odom_lag_s{0.0};
  // Wheels blocked: the pose stays where it is and odom measures zero speed, whatever is commanded.
  std::atomic<bool> stuck{false};

  /// Walls the scans see (segments in odom), replacing the open space; set while running.
  void setWalls(std::vector<Segment> walls) {
    std::lock_guard<std::mutex> l(mutex_);
    walls_ = std::move(walls);
  }

  explicit FakeRobot(ros::NodeHandle& nh, FakeRobotOptions options = {})
      : options_(std::move(options)),
        scan_pub_(nh.advertise<sensor_msgs::LaserScan>("scan", 5)),
        odom_pub_(nh.advertise<nav_msgs::Odometry>("odom", 10)),
        cmd_sub_(nh.subscribe("cmd_vel", 2000, &FakeRobot::onCmd, this)) {
    if (options_.publish_obstacles) obstacles_pub_ = nh.advertise<TrackedObstacleArray>("obstacles", 10);
  }
  ~FakeRobot() { stop(); }

  void start() {
    thread_ = std::thread([this] { loop(); });
  }
  void stop() {
    running_ = false;
    if (thread_.joinable()) thread_.join();
  }

  ros::Time now() const { return options_.clock ? options_.clock() : ros::Time::now(); }
  Pose2 pose() {
    std::lock_guard<std::mutex> l(mutex_);
    return pose_;
  }
  std::vector<Command> commands() {
    std::lock_guard<std::mutex> l(mutex_);
    return commands_;
  }
  Command lastCommand() {
    std::lock_guard<std::mutex> l(mutex_);
    return commands_.empty() ? Command{0.0, 0.0, 0.0} : commands_.back();
  }
  /// Stamp and wall time of the last odom -> base_footprint sent: tf can be looked up at any time up to it.
  ros::Time lastTfStamp() {
    std::lock_guard<std::mutex> l(mutex_);
    return last_tf_stamp_;
  }
  double lastTfWall() { return last_tf_wall_.load(); }
  /// Wall time of the first spoiled scan / lagged odom sent since armFaultClocks (0: none yet).
  double firstFaultyScanWall() { return first_bad_scan_wall_.load(); }
  double firstLaggedOdomWall() { return first_lagged_odom_wall_.load(); }
  void armFaultClocks() {
    first_bad_scan_wall_ = 0.0;
    first_lagged_odom_wall_ = 0.0;
  }
  /// Every input has at least `n` subscribers.
  bool inputsSubscribed(size_t n) {
    return scan_pub_.getNumSubscribers() >= n && odom_pub_.getNumSubscribers() >= n &&
           (!options_.publish_obstacles || obstacles_pub_.getNumSubscribers() >= n);
  }

  /// Odom at the current pose with the velocity (v, w), out of turn.
  void publishOdom(const ros::Time& stamp, double v, double w) { publishOdom(stamp, pose(), v, w); }
  /// Obstacles out of turn (publish_obstacles only).
  void publishObstacles(const TrackedObstacleArray& msg) {
    if (options_.publish_obstacles) obstacles_pub_.publish(msg);
  }

 private:
  void onCmd(const geometry_msgs::Twist::ConstPtr& m) {
    std::lock_guard<std::mutex> l(mutex_);
    commands_.push_back({wallNow(), m->linear.x, m->angular.z});
    v_ = m->linear.x;
    w_ = m->angular.z;
  }

  void publishOdom(const ros::Time& stamp, const Pose2& p, double v, double w) {
    nav_msgs::Odometry o;
    o.header.stamp = stamp;
    o.header.frame_id = "odom";
    o.child_frame_id = "base_footprint";
    o.pose.pose.position.x = p.x;
    o.pose.pose.position.y = p.y;
    o.pose.pose.orientation.z = std::sin(p.theta / 2.0);
    o.pose.pose.orientation.w = std::cos(p.theta / 2.0);
    o.twist.twist.linear.x = v;
    o.twist.twist.angular.z = w;
    odom_pub_.publish(o);
  }

  void publishTf(const ros::Time& stamp, const Pose2& p, double now_wall) {
    std::vector<geometry_msgs::TransformStamped> tfs;
    const bool base = feed_tf;
    if (base) tfs.push_back(baseInOdom(stamp, p));
    // The laser sits on the base (its scans must be placeable in the fixed frame, or they are rejected).
    geometry_msgs::TransformStamped laser;
    laser.header.stamp = stamp;
    laser.header.frame_id = "base_footprint";
    laser.child_frame_id = "laser";
    laser.transform.rotation.w = 1.0;
    tfs.push_back(laser);
    tf_.sendTransform(tfs);
    if (base) {
      std::lock_guard<std::mutex> l(mutex_);
      last_tf_stamp_ = stamp;
      last_tf_wall_ = now_wall;
    }
  }

  void loop() {
    ros::WallRate rate(options_.rate_hz);
    int tick = 0;
    double last = wallNow();
    while (running_ && ros::ok()) {
      const double now_wall = wallNow();
      const ros::Time stamp = now();
      double v, w;
      Pose2 p;
      {
        std::lock_guard<std::mutex> l(mutex_);
        const bool blocked = stuck;
        if (!blocked) pose_ = integrateUnicycle(pose_, v_, w_, now_wall - last);
        p = pose_;
        v = blocked ? 0.0 : v_;
        w = blocked ? 0.0 : w_;
      }
      last = now_wall;
      publishTf(stamp, p, now_wall);
      if (feed_odom) {
        const double lag = odom_lag_s;
        publishOdom(stamp - ros::Duration(lag), p, v, w);
        if (lag > 0.0 && first_lagged_odom_wall_ == 0.0) first_lagged_odom_wall_ = now_wall;
      }
      if (tick % options_.scan_every == 0) {
        if (feed_scan) {
          const ScanFault fault = scan_fault;
          sensor_msgs::LaserScan s = makeScan(stamp, options_.scan);
          renderWalls(s, p);
          spoilScan(s, fault);
          scan_pub_.publish(s);
          if (fault != ScanFault::kNone && first_bad_scan_wall_ == 0.0) first_bad_scan_wall_ = now_wall;
        }
        if (feed_obstacles) publishObstacles(farObstacles(stamp));
      }
      ++tick;
      rate.sleep();
    }
  }

  // Each beam's range to the nearest wall (the laser sits on the base).
  void renderWalls(sensor_msgs::LaserScan& s, const Pose2& p) {
    std::vector<Segment> walls;
    {
      std::lock_guard<std::mutex> l(mutex_);
      walls = walls_;
    }
    for (size_t k = 0; k < s.ranges.size() && !walls.empty(); ++k) {
      const double a = p.theta + s.angle_min + static_cast<double>(k) * s.angle_increment;
      const Vec2 o(p.x, p.y), d(std::cos(a), std::sin(a));
      double best = std::numeric_limits<double>::infinity();
      for (const Segment& w : walls) {
        const Vec2 e = w.b - w.a;
        const double den = d.x() * e.y() - d.y() * e.x();
        if (std::abs(den) < 1e-12) continue;
        const Vec2 q = w.a - o;
        const double t = (q.x() * e.y() - q.y() * e.x()) / den, u = (q.x() * d.y() - q.y() * d.x()) / den;
        if (t > 0.0 && u >= 0.0 && u <= 1.0) best = std::min(best, t);
      }
      if (best >= s.range_min && best <= s.range_max) s.ranges[k] = static_cast<float>(best);
    }
  }

  const FakeRobotOptions options_;
  ros::Publisher scan_pub_, odom_pub_, obstacles_pub_;
  ros::Subscriber cmd_sub_;
  tf2_ros::TransformBroadcaster tf_;
  std::thread thread_;
  std::atomic<bool> running_{true};
  std::mutex mutex_;
  Pose2 pose_{0.0, 0.0, 0.0};
  double v_ = 0.0, w_ = 0.0;
  std::vector<Segment> walls_;
  ros::Time last_tf_stamp_;
  std::vector<Command> commands_;
  std::atomic<double> first_bad_scan_wall_{0.0}, first_lagged_odom_wall_{0.0}, last_tf_wall_{0.0};
};

/// What a topic published, with the wall time of receipt: all of it, or the last `keep` messages.
template <class Msg>
class TopicLog {
 public:
  struct Entry {
    double wall;
    Msg msg;
  };

  TopicLog(ros::NodeHandle& nh, const std::string& topic, uint32_t queue, size_t keep = 0)
      : keep_(keep), sub_(nh.subscribe(topic, queue, &TopicLog::onMessage, this)) {}

  bool any() {
    std::lock_guard<std::mutex> l(mutex_);
    return !entries_.empty();
  }
  /// The last message (a default one before the first).
  Msg last() {
    std::lock_guard<std::mutex> l(mutex_);
    return entries_.empty() ? Msg() : entries_.back().msg;
  }
  /// Wall time of the last receipt (0: none yet).
  double lastWall() {
    std::lock_guard<std::mutex> l(mutex_);
    return entries_.empty() ? 0.0 : entries_.back().wall;
  }
  std::vector<Entry> entries() {
    std::lock_guard<std::mutex> l(mutex_);
    return std::vector<Entry>(entries_.begin(), entries_.end());
  }
  /// The message stamped `stamp`, if one came.
  std::optional<Msg> find(const ros::Time& stamp) {
    std::lock_guard<std::mutex> l(mutex_);
    for (auto it = entries_.rbegin(); it != entries_.rend(); ++it) {
      if (it->msg.header.stamp == stamp) return it->msg;
    }
    return std::nullopt;
  }

 private:
  void onMessage(const typename Msg::ConstPtr& m) {
    std::lock_guard<std::mutex> l(mutex_);
    entries_.push_back({wallNow(), *m});
    if (keep_ > 0 && entries_.size() > keep_) entries_.pop_front();
  }

  size_t keep_;
  std::mutex mutex_;
  std::deque<Entry> entries_;
  ros::Subscriber sub_;  // last: unsubscribed before the rest goes
};

/// What a fixture driving the pipeline sets up: the robot (on a SimClock it owns, with `sim_clock`), the goal
/// publisher, the log of planner/status and a running spinner. The robot is started by the test.
class RobotHarness {
 public:
  explicit RobotHarness(FakeRobotOptions options, bool sim_clock = false, uint32_t spinner_threads = 2)
      : clock(sim_clock ? std::make_unique<SimClock>(nh) : nullptr),
        robot(nh, withClock(std::move(options), clock.get())),
        goal_pub(nh.advertise<geometry_msgs::PoseStamped>("move_base_simple/goal", 2)),
        status(nh, "planner/status", 200),
        spinner(spinner_threads) {
    if (clock) clock->start();
    spinner.start();
  }
  ~RobotHarness() { stop(); }

  /// Stops the robot, the clock and the callbacks.
  void stop() {
    robot.stop();
    if (clock) clock->stop();
    spinner.stop();
  }

  /// Waits until every input has `input_subscribers` subscribers, dovs_node and planner_node take goals and
  /// the planner has said something.
  bool waitUntilReady(size_t input_subscribers, double timeout_s) {
    return waitUntilReadyFor(input_subscribers, 2, timeout_s);
  }
  /// The same with `goal_subscribers` on move_base_simple/goal (1 when dovs_node takes planner/local_goal).
  bool waitUntilReadyFor(size_t input_subscribers, size_t goal_subscribers, double timeout_s) {
    return waitFor(
        [&] {
          return robot.inputsSubscribed(input_subscribers) && goal_pub.getNumSubscribers() >= goal_subscribers &&
                 status.any();
        },
        timeout_s);
  }

  PlannerStatus lastStatus() { return status.last(); }

  /// A goal `distance` ahead of the robot, in `frame`, stamped now.
  geometry_msgs::PoseStamped goalAhead(double distance, const std::string& frame = "odom") {
    const Pose2 p = robot.pose();
    geometry_msgs::PoseStamped g;
    g.header.stamp = robot.now();
    g.header.frame_id = frame;
    g.pose.position.x = p.x + distance * std::cos(p.theta);
    g.pose.position.y = p.y + distance * std::sin(p.theta);
    g.pose.orientation.w = 1.0;
    return g;
  }

  /// Gives a fresh goal `distance` ahead and waits until the planner drives on it at >= `min_v`: a velocity space
  /// built for this goal has come and the planner said ACTIVE after it. (A robot still moving from an earlier
  /// goal does not count: until dovs_node has built for the new goal, the planner has nothing valid to act on.)
  void driveUntilMoving(double distance, double min_v, double timeout_s) {
    TopicLog<Dovs> built(nh, "dovs", 10);
    const geometry_msgs::PoseStamped goal = goalAhead(distance);
    goal_pub.publish(goal);
    const bool for_goal =
        waitFor([&] { return built.any() && built.last().goal_stamp == goal.header.stamp; }, timeout_s);
    ASSERT_TRUE(for_goal) << "no velocity space built for the new goal: planner state " << int(lastStatus().state)
                          << " (" << lastStatus().reason << ")";
    const double built_at = built.lastWall();
    const bool moving = waitFor(
        [&] {
          return status.lastWall() > built_at && lastStatus().state == PlannerStatus::ACTIVE &&
                 robot.lastCommand().v >= min_v;
        },
        timeout_s);
    ASSERT_TRUE(moving) << "the pipeline does not drive: state " << int(lastStatus().state) << " ("
                        << lastStatus().reason << "), last v " << robot.lastCommand().v;
  }

  ros::NodeHandle nh;
  std::unique_ptr<SimClock> clock;
  FakeRobot robot;
  ros::Publisher goal_pub;
  TopicLog<PlannerStatus> status;
  ros::AsyncSpinner spinner;

 private:
  static FakeRobotOptions withClock(FakeRobotOptions options, SimClock* clock) {
    if (clock) options.clock = [clock] { return clock->now(); };
    return options;
  }
};

}  // namespace dqn_dovs::test
