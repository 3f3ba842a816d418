// DQN-DOVS on the robot: a trained Q-network picks one of the 8 dynamic-window actions from the DOVS state.
// ROS-free.
#pragma once

#include <memory>
#include <string>

#include "dqn_dovs/dovs/state.h"
#include "dqn_dovs/planning/planner.h"
#include "dqn_dovs/policy/action_shield.h"
#include "dqn_dovs/policy/qnetwork.h"

namespace dqn_dovs {

/// Parameters of the DQN-DOVS planner. Defaults live here only.
struct DqnDovsConfig {
  /// The `.dqnw` weight file. Relative paths are resolved by the caller (the CLI uses the working directory).
  std::string model_path = "models/dqn_dovs.dqnw";
  /// The state normalisation the caller builds states with; the network must have been trained with the same
  /// (compared field by field when the network is loaded).
  StateNormalization normalization;
  /// Relative tolerance of that comparison.
  float normalization_tolerance = 1e-4f;
  /// The action shield (action_shield.h): the network chooses among the actions the DOVS finds safe whenever
  /// there are any. `shield.enabled = false` is the paper's DQN-DOVS (validity mask only).
  ActionShieldConfig shield;

  /// Empty when consistent, otherwise a message naming the offending field and why.
  std::string validate() const;
};

/// Masked argmax of the Q-network over the 8 actions of PlannerInput::actions, on PlannerInput::state; the mask
/// is the action set's validity mask narrowed by the action shield on PlannerInput::dovs (when the shield is
/// enabled; a missing DOVS then decelerates).
/// A state that cannot be evaluated (missing, wrong size, NaN/inf), an all-invalid mask or an inference error
/// never throws: the planner decelerates (decelerationCommand) and says why in the note.
class DqnDovsPlanner : public Planner {
 public:
  /// Loads the network. Throws PlannerError naming the file and the reason when it cannot be loaded or was
  /// trained with another state normalisation, or when the configuration is invalid.
  explicit DqnDovsPlanner(const DqnDovsConfig& config = DqnDovsConfig());

  std::string name() const override { return config_.shield.enabled ? "dqn_dovs" : "dqn_dovs_unshielded"; }
  /// Throws PlannerError only when input.actions or input.observation is null (nothing to decelerate from).
  PlannerDecision decide(const PlannerInput& input) override;

  const QNetwork& network() const { return *network_; }
  const DqnDovsConfig& config() const { return config_; }

 private:
  DqnDovsConfig config_;
  std::shared_ptr<const QNetwork> network_;  // immutable after loading; QNetwork inference is thread-safe
};

}  // namespace dqn_dovs
