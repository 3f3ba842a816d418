// The decision path every front end runs (policy/dovs_decision.h): the decision fields of a velocity space (what
// dovs_node sends and the evaluation's DQN-DOVS planner hands on), the choice on them, and the static last line.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "dqn_dovs/dovs/actions.h"
#include "dqn_dovs/dovs/dovs.h"
#include "dqn_dovs/dovs/state.h"
#include "dqn_dovs/policy/action_shield.h"
#include "dqn_dovs/policy/dovs_decision.h"
#include "dqn_dovs/policy/qnetwork.h"
#include "dqn_dovs/policy/static_safety.h"
#include "source_paths.h"

namespace dqn_dovs {
namespace {

/// The robot at the origin heading +x at 0.5 m/s, the goal 6 m ahead, a wall across its way 1 m ahead.
Observation wallAhead() {
  Observation obs;
  obs.robot_twist = {0.5, 0.0};
  obs.goal = Vec2(6.0, 0.0);
  obs.segments = {Segment{Vec2(1.0, -2.0), Vec2(1.0, 2.0)}};
  return obs;
}

QNetwork shippedNetwork() { return QNetwork::load(std::string(DQN_DOVS_SOURCE_DIR) + "/models/dqn_dovs.dqnw"); }

/// The velocity space, actions and state of `wallAhead()` as every front end builds them (buildVelocitySpaceStep).
struct Scene {
  Observation obs = wallAhead();
  RobotLimits limits;
  StateNormalization norm;
  VelocitySpace dovs;
  VelocitySpaceStep step;
  Scene() {
    DovsBuilder builder(limits, DovsConfig{});
    buildVelocitySpaceStep(obs, limits, norm, builder, dovs, step);
  }
};

TEST(DovsDecision, TheFieldsAreWhatTheVelocitySpaceAndTheShieldGive) {
  const Scene scene;
  const Observation& obs = scene.obs;
  const RobotLimits& limits = scene.limits;
  const VelocitySpace& dovs = scene.dovs;
  const ActionSet& actions = scene.step.actions;
  const StateNormalization& norm = scene.norm;
  const StateVector& state = scene.step.state;
  EXPECT_EQ(state, buildState(dovs, obs, norm));
  const ShieldedMask shielded = shieldStep(actions, dovs, obs, ActionShieldConfig{});
  // Without a goal the goal-line actions are masked first.
  const ShieldedMask no_goal = shieldStep(actions, dovs, obs, ActionShieldConfig{}, false);
  for (size_t i = static_cast<size_t>(kActionGoalHigh); i < no_goal.mask.size(); ++i) EXPECT_FALSE(no_goal.mask[i]);
  StaticSafetyConfig statics;
  const DovsDecision d = decisionFields(state, norm, actions, shielded, obs, limits, statics);
  ASSERT_EQ(d.state.size(), static_cast<size_t>(state.size()));
  for (int i = 0; i < state.size(); ++i) EXPECT_EQ(d.state[static_cast<size_t>(i)], state(i));
  ASSERT_EQ(d.state_normalization.size(), norm.fields().size());
  for (size_t i = 0; i < static_cast<size_t>(kNumActions); ++i) {
    EXPECT_EQ(d.action_v[i], actions.velocities[i].v);
    EXPECT_EQ(d.action_w[i], actions.velocities[i].w);
    EXPECT_EQ(d.action_valid[i], shielded.mask[i]);
  }
  EXPECT_EQ(d.escape, shielded.has_escape);
  EXPECT_EQ(d.static_segments.size(), 4u);  // the wall, in the fixed frame
  EXPECT_TRUE(d.static_discs.empty());
  statics.enabled = false;
  EXPECT_TRUE(decisionFields(state, norm, actions, shielded, obs, limits, statics).static_segments.empty());

  // The shipped network chooses on them: the escape when the shield has one, else a valid action.
  std::string why;
  const int a = chooseAction(shippedNetwork(), d, why);
  ASSERT_GE(a, 0) << why;
  EXPECT_TRUE(a == kEscapeChoice || d.action_valid[static_cast<size_t>(a)]);
  ShieldedMask boxed = shielded;
  boxed.has_escape = true;
  boxed.escape = {0.2, 0.4};
  const DovsDecision e = decisionFields(state, norm, actions, boxed, obs, limits, statics);
  EXPECT_EQ(chooseAction(shippedNetwork(), e, why), kEscapeChoice);
  EXPECT_EQ(choiceVelocity(e, kEscapeChoice).w, 0.4);
}

TEST(DovsDecision, TheStaticLastLineBrakesBeforeTheWallAndOnlyWhenOn) {
  const Scene scene;
  const RobotLimits& limits = scene.limits;
  const ShieldedMask open = shieldStep(scene.step.actions, scene.dovs, scene.obs, ActionShieldConfig{});
  const StaticSafetyConfig statics;
  const DovsDecision d =
      decisionFields(scene.step.state, scene.norm, scene.step.actions, open, scene.obs, limits, statics);
  // 0.7 m/s straight at a wall 1 m ahead (0.8 m from the body) from 0.5 m/s: the braking trajectory reaches it.
  const Twist2 fast{0.7, 0.0};
  const Pose2 closer{0.4, 0.0, 0.0};
  const LastLine line = staticLastLine(d, fast, closer, {0.6, 0.0}, limits, statics);
  EXPECT_TRUE(line.fault.empty()) << line.fault;
  EXPECT_TRUE(line.corrected);
  EXPECT_LT(line.command.v, fast.v);
  // Far from it the target passes unchanged; with the rule off it always does.
  const LastLine far = staticLastLine(d, {0.3, 0.0}, Pose2{-3.0, 0.0, 0.0}, {0.3, 0.0}, limits, statics);
  EXPECT_FALSE(far.corrected);
  EXPECT_EQ(far.command.v, 0.3);
  StaticSafetyConfig off;
  off.enabled = false;
  const LastLine none = staticLastLine(d, fast, closer, {0.6, 0.0}, limits, off);
  EXPECT_FALSE(none.corrected);
  EXPECT_EQ(none.command.v, fast.v);
  // Geometry a message could carry broken is refused, naming it.
  DovsDecision broken = d;
  broken.static_segments.push_back(1.0f);
  EXPECT_NE(staticLastLine(broken, fast, closer, {0.6, 0.0}, limits, statics).fault.find("multiple of 4"),
            std::string::npos);
  broken = d;
  broken.static_segments[0] = std::numeric_limits<float>::quiet_NaN();
  EXPECT_NE(staticLastLine(broken, fast, closer, {0.6, 0.0}, limits, statics).fault.find("NaN"), std::string::npos);
}

}  // namespace
}  // namespace dqn_dovs
