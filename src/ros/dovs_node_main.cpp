#include <ros/ros.h>

#include "dovs_node.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "dovs");
  // These handles outlive the node: when the last handle goes, roscpp shuts rosconsole down, and the fatal
  // message below (the reason the node refuses to start) would never be printed.
  ros::NodeHandle nh, pnh("~");
  try {
    dqn_dovs::DovsNode node(nh, pnh);
    ros::spin();
  } catch (const std::exception& e) {
    ROS_FATAL("dovs: %s", e.what());
    return 1;
  }
  return 0;
}
