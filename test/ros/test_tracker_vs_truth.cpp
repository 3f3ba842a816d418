// Node-level test: the tracker's output, fed by the simulator's LIDAR, agrees with the simulator's truth.
#include <geometry_msgs/Twist.h>
#include <gtest/gtest.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <mutex>
#include <vector>

#include "dqn_dovs/TrackedObstacleArray.h"

namespace {

struct Recorder {
  std::mutex mutex;
  std::map<double, dqn_dovs::TrackedObstacleArray> truth;  // by stamp
  std::vector<dqn_dovs::TrackedObstacleArray> tracks;
  nav_msgs::Odometry odom;
  bool have_odom = false;
  void onTruth(const dqn_dovs::TrackedObstacleArray::ConstPtr& m) {
    std::lock_guard<std::mutex> l(mutex);
    truth[m->header.stamp.toSec()] = *m;
  }
  void onTracks(const dqn_dovs::TrackedObstacleArray::ConstPtr& m) {
    std::lock_guard<std::mutex> l(mutex);
    tracks.push_back(*m);
  }
  void onOdom(const nav_msgs::Odometry::ConstPtr& m) {
    std::lock_guard<std::mutex> l(mutex);
    odom = *m;
    have_odom = true;
  }
};

TEST(TrackerNode, TracksMatchGroundTruthWhileTheRobotMoves) {
  ros::NodeHandle nh, pnh("~");
  const double duration = pnh.param("duration", 15.0);
  Recorder rec;
  auto truth_sub = nh.subscribe("ground_truth/obstacles", 50, &Recorder::onTruth, &rec);
  auto tracks_sub = nh.subscribe("obstacles", 50, &Recorder::onTracks, &rec);
  auto odom_sub = nh.subscribe("odom", 50, &Recorder::onOdom, &rec);
  auto cmd_pub = nh.advertise<geometry_msgs::Twist>("cmd_vel", 5);

  ros::AsyncSpinner spinner(2);
  spinner.start();
  ASSERT_TRUE(ros::Time::waitForValid(ros::WallDuration(20.0))) << "no /clock from simulator_node";
  const ros::Time start = ros::Time::now();
  ros::WallTime wall_deadline = ros::WallTime::now() + ros::WallDuration(duration * 4 + 30.0);
  while (ros::ok() && ros::Time::now() - start < ros::Duration(duration) && ros::WallTime::now() < wall_deadline) {
    geometry_msgs::Twist cmd;
    cmd.linear.x = 0.3;  // a slow arc keeps the robot moving, so ego-motion must not leak into tracks
    cmd.angular.z = 0.25;
    cmd_pub.publish(cmd);
    ros::WallDuration(0.02).sleep();
  }
  spinner.stop();

  std::lock_guard<std::mutex> l(rec.mutex);
  ASSERT_GT(rec.tracks.size(), 50u) << "too few obstacle messages from obstacle_tracker_node";
  ASSERT_TRUE(rec.have_odom);
  EXPECT_GT(rec.odom.twist.twist.linear.x, 0.2) << "the robot did not move";

  double sq_pos = 0.0, sq_speed = 0.0;
  int matched = 0, matched_for_speed = 0, truths_near = 0, truths_found = 0;
  for (const auto& tr : rec.tracks) {
    EXPECT_EQ(tr.header.frame_id, "odom");
    auto it = rec.truth.find(tr.header.stamp.toSec());
    if (it == rec.truth.end()) continue;
    for (const auto& g : it->second.obstacles) {
      double best = 1e9;
      const dqn_dovs::ObstacleTrack* best_track = nullptr;
      for (const auto& t : tr.obstacles) {
        const double d = std::hypot(t.center.x - g.center.x, t.center.y - g.center.y);
        if (d < best) {
          best = d;
          best_track = &t;
        }
      }
      const bool near_robot =
          std::hypot(g.center.x - rec.odom.pose.pose.position.x, g.center.y - rec.odom.pose.pose.position.y) < 3.0;
      if (near_robot) ++truths_near;
      if (!best_track || best > 0.5) continue;
      if (near_robot) ++truths_found;
      sq_pos += best * best;
      ++matched;
      if (best_track->age > 1.0 && g.speed > 0.1) {
        sq_speed += std::pow(best_track->speed - g.speed, 2);
        ++matched_for_speed;
      }
    }
    for (const auto& t : tr.obstacles) {
      EXPECT_TRUE(std::isfinite(t.center.x) && std::isfinite(t.center.y) && std::isfinite(t.speed));
      EXPECT_GT(t.radius, 0.0);
      EXPECT_LT(t.radius, 0.7) << "a wall must never become a circle";
    }
  }
  ASSERT_GT(matched, 100) << "tracks were not matched to ground truth";
  const double pos_rmse = std::sqrt(sq_pos / matched);
  EXPECT_LT(pos_rmse, 0.08) << "position RMSE " << pos_rmse;
  ASSERT_GT(matched_for_speed, 20);
  const double speed_rmse = std::sqrt(sq_speed / matched_for_speed);
  EXPECT_LT(speed_rmse, 0.2) << "speed RMSE " << speed_rmse;
  // Most obstacles near the robot are tracked (some are occluded by others).
  ASSERT_GT(truths_near, 0);
  EXPECT_GT(static_cast<double>(truths_found) / truths_near, 0.6);
  RecordProperty("pos_rmse_m", std::to_string(pos_rmse));
  RecordProperty("speed_rmse_mps", std::to_string(speed_rmse));
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_tracker_vs_truth");
  return RUN_ALL_TESTS();
}
