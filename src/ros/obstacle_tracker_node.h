// ROS wrapper of the ObstacleTracker: LaserScan + tf -> TrackedObstacleArray (+ rviz markers).
#pragma once

#include <nav_msgs/OccupancyGrid.h>
#include <ros/ros.h>
#include <sensor_msgs/LaserScan.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <memory>
#include <string>

#include "dqn_dovs/perception/tracker.h"
#include "transform_wait.h"

namespace dqn_dovs {

class ObstacleTrackerNode {
 public:
  /// Reads and validates parameters (throws ParameterError naming the culprit), then subscribes.
  ObstacleTrackerNode(ros::NodeHandle nh, ros::NodeHandle pnh);

 private:
  void onScan(const sensor_msgs::LaserScan::ConstPtr& msg);
  void onMap(const nav_msgs::OccupancyGrid::ConstPtr& msg);
  /// The map as this scan sees it: empty without a map or without the map -> fixed_frame transform at `stamp`.
  MapStructureView mapView(const ros::Time& stamp);

  ros::NodeHandle nh_, pnh_;
  std::string fixed_frame_;
  double tf_timeout_s_ = 0.1;
  bool publish_markers_ = true;
  bool use_map_ = false;
  bool map_unknown_is_occupied_ = false;
  std::unique_ptr<KnownStructure> map_;  // the last map received, in map_frame_
  std::string map_frame_;
  std::unique_ptr<ObstacleTracker> tracker_;
  tf2_ros::Buffer tf_buffer_;
  // The waiter before the listener: the listener's thread, which calls the waiter, stops first.
  TransformWaiter tf_waiter_;
  tf2_ros::TransformListener tf_listener_;
  ros::Subscriber scan_sub_, map_sub_;
  ros::Publisher obstacles_pub_, markers_pub_;
  ros::Time last_stamp_;
};

/// Reads `tracker/*` parameters (config/tracker.yaml) over the defaults and validates them.
TrackerConfig loadTrackerConfig(const ros::NodeHandle& pnh);

}  // namespace dqn_dovs
