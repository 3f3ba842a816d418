// dovs_node's and planner_node's per-message steps around the action shield's escape: the Dovs message carries
// it when the robot is boxed in, and the planner's choice then is the escape velocity, not the network's.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>

#include "conversions.h"
#include "dqn_dovs/action_shield.h"
#include "dqn_dovs/dovs.h"
#include "dqn_dovs/qnetwork.h"
#include "../core/obstacle_test_helpers.h"
#include "pipeline_steps.h"

namespace dqn_dovs {
namespace {

using test::movingDisc;

struct Step {
  DovsStep step;
  VelocitySpace space;
};

Step build(const Twist2& current, const std::vector<MovingObstacle>& obstacles) {
  const RobotLimits limits;
  const DovsConfig config;
  DovsBuilder builder(limits, config);
  TrackedObstacleArray msg = movingObstaclesToMsg(obstacles, {});
  msg.header.stamp = ros::Time(10.0);
  msg.header.frame_id = "odom";
  Step s;
  const std::string error = buildDovsStep(msg, Pose2{}, current, Vec2(4.0, 0.0), limits,
                                          dovsStateNormalization(limits, config), ActionShieldConfig{},
                                          "base_footprint", builder, s.space, s.step);
  EXPECT_EQ(error, "");
  return s;
}

QNetwork shippedNetwork() { return QNetwork::load(std::string(DQN_DOVS_SOURCE_DIR) + "/models/dqn_dovs.dqnw"); }

TEST(PipelineSteps, BoxedInTheMessageCarriesTheEscapeAndThePlannerHoldsIt) {
  // A disc coming head-on at 1 m/s, nearly touching: every velocity of the window is in its DOV.
  const Step s = build({0.3, 0.0}, {movingDisc(0.9, 0.0, kPi, 1.0)});
  ASSERT_EQ(s.step.shield_level, ShieldLevel::kLatest);
  const Dovs& d = s.step.msg;
  ASSERT_TRUE(d.escape);
  const Twist2 expected = escapeVelocity(s.step.observation, RobotLimits{}, DovsConfig{}.safety_factor,
                                         ActionShieldConfig{});
  EXPECT_DOUBLE_EQ(d.escape_v, expected.v);
  EXPECT_DOUBLE_EQ(d.escape_w, expected.w);
  const QNetwork net = shippedNetwork();
  std::string why;
  EXPECT_EQ(chooseAction(net, d, why), kEscapeChoice);
  EXPECT_EQ(why, "");
  const Twist2 u = choiceVelocity(d, kEscapeChoice);
  EXPECT_EQ(u.v, d.escape_v);
  EXPECT_EQ(u.w, d.escape_w);
  // The escape is a velocity of the dynamic window.
  EXPECT_TRUE(makeDynamicWindow({0.3, 0.0}, RobotLimits{}).contains(u, RobotLimits{}, 1e-9));

  Dovs bad = d;
  bad.escape_w = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(chooseAction(net, bad, why), -1);
  EXPECT_NE(why.find("escape"), std::string::npos) << why;
  EXPECT_THROW(choiceVelocity(d, -1), std::out_of_range);
}

TEST(PipelineSteps, WithAFreeActionThereIsNoEscapeAndTheNetworkChooses) {
  const Step s = build({0.3, 0.0}, {movingDisc(2.5, 1.5, 0.0, 0.3)});
  const Dovs& d = s.step.msg;
  EXPECT_FALSE(d.escape);
  EXPECT_EQ(d.escape_v, 0.0);
  std::string why;
  const int a = chooseAction(shippedNetwork(), d, why);
  ASSERT_GE(a, 0) << why;
  ASSERT_LT(a, kNumActions);
  EXPECT_TRUE(d.action_valid[static_cast<size_t>(a)]);
  EXPECT_EQ(choiceVelocity(d, a).v, d.action_v[static_cast<size_t>(a)]);
}

}  // namespace
}  // namespace dqn_dovs
