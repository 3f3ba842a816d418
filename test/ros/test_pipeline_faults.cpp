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
#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/Twist.h>
#include <geometry_msgs/TwistStamped.h>
#include <gtest/gtest.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Clock.h>
#include <sensor_msgs/LaserScan.h>
#include <tf2_ros/transform_broadcaster.h>

#include <atomic>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iomanip>
#include <iostream>
#include <limits>
#include <mutex>
#include <sstream>
#include <thread>
#include <vector>

#include "dqn_dovs/Dovs.h"
#include "dqn_dovs/PlannerStatus.h"
#include "dqn_dovs/TrackedObstacleArray.h"
#include "dqn_dovs/common/geometry.h"

namespace {

using dqn_dovs::PlannerStatus;

// config/robot.yaml and config/planner.yaml (the .test loads them into the nodes).
constexpr double kVMax = 0.7, kWMax = 3.14159, kAv = 0.5, kAw = 2.0, kMaxInputAge = 0.5;
constexpr double kMaxRampStep = 0.1;  // planner_node: the longest step one command may take credit for
// Commands received this soon after the fault may have left the planner before it saw the fault.
constexpr double kGrace = 0.03;

double wallNow() { return ros::WallTime::now().toSec(); }

struct Cmd {
  double wall;  // receipt (wall clock, s)
  double v, w;
};

struct Stamped {
  ros::Time stamp;
  uint32_t seq;
  double v, w;
};

struct StatusAt {
  double wall;
  PlannerStatus msg;
};

enum class ScanFault { kNone, kNaN, kInfField, kEmpty, kWrongSize, kUnknownFrame };

/// The robot, its sensors and the clock.
class World {
 public:
  std::atomic<int> scan_fault{static_cast<int>(ScanFault::kNone)};
  std::atomic<bool> send_tf{true}, stale_odom{false};

  explicit World(ros::NodeHandle& nh)
      : clock_pub_(nh.advertise<rosgraph_msgs::Clock>("/clock", 20)),
        scan_pub_(nh.advertise<sensor_msgs::LaserScan>("scan", 5)),
        odom_pub_(nh.advertise<nav_msgs::Odometry>("odom", 10)),
        cmd_sub_(nh.subscribe("cmd_vel", 2000, &World::onCmd, this)),
        stamped_sub_(nh.subscribe("planner/cmd_vel_stamped", 5000, &World::onStamped, this)),
        wall0_(wallNow()) {}

  void startClock() {
    clock_thread_ = std::thread([this] {
      ros::WallRate rate(200.0);
      while (running_ && ros::ok()) {
        rosgraph_msgs::Clock c;
        c.clock = ros::Time(simNow());
        clock_pub_.publish(c);
        rate.sleep();
      }
    });
  }
  void startRobot() {
    robot_thread_ = std::thread([this] { loop(); });
  }
  void stop() {
    running_ = false;
    if (clock_thread_.joinable()) clock_thread_.join();
    if (robot_thread_.joinable()) robot_thread_.join();
  }

  /// Simulated time: 1:1 with the wall clock, plus the jumps injected so far.
  double simNow() {
    std::lock_guard<std::mutex> l(clock_mutex_);
    return kBase + (wallNow() - wall0_) + offset_;
  }
  /// Makes the clock jump by `s` seconds; returns the wall time of the jump.
  double jump(double s) {
    std::lock_guard<std::mutex> l(clock_mutex_);
    offset_ += s;
    return wallNow();
  }

  dqn_dovs::Pose2 pose() {
    std::lock_guard<std::mutex> l(mutex_);
    return pose_;
  }
  std::vector<Cmd> commands() {
    std::lock_guard<std::mutex> l(mutex_);
    return commands_;
  }
  Cmd lastCommand() {
    std::lock_guard<std::mutex> l(mutex_);
    return commands_.empty() ? Cmd{0.0, 0.0, 0.0} : commands_.back();
  }
  std::vector<Stamped> stamped() {
    std::lock_guard<std::mutex> l(mutex_);
    return stamped_;
  }
  /// Wall time of the first faulty scan / stale odom published since the fault was switched on (0: none yet).
  double firstFaultyScanWall() { return first_bad_scan_wall_.load(); }
  double firstStaleOdomWall() { return first_stale_odom_wall_.load(); }
  double lastTfWall() { return last_tf_wall_.load(); }
  void armFaultClocks() {
    first_bad_scan_wall_ = 0.0;
    first_stale_odom_wall_ = 0.0;
  }
  size_t subscribersReady() { return scan_pub_.getNumSubscribers() >= 2 && odom_pub_.getNumSubscribers() >= 2; }

 private:
  static constexpr double kBase = 1000.0;  // s; far from 0, so the backwards jump stays positive

  void onCmd(const geometry_msgs::Twist::ConstPtr& m) {
    std::lock_guard<std::mutex> l(mutex_);
    commands_.push_back({wallNow(), m->linear.x, m->angular.z});
    v_ = m->linear.x;
    w_ = m->angular.z;
  }
  void onStamped(const geometry_msgs::TwistStamped::ConstPtr& m) {
    std::lock_guard<std::mutex> l(mutex_);
    stamped_.push_back({m->header.stamp, m->header.seq, m->twist.linear.x, m->twist.angular.z});
  }

  sensor_msgs::LaserScan scan(const ros::Time& stamp, ScanFault fault) {
    sensor_msgs::LaserScan s;
    s.header.stamp = stamp;
    s.header.frame_id = "laser";
    const int beams = 360;
    s.angle_min = static_cast<float>(-M_PI);
    s.angle_increment = static_cast<float>(2.0 * M_PI / beams);
    s.angle_max = static_cast<float>(s.angle_min + (beams - 1) * s.angle_increment);
    s.range_min = 0.05f;
    s.range_max = 10.0f;
    s.scan_time = 0.1f;
    s.ranges.assign(beams, std::numeric_limits<float>::infinity());  // open space: no return
    switch (fault) {
      case ScanFault::kNone:
        break;
      case ScanFault::kNaN:
        s.ranges.assign(beams, std::numeric_limits<float>::quiet_NaN());
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
    return s;
  }

  void loop() {
    const double period = 0.05;
    ros::WallRate rate(1.0 / period);
    int tick = 0;
    double last = wallNow();
    while (running_ && ros::ok()) {
      const double now_wall = wallNow();
      const ros::Time stamp(simNow());
      double v, w;
      dqn_dovs::Pose2 p;
      {
        std::lock_guard<std::mutex> l(mutex_);
        pose_ = dqn_dovs::integrateUnicycle(pose_, v_, w_, now_wall - last);
        p = pose_;
        v = v_;
        w = w_;
      }
      last = now_wall;
      std::vector<geometry_msgs::TransformStamped> tfs;
      if (send_tf) {
        geometry_msgs::TransformStamped t;
        t.header.stamp = stamp;
        t.header.frame_id = "odom";
        t.child_frame_id = "base_footprint";
        t.transform.translation.x = p.x;
        t.transform.translation.y = p.y;
        t.transform.rotation.z = std::sin(p.theta / 2.0);
        t.transform.rotation.w = std::cos(p.theta / 2.0);
        tfs.push_back(t);
      }
      geometry_msgs::TransformStamped laser;
      laser.header.stamp = stamp;
      laser.header.frame_id = "base_footprint";
      laser.child_frame_id = "laser";
      laser.transform.rotation.w = 1.0;
      tfs.push_back(laser);
      tf_.sendTransform(tfs);
      if (send_tf) last_tf_wall_ = now_wall;

      nav_msgs::Odometry o;
      o.header.stamp = stale_odom ? stamp - ros::Duration(1.5) : stamp;
      o.header.frame_id = "odom";
      o.child_frame_id = "base_footprint";
      o.pose.pose.position.x = p.x;
      o.pose.pose.position.y = p.y;
      o.pose.pose.orientation.z = std::sin(p.theta / 2.0);
      o.pose.pose.orientation.w = std::cos(p.theta / 2.0);
      o.twist.twist.linear.x = v;
      o.twist.twist.angular.z = w;
      odom_pub_.publish(o);
      if (stale_odom && first_stale_odom_wall_ == 0.0) first_stale_odom_wall_ = now_wall;

      if (tick % 2 == 0) {
        const auto fault = static_cast<ScanFault>(scan_fault.load());
        scan_pub_.publish(scan(stamp, fault));
        if (fault != ScanFault::kNone && first_bad_scan_wall_ == 0.0) first_bad_scan_wall_ = now_wall;
      }
      ++tick;
      rate.sleep();
    }
  }

  ros::Publisher clock_pub_, scan_pub_, odom_pub_;
  ros::Subscriber cmd_sub_, stamped_sub_;
  tf2_ros::TransformBroadcaster tf_;
  std::thread clock_thread_, robot_thread_;
  std::atomic<bool> running_{true};
  std::mutex clock_mutex_;
  double wall0_, offset_ = 0.0;
  std::mutex mutex_;
  dqn_dovs::Pose2 pose_{0.0, 0.0, 0.0};
  double v_ = 0.0, w_ = 0.0;
  std::vector<Cmd> commands_;
  std::vector<Stamped> stamped_;
  std::atomic<double> first_bad_scan_wall_{0.0}, first_stale_odom_wall_{0.0}, last_tf_wall_{0.0};
};

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
    nh_ = new ros::NodeHandle;
    world_ = new World(*nh_);
    world_->startClock();
    goal_pub_ = new ros::Publisher(nh_->advertise<geometry_msgs::PoseStamped>("move_base_simple/goal", 2));
    status_sub_ = new ros::Subscriber(nh_->subscribe("planner/status", 200, &PipelineFaults::onStatus));
    obstacles_sub_ = new ros::Subscriber(nh_->subscribe("obstacles", 50, &PipelineFaults::onObstacles));
    dovs_sub_ = new ros::Subscriber(nh_->subscribe("dovs", 50, &PipelineFaults::onDovs));
    spinner_ = new ros::AsyncSpinner(3);
    spinner_->start();
    world_->startRobot();
    waitFor([] { return world_->subscribersReady() && goal_pub_->getNumSubscribers() >= 2 && haveStatus(); }, 60.0);
  }
  static void TearDownTestSuite() {
    writeFigures();
    world_->stop();
    spinner_->stop();
    delete spinner_;
    delete dovs_sub_;
    delete obstacles_sub_;
    delete status_sub_;
    delete goal_pub_;
    delete world_;
    delete nh_;
  }

  static bool haveStatus() {
    std::lock_guard<std::mutex> l(mutex_);
    return !statuses_.empty();
  }
  static void onStatus(const PlannerStatus::ConstPtr& m) {
    std::lock_guard<std::mutex> l(mutex_);
    statuses_.push_back({wallNow(), *m});
  }
  static void onObstacles(const dqn_dovs::TrackedObstacleArray::ConstPtr&) { last_obstacles_wall_ = wallNow(); }
  static void onDovs(const dqn_dovs::Dovs::ConstPtr&) { last_dovs_wall_ = wallNow(); }
  static PlannerStatus lastStatus() {
    std::lock_guard<std::mutex> l(mutex_);
    return statuses_.empty() ? PlannerStatus() : statuses_.back().msg;
  }

  static bool waitFor(const std::function<bool()>& condition, double timeout_s) {
    const double deadline = wallNow() + timeout_s;
    while (ros::ok() && wallNow() < deadline) {
      if (condition()) return true;
      ros::WallDuration(0.005).sleep();
    }
    return condition();
  }

  /// A fresh goal 5 m ahead; waits until the robot drives at >= 0.4 m/s.
  static void driveUntilMoving() {
    const dqn_dovs::Pose2 p = world_->pose();
    geometry_msgs::PoseStamped g;
    g.header.stamp = ros::Time(world_->simNow());
    g.header.frame_id = "odom";
    g.pose.position.x = p.x + 5.0 * std::cos(p.theta);
    g.pose.position.y = p.y + 5.0 * std::sin(p.theta);
    g.pose.orientation.w = 1.0;
    goal_pub_->publish(g);
    const bool moving =
        waitFor([] { return lastStatus().state == PlannerStatus::ACTIVE && world_->lastCommand().v >= 0.4; }, 25.0);
    ASSERT_TRUE(moving) << "the pipeline does not drive: state " << int(lastStatus().state) << " ("
                        << lastStatus().reason << "), last v " << world_->lastCommand().v;
  }

  /// Measures the stop after a fault at `fault_wall` (wall clock): time to the first zero command, braking
  /// only, planner/status STOPPED naming one of `culprits`.
  static StopFigure expectStop(const std::string& name, double fault_wall, const std::vector<std::string>& culprits,
                               bool expect_hold = true) {
    StopFigure f;
    f.fault = name;
    const bool zero = waitFor(
        [&] {
          const Cmd c = world_->lastCommand();
          return c.wall > fault_wall && c.v == 0.0 && c.w == 0.0;
        },
        8.0);
    EXPECT_TRUE(zero) << name << ": cmd_vel never reached zero; last v " << world_->lastCommand().v << ", status '"
                      << lastStatus().reason << "'";
    const std::vector<Cmd> cmds = world_->commands();
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
    {
      std::lock_guard<std::mutex> l(mutex_);
      for (const StatusAt& s : statuses_) {
        if (s.wall < fault_wall || s.msg.state != PlannerStatus::STOPPED) continue;
        for (const std::string& c : culprits) {
          if (s.msg.reason.find(c) != std::string::npos) f.reason = s.msg.reason;
        }
        if (!f.reason.empty()) break;
      }
    }
    EXPECT_FALSE(f.reason.empty()) << name << ": planner/status never said STOPPED naming '" << culprits.front()
                                   << "'; last reason '" << lastStatus().reason << "'";
    if (expect_hold) {
      // It stays stopped while the fault lasts.
      ros::WallDuration(0.4).sleep();
      const Cmd c = world_->lastCommand();
      EXPECT_EQ(c.v, 0.0) << name;
      EXPECT_EQ(c.w, 0.0) << name;
    }
    std::cout << "[fault] " << std::left << std::setw(22) << name << " v " << std::fixed << std::setprecision(3) << f.v
              << " m/s, w " << f.w << " rad/s: zero after " << f.stop_s << " s (bound " << f.bound_s
              << " s); status: " << f.reason << std::endl;
    {
      std::lock_guard<std::mutex> l(mutex_);
      figures_.push_back(f);
    }
    return f;
  }

  /// The fault is gone: every node is still up and publishing, and the robot drives again.
  static void expectRecovery(const std::string& name) {
    const double t = wallNow();
    EXPECT_TRUE(waitFor([&] { return last_obstacles_wall_.load() > t && last_dovs_wall_.load() > t; }, 5.0))
        << name << ": the tracker or dovs_node stopped publishing";
    EXPECT_TRUE(
        waitFor([] { return lastStatus().state == PlannerStatus::ACTIVE && world_->lastCommand().v > 0.05; }, 10.0))
        << name << ": the planner does not drive again: '" << lastStatus().reason << "'";
  }

  static void scanCase(const std::string& name, ScanFault fault, const std::vector<std::string>& culprits) {
    driveUntilMoving();
    if (HasFatalFailure()) return;
    world_->armFaultClocks();
    world_->scan_fault = static_cast<int>(fault);
    ASSERT_TRUE(waitFor([] { return world_->firstFaultyScanWall() > 0.0; }, 1.0));
    expectStop(name, world_->firstFaultyScanWall(), culprits);
    world_->scan_fault = static_cast<int>(ScanFault::kNone);
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

  static ros::NodeHandle* nh_;
  static World* world_;
  static ros::Publisher* goal_pub_;
  static ros::Subscriber *status_sub_, *obstacles_sub_, *dovs_sub_;
  static ros::AsyncSpinner* spinner_;
  static std::mutex mutex_;
  static std::vector<StatusAt> statuses_;
  static std::vector<StopFigure> figures_;
  static std::atomic<double> last_obstacles_wall_, last_dovs_wall_;
};

ros::NodeHandle* PipelineFaults::nh_ = nullptr;
World* PipelineFaults::world_ = nullptr;
ros::Publisher* PipelineFaults::goal_pub_ = nullptr;
ros::Subscriber* PipelineFaults::status_sub_ = nullptr;
ros::Subscriber* PipelineFaults::obstacles_sub_ = nullptr;
ros::Subscriber* PipelineFaults::dovs_sub_ = nullptr;
ros::AsyncSpinner* PipelineFaults::spinner_ = nullptr;
std::mutex PipelineFaults::mutex_;
std::vector<StatusAt> PipelineFaults::statuses_;
std::vector<StopFigure> PipelineFaults::figures_;
std::atomic<double> PipelineFaults::last_obstacles_wall_{0.0};
std::atomic<double> PipelineFaults::last_dovs_wall_{0.0};

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
  const double at = world_->jump(-30.0);
  expectStop("clock jumps back 30 s", at, {"clock jumped backwards"}, false);
  expectRecovery("clock jumps back 30 s");
}

TEST_F(PipelineFaults, ClockJumpingForwardsStopsTheRobotThenItResumes) {
  driveUntilMoving();
  if (HasFatalFailure()) return;
  const double at = world_->jump(30.0);
  expectStop("clock jumps ahead 30 s", at, {"clock jumped forwards"}, false);
  expectRecovery("clock jumps ahead 30 s");
}

// The robot transform stops: it is stale max_input_age after the last one. The tracker and dovs_node
// starve at the same time, so the first stale input the planner names may be the dovs.
TEST_F(PipelineFaults, MissingRobotTransformStopsTheRobot) {
  driveUntilMoving();
  if (HasFatalFailure()) return;
  world_->send_tf = false;
  ros::WallDuration(0.06).sleep();
  const double stale_at = world_->lastTfWall() + kMaxInputAge;
  expectStop("tf missing", stale_at, {"transform", "dovs"});
  world_->send_tf = true;
  expectRecovery("tf missing");
}

// Odom keeps coming, but stamped 1.5 s in the past (a driver with a stuck clock): stale at once.
TEST_F(PipelineFaults, OdomWithStaleStampsStopsTheRobot) {
  driveUntilMoving();
  if (HasFatalFailure()) return;
  world_->armFaultClocks();
  world_->stale_odom = true;
  ASSERT_TRUE(waitFor([] { return world_->firstStaleOdomWall() > 0.0; }, 1.0));
  expectStop("odom stale stamps", world_->firstStaleOdomWall(), {"odom"});
  world_->stale_odom = false;
  expectRecovery("odom stale stamps");
}

// Every command the planner published during all of the above (faults, clock jumps included) against the
// safety envelope, with the publish stamps it used: feasible, finite, and within a_v * dt, a_w * dt of the
// previous command (dt = the stamps' difference, 0 when the clock went back, capped at 0.1 s). The envelope
// never had to correct the planner's own ramp.
TEST_F(PipelineFaults, PublishedStreamStaysInsideTheSafetyEnvelope) {
  const std::vector<Stamped> s = world_->stamped();
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

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_pipeline_faults");
  const int result = RUN_ALL_TESTS();
  ros::shutdown();
  return result;
}
