// The 8 actions at the edges of the velocity space and the goal line's special cases.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "dqn_dovs/dovs/actions.h"

namespace dqn_dovs {
namespace {

const RobotLimits kLimits;  // dv = 0.1 m/s, dw = 0.4 rad/s

void expectTwist(const Twist2& t, double v, double w, const char* what) {
  EXPECT_NEAR(t.v, v, 1e-9) << what;
  EXPECT_NEAR(t.w, w, 1e-9) << what;
}

void expectAllValidInsideWindow(const ActionSet& a) {
  for (int i = 0; i < kNumActions; ++i) {
    if (!a.valid[static_cast<size_t>(i)]) continue;
    EXPECT_TRUE(a.window.contains(a.velocities[static_cast<size_t>(i)], kLimits, 1e-7)) << "action " << i;
  }
  for (int i = 0; i <= kActionKeep; ++i) EXPECT_TRUE(a.valid[static_cast<size_t>(i)]) << "action " << i;
}

TEST(GoalLine, CurvatureOfTheCircleThroughTheGoal) {
  const GoalLine ahead = goalLine({2.0, 0.0});
  EXPECT_EQ(ahead.kind, GoalLine::Kind::kArc);
  EXPECT_DOUBLE_EQ(ahead.curvature_1pm, 0.0);
  const GoalLine left = goalLine({1.0, 1.0});
  EXPECT_DOUBLE_EQ(left.curvature_1pm, 1.0);  // unit circle centred at (0, 1)
  const GoalLine side = goalLine({0.0, -2.0});
  EXPECT_EQ(side.kind, GoalLine::Kind::kArc);
  EXPECT_DOUBLE_EQ(side.curvature_1pm, -1.0);  // half circle to the right
  const GoalLine behind = goalLine({-1.0, -0.2});
  EXPECT_EQ(behind.kind, GoalLine::Kind::kTurnInPlace);
  EXPECT_EQ(behind.turn_sign, -1.0);
  EXPECT_EQ(goalLine({-3.0, 0.0}).turn_sign, 1.0);
  EXPECT_EQ(goalLine({1e-4, 0.0}).kind, GoalLine::Kind::kNone);
  EXPECT_THROW(goalLine({std::nan(""), 1.0}), ActionError);
}

TEST(Actions, StandingStillWithTheGoalAhead) {
  const ActionSet a = computeActions({0.0, 0.0}, {2.0, 0.0}, kLimits);
  expectTwist(a.velocities[kActionDwTop], 0.1, 0.0, "top");
  expectTwist(a.velocities[kActionDwBottom], 0.0, 0.0, "bottom clipped at v = 0");
  expectTwist(a.velocities[kActionDwLeft], 0.0, -0.4, "left");
  expectTwist(a.velocities[kActionDwRight], 0.0, 0.4, "right");
  expectTwist(a.velocities[kActionKeep], 0.0, 0.0, "keep");
  ASSERT_TRUE(a.valid[kActionGoalHigh] && a.valid[kActionGoalLow] && a.valid[kActionGoalCurrent]);
  expectTwist(a.velocities[kActionGoalHigh], 0.1, 0.0, "goal high");
  expectTwist(a.velocities[kActionGoalLow], 0.0, 0.0, "goal low");
  expectTwist(a.velocities[kActionGoalCurrent], 0.0, 0.0, "goal at current v");
  EXPECT_EQ(a.numValid(), 8);
  expectAllValidInsideWindow(a);
}

TEST(Actions, AtMaximumSpeedTheCornersAreClippedIntoTheTriangle) {
  const ActionSet a = computeActions({0.7, 0.0}, {5.0, 0.0}, kLimits);
  expectTwist(a.velocities[kActionDwTop], 0.7, 0.0, "top");
  expectTwist(a.velocities[kActionDwBottom], 0.6, 0.0, "bottom");
  expectTwist(a.velocities[kActionDwLeft], 0.7, 0.0, "left: no turning at v_max");
  expectTwist(a.velocities[kActionDwRight], 0.7, 0.0, "right");
  expectTwist(a.velocities[kActionGoalHigh], 0.7, 0.0, "goal high");
  expectTwist(a.velocities[kActionGoalLow], 0.6, 0.0, "goal low");
  expectAllValidInsideWindow(a);
}

TEST(Actions, AtTheAngularLimit) {
  // On the triangle's edge: w = w_max (1 - v / v_max).
  const Twist2 cur{0.35, kPi / 2};
  const ActionSet a = computeActions(cur, {1.0, 3.0}, kLimits);
  expectTwist(a.velocities[kActionDwTop], 0.35, kPi / 2, "top cannot speed up while turning this fast");
  expectTwist(a.velocities[kActionDwRight], 0.35, kPi / 2, "right cannot turn faster");
  expectTwist(a.velocities[kActionDwLeft], 0.35, kPi / 2 - 0.4, "left");
  expectTwist(a.velocities[kActionDwBottom], 0.25, kPi / 2, "bottom");
  expectAllValidInsideWindow(a);
  // At v = 0 the turn rate itself is limited to w_max.
  const ActionSet spin = computeActions({0.0, kPi}, {1.0, 0.0}, kLimits);
  expectTwist(spin.velocities[kActionDwRight], 0.0, kPi, "right at w_max");
  expectTwist(spin.velocities[kActionDwTop], 0.0, kPi, "top at w_max");
  expectAllValidInsideWindow(spin);
}

TEST(Actions, InfeasibleCurrentVelocityIsClippedFirst) {
  const ActionSet a = computeActions({0.9, 0.0}, {1.0, 0.0}, kLimits);
  expectTwist(a.velocities[kActionKeep], 0.7, 0.0, "keep");
  expectAllValidInsideWindow(a);
}

TEST(Actions, GoalBehindTurnsInPlace) {
  const ActionSet still = computeActions({0.0, 0.0}, {-2.0, 0.5}, kLimits);
  EXPECT_EQ(still.goal_line.kind, GoalLine::Kind::kTurnInPlace);
  ASSERT_TRUE(still.valid[kActionGoalHigh] && still.valid[kActionGoalLow] && still.valid[kActionGoalCurrent]);
  expectTwist(still.velocities[kActionGoalHigh], 0.0, 0.4, "fastest turn toward the goal side");
  expectTwist(still.velocities[kActionGoalLow], 0.0, 0.0, "slowest");
  expectAllValidInsideWindow(still);
  // Moving at 0.3 m/s the window does not reach v = 0: no goal action.
  const ActionSet moving = computeActions({0.3, 0.0}, {-2.0, -0.5}, kLimits);
  EXPECT_FALSE(moving.valid[kActionGoalHigh] || moving.valid[kActionGoalLow] || moving.valid[kActionGoalCurrent]);
  EXPECT_EQ(moving.numValid(), 5);
  // At 0.05 m/s it does, but not at the current v.
  const ActionSet slow = computeActions({0.05, 0.0}, {-2.0, -0.5}, kLimits);
  EXPECT_TRUE(slow.valid[kActionGoalHigh]);
  expectTwist(slow.velocities[kActionGoalHigh], 0.0, -0.2, "rhombus at v = 0");
  EXPECT_FALSE(slow.valid[kActionGoalCurrent]);
}

TEST(Actions, GoalAtTheRobotHasNoGoalActions) {
  const ActionSet a = computeActions({0.2, 0.1}, {0.0, 0.0}, kLimits);
  EXPECT_EQ(a.goal_line.kind, GoalLine::Kind::kNone);
  EXPECT_EQ(a.numValid(), 5);
  for (int i = kActionGoalHigh; i <= kActionGoalCurrent; ++i)
    expectTwist(a.velocities[static_cast<size_t>(i)], 0.2, 0.1, "invalid holds keep");
}

TEST(Actions, GoalLineTangentToTheWindowTouchesOneCorner) {
  // Window around (0.3, 0): left corner (0.3, -0.4). The line w = -4/3 v meets the rhombus only there.
  const ActionSet a = computeActions({0.3, 0.0}, {0.75, -0.75}, kLimits);
  ASSERT_NEAR(a.goal_line.curvature_1pm, -4.0 / 3.0, 1e-12);
  ASSERT_TRUE(a.valid[kActionGoalHigh] && a.valid[kActionGoalLow] && a.valid[kActionGoalCurrent]);
  expectTwist(a.velocities[kActionGoalHigh], 0.3, -0.4, "high at the corner");
  expectTwist(a.velocities[kActionGoalLow], 0.3, -0.4, "low at the corner");
  expectTwist(a.velocities[kActionGoalCurrent], 0.3, -0.4, "current v at the corner");
  // A slightly steeper line misses the window.
  const ActionSet miss = computeActions({0.3, 0.0}, {0.7, -0.75}, kLimits);
  EXPECT_LT(miss.goal_line.curvature_1pm, -4.0 / 3.0);
  EXPECT_EQ(miss.numValid(), 5);
}

TEST(Actions, GoalLineCrossingTheWindow) {
  const ActionSet a = computeActions({0.3, 0.0}, {2.0, 1.0}, kLimits);  // k = 0.4
  ASSERT_TRUE(a.valid[kActionGoalHigh] && a.valid[kActionGoalLow] && a.valid[kActionGoalCurrent]);
  const Twist2 hi = a.velocities[kActionGoalHigh], lo = a.velocities[kActionGoalLow];
  EXPECT_GT(hi.v, lo.v);
  EXPECT_NEAR(hi.w, 0.4 * hi.v, 1e-9);
  EXPECT_NEAR(lo.w, 0.4 * lo.v, 1e-9);
  // Both ends on the rhombus border.
  EXPECT_NEAR(std::abs(hi.v - 0.3) / 0.1 + std::abs(hi.w) / 0.4, 1.0, 1e-9);
  EXPECT_NEAR(std::abs(lo.v - 0.3) / 0.1 + std::abs(lo.w) / 0.4, 1.0, 1e-9);
  expectTwist(a.velocities[kActionGoalCurrent], 0.3, 0.12, "current v");
}

TEST(Actions, RandomInputsGiveActionsInsideTheFeasibleWindow) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int k = 0; k < 2000; ++k) {
    const Twist2 cur = kLimits.clipToFeasible({0.8 * u(rng), kPi * (2.2 * u(rng) - 1.1)});
    const Vec2 goal(8.0 * u(rng) - 4.0, 8.0 * u(rng) - 4.0);
    const ActionSet a = computeActions(cur, goal, kLimits);
    expectAllValidInsideWindow(a);
    if (a.valid[kActionGoalHigh]) {
      EXPECT_GE(a.velocities[kActionGoalHigh].v, a.velocities[kActionGoalLow].v - 1e-12);
    }
  }
}

TEST(Actions, NonFiniteInputIsAnError) {
  EXPECT_THROW(computeActions({std::nan(""), 0.0}, {1.0, 0.0}, kLimits), ActionError);
  EXPECT_THROW(computeActions({0.0, 0.0}, {1.0, std::numeric_limits<double>::infinity()}, kLimits), ActionError);
  RobotLimits bad;
  bad.a_v = -1.0;
  try {
    computeActions({0.0, 0.0}, {1.0, 0.0}, bad);
    FAIL();
  } catch (const ActionError& e) {
    EXPECT_NE(std::string(e.what()).find("a_v"), std::string::npos);
  }
}

}  // namespace
}  // namespace dqn_dovs
