#include <ros/ros.h>

#include "simulator_node.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "simulator");
  try {
    dqn_dovs::SimulatorNode node(ros::NodeHandle(), ros::NodeHandle("~"));
    node.run();
  } catch (const std::exception& e) {
    ROS_FATAL("simulator: %s", e.what());
    return 1;
  }
  return 0;
}
