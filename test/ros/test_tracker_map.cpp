// Node-level test: obstacle_tracker_node with use_map. The test node publishes the laser at the odom origin, a
// map frame in which odom sits at (-0.3, 0.5) turned by 0.2 rad, and full-turn scans of two still discs: a chair at
// (2, 0) and a box at (-2, 0.5) (odom). Before any map both are tracked; once a latched occupancy grid showing the
// chair (in the map frame) has arrived, the chair is never a track (its outline comes out as segments) and the box
// still is; a malformed grid afterwards is refused and the chair stays untracked.
#include <gtest/gtest.h>
#include <nav_msgs/OccupancyGrid.h>
#include <ros/ros.h>
#include <sensor_msgs/LaserScan.h>
#include <tf2_ros/static_transform_broadcaster.h>

#include <cmath>
#include <map>
#include <mutex>
#include <optional>

#include "dqn_dovs/TrackedObstacleArray.h"
#include "dqn_dovs/common/geometry.h"
#include "fake_robot.h"

namespace {

using dqn_dovs::Pose2;
using dqn_dovs::TrackedObstacleArray;
using dqn_dovs::Vec2;

constexpr double kScanPeriod = 0.1;
constexpr double kRadius = 0.2;
const Vec2 kChair(2.0, 0.0), kBox(-2.0, 0.5);
const Pose2 kOdomInMap{-0.3, 0.5, 0.2};

sensor_msgs::LaserScan discsScan(const ros::Time& stamp) {
  sensor_msgs::LaserScan s = dqn_dovs::test::makeScan(stamp, dqn_dovs::test::fullTurnScan(kScanPeriod), "laser");
  for (size_t i = 0; i < s.ranges.size(); ++i) {
    const double a = s.angle_min + static_cast<double>(i) * static_cast<double>(s.angle_increment);
    for (const Vec2& c : {kChair, kBox}) {
      if (const auto r = dqn_dovs::rayCircle(Vec2::Zero(), Vec2(std::cos(a), std::sin(a)), {c, kRadius})) {
        s.ranges[i] = static_cast<float>(*r);
      }
    }
  }
  return s;
}

/// A 6 x 6 m grid at 5 cm from (-3, -3) in frame map, occupied where the chair stands (a disc of its radius).
nav_msgs::OccupancyGrid chairMap() {
  nav_msgs::OccupancyGrid g;
  g.header.frame_id = "map";
  g.info.resolution = 0.05f;
  g.info.width = g.info.height = 120;
  g.info.origin.position.x = g.info.origin.position.y = -3.0;
  g.info.origin.orientation.w = 1.0;
  g.data.assign(120 * 120, 0);
  const Vec2 chair = kOdomInMap.toWorld(kChair);
  for (int j = 0; j < 120; ++j) {
    for (int i = 0; i < 120; ++i) {
      const Vec2 centre(-3.0 + (i + 0.5) * 0.05, -3.0 + (j + 0.5) * 0.05);
      if ((centre - chair).norm() <= kRadius) g.data[static_cast<size_t>(j) * 120 + i] = 100;
    }
  }
  return g;
}

class TrackerMap : public ::testing::Test {
 protected:
  void SetUp() override {
    scan_pub_ = nh_.advertise<sensor_msgs::LaserScan>("scan", 10);
    map_pub_ = nh_.advertise<nav_msgs::OccupancyGrid>("map", 1, true);
    obstacles_sub_ = nh_.subscribe("obstacles", 50, &TrackerMap::onObstacles, this);
    spinner_.start();
    const ros::Time now = ros::Time::now();
    static_tf_.sendTransform({dqn_dovs::test::planarTransform(now, "odom", "laser", Pose2{}),
                              dqn_dovs::test::planarTransform(now, "map", "odom", kOdomInMap)});
    ASSERT_TRUE(dqn_dovs::test::waitFor(
        [&] { return scan_pub_.getNumSubscribers() > 0 && obstacles_sub_.getNumPublishers() > 0; }, 20.0, 0.05));
  }

  void onObstacles(const TrackedObstacleArray::ConstPtr& msg) {
    std::lock_guard<std::mutex> lock(mutex_);
    received_[msg->header.stamp] = *msg;
  }

  /// 2 s of scans from a fresh time base (the jump resets the tracks, so each run starts clean); the outputs of
  /// its last second.
  std::vector<TrackedObstacleArray> run() {
    base_offset_s_ += 1000.0;
    const ros::Time base = ros::Time::now() + ros::Duration(base_offset_s_);
    std::vector<TrackedObstacleArray> late;
    for (int k = 0; k < 20; ++k) {
      const ros::Time stamp = base + ros::Duration(k * kScanPeriod);
      scan_pub_.publish(discsScan(stamp));
      std::optional<TrackedObstacleArray> out;
      dqn_dovs::test::waitFor(
          [&] {
            std::lock_guard<std::mutex> lock(mutex_);
            const auto it = received_.find(stamp);
            if (it != received_.end()) out = it->second;
            return out.has_value();
          },
          1.0);
      EXPECT_TRUE(out.has_value()) << "no output for scan " << k;
      if (out && k >= 10) late.push_back(*out);
    }
    return late;
  }

  static int tracksNear(const TrackedObstacleArray& a, const Vec2& p) {
    int n = 0;
    for (const auto& o : a.obstacles) n += (Vec2(o.center.x, o.center.y) - p).norm() < 0.3 ? 1 : 0;
    return n;
  }
  static int segmentsNear(const TrackedObstacleArray& a, const Vec2& p) {
    int n = 0;
    for (const auto& s : a.segments) {
      n += (Vec2(s.first_point.x, s.first_point.y) - p).norm() < 0.3 &&
           (Vec2(s.last_point.x, s.last_point.y) - p).norm() < 0.3;
    }
    return n;
  }

  ros::NodeHandle nh_;
  ros::AsyncSpinner spinner_{1};
  ros::Publisher scan_pub_, map_pub_;
  ros::Subscriber obstacles_sub_;
  tf2_ros::StaticTransformBroadcaster static_tf_;
  std::mutex mutex_;
  std::map<ros::Time, TrackedObstacleArray> received_;
  double base_offset_s_ = 0.0;
};

TEST_F(TrackerMap, WhatTheMapShowsIsNeverTrackedWhatItDoesNotStillIs) {
  const auto before = run();
  ASSERT_FALSE(before.empty());
  for (const auto& a : before) {
    EXPECT_EQ(tracksNear(a, kChair), 1) << "without a map the chair is an obstacle like any other";
    EXPECT_EQ(tracksNear(a, kBox), 1);
  }

  map_pub_.publish(chairMap());
  ros::WallDuration(0.5).sleep();  // the latched map reaches the node
  const auto with_map = run();
  ASSERT_FALSE(with_map.empty());
  for (const auto& a : with_map) {
    EXPECT_EQ(tracksNear(a, kChair), 0) << "the map shows the chair: it is structure";
    EXPECT_GE(segmentsNear(a, kChair), 2) << "its outline, seen from the laser, comes out as segments";
    EXPECT_EQ(tracksNear(a, kBox), 1) << "the box is not on the map";
  }

  nav_msgs::OccupancyGrid bad = chairMap();
  bad.data.resize(10);  // fewer cells than width x height
  map_pub_.publish(bad);
  ros::WallDuration(0.5).sleep();
  for (const auto& a : run()) EXPECT_EQ(tracksNear(a, kChair), 0) << "a malformed grid keeps the previous map";
}

}  // namespace

int main(int argc, char** argv) { return dqn_dovs::test::runRostestNode(argc, argv, "test_tracker_map"); }
