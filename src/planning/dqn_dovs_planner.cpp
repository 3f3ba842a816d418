#include "dqn_dovs/planning/dqn_dovs_planner.h"

#include <cmath>
#include <sstream>

#include "dqn_dovs/policy/dovs_decision.h"

namespace dqn_dovs {

// The network's feature inputs and the state's layout agree (docs/dovs.md "The previous action").
static_assert(QNetwork::kFeatureCount == kNumFeatures &&
                  QNetwork::kFeatureCountWithPreviousChoice == kNumFeatures + kPreviousChoiceInputs,
              "the Q-network reads the state's features, and with the previous choice 9 more");

std::string DqnDovsConfig::validate() const {
  if (model_path.empty()) return "dqn_dovs.model_path is empty";
  if (const std::string e = normalization.validate(); !e.empty()) return "dqn_dovs.normalization: " + e;
  if (const std::string e = shield.validate(); !e.empty()) return "dqn_dovs." + e;
  if (!(std::isfinite(normalization_tolerance) && normalization_tolerance >= 0.0f)) {
    std::ostringstream os;
    os << "dqn_dovs.normalization_tolerance = " << normalization_tolerance << ": must be finite and >= 0";
    return os.str();
  }
  return {};
}

namespace {

std::shared_ptr<const QNetwork> loadNetwork(const DqnDovsConfig& config) {
  if (const std::string e = config.validate(); !e.empty()) throw PlannerError("DQN-DOVS configuration: " + e);
  std::shared_ptr<const QNetwork> net;
  try {
    net = std::make_shared<const QNetwork>(QNetwork::load(config.model_path));
  } catch (const std::exception& e) {
    throw PlannerError("DQN-DOVS: cannot load the Q-network '" + config.model_path + "': " + e.what());
  }
  std::string mismatch = net->normalizationMismatch(config.normalization.fields(), config.normalization_tolerance);
  if (mismatch.empty()) mismatch = net->gridChannelsMismatch(config.normalization.grid_channels);
  if (mismatch.empty()) mismatch = net->previousActionMismatch(config.normalization.previous_action != 0);
  if (mismatch.empty())
    mismatch = net->tokenLayoutMismatch(config.normalization.wall_rays, config.normalization.person_tokens,
                                        config.normalization.route_points);
  if (!mismatch.empty()) {
    throw PlannerError("DQN-DOVS: the Q-network '" + config.model_path +
                       "' was trained with another state normalisation or layout: " + mismatch);
  }
  return net;
}

}  // namespace

DqnDovsPlanner::DqnDovsPlanner(const DqnDovsConfig& config) : config_(config), network_(loadNetwork(config)) {}

PlannerDecision DqnDovsPlanner::decide(const PlannerInput& input) {
  if (input.observation == nullptr) throw PlannerError("DQN-DOVS: the planner input has no observation");
  if (input.actions == nullptr) throw PlannerError("DQN-DOVS: the planner input has no action set");
  PlannerDecision decision;
  const Observation& obs = *input.observation;
  const Twist2 current = obs.robot_twist;
  auto decelerate = [&](const std::string& why) {
    decision.command = decelerationCommand(current, input.limits);
    decision.action = -1;
    decision.note = "decelerate: " + why;
    return decision;
  };
  if (input.state == nullptr) return decelerate("no network state");
  // The robot's decision path (policy/dovs_decision.h): the shield's mask and escape and the static geometry as
  // dovs_node puts them in a Dovs message, the choice planner_node makes on it, and its static last line.
  ShieldedMask shielded;  // without the shield: the validity mask
  shielded.mask = input.actions->valid;
  if (config_.shield.enabled) {
    if (input.dovs == nullptr) return decelerate("the action shield has no DOVS");
    shielded = shieldStep(*input.actions, *input.dovs, obs, config_.shield);
  }
  const DovsDecision fields = decisionFields(*input.state, config_.normalization, *input.actions, shielded, obs,
                                             input.limits, config_.shield.statics);
  std::string why;
  const int choice = chooseAction(*network_, fields, why);
  if (choice < 0) {
    const std::string robot_prefix = "planner error: ";  // planner_node's status names the planner; a note need not
    return decelerate(why.rfind(robot_prefix, 0) == 0 ? why.substr(robot_prefix.size()) : why);
  }
  const Twist2 target = input.limits.clipToFeasible(choiceVelocity(fields, choice));
  const LastLine last = staticLastLine(fields, target, obs.robot_pose, current, input.limits, config_.shield.statics);
  if (!last.fault.empty()) return decelerate(last.fault);
  decision.command = last.command;
  if (choice == kEscapeChoice) {
    // Boxed in: the shield's escape velocity, not an action.
    decision.action = -1;
    decision.note = std::string("escape (shield: ") + shieldLevelName(shielded.level) + ", " +
                    escapeTierName(shielded.escape_tier) + ")";
  } else {
    decision.action = choice;
    decision.note = "action " + std::to_string(choice);
    if (shielded.level != ShieldLevel::kDisabled)
      decision.note += std::string(" (shield: ") + shieldLevelName(shielded.level) + ")";
  }
  if (last.corrected) decision.note += " (static last line)";
  return decision;
}

}  // namespace dqn_dovs
