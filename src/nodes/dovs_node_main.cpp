#include <ros/ros.h>

#include "dovs_node.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "dovs");
  try {
    dqn_dovs::DovsNode node(ros::NodeHandle(), ros::NodeHandle("~"));
    ros::spin();
  } catch (const std::exception& e) {
    ROS_FATAL("dovs: %s", e.what());
    return 1;
  }
  return 0;
}
