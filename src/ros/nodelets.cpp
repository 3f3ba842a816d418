// The pipeline's three nodes as nodelets (nodelet_plugins.xml): the same adapter classes as the executables,
// loaded into one nodelet manager so that scans, tracks and velocity spaces pass between them inside one process
// instead of over TCP (launch/pipeline.launch, nodelets:=true). Each nodelet gets its own single-threaded
// callback queue, so every class sees its callbacks one at a time, as in its own process.
#include <nodelet/nodelet.h>

#include <memory>
#include <pluginlib/class_list_macros.hpp>
#include <stdexcept>
#include <string>

#include "dovs_node.h"
#include "obstacle_tracker_node.h"
#include "planner_node.h"

namespace dqn_dovs {

/// Holds one node object for the nodelet's lifetime. A node that refuses to start (bad parameters, a bad
/// weight file) logs why as FATAL and throws, so the manager's load fails and the loader process exits with an
/// error (with required="true" in the launch file, the whole pipeline stops, as with the executables).
template <typename Node>
class NodeNodelet : public nodelet::Nodelet {
 public:
  explicit NodeNodelet(const char* what) : what_(what) {}

 private:
  void onInit() override {
    try {
      node_ = std::make_unique<Node>(getNodeHandle(), getPrivateNodeHandle());
    } catch (const std::exception& e) {
      NODELET_FATAL("%s (%s): %s", getName().c_str(), what_, e.what());
      throw std::runtime_error(getName() + ": " + e.what());
    }
  }

  const char* what_;
  std::unique_ptr<Node> node_;
};

class ObstacleTrackerNodelet : public NodeNodelet<ObstacleTrackerNode> {
 public:
  ObstacleTrackerNodelet() : NodeNodelet("obstacle_tracker") {}
};

class DovsNodelet : public NodeNodelet<DovsNode> {
 public:
  DovsNodelet() : NodeNodelet("dovs") {}
};

class PlannerNodelet : public NodeNodelet<PlannerNode> {
 public:
  PlannerNodelet() : NodeNodelet("planner") {}
};

}  // namespace dqn_dovs

PLUGINLIB_EXPORT_CLASS(dqn_dovs::ObstacleTrackerNodelet, nodelet::Nodelet)
PLUGINLIB_EXPORT_CLASS(dqn_dovs::DovsNodelet, nodelet::Nodelet)
PLUGINLIB_EXPORT_CLASS(dqn_dovs::PlannerNodelet, nodelet::Nodelet)
