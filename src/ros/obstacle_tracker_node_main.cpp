#include <ros/ros.h>

#include "obstacle_tracker_node.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "obstacle_tracker");
  // These handles outlive the node: when the last handle goes, roscpp shuts rosconsole down, and the fatal
  // message below (the reason the node refuses to start) would never be printed.
  ros::NodeHandle nh, pnh("~");
  try {
    dqn_dovs::ObstacleTrackerNode node(nh, pnh);
    ros::spin();
  } catch (const std::exception& e) {
    ROS_FATAL("obstacle_tracker: %s", e.what());
    return 1;
  }
  return 0;
}
