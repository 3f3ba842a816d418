// The planner's side of one DOVS step, ROS-free: what a Dovs message carries for the decision (the network state
// and its normalisation, the 8 actions with their mask, the shield's escape, the static geometry) and the checks
// and choice made on it. planner_node and the bag replay fill it from each dqn_dovs/Dovs message
// (dovsDecisionFromMessage); the fuzz target fills it from fuzzed wire bytes.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "dqn_dovs/common/types.h"
#include "dqn_dovs/dovs/actions.h"
#include "dqn_dovs/dovs/state.h"
#include "dqn_dovs/policy/action_shield.h"
#include "dqn_dovs/policy/qnetwork.h"
#include "dqn_dovs/policy/static_safety.h"

namespace dqn_dovs {

/// The choice that stands for the action shield's escape velocity (DovsDecision::escape), after the 8 actions.
constexpr int kEscapeChoice = kNumActions;

/// The decision fields of one Dovs message (same names, units and layouts as msg/Dovs.msg).
struct DovsDecision {
  std::vector<float> state;                    ///< the network state (QNetwork::kStateSize floats)
  std::vector<float> state_normalization;      ///< the StateNormalization values `state` was built with
  std::array<double, kNumActions> action_v{};  ///< m/s
  std::array<double, kNumActions> action_w{};  ///< rad/s
  std::array<bool, kNumActions> action_valid{};
  bool escape = false;                 ///< boxed in: the shield's escape velocity replaces the network's choice
  double escape_v = 0.0;               ///< m/s
  double escape_w = 0.0;               ///< rad/s
  std::vector<float> static_segments;  ///< x1 y1 x2 y2 per segment, m (fixed frame)
  std::vector<float> static_discs;     ///< x y radius per disc, m (fixed frame)
};

/// The decision fields of any message type laid out like dqn_dovs/Dovs (the generated ROS message), copied.
template <class Message>
DovsDecision dovsDecisionFromMessage(const Message& m) {
  DovsDecision d;
  d.state.assign(m.state.begin(), m.state.end());
  d.state_normalization.assign(m.state_normalization.begin(), m.state_normalization.end());
  for (size_t i = 0; i < static_cast<size_t>(kNumActions); ++i) {
    d.action_v[i] = m.action_v[i];
    d.action_w[i] = m.action_w[i];
    d.action_valid[i] = m.action_valid[i];
  }
  d.escape = m.escape;
  d.escape_v = m.escape_v;
  d.escape_w = m.escape_w;
  d.static_segments.assign(m.static_segments.begin(), m.static_segments.end());
  d.static_discs.assign(m.static_discs.begin(), m.static_discs.end());
  return d;
}

/// The inverse: `d`'s decision fields written into a message laid out like dqn_dovs/Dovs (dovs_node's).
template <class Message>
void dovsDecisionToMessage(const DovsDecision& d, Message& m) {
  m.state.assign(d.state.begin(), d.state.end());
  m.state_normalization.assign(d.state_normalization.begin(), d.state_normalization.end());
  for (size_t i = 0; i < static_cast<size_t>(kNumActions); ++i) {
    m.action_v[i] = d.action_v[i];
    m.action_w[i] = d.action_w[i];
    m.action_valid[i] = d.action_valid[i];
  }
  m.escape = d.escape;
  m.escape_v = d.escape_v;
  m.escape_w = d.escape_w;
  m.static_segments.assign(d.static_segments.begin(), d.static_segments.end());
  m.static_discs.assign(d.static_discs.begin(), d.static_discs.end());
}

/// The shield's step of a decision: `actions`' validity mask narrowed by the action shield (shieldActions; with
/// shield.enabled false, the validity mask), the goal-line actions masked first when there is no goal.
ShieldedMask shieldStep(const ActionSet& actions, const VelocitySpace& dovs, const Observation& observation,
                        const ActionShieldConfig& shield, bool has_goal = true);

/// The decision fields of one velocity space, as dovs_node sends them in its Dovs message and the evaluation's
/// DQN-DOVS planner hands them on: `state` and the normalisation it was built with, the 8 actions' velocities under
/// the shield's mask (`shielded`), its escape, and with statics.enabled the static geometry of `observation` (the one
/// the velocity space was built from) as StaticScene keeps it, in the fixed frame.
DovsDecision decisionFields(const StateVector& state, const StateNormalization& normalization, const ActionSet& actions,
                            const ShieldedMask& shielded, const Observation& observation, const RobotLimits& limits,
                            const StaticSafetyConfig& statics);

/// The planner's choice: kEscapeChoice when the decision carries the shield's escape, else the network's best valid
/// action (masked by action_valid; an action with a NaN/inf velocity is never chosen). Returns the choice, or -1
/// with `why` naming the problem (wrong state size, a normalisation other than the network's training, every
/// action masked, the network rejecting the state, a NaN/inf escape velocity).
int chooseAction(const QNetwork& network, const DovsDecision& decision, std::string& why);

/// The velocity a choice of chooseAction commands. Throws std::out_of_range for -1 or other non-choices.
Twist2 choiceVelocity(const DovsDecision& decision, int choice);

/// The static last line on a choice: with statics.enabled, `target`'s braking trajectory from `robot_pose` (in the
/// decision's fixed frame) at the velocity last commanded (`current`) must keep clear of the decision's static
/// geometry, or else the nearest velocity whose does is commanded (staticSafeCommand).
struct LastLine {
  Twist2 command;          ///< what to command: `target`, or the correction
  bool corrected = false;  ///< the correction replaced `target`
  std::string fault;       ///< the static geometry cannot be used (nothing to command then); "" when fine
};
LastLine staticLastLine(const DovsDecision& decision, const Twist2& target, const Pose2& robot_pose,
                        const Twist2& current, const RobotLimits& limits, const StaticSafetyConfig& statics);

/// The decision's static geometry as an observation seen from `robot_pose` (the robot now, in the geometry's frame)
/// moving at `twist`. Returns why it cannot be used ("" when fine): a length that is not a multiple of 4 / 3,
/// NaN/inf values.
std::string staticObservation(const DovsDecision& decision, const Pose2& robot_pose, const Twist2& twist,
                              Observation& out);

}  // namespace dqn_dovs
