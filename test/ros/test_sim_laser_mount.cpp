// Node-level test: simulator_node scans from the LIDAR mount it is given (the robot description's laser link, or
// the lidar/mount_* parameters that override it), and every edge of the TF tree has exactly one publisher.
//
// The robot stands at the origin of the empty 8 x 8 m room (test/data/empty_room.txt) with a noise-free LIDAR, so
// every beam's range is known in closed form from the laser's pose. Parameters of this test node:
//   expected_x, expected_y (m), expected_yaw (rad): the mount the scan must come from;
//   laser_tf_publisher: the node that must publish base_footprint -> laser (on /tf or /tf_static).
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <sensor_msgs/LaserScan.h>
#include <tf2/utils.h>
#include <tf2_msgs/TFMessage.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <tuple>

namespace {

constexpr double kRoomHalfSize = 4.0;

/// Range from (x, y) along `angle` to the walls of the square room |x|, |y| <= kRoomHalfSize.
double rangeToRoomWalls(double x, double y, double angle) {
  const double c = std::cos(angle), s = std::sin(angle);
  double t = 1e9;
  if (c > 1e-12) t = std::min(t, (kRoomHalfSize - x) / c);
  if (c < -1e-12) t = std::min(t, (-kRoomHalfSize - x) / c);
  if (s > 1e-12) t = std::min(t, (kRoomHalfSize - y) / s);
  if (s < -1e-12) t = std::min(t, (-kRoomHalfSize - y) / s);
  return t;
}

/// The largest difference between the scan's finite ranges and those of a laser at (x, y, yaw) in the room.
double worstRangeError(const sensor_msgs::LaserScan& scan, double x, double y, double yaw, int* finite_beams) {
  double worst = 0.0;
  *finite_beams = 0;
  for (size_t i = 0; i < scan.ranges.size(); ++i) {
    if (!std::isfinite(scan.ranges[i])) continue;
    ++*finite_beams;
    const double angle = yaw + scan.angle_min + static_cast<double>(i) * scan.angle_increment;
    worst = std::max(worst, std::abs(scan.ranges[i] - rangeToRoomWalls(x, y, angle)));
  }
  return worst;
}

struct Edge {
  std::string parent, publisher;
  bool operator<(const Edge& o) const { return std::tie(parent, publisher) < std::tie(o.parent, o.publisher); }
};

struct TfRecorder {
  std::mutex mutex;
  std::map<std::string, std::set<Edge>> edges;  // child frame -> (parent, publisher) seen on /tf and /tf_static
  void onTf(const ros::MessageEvent<const tf2_msgs::TFMessage>& event) {
    std::lock_guard<std::mutex> l(mutex);
    for (const auto& t : event.getConstMessage()->transforms) {
      edges[t.child_frame_id].insert({t.header.frame_id, event.getPublisherName()});
    }
  }
};

TEST(SimulatorLaserMount, ScanAndTfComeFromTheMount) {
  ros::NodeHandle nh, pnh("~");
  const double expected_x = pnh.param("expected_x", 0.0);
  const double expected_y = pnh.param("expected_y", 0.0);
  const double expected_yaw = pnh.param("expected_yaw", 0.0);
  const std::string laser_tf_publisher = pnh.param<std::string>("laser_tf_publisher", "/simulator");

  TfRecorder tf_rec;
  auto tf_sub = nh.subscribe("/tf", 200, &TfRecorder::onTf, &tf_rec);
  auto tf_static_sub = nh.subscribe("/tf_static", 20, &TfRecorder::onTf, &tf_rec);
  tf2_ros::Buffer buffer;
  tf2_ros::TransformListener listener(buffer);
  std::mutex scan_mutex;
  std::optional<sensor_msgs::LaserScan> scan;
  int scans = 0;
  auto scan_sub = nh.subscribe<sensor_msgs::LaserScan>("scan", 5, [&](const sensor_msgs::LaserScan::ConstPtr& m) {
    std::lock_guard<std::mutex> l(scan_mutex);
    scan = *m;
    ++scans;
  });
  ros::AsyncSpinner spinner(2);
  spinner.start();
  ASSERT_TRUE(ros::Time::waitForValid(ros::WallDuration(20.0))) << "no /clock from simulator_node";

  // Some scans and two seconds of /tf, so that a second publisher of an edge would have shown up.
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(30.0);
  const ros::WallTime listen_until = ros::WallTime::now() + ros::WallDuration(2.0);
  while (ros::ok() && ros::WallTime::now() < deadline) {
    {
      std::lock_guard<std::mutex> l(scan_mutex);
      if (scans >= 5 && ros::WallTime::now() > listen_until) break;
    }
    ros::WallDuration(0.05).sleep();
  }

  std::string tf_error;
  ASSERT_TRUE(buffer.canTransform("base_footprint", "laser", ros::Time(0), ros::Duration(5.0), &tf_error)) << tf_error;
  const geometry_msgs::TransformStamped mount = buffer.lookupTransform("base_footprint", "laser", ros::Time(0));
  EXPECT_NEAR(mount.transform.translation.x, expected_x, 1e-6);
  EXPECT_NEAR(mount.transform.translation.y, expected_y, 1e-6);
  EXPECT_NEAR(tf2::getYaw(mount.transform.rotation), expected_yaw, 1e-6);

  {
    std::lock_guard<std::mutex> l(scan_mutex);
    ASSERT_TRUE(scan.has_value()) << "no scan from simulator_node";
    EXPECT_EQ(scan->header.frame_id, "laser");
    // The robot stands at the origin facing +x: the laser is at the mount in the room frame.
    int finite = 0;
    const double error = worstRangeError(*scan, expected_x, expected_y, expected_yaw, &finite);
    EXPECT_GT(finite, static_cast<int>(scan->ranges.size()) * 9 / 10) << "most beams must hit a wall";
    EXPECT_LT(error, 1e-3) << "the scan does not come from a laser at (" << expected_x << ", " << expected_y << ", "
                           << expected_yaw << ")";
    // The check can tell: a laser on the base's centre would be off by centimetres.
    int unused = 0;
    EXPECT_GT(worstRangeError(*scan, 0.0, 0.0, 0.0, &unused), 0.05);
  }

  std::lock_guard<std::mutex> l(tf_rec.mutex);
  ASSERT_TRUE(tf_rec.edges.count("laser")) << "nobody publishes the laser frame";
  for (const auto& [child, edges] : tf_rec.edges) {
    std::string seen;
    for (const Edge& e : edges) seen += " " + e.parent + " (by " + e.publisher + ")";
    EXPECT_EQ(edges.size(), 1u) << "frame '" << child << "' has more than one parent or publisher:" << seen;
  }
  const Edge& laser_edge = *tf_rec.edges["laser"].begin();
  EXPECT_EQ(laser_edge.publisher, laser_tf_publisher) << "laser's parent " << laser_edge.parent;
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_sim_laser_mount");
  return RUN_ALL_TESTS();
}
