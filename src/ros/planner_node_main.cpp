#include <ros/ros.h>

#include "planner_node.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "planner");
  // These handles outlive the node: when the last handle goes, roscpp shuts rosconsole down, and the fatal
  // message below (the reason the node refuses to start) would never be printed.
  ros::NodeHandle nh, pnh("~");
  try {
    dqn_dovs::PlannerNode node(nh, pnh);
    ros::spin();
  } catch (const std::exception& e) {
    ROS_FATAL("planner: %s", e.what());
    return 1;
  }
  return 0;
}
