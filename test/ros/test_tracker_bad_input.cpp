// Node-level test of obstacle_tracker_node against malformed input: scans with NaN/inf/out-of-range beams,
// empty scans, zero or NaN angle increments, bad range limits, unknown frames, repeated stamps and time
// going backwards (a looping bag). The node must stay up, publish nothing for the unusable scans, never
// report a track made of garbage, and track a real disc again right afterwards.
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <sensor_msgs/LaserScan.h>
#include <tf2_ros/static_transform_broadcaster.h>

#include <cmath>
#include <limits>
#include <map>
#include <mutex>
#include <optional>

#include "dqn_dovs/TrackedObstacleArray.h"
#include "dqn_dovs/common/geometry.h"
#include "fake_robot.h"

namespace {

using dqn_dovs::TrackedObstacleArray;
using dqn_dovs::Vec2;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();
// The static laser pose in odom: the tracks must come out in odom, not in the laser frame.
constexpr double kLaserX = 1.0, kLaserY = 2.0, kLaserYaw = 0.3;
constexpr double kDiscRadius = 0.2;
constexpr double kScanPeriod = 0.1;

/// A 360-beam, full-turn scan of one disc (centre given in the laser frame); every other beam is a non-return.
sensor_msgs::LaserScan discScan(const ros::Time& stamp, const Vec2& centre_laser, const std::string& frame = "laser") {
  sensor_msgs::LaserScan s = dqn_dovs::test::makeScan(stamp, dqn_dovs::test::fullTurnScan(kScanPeriod), frame);
  const dqn_dovs::Circle disc{centre_laser, kDiscRadius};
  for (size_t i = 0; i < s.ranges.size(); ++i) {
    const double a = s.angle_min + static_cast<double>(i) * static_cast<double>(s.angle_increment);
    if (const auto r = dqn_dovs::rayCircle(Vec2::Zero(), Vec2(std::cos(a), std::sin(a)), disc)) {
      s.ranges[i] = static_cast<float>(*r);
    }
  }
  return s;
}

/// The disc's centre in the laser frame at time t (s) of a run: walking across at 0.5 m/s, 2 m ahead.
Vec2 discAt(double t) { return Vec2(2.0, -0.6 + 0.5 * t); }

Vec2 laserToOdom(const Vec2& p) {
  const double c = std::cos(kLaserYaw), s = std::sin(kLaserYaw);
  return Vec2(kLaserX + c * p.x() - s * p.y(), kLaserY + s * p.x() + c * p.y());
}

class TrackerBadInput : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    nh_ = new ros::NodeHandle;
    scan_pub_ = new ros::Publisher(nh_->advertise<sensor_msgs::LaserScan>("scan", 10));
    obstacles_sub_ = new ros::Subscriber(nh_->subscribe("obstacles", 50, &TrackerBadInput::onObstacles));
    spinner_ = new ros::AsyncSpinner(1);
    spinner_->start();
    broadcaster_ = new tf2_ros::StaticTransformBroadcaster;
    geometry_msgs::TransformStamped t;
    t.header.stamp = ros::Time::now();
    t.header.frame_id = "odom";
    t.child_frame_id = "laser";
    t.transform.translation.x = kLaserX;
    t.transform.translation.y = kLaserY;
    t.transform.rotation.z = std::sin(kLaserYaw / 2.0);
    t.transform.rotation.w = std::cos(kLaserYaw / 2.0);
    broadcaster_->sendTransform(t);
    dqn_dovs::test::waitFor([] { return scan_pub_->getNumSubscribers() > 0 && obstacles_sub_->getNumPublishers() > 0; },
                            20.0, 0.05);
  }

  static void TearDownTestSuite() {
    spinner_->stop();
    delete spinner_;
    delete broadcaster_;
    delete obstacles_sub_;
    delete scan_pub_;
    delete nh_;
  }

  static void onObstacles(const TrackedObstacleArray::ConstPtr& msg) {
    std::lock_guard<std::mutex> lock(mutex_);
    received_[msg->header.stamp] = *msg;
  }

  /// Publishes `scan` and waits for the tracker's output with the scan's stamp (nullopt after `wait_s`).
  static std::optional<TrackedObstacleArray> send(const sensor_msgs::LaserScan& scan, double wait_s = 1.0) {
    scan_pub_->publish(scan);
    std::optional<TrackedObstacleArray> out;
    dqn_dovs::test::waitFor(
        [&] {
          std::lock_guard<std::mutex> lock(mutex_);
          const auto it = received_.find(scan.header.stamp);
          if (it != received_.end()) out = it->second;
          return out.has_value();
        },
        wait_s);
    return out;
  }

  /// A fresh time base far from every earlier one: the tracker resets on the jump, so tests do not interact.
  static ros::Time freshBase() {
    base_offset_s_ += 1000.0;
    return ros::Time::now() + ros::Duration(base_offset_s_);
  }

  /// Good scans of the walking disc for t in [t0, t0 + n * period); returns the last output.
  static TrackedObstacleArray runGood(const ros::Time& base, double t0, int n) {
    TrackedObstacleArray last;
    for (int k = 0; k < n; ++k) {
      const double t = t0 + k * kScanPeriod;
      const auto out = send(discScan(base + ros::Duration(t), discAt(t)));
      EXPECT_TRUE(out.has_value()) << "no output for a good scan at t = " << t << " s: is the node still up?";
      if (out) last = *out;
    }
    return last;
  }

  static ros::NodeHandle* nh_;
  static ros::Publisher* scan_pub_;
  static ros::Subscriber* obstacles_sub_;
  static ros::AsyncSpinner* spinner_;
  static tf2_ros::StaticTransformBroadcaster* broadcaster_;
  static std::mutex mutex_;
  static std::map<ros::Time, TrackedObstacleArray> received_;
  static double base_offset_s_;
};

ros::NodeHandle* TrackerBadInput::nh_ = nullptr;
ros::Publisher* TrackerBadInput::scan_pub_ = nullptr;
ros::Subscriber* TrackerBadInput::obstacles_sub_ = nullptr;
ros::AsyncSpinner* TrackerBadInput::spinner_ = nullptr;
tf2_ros::StaticTransformBroadcaster* TrackerBadInput::broadcaster_ = nullptr;
std::mutex TrackerBadInput::mutex_;
std::map<ros::Time, TrackedObstacleArray> TrackerBadInput::received_;
double TrackerBadInput::base_offset_s_ = 0.0;

// The harness itself: good scans give one confirmed track at the right place in odom. Without this the
// "no track" checks below could pass on a tracker that never tracks anything.
TEST_F(TrackerBadInput, GoodScansGiveOneTrackInTheFixedFrame) {
  ASSERT_GT(scan_pub_->getNumSubscribers(), 0u) << "obstacle_tracker_node is not subscribed to scan";
  const ros::Time base = freshBase();
  const TrackedObstacleArray last = runGood(base, 0.0, 8);
  EXPECT_EQ(last.header.frame_id, "odom");
  ASSERT_EQ(last.obstacles.size(), 1u);
  const Vec2 truth = laserToOdom(discAt(0.7));
  EXPECT_NEAR(last.obstacles[0].center.x, truth.x(), 0.1);
  EXPECT_NEAR(last.obstacles[0].center.y, truth.y(), 0.1);
  EXPECT_NEAR(last.obstacles[0].radius, kDiscRadius, 0.08);
  EXPECT_NEAR(last.obstacles[0].speed, 0.5, 0.3);
}

// Beams that are NaN, +-inf, negative, below range_min or above range_max are ignored: the scan is used
// (the output flows) but no obstacle, track or segment comes out of them, however often they repeat.
TEST_F(TrackerBadInput, InvalidBeamsNeverMakeATrack) {
  const ros::Time base = freshBase();
  double t = 0.0;
  auto next = [&](sensor_msgs::LaserScan s) {
    s.header.stamp = base + ros::Duration(t);
    t += kScanPeriod;
    return s;
  };
  for (int k = 0; k < 6; ++k) {
    for (const double bad : {kNaN, kInf, -kInf, -1.0}) {
      sensor_msgs::LaserScan s = next(discScan(base, discAt(t)));
      for (auto& r : s.ranges) r = static_cast<float>(bad);
      const auto out = send(s);
      ASSERT_TRUE(out.has_value()) << "a scan of " << bad << " beams must be used (and give nothing)";
      EXPECT_TRUE(out->obstacles.empty()) << "phantom track from " << bad << " beams";
      EXPECT_TRUE(out->segments.empty());
    }
    // The disc's returns fall outside [range_min, range_max]: a real-looking pattern that must be ignored.
    sensor_msgs::LaserScan below = next(discScan(base, discAt(t)));
    below.range_min = 3.0f;
    sensor_msgs::LaserScan above = next(discScan(base, discAt(t)));
    above.range_max = 1.5f;
    for (const auto& s : {below, above}) {
      const auto out = send(s);
      ASSERT_TRUE(out.has_value());
      EXPECT_TRUE(out->obstacles.empty()) << "phantom track from returns outside the range limits";
    }
  }
}

// Scans that cannot be used at all are dropped (nothing published for them) and leave no trace: the first
// good scan afterwards is the disc's first hit, so no confirmed track can exist yet.
TEST_F(TrackerBadInput, MalformedScansAreDroppedWithoutATrace) {
  const ros::Time base = freshBase();
  int dropped = 0;
  for (int k = 0; k < 5; ++k) {
    const double t = 0.1 * k;
    const ros::Time stamp = base + ros::Duration(t);
    std::vector<std::pair<std::string, sensor_msgs::LaserScan>> bad;
    auto add = [&](const std::string& what, const auto& modify) {
      sensor_msgs::LaserScan s = discScan(stamp, discAt(t));
      // Unique stamps so that an output can be told apart from the others.
      s.header.stamp = stamp + ros::Duration(1e-4 * static_cast<double>(bad.size()));
      modify(s);
      bad.emplace_back(what, s);
    };
    add("empty ranges", [](sensor_msgs::LaserScan& s) { s.ranges.clear(); });
    add("zero angle_increment", [](sensor_msgs::LaserScan& s) { s.angle_increment = 0.0f; });
    add("NaN angle_increment", [](sensor_msgs::LaserScan& s) { s.angle_increment = static_cast<float>(kNaN); });
    add("inf angle_min", [](sensor_msgs::LaserScan& s) { s.angle_min = static_cast<float>(kInf); });
    add("range_min >= range_max", [](sensor_msgs::LaserScan& s) { s.range_min = 12.0f; });
    add("inf range_max", [](sensor_msgs::LaserScan& s) { s.range_max = static_cast<float>(kInf); });
    add("more than one turn", [](sensor_msgs::LaserScan& s) { s.angle_increment *= 2.0f; });
    add("empty frame_id", [](sensor_msgs::LaserScan& s) { s.header.frame_id.clear(); });
    add("unknown frame_id", [](sensor_msgs::LaserScan& s) { s.header.frame_id = "no_such_frame"; });
    for (size_t i = 0; i < bad.size(); ++i) {
      // The all-inf marker right behind the bad scan is used (it has nothing in it): once its output is here,
      // the bad scan before it has been handled too (one connection, handled in order).
      sensor_msgs::LaserScan marker = discScan(stamp + ros::Duration(0.002 + 1e-4 * static_cast<double>(i)), discAt(t));
      for (auto& r : marker.ranges) r = std::numeric_limits<float>::infinity();
      scan_pub_->publish(bad[i].second);
      const auto marker_out = send(marker);
      ASSERT_TRUE(marker_out.has_value()) << "no output after a scan with " << bad[i].first << ": is the node up?";
      EXPECT_TRUE(marker_out->obstacles.empty()) << "a track appeared after a scan with " << bad[i].first;
      std::lock_guard<std::mutex> lock(mutex_);
      const bool published = received_.count(bad[i].second.header.stamp) > 0;
      EXPECT_FALSE(published) << "a scan with " << bad[i].first << " must be dropped, yet an output came";
      if (!published) ++dropped;
    }
  }
  EXPECT_EQ(dropped, 45);
  // Recovery: good scans are tracked again; the disc needs its confirm_hits (3) before it is reported.
  const ros::Time good = base + ros::Duration(10.0);
  const auto first = send(discScan(good, discAt(0.0)));
  ASSERT_TRUE(first.has_value()) << "obstacle_tracker_node stopped publishing after malformed scans";
  EXPECT_TRUE(first->obstacles.empty()) << "a track was confirmed from dropped scans";
  const TrackedObstacleArray last = runGood(good, 0.1, 5);
  ASSERT_EQ(last.obstacles.size(), 1u) << "the tracker did not recover";
}

// A repeated stamp is one measurement used twice: dropped.
TEST_F(TrackerBadInput, RepeatedStampIsDropped) {
  const ros::Time base = freshBase();
  runGood(base, 0.0, 4);
  sensor_msgs::LaserScan again = discScan(base + ros::Duration(0.3), discAt(0.3));
  {
    std::lock_guard<std::mutex> lock(mutex_);
    received_.erase(again.header.stamp);
  }
  EXPECT_FALSE(send(again, 0.4).has_value());
  const TrackedObstacleArray after = runGood(base, 0.4, 2);
  EXPECT_EQ(after.obstacles.size(), 1u);
}

// A bag that loops: stamps jump back by the bag's length. The tracks are reset (no track survives into the
// past, none is reported before it is confirmed again) and the new track gets a new id.
TEST_F(TrackerBadInput, TimeGoingBackwardsResetsTracks) {
  const ros::Time base = freshBase();
  const TrackedObstacleArray before = runGood(base, 0.0, 10);
  ASSERT_EQ(before.obstacles.size(), 1u);
  const int old_id = before.obstacles[0].id;
  // The same scans again, as a looping bag replays them (stamps 1 s earlier than the last one).
  const ros::Time looped = base + ros::Duration(-0.05);
  const auto first = send(discScan(looped, discAt(0.0)));
  ASSERT_TRUE(first.has_value()) << "after time went backwards the scan must be used (tracks reset)";
  EXPECT_TRUE(first->obstacles.empty()) << "a track survived time going backwards";
  const auto second = send(discScan(looped + ros::Duration(0.1), discAt(0.1)));
  ASSERT_TRUE(second.has_value());
  EXPECT_TRUE(second->obstacles.empty()) << "a track was reported before its confirm_hits";
  const TrackedObstacleArray after = runGood(looped, 0.2, 6);
  ASSERT_EQ(after.obstacles.size(), 1u);
  EXPECT_NE(after.obstacles[0].id, old_id) << "track ids must never be reused";
  EXPECT_NEAR(after.obstacles[0].speed, 0.5, 0.3) << "the velocity must come from the new scans only";
}

}  // namespace

int main(int argc, char** argv) { return dqn_dovs::test::runRostestNode(argc, argv, "test_tracker_bad_input"); }
