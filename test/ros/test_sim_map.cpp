// Node-level test: sim.launch in a building world with people publishes the map a robot would be given of it, and
// the pipeline uses it as on the robot:
//   - the simulator's latched `map` is in the room frame ('map', odometry drifting from it), holds the furniture
//     (every still ground-truth obstacle's centre is an occupied cell) and never a person (every moving one's centre
//     is free), and the robot stands on a free cell;
//   - the planner plans its route on it: planner/route runs from near the robot's start to the scenario's goal;
//   - with tracker_map the tracker never reports a track on a piece of furniture (centres compared in 'map'
//     through the drifting map -> odom), while it does report the people;
//   - the robot drives (the velocity space with the map's walls, dovs_map, keeps the pipeline going).
#include <geometry_msgs/PoseStamped.h>
#include <gtest/gtest.h>
#include <nav_msgs/OccupancyGrid.h>
#include <nav_msgs/Odometry.h>
#include <nav_msgs/Path.h>
#include <ros/ros.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <algorithm>
#include <cmath>
#include <mutex>
#include <optional>
#include <vector>

#include "dqn_dovs/TrackedObstacleArray.h"

namespace {

struct Record {
  std::mutex mutex;
  std::optional<nav_msgs::OccupancyGrid> map;
  std::optional<nav_msgs::Path> route;
  std::optional<geometry_msgs::PoseStamped> goal;
  std::vector<nav_msgs::Odometry> truth_odom;
  std::vector<dqn_dovs::TrackedObstacleArray> truth;
  std::vector<dqn_dovs::TrackedObstacleArray> tracks;
};

// The value of the map cell holding (x, y) of the map's frame; -2 outside the grid.
int cellAt(const nav_msgs::OccupancyGrid& map, double x, double y) {
  const auto& info = map.info;
  const int i = static_cast<int>(std::floor((x - info.origin.position.x) / info.resolution));
  const int j = static_cast<int>(std::floor((y - info.origin.position.y) / info.resolution));
  if (i < 0 || j < 0 || i >= static_cast<int>(info.width) || j >= static_cast<int>(info.height)) return -2;
  return map.data[static_cast<size_t>(j) * info.width + i];
}

TEST(SimulatorMap, TheWorldsMapReachesThePlannerTheTrackerAndTheVelocitySpace) {
  ros::NodeHandle nh;
  Record rec;
  tf2_ros::Buffer tf_buffer(ros::Duration(60.0));
  tf2_ros::TransformListener tf_listener(tf_buffer);
  auto keep = [&rec](auto& slot) {
    return [&rec, &slot](const auto& m) {
      std::lock_guard<std::mutex> l(rec.mutex);
      slot = *m;
    };
  };
  auto append = [&rec](auto& list) {
    return [&rec, &list](const auto& m) {
      std::lock_guard<std::mutex> l(rec.mutex);
      list.push_back(*m);
    };
  };
  ros::Subscriber s1 = nh.subscribe<nav_msgs::OccupancyGrid>("map", 1, keep(rec.map));
  ros::Subscriber s2 = nh.subscribe<nav_msgs::Path>("planner/route", 1, keep(rec.route));
  ros::Subscriber s3 = nh.subscribe<geometry_msgs::PoseStamped>("move_base_simple/goal", 1, keep(rec.goal));
  ros::Subscriber s4 = nh.subscribe<nav_msgs::Odometry>("ground_truth/odom", 50, append(rec.truth_odom));
  ros::Subscriber s5 = nh.subscribe<dqn_dovs::TrackedObstacleArray>("ground_truth/obstacles", 50, append(rec.truth));
  ros::Subscriber s6 = nh.subscribe<dqn_dovs::TrackedObstacleArray>("obstacles", 50, append(rec.tracks));
  ros::AsyncSpinner spinner(2);
  spinner.start();
  ASSERT_TRUE(ros::Time::waitForValid(ros::WallDuration(30.0))) << "no /clock from simulator_node";
  const ros::Time start = ros::Time::now();
  const double sim_seconds = ros::NodeHandle("~").param("sim_seconds", 8.0);
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(120.0);
  while (ros::ok() && ros::WallTime::now() < deadline && (ros::Time::now() - start).toSec() < sim_seconds) {
    ros::WallDuration(0.05).sleep();
  }
  spinner.stop();
  std::lock_guard<std::mutex> l(rec.mutex);

  ASSERT_TRUE(rec.map) << "no map from the simulator";
  const nav_msgs::OccupancyGrid& map = *rec.map;
  EXPECT_EQ(map.header.frame_id, "map") << "the map lies in the room frame, not in drifting odom";
  EXPECT_NEAR(map.info.resolution, 0.05, 1e-6);
  size_t occupied = 0;
  for (const int8_t v : map.data) {
    ASSERT_TRUE(v == 0 || v == 100) << "a known world's map has free and occupied cells only, got " << int(v);
    occupied += v == 100;
  }
  EXPECT_GT(occupied, map.data.size() / 100) << "hardly any walls in the map";
  EXPECT_LT(occupied, map.data.size() / 2);

  ASSERT_FALSE(rec.truth.empty()) << "no ground truth";
  const dqn_dovs::TrackedObstacleArray& first = rec.truth.front();
  ASSERT_EQ(first.header.frame_id, "map");
  std::vector<std::pair<double, double>> furniture;
  int people = 0;
  for (const auto& o : first.obstacles) {
    if (o.is_static) {
      furniture.emplace_back(o.center.x, o.center.y);
      EXPECT_EQ(cellAt(map, o.center.x, o.center.y), 100)
          << "a piece of furniture at (" << o.center.x << ", " << o.center.y << ") is not in the map";
    } else {
      ++people;
      EXPECT_EQ(cellAt(map, o.center.x, o.center.y), 0)
          << "a person at (" << o.center.x << ", " << o.center.y << ") is in the map";
    }
  }
  ASSERT_FALSE(furniture.empty()) << "the clutter world has no furniture";
  ASSERT_GT(people, 0);
  ASSERT_FALSE(rec.truth_odom.empty());
  const auto& p0 = rec.truth_odom.front().pose.pose.position;
  EXPECT_EQ(cellAt(map, p0.x, p0.y), 0) << "the robot starts on an occupied cell";

  ASSERT_TRUE(rec.goal) << "no goal from the simulator";
  ASSERT_TRUE(rec.route) << "the planner published no route on the simulator's map";
  ASSERT_GE(rec.route->poses.size(), 2u);
  const auto& route_end = rec.route->poses.back().pose.position;
  EXPECT_LT(std::hypot(route_end.x - rec.goal->pose.position.x, route_end.y - rec.goal->pose.position.y), 0.1)
      << "the route does not end at the goal";
  // The latest route: planned again from wherever the robot was when people blocked it.
  const auto& route_start = rec.route->poses.front().pose.position;
  double nearest = INFINITY;
  for (const auto& o : rec.truth_odom) {
    nearest =
        std::min(nearest, std::hypot(route_start.x - o.pose.pose.position.x, route_start.y - o.pose.pose.position.y));
  }
  EXPECT_LT(nearest, 0.3) << "the route does not start where the robot was";

  // Tracks (odom) against the furniture (map), through map -> odom at each scan's stamp.
  int compared = 0, on_furniture = 0, moving_tracks = 0;
  for (const auto& scan : rec.tracks) {
    geometry_msgs::TransformStamped map_odom;
    try {
      map_odom = tf_buffer.lookupTransform("map", scan.header.frame_id, scan.header.stamp);
    } catch (const tf2::TransformException&) {
      continue;
    }
    const double yaw = 2.0 * std::atan2(map_odom.transform.rotation.z, map_odom.transform.rotation.w);
    const double c = std::cos(yaw), s = std::sin(yaw);
    ++compared;
    for (const auto& t : scan.obstacles) {
      const double x = map_odom.transform.translation.x + c * t.center.x - s * t.center.y;
      const double y = map_odom.transform.translation.y + s * t.center.x + c * t.center.y;
      moving_tracks += !t.is_static;
      for (const auto& f : furniture) on_furniture += std::hypot(x - f.first, y - f.second) < 0.15;
    }
  }
  EXPECT_GT(compared, 20) << "too few track messages could be placed in 'map'";
  EXPECT_EQ(on_furniture, 0) << "the tracker reported furniture the map shows";
  EXPECT_GT(moving_tracks, 0) << "the tracker reported no people";

  const auto& p1 = rec.truth_odom.back().pose.pose.position;
  EXPECT_GT(std::hypot(p1.x - p0.x, p1.y - p0.y), 0.3) << "the robot did not drive";
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_sim_map");
  return RUN_ALL_TESTS();
}
