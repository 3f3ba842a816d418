// Node-level test: with odometry/level high and map_frame set, simulator_node's odom -> base_footprint (and /odom)
// is the drifting wheel odometry while map -> odom makes map -> base_footprint the truth (ground_truth/odom).
// The test drives the robot on an arc in the empty room for `drive_time` simulated seconds.
#include <geometry_msgs/Twist.h>
#include <gtest/gtest.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <tf2/utils.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <mutex>
#include <optional>
#include <string>

#include "dqn_dovs/SimStatus.h"
#include "dqn_dovs/TrackedObstacleArray.h"

namespace {

struct Pose {
  double x, y, yaw;
};

Pose poseOf(const geometry_msgs::Pose& p) { return {p.position.x, p.position.y, tf2::getYaw(p.orientation)}; }
Pose poseOf(const geometry_msgs::TransformStamped& t) {
  return {t.transform.translation.x, t.transform.translation.y, tf2::getYaw(t.transform.rotation)};
}
double angleDiff(double a, double b) { return std::abs(std::remainder(a - b, 2.0 * M_PI)); }
double distance(const Pose& a, const Pose& b) { return std::hypot(a.x - b.x, a.y - b.y); }

struct Recorder {
  std::mutex mutex;
  std::map<double, nav_msgs::Odometry> truth, odom;  // by stamp
  std::string obstacles_frame, status_frame;
  void onTruth(const nav_msgs::Odometry::ConstPtr& m) {
    std::lock_guard<std::mutex> l(mutex);
    truth[m->header.stamp.toSec()] = *m;
  }
  void onOdom(const nav_msgs::Odometry::ConstPtr& m) {
    std::lock_guard<std::mutex> l(mutex);
    odom[m->header.stamp.toSec()] = *m;
  }
  void onObstacles(const dqn_dovs::TrackedObstacleArray::ConstPtr& m) {
    std::lock_guard<std::mutex> l(mutex);
    obstacles_frame = m->header.frame_id;
  }
  void onStatus(const dqn_dovs::SimStatus::ConstPtr& m) {
    std::lock_guard<std::mutex> l(mutex);
    status_frame = m->header.frame_id;
  }
};

TEST(SimulatorOdometry, OdomDriftsAndMapToBaseIsTheTruth) {
  ros::NodeHandle nh, pnh("~");
  const double drive_time = pnh.param("drive_time", 12.0);
  Recorder rec;
  auto truth_sub = nh.subscribe("ground_truth/odom", 500, &Recorder::onTruth, &rec);
  auto odom_sub = nh.subscribe("odom", 500, &Recorder::onOdom, &rec);
  auto obstacles_sub = nh.subscribe("ground_truth/obstacles", 5, &Recorder::onObstacles, &rec);
  auto status_sub = nh.subscribe("sim/status", 5, &Recorder::onStatus, &rec);
  auto cmd_pub = nh.advertise<geometry_msgs::Twist>("cmd_vel", 5);
  tf2_ros::Buffer buffer(ros::Duration(120.0));
  tf2_ros::TransformListener listener(buffer);
  ros::AsyncSpinner spinner(2);
  spinner.start();
  ASSERT_TRUE(ros::Time::waitForValid(ros::WallDuration(20.0))) << "no /clock from simulator_node";
  ros::WallDuration(1.0).sleep();  // the subscriptions connect while the robot stands at its start

  // An arc of radius 1.5 m about (0, 1.5): it stays inside the empty 8 x 8 m room.
  const ros::Time start = ros::Time::now();
  const ros::WallTime wall_deadline = ros::WallTime::now() + ros::WallDuration(drive_time * 3.0 + 20.0);
  while (ros::ok() && ros::Time::now() - start < ros::Duration(drive_time) && ros::WallTime::now() < wall_deadline) {
    geometry_msgs::Twist cmd;
    cmd.linear.x = 0.45;
    cmd.angular.z = 0.3;
    cmd_pub.publish(cmd);
    ros::WallDuration(0.02).sleep();
  }
  ros::WallDuration(0.5).sleep();
  spinner.stop();

  std::lock_guard<std::mutex> l(rec.mutex);
  ASSERT_GT(rec.truth.size(), 20u) << "too few ground_truth/odom messages";
  const nav_msgs::Odometry& first = rec.truth.begin()->second;
  const nav_msgs::Odometry& last = rec.truth.rbegin()->second;
  EXPECT_EQ(last.header.frame_id, "map");
  EXPECT_EQ(rec.obstacles_frame, "map");
  EXPECT_EQ(rec.status_frame, "map");
  const Pose truth_start = poseOf(first.pose.pose), truth_end = poseOf(last.pose.pose);
  ASSERT_GT(distance(truth_start, truth_end), 1.0) << "the robot did not move";

  // At the start the odometry is the truth: map -> odom is the identity.
  const geometry_msgs::TransformStamped map_odom_start =
      buffer.lookupTransform("map", "odom", first.header.stamp, ros::Duration(1.0));
  const Pose start_offset = poseOf(map_odom_start);
  EXPECT_LT(std::hypot(start_offset.x, start_offset.y), 1e-9);
  EXPECT_LT(std::abs(start_offset.yaw), 1e-9);

  // After driving: map -> base_footprint is the truth, odom -> base_footprint (and /odom) is not.
  const ros::Time t = last.header.stamp;
  const Pose map_base = poseOf(buffer.lookupTransform("map", "base_footprint", t, ros::Duration(1.0)));
  EXPECT_LT(distance(map_base, truth_end), 1e-6) << "map -> base_footprint is not the ground truth";
  EXPECT_LT(angleDiff(map_base.yaw, truth_end.yaw), 1e-6);

  const Pose map_odom = poseOf(buffer.lookupTransform("map", "odom", t, ros::Duration(1.0)));
  EXPECT_GT(std::hypot(map_odom.x, map_odom.y) + std::abs(map_odom.yaw), 0.02)
      << "map -> odom is still the identity after " << drive_time << " s of driving with high odometry drift";

  const Pose odom_base = poseOf(buffer.lookupTransform("odom", "base_footprint", t, ros::Duration(1.0)));
  EXPECT_GT(distance(odom_base, truth_end) + angleDiff(odom_base.yaw, truth_end.yaw), 0.02)
      << "odom -> base_footprint is the truth: the odometry does not drift";
  const auto odom_at_t = rec.odom.find(t.toSec());
  ASSERT_NE(odom_at_t, rec.odom.end()) << "no /odom with the stamp of the last ground truth";
  EXPECT_EQ(odom_at_t->second.header.frame_id, "odom");
  const Pose odom_msg = poseOf(odom_at_t->second.pose.pose);
  EXPECT_LT(distance(odom_msg, odom_base), 1e-6) << "/odom and odom -> base_footprint disagree";
  std::printf("drift after %.1f s: map -> odom (%.4f m, %.4f m, %.4f rad)\n", drive_time, map_odom.x, map_odom.y,
              map_odom.yaw);
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_sim_odometry");
  return RUN_ALL_TESTS();
}
