#include "dqn_dovs/planning/dqn_dovs_planner.h"

#include <cmath>
#include <sstream>

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
  const Twist2 current = input.observation->robot_twist;
  auto decelerate = [&](const std::string& why) {
    decision.command = decelerationCommand(current, input.limits);
    decision.action = -1;
    decision.note = "decelerate: " + why;
    return decision;
  };
  if (input.state == nullptr) return decelerate("no network state");
  QNetwork::ActionMask mask;
  for (size_t i = 0; i < mask.size(); ++i) mask[i] = input.actions->valid[i];
  ShieldLevel shield_level = ShieldLevel::kDisabled;
  if (config_.shield.enabled) {
    if (input.dovs == nullptr) return decelerate("the action shield has no DOVS");
    const ShieldedMask shielded = shieldActions(*input.actions, *input.dovs, *input.observation, config_.shield);
    mask = shielded.mask;
    shield_level = shielded.level;
    if (shielded.has_escape) {
      // Boxed in: the shield's escape velocity, not an action.
      if (!std::isfinite(shielded.escape.v) || !std::isfinite(shielded.escape.w))
        return decelerate("escape is not finite");
      decision.command = shielded.escape;
      decision.action = -1;
      decision.note = std::string("escape (shield: ") + shieldLevelName(shielded.level) + ", " +
                      escapeTierName(shielded.escape_tier) + ")";
      return decision;
    }
  }
  int a = -1;
  try {
    a = network_->selectAction(*input.state, mask);
  } catch (const std::exception& e) {
    return decelerate(e.what());
  }
  if (a < 0) return decelerate("every action is masked");
  const Twist2 u = input.actions->velocities[static_cast<size_t>(a)];
  if (!std::isfinite(u.v) || !std::isfinite(u.w)) return decelerate("action " + std::to_string(a) + " is not finite");
  decision.command = u;
  decision.action = a;
  decision.note = "action " + std::to_string(a);
  if (shield_level != ShieldLevel::kDisabled)
    decision.note += std::string(" (shield: ") + shieldLevelName(shield_level) + ")";
  return decision;
}

}  // namespace dqn_dovs
