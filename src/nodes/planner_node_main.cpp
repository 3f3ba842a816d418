#include <ros/ros.h>

#include "planner_node.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "planner");
  try {
    dqn_dovs::PlannerNode node(ros::NodeHandle(), ros::NodeHandle("~"));
    ros::spin();
  } catch (const std::exception& e) {
    ROS_FATAL("planner: %s", e.what());
    return 1;
  }
  return 0;
}
