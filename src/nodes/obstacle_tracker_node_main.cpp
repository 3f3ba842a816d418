#include <ros/ros.h>

#include "obstacle_tracker_node.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "obstacle_tracker");
  try {
    dqn_dovs::ObstacleTrackerNode node(ros::NodeHandle(), ros::NodeHandle("~"));
    ros::spin();
  } catch (const std::exception& e) {
    ROS_FATAL("obstacle_tracker: %s", e.what());
    return 1;
  }
  return 0;
}
