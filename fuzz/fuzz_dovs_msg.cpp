// libFuzzer target: a dqn_dovs/Dovs message as it arrives on the wire (ros::serialization bytes) consumed the
// way planner_node consumes it: its decision fields (core policy/dovs_decision.h, dovsDecisionFromMessage), the
// core's chooseAction with the shipped network, then the chosen action's velocity clipped into the feasible set. Run:
// make fuzz (or scripts/fuzz.sh dovs_msg SECONDS).
//
// Inputs whose array length prefixes claim more elements than the input holds are skipped before
// deserialisation: roscpp's deserialiser resizes the vector before it checks the stream, and the transport
// bounds a real message's size; that allocation is roscpp's, not the planner's.
#include <ros/serialization.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>

#include "dqn_dovs/Dovs.h"
#include "dqn_dovs/common/robot_model.h"
#include "dqn_dovs/policy/dovs_decision.h"
#include "dqn_dovs/policy/qnetwork.h"
#include "dqn_dovs/policy/static_safety.h"
#include "fuzz_common.h"

namespace {

using dqn_dovs::fuzz::require;

std::unique_ptr<dqn_dovs::QNetwork> g_network;

// Walks the wire layout of dqn_dovs/Dovs (msg/Dovs.msg) and checks that every length prefix fits.
bool lengthsFit(const std::uint8_t* data, std::size_t size) {
  std::size_t pos = 0;
  auto skip = [&](std::size_t n) {
    if (n > size - pos) return false;
    pos += n;
    return true;
  };
  auto array = [&](std::size_t element_size) {
    if (size - pos < 4) return false;
    std::uint32_t n = 0;
    for (int i = 0; i < 4; ++i) n |= static_cast<std::uint32_t>(data[pos + i]) << (8 * i);
    pos += 4;
    return skip(static_cast<std::size_t>(n) * element_size);
  };
  // header: seq, stamp, frame_id
  if (!skip(4 + 8) || !array(1)) return false;
  // has_goal, goal_stamp, goal_x goal_y, v_max w_max dv dw v w, goal_line_kind, goal_curvature goal_turn_sign,
  // action_v/w/valid, escape, escape_v, escape_w, escape_tier
  if (!skip(1 + 8 + 2 * 8 + 6 * 8 + 1 + 2 * 8 + 8 * 8 + 8 * 8 + 8 + 1 + 2 * 8 + 1)) return false;
  // static_frame, static_segments, static_discs
  if (!array(1) || !array(4) || !array(4)) return false;
  // trajectory_curvature, trajectory_pure_rotation, v_top, w_top, interval_begin, interval_lo, interval_hi
  if (!array(4) || !array(1) || !array(4) || !array(4) || !array(4) || !array(4) || !array(4)) return false;
  if (!skip(2 + 2)) return false;                  // grid_rows, grid_cols
  if (!array(4) || !array(4)) return false;        // state, state_normalization
  return array(1) && skip(8 + 8 + 1) && array(1);  // planner, planner_v, planner_w, planner_action, planner_note
}

void consume(const std::uint8_t* data, std::size_t size) {
  if (!lengthsFit(data, size)) return;
  dqn_dovs::Dovs msg;
  ros::serialization::IStream stream(const_cast<std::uint8_t*>(data), static_cast<std::uint32_t>(size));
  try {
    ros::serialization::deserialize(stream, msg);
  } catch (const ros::serialization::StreamOverrunException&) {
    require(false, "a message whose lengths fit must deserialise");
  }
  require(ros::serialization::serializationLength(msg) == size - stream.getLength(),
          "the deserialised message accounts for the bytes it read");

  // planner_node::decide: the message must have a goal and a state of the network's size, then chooseAction.
  const dqn_dovs::DovsDecision decision = dqn_dovs::dovsDecisionFromMessage(msg);
  std::string why;
  const int a = dqn_dovs::chooseAction(*g_network, decision, why);
  if (msg.state.size() != static_cast<std::size_t>(g_network->stateSize())) {
    require(a == -1 && !why.empty(), "a state of the wrong size gives no action and a reason");
    return;
  }
  if (a < 0) {
    require(a == -1 && !why.empty(), "no action comes with a reason");
    return;
  }
  require(why.empty(), "a chosen action comes without a problem");
  require((a == dqn_dovs::kEscapeChoice) == static_cast<bool>(msg.escape),
          "the escape is chosen exactly when the message carries one");
  require(a == dqn_dovs::kEscapeChoice ||
              (a < dqn_dovs::QNetwork::kActionCount && msg.action_valid[static_cast<std::size_t>(a)]),
          "the chosen action is one the message marks valid");
  const dqn_dovs::Twist2 chosen = dqn_dovs::choiceVelocity(decision, a);
  const double v = chosen.v, w = chosen.w;
  require(std::isfinite(v) && std::isfinite(w), "the chosen action has a finite velocity");
  const dqn_dovs::RobotLimits limits;
  const dqn_dovs::Twist2 target = limits.clipToFeasible({v, w});
  require(std::isfinite(target.v) && std::isfinite(target.w) && limits.feasible(target, 1e-6),
          "the commanded target is feasible");

  // planner_node's last line: the static geometry the message carries, seen from the robot, and the target
  // replaced by a statically safe one when its braking trajectory reaches it.
  dqn_dovs::Observation seen;
  const dqn_dovs::Twist2 current = limits.clipToFeasible({msg.v, msg.w});
  const std::string bad = dqn_dovs::staticObservation(decision, dqn_dovs::Pose2{}, current, seen);
  if (!bad.empty()) return;  // refused with a reason: the planner halts
  const dqn_dovs::StaticSafetyConfig statics;
  const dqn_dovs::StaticScene scene(seen, limits, statics);
  const dqn_dovs::Twist2 sent = dqn_dovs::staticSafeCommand(scene, current, target, limits, statics);
  require(std::isfinite(sent.v) && std::isfinite(sent.w) && limits.feasible(sent, 1e-6),
          "the statically checked target is finite and feasible");
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  const char* path = std::getenv("DQN_DOVS_FUZZ_MODEL");
  const std::string model = path != nullptr ? path : DQN_DOVS_FUZZ_DEFAULT_MODEL;
  try {
    g_network = std::make_unique<dqn_dovs::QNetwork>(dqn_dovs::QNetwork::load(model));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fuzz_dovs_msg: cannot load the network: %s\n", e.what());
    std::exit(2);
  }
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    consume(data, size);
  } catch (const dqn_dovs::fuzz::InvariantViolation& e) {
    std::fprintf(stderr, "fuzz_dovs_msg: %s\n", e.what());
    std::abort();
  }
  return 0;
}
