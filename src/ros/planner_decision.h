// planner_node's decision adapter: the Q-network and the static last line on each Dovs message. It loads the model
// (refusing one trained on another state), takes each Dovs built for the current goal, runs the core's choice on its
// decision fields once per message (policy/dovs_decision.h: the network's action or the shield's escape) and, every
// control period, checks the chosen velocity's braking against the static geometry the message carries.
#pragma once

#include <ros/ros.h>

#include <cstdint>
#include <memory>
#include <string>

#include "dqn_dovs/Dovs.h"
#include "dqn_dovs/common/robot_model.h"
#include "dqn_dovs/dovs/dovs.h"
#include "dqn_dovs/planning/planner.h"
#include "dqn_dovs/policy/dovs_decision.h"
#include "dqn_dovs/policy/qnetwork.h"
#include "dqn_dovs/policy/static_safety.h"
#include "dqn_dovs/supervision/supervisor.h"
#include "planner_navigation.h"

namespace dqn_dovs {

class PlannerDecisionAdapter {
 public:
  /// Reads model_path, static_safety/*, action_shield/* and dovs/* and loads the model; throws (ParameterError,
  /// WeightFileError) naming the culprit, also when the model was trained with another state normalisation or
  /// layout than dovs/* and robot/* give.
  PlannerDecisionAdapter(ros::NodeHandle nh, ros::NodeHandle pnh, const std::string& fixed_frame,
                         const RobotLimits& limits, Supervisor& supervisor);
  /// Subscribes to `dovs`, taking only velocity spaces built for `navigation`'s goal (which must outlive this).
  void start(const PlannerNavigation& navigation);

  /// The network (planner dqn_dovs; null for another planner, which decides in dovs_node).
  const QNetwork* network() const { return network_.get(); }
  /// The `planner` parameter: dqn_dovs (the network here) or the registry planner dovs_node runs (s_dovs, dwa,
  /// orca_diffdrive), whose command each Dovs message carries.
  const std::string& planner() const { return planner_; }

  /// Why there is no velocity space to decide on now ("" when there is one): the goal cannot be placed, no Dovs yet,
  /// one built for another goal, or a state of the wrong size.
  std::string spaceFault() const;
  /// The decision for the robot at `pose`: the network's action or the shield's escape from the last Dovs, then
  /// the static last line against the geometry the Dovs carries.
  Choice choose(const Pose2& pose);
  /// Forgets the last Dovs and its choice (after the clock jumped back: it is stamped in the new clock's future).
  void forget();

  uint32_t staticCorrections() const { return static_corrections_; }
  const std::string& staticLast() const { return static_last_; }

 private:
  void onDovs(const Dovs::ConstPtr& msg);
  /// Loads model_path and checks it against the states dovs/* and robot/* give (ParameterError, WeightFileError).
  void loadModel(const ros::NodeHandle& pnh, const std::string& model_path, const DovsConfig& dovs);
  /// The network's action for last_dovs_ (computed once per message); -1 with `why` when there is none.
  int actionForLastDovs(std::string& why);

  std::string fixed_frame_;
  RobotLimits limits_;
  std::string planner_ = "dqn_dovs";
  ros::NodeHandle nh_;
  Supervisor& supervisor_;
  const PlannerNavigation* navigation_ = nullptr;
  StaticSafetyConfig statics_;
  std::unique_ptr<QNetwork> network_;
  uint32_t static_corrections_ = 0;
  std::string static_last_;

  Dovs::ConstPtr last_dovs_;
  Dovs::ConstPtr chosen_for_;     // the message chosen_decision_, chosen_action_ and chosen_why_ belong to
  DovsDecision chosen_decision_;  // its decision fields (state, actions, escape, static geometry)
  int chosen_action_ = -1;
  std::string chosen_why_;

  ros::Subscriber dovs_sub_;
  ros::Publisher latency_pub_;
};

}  // namespace dqn_dovs
