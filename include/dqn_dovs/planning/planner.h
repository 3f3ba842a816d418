// One interface for every planner of the project (DQN-DOVS, S-DOVS, ORCA, DWA): observation in, (v, w) out.
#pragma once

#include <Eigen/Core>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "dqn_dovs/common/robot_model.h"
#include "dqn_dovs/common/types.h"
#include "dqn_dovs/dovs/actions.h"
#include "dqn_dovs/dovs/dovs.h"
#include "dqn_dovs/dovs/state.h"
#include "dqn_dovs/policy/action_shield.h"

namespace dqn_dovs {

class PlannerError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Everything a planner may read at one decision instant. The DOVS, the action set and the network state
/// are built once per decision by the caller (episode runner or ROS node) and shared by all planners.
struct PlannerInput {
  const Observation* observation = nullptr;  ///< fixed-frame view of the world (tracked or true obstacles)
  const VelocitySpace* dovs = nullptr;       ///< the dynamic object velocity space at this instant
  const ActionSet* actions = nullptr;        ///< the 8 dynamic-window actions and their mask
  const Eigen::VectorXf* state = nullptr;    ///< the 408-float network state (may be null for classic planners)
  RobotLimits limits;
};

struct PlannerDecision {
  Twist2 command;    ///< velocity to reach by the end of the control period (inside the dynamic window)
  int action = -1;   ///< index into the action set when the planner chose one of the 8 actions, else -1
  std::string note;  ///< short human-readable reason (strategy name, fallback cause)
  /// Set only by planners of a holonomic robot (`orca_holonomic`): the fixed-frame velocity (vx, vy) in m/s to
  /// hold for the control period. Episode::stepDecision executes it with World::stepHolonomic; every other
  /// caller (a differential-drive robot) ignores it and applies `command`, which such planners still fill.
  std::optional<Vec2> holonomic_velocity;
};

class Planner {
 public:
  virtual ~Planner() = default;
  /// Stable name used by the evaluation CLI (`dqn_dovs`, `s_dovs`, ...).
  virtual std::string name() const = 0;
  /// Called at the start of every episode / new goal.
  virtual void reset() {}
  /// Chooses the command for the next control period. Must not throw on odd but finite input; throws
  /// PlannerError for unusable input (the caller decelerates).
  virtual PlannerDecision decide(const PlannerInput& input) = 0;
};

/// Builds a planner by name with its default configuration; `model_path` is used by `dqn_dovs`; `shield`, when
/// given, replaces the default action shield of the DQN-DOVS planners (a variant's own changes still apply);
/// `normalization`, when given, is the one the caller's states are built with (stateNormalization of its robot
/// and DOVS; default: the default robot's and DOVS's), which a DQN-DOVS planner's network must have been trained
/// with. Throws PlannerError for an unknown name (the message lists the known ones).
std::unique_ptr<Planner> makePlanner(const std::string& name, const std::string& model_path = "",
                                     const ActionShieldConfig* shield = nullptr,
                                     const StateNormalization* normalization = nullptr);

/// Names accepted by makePlanner.
std::vector<std::string> plannerNames();

/// The planners a differential-drive robot can run on what it senses (the nodes' `planner` parameter): dqn_dovs,
/// s_dovs, dwa, orca_diffdrive. Not the DQN-DOVS ablations, the holonomic ORCA, or the oracle and the bound (they
/// read the world's truth).
const std::vector<std::string>& robotPlannerNames();
/// "" when `name` is one of robotPlannerNames(), otherwise why not, listing them.
std::string robotPlannerFault(const std::string& name);

}  // namespace dqn_dovs
