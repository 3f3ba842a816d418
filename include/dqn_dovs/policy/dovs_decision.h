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
#include "dqn_dovs/policy/qnetwork.h"

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

/// The planner's choice: kEscapeChoice when the decision carries the shield's escape, else the network's best valid
/// action (masked by action_valid; an action with a NaN/inf velocity is never chosen). Returns the choice, or -1
/// with `why` naming the problem (wrong state size, a normalisation other than the network's training, every
/// action masked, the network rejecting the state, a NaN/inf escape velocity).
int chooseAction(const QNetwork& network, const DovsDecision& decision, std::string& why);

/// The velocity a choice of chooseAction commands. Throws std::out_of_range for -1 or other non-choices.
Twist2 choiceVelocity(const DovsDecision& decision, int choice);

/// The decision's static geometry as an observation seen from `robot_pose` (the robot now, in the geometry's frame)
/// moving at `twist`. Returns why it cannot be used ("" when fine): a length that is not a multiple of 4 / 3,
/// NaN/inf values.
std::string staticObservation(const DovsDecision& decision, const Pose2& robot_pose, const Twist2& twist,
                              Observation& out);

}  // namespace dqn_dovs
