// Node-level test: dovs_node with use_map. The test node plays the robot (tf odom -> base_footprint, odom,
// empty obstacle lists from the tracker) and publishes a latched occupancy grid in frame `map`, which sits
// 0.3 m along x from odom: the map's wall at x = 0.3 m must appear in the Dovs message's static geometry (the
// walls within braking reach) at x = 0.6 m in odom, and only after the map arrives.
#include <geometry_msgs/TransformStamped.h>
#include <gtest/gtest.h>
#include <nav_msgs/OccupancyGrid.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <tf2_ros/transform_broadcaster.h>

#include <cmath>
#include <mutex>
#include <optional>

#include "dqn_dovs/Dovs.h"
#include "dqn_dovs/TrackedObstacleArray.h"
#include "fake_robot.h"

namespace {

/// A 4 x 4 m grid at 0.1 m from (-2, -2) in `frame`, free but for a wall one cell thick at x in [0.3, 0.4).
nav_msgs::OccupancyGrid wallMap(const std::string& frame) {
  nav_msgs::OccupancyGrid g;
  g.header.frame_id = frame;
  g.info.resolution = 0.1f;
  g.info.width = 40;
  g.info.height = 40;
  g.info.origin.position.x = -2.0;
  g.info.origin.position.y = -2.0;
  g.info.origin.orientation.w = 1.0;
  g.data.assign(40 * 40, 0);
  for (int j = 0; j < 40; ++j) g.data[static_cast<size_t>(j) * 40 + 23] = 100;  // column 23: x in [0.3, 0.4)
  return g;
}

class DovsMap : public ::testing::Test {
 protected:
  void SetUp() override {
    dovs_sub_ = nh_.subscribe("dovs", 10, &DovsMap::onDovs, this);
    obstacles_pub_ = nh_.advertise<dqn_dovs::TrackedObstacleArray>("obstacles", 5);
    odom_pub_ = nh_.advertise<nav_msgs::Odometry>("odom", 5);
    map_pub_ = nh_.advertise<nav_msgs::OccupancyGrid>("map", 1, true);
    geometry_msgs::TransformStamped map_to_odom;
    map_to_odom.header.stamp = ros::Time::now();
    map_to_odom.header.frame_id = "map";
    map_to_odom.child_frame_id = "odom";
    map_to_odom.transform.translation.x = -0.3;  // odom's origin sits at x = -0.3 in map: map x = odom x - 0.3
    map_to_odom.transform.rotation.w = 1.0;
    static_tf_.sendTransform(map_to_odom);
  }

  /// One period of the robot at the odom origin: tf, odom, an empty obstacle list (no segments from the scan).
  void publishRobot() {
    const ros::Time now = ros::Time::now();
    dqn_dovs::test::publishStandingRobot(tf_, odom_pub_, now);
    ros::WallDuration(0.02).sleep();
    dqn_dovs::TrackedObstacleArray a;
    a.header.stamp = now;
    a.header.frame_id = "odom";
    obstacles_pub_.publish(a);
  }

  /// Runs the robot for `seconds` and returns the last Dovs message received in that time.
  std::optional<dqn_dovs::Dovs> runFor(double seconds) {
    {
      std::lock_guard<std::mutex> l(mutex_);
      last_.reset();
    }
    const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(seconds);
    while (ros::ok() && ros::WallTime::now() < end) {
      publishRobot();
      ros::WallDuration(0.08).sleep();
    }
    std::lock_guard<std::mutex> l(mutex_);
    return last_;
  }

  void onDovs(const dqn_dovs::Dovs::ConstPtr& m) {
    std::lock_guard<std::mutex> l(mutex_);
    last_ = *m;
  }

  /// Segments of the message (x1 y1 x2 y2) lying on the line x = x0 within 5 cm.
  static int segmentsAtX(const dqn_dovs::Dovs& d, double x0) {
    int n = 0;
    for (size_t k = 0; k + 3 < d.static_segments.size(); k += 4) {
      if (std::abs(d.static_segments[k] - x0) < 0.05 && std::abs(d.static_segments[k + 2] - x0) < 0.05) ++n;
    }
    return n;
  }

  ros::NodeHandle nh_;
  ros::Subscriber dovs_sub_;
  ros::Publisher obstacles_pub_, odom_pub_, map_pub_;
  tf2_ros::TransformBroadcaster tf_;
  tf2_ros::StaticTransformBroadcaster static_tf_;
  std::mutex mutex_;
  std::optional<dqn_dovs::Dovs> last_;
};

TEST_F(DovsMap, MapWallsJoinTheStaticGeometryInTheFixedFrame) {
  ros::AsyncSpinner spinner(1);
  spinner.start();
  const auto before = runFor(2.0);
  ASSERT_TRUE(before.has_value()) << "dovs_node published nothing";
  EXPECT_EQ(segmentsAtX(*before, 0.6), 0) << "no map yet: no wall at x = 0.6";

  map_pub_.publish(wallMap("map"));
  const auto with = runFor(2.0);
  ASSERT_TRUE(with.has_value());
  EXPECT_EQ(with->static_frame, "odom");
  EXPECT_GE(segmentsAtX(*with, 0.6), 1) << "the map's wall at x = 0.3 in map is at x = 0.6 in odom";
  EXPECT_EQ(segmentsAtX(*with, 0.3), 0) << "the map -> odom transform was not applied";

  // A malformed grid (data size not width x height) is refused; the previous map's walls stay.
  nav_msgs::OccupancyGrid bad = wallMap("map");
  bad.data.resize(10);
  map_pub_.publish(bad);
  const auto after = runFor(1.5);
  ASSERT_TRUE(after.has_value());
  EXPECT_GE(segmentsAtX(*after, 0.6), 1);
  spinner.stop();
}

}  // namespace

int main(int argc, char** argv) { return dqn_dovs::test::runRostestNode(argc, argv, "test_dovs_map"); }
