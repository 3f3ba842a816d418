#include "dqn_dovs/policy/dovs_decision.h"

#include <cmath>
#include <stdexcept>

#include "dqn_dovs/dovs/state.h"

namespace dqn_dovs {

std::string staticObservation(const DovsDecision& dovs, const Pose2& robot_pose, const Twist2& twist,
                              Observation& out) {
  out = Observation();
  out.robot_pose = robot_pose;
  out.robot_twist = twist;
  out.goal = robot_pose.position();
  if (dovs.static_segments.empty() && dovs.static_discs.empty()) return {};
  if (dovs.static_segments.size() % 4 != 0) return "dovs static_segments length is not a multiple of 4";
  if (dovs.static_discs.size() % 3 != 0) return "dovs static_discs length is not a multiple of 3";
  for (float x : dovs.static_segments) {
    if (!std::isfinite(x)) return "dovs static_segments has NaN/inf";
  }
  for (float x : dovs.static_discs) {
    if (!std::isfinite(x)) return "dovs static_discs has NaN/inf";
  }
  const auto& s = dovs.static_segments;
  for (size_t i = 0; i + 3 < s.size(); i += 4)
    out.segments.push_back(Segment{Vec2(s[i], s[i + 1]), Vec2(s[i + 2], s[i + 3])});
  const auto& d = dovs.static_discs;
  for (size_t i = 0; i + 2 < d.size(); i += 3) {
    MovingObstacle m;
    m.center = Vec2(d[i], d[i + 1]);
    m.radius = d[i + 2];
    m.speed = 0.0;
    m.is_static = true;
    out.obstacles.push_back(m);
  }
  return {};
}

ShieldedMask shieldStep(const ActionSet& actions, const VelocitySpace& dovs, const Observation& observation,
                        const ActionShieldConfig& shield, bool has_goal) {
  if (has_goal) return shieldActions(actions, dovs, observation, shield);
  // Without a goal there is no goal line: the shield chooses among the window actions only.
  ActionSet choosable = actions;
  for (size_t i = static_cast<size_t>(kActionGoalHigh); i < choosable.valid.size(); ++i) choosable.valid[i] = false;
  return shieldActions(choosable, dovs, observation, shield);
}

DovsDecision decisionFields(const StateVector& state, const StateNormalization& normalization, const ActionSet& actions,
                            const ShieldedMask& shielded, const Observation& observation, const RobotLimits& limits,
                            const StaticSafetyConfig& statics) {
  DovsDecision d;
  d.state.assign(state.data(), state.data() + state.size());
  for (const auto& field : normalization.fields()) d.state_normalization.push_back(field.second);
  for (size_t i = 0; i < static_cast<size_t>(kNumActions); ++i) {
    d.action_v[i] = actions.velocities[i].v;
    d.action_w[i] = actions.velocities[i].w;
    d.action_valid[i] = shielded.mask[i];
  }
  d.escape = shielded.has_escape;
  d.escape_v = shielded.has_escape ? shielded.escape.v : 0.0;
  d.escape_w = shielded.has_escape ? shielded.escape.w : 0.0;
  if (statics.enabled) {
    const StaticScene scene(observation, limits, statics);
    d.static_segments = scene.flatSegments(observation.robot_pose);
    d.static_discs = scene.flatDiscs(observation.robot_pose);
  }
  return d;
}

LastLine staticLastLine(const DovsDecision& decision, const Twist2& target, const Pose2& robot_pose,
                        const Twist2& current, const RobotLimits& limits, const StaticSafetyConfig& statics) {
  LastLine out;
  out.command = target;
  if (!statics.enabled) return out;
  Observation now_seen;
  out.fault = staticObservation(decision, robot_pose, current, now_seen);
  if (!out.fault.empty()) return out;
  const StaticScene scene(now_seen, limits, statics);
  const Twist2 safe = staticSafeCommand(scene, current, target, limits, statics);
  out.corrected = safe.v != target.v || safe.w != target.w;
  out.command = safe;
  return out;
}

Twist2 choiceVelocity(const DovsDecision& dovs, int choice) {
  if (choice == kEscapeChoice) return {dovs.escape_v, dovs.escape_w};
  if (choice < 0 || choice >= kNumActions) throw std::out_of_range("choiceVelocity: choice " + std::to_string(choice));
  return {dovs.action_v[static_cast<size_t>(choice)], dovs.action_w[static_cast<size_t>(choice)]};
}

int chooseAction(const QNetwork& network, const DovsDecision& dovs, std::string& why) {
  why.clear();
  if (dovs.state.size() != static_cast<size_t>(network.stateSize())) {
    // The usual cause: dovs_node builds states with other grid channels than the model was trained on.
    const int features = QNetwork::kFeatureCount, cells = QNetwork::kGridRows * QNetwork::kGridCols;
    const size_t n = dovs.state.size();
    why = "dovs state has " + std::to_string(n) + " values, the model reads " + std::to_string(network.stateSize()) +
          " (" + std::to_string(network.gridChannels()) + " grid channels, " + std::to_string(network.featureCount()) +
          " features)";
    if (n >= static_cast<size_t>(features) && (n - features) % cells == 0)
      why += ": dovs_node builds " + std::to_string((n - features) / cells) +
             " grid channels (check dovs/grid_channels of dovs_node)";
    return -1;
  }
  // The state must be normalised the way the network was trained (dovs_node builds it from its own robot/* and
  // dovs/* parameters, which may differ from the planner's), its grid encoded the same way.
  StateNormalization built;
  std::string count_problem;
  if (!StateNormalization::fromValues(dovs.state_normalization, built, count_problem)) {
    why = "dovs " + count_problem;
    return -1;
  }
  const std::vector<std::pair<std::string, float>> used = built.fields();
  if (const std::string mismatch = network.normalizationMismatch(used, 1e-4f); !mismatch.empty()) {
    why =
        "planner error: the dovs states are normalised differently from the model's training (check robot/* and "
        "dovs/obstacle_range and dovs/grid_contact_horizon of dovs_node): " +
        mismatch;
    return -1;
  }
  // An action whose velocity is NaN/inf cannot be commanded (clipping it into the feasible set would turn it
  // into a silent stop while the planner reports itself active): it is never chosen.
  if (dovs.escape) {
    // Boxed in: the shield's escape velocity, not the network's choice.
    if (!std::isfinite(dovs.escape_v) || !std::isfinite(dovs.escape_w)) {
      why = "planner error: the shield's escape velocity is NaN/inf";
      return -1;
    }
    return kEscapeChoice;
  }
  QNetwork::ActionMask mask;
  int non_finite = -1;
  for (size_t i = 0; i < mask.size(); ++i) {
    const bool finite = std::isfinite(dovs.action_v[i]) && std::isfinite(dovs.action_w[i]);
    if (dovs.action_valid[i] && !finite && non_finite < 0) non_finite = static_cast<int>(i);
    mask[i] = dovs.action_valid[i] && finite;
  }
  const Eigen::Map<const Eigen::VectorXf> state(dovs.state.data(), static_cast<Eigen::Index>(dovs.state.size()));
  int a = -1;
  try {
    a = network.selectAction(state, mask);
  } catch (const std::exception& e) {
    why = std::string("planner error: ") + e.what();
    return -1;
  }
  if (a < 0) {
    why = non_finite < 0 ? std::string("planner error: every action is masked")
                         : "planner error: every action is masked or has a NaN/inf velocity (action " +
                               std::to_string(non_finite) + ")";
  }
  return a;
}

}  // namespace dqn_dovs
