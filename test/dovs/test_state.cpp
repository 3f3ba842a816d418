// The 408-float network state: grid layout, features of known scenes, far-away defaults, normalisation.
#include <gtest/gtest.h>

#include <cmath>

#include "dqn_dovs/dovs/state.h"

namespace dqn_dovs {
namespace {

Observation knownScene() {
  Observation obs;
  obs.robot_pose = {1.0, 1.0, kPi / 2};  // facing +y
  obs.robot_twist = {0.35, -kPi / 2};
  obs.goal = {1.0, 4.0};  // 3 m straight ahead
  MovingObstacle o;
  o.center = {0.0, 1.0};  // 1 m to the robot's left
  o.radius = 0.3;
  o.heading = kPi;  // moving toward -x: straight at the robot... in world terms; relative heading +pi/2
  o.speed = 0.75;
  obs.obstacles.push_back(o);
  return obs;
}

TEST(State, FeaturesOfAKnownScene) {
  const Observation obs = knownScene();
  const VelocitySpace d = buildDovs(obs, RobotLimits{}, DovsConfig{});
  const FeatureVector f = computeFeatures(d, obs, StateNormalization{});
  EXPECT_NEAR(f[kFeatureV], 0.5, 1e-6);
  EXPECT_NEAR(f[kFeatureW], -0.5, 1e-6);
  EXPECT_NEAR(f[kFeatureGoalDistance], 0.3, 1e-6);
  EXPECT_NEAR(f[kFeatureGoalAngle], 0.0, 1e-6);
  EXPECT_NEAR(f[kFeatureObstacleHeading], 0.5, 1e-6);
  EXPECT_NEAR(f[kFeatureObstacleSpeed], 0.5, 1e-6);
  EXPECT_NEAR(f[kFeatureObstacleBearing], 0.5, 1e-6);
  EXPECT_NEAR(f[kFeatureObstacleClearance], (1.0 - 0.3 - 0.2) / 4.0, 1e-6);
}

TEST(State, ClosestObstacleIsChosenByClearance) {
  Observation obs = knownScene();
  MovingObstacle big;
  big.center = {1.0, 2.2};  // 1.2 m ahead but radius 0.8: clearance 0.2
  big.radius = 0.8;
  big.is_static = true;
  obs.obstacles.push_back(big);
  const VelocitySpace d = buildDovs(obs, RobotLimits{}, DovsConfig{});
  ASSERT_TRUE(d.closestObstacle().found);
  EXPECT_EQ(d.closestObstacle().index, 1);
  const FeatureVector f = computeFeatures(d, obs, StateNormalization{});
  EXPECT_NEAR(f[kFeatureObstacleBearing], 0.0, 1e-6);
  EXPECT_NEAR(f[kFeatureObstacleClearance], 0.2 / 4.0, 1e-6);
  EXPECT_EQ(f[kFeatureObstacleSpeed], 0.0f);    // static
  EXPECT_EQ(f[kFeatureObstacleHeading], 0.0f);  // static: heading means nothing
}

TEST(State, FarAwayDefaultsWhenNoObstacleIsInRange) {
  Observation obs = knownScene();
  obs.obstacles[0].center = {1.0, 6.0};  // 5 m away
  const VelocitySpace d = buildDovs(obs, RobotLimits{}, DovsConfig{});
  StateNormalization n;
  const FeatureVector f = computeFeatures(d, obs, n);
  EXPECT_EQ(f[kFeatureObstacleHeading], n.far_heading);
  EXPECT_EQ(f[kFeatureObstacleSpeed], n.far_speed);
  EXPECT_EQ(f[kFeatureObstacleBearing], n.far_bearing);
  EXPECT_EQ(f[kFeatureObstacleClearance], n.far_clearance);
  n.far_clearance = 0.75f;
  EXPECT_EQ(computeFeatures(d, obs, n)[kFeatureObstacleClearance], 0.75f);
}

TEST(State, FeaturesAreClamped) {
  Observation obs = knownScene();
  obs.goal = {1.0, 60.0};
  obs.robot_twist = {0.9, -7.0};
  const VelocitySpace d = buildDovs(obs, RobotLimits{}, DovsConfig{});
  const FeatureVector f = computeFeatures(d, obs, StateNormalization{});
  EXPECT_EQ(f[kFeatureGoalDistance], 1.0f);
  EXPECT_EQ(f[kFeatureV], 1.0f);
  EXPECT_EQ(f[kFeatureW], -1.0f);
  for (float x : f) EXPECT_LE(std::abs(x), 1.0f);
}

TEST(State, LayoutIsGridRowMajorThenFeatures) {
  const Observation obs = knownScene();
  const VelocitySpace d = buildDovs(obs, RobotLimits{}, DovsConfig{});
  const StateVector s = buildState(d, obs, StateNormalization{});
  static_assert(StateVector::RowsAtCompileTime == 408, "state size");
  for (int r = 0; r < 20; ++r)
    for (int c = 0; c < 20; ++c) EXPECT_EQ(s(r * 20 + c), d.gridCell(r, c));
  const FeatureVector f = computeFeatures(d, obs, StateNormalization{});
  for (int i = 0; i < 8; ++i) EXPECT_EQ(s(400 + i), f[static_cast<size_t>(i)]);
  for (int i = 0; i < 400; ++i) EXPECT_TRUE(s(i) == 1.0f || s(i) == -1.0f);
}

TEST(State, WrongGridSizeOrNonFiniteInputIsAnError) {
  const Observation obs = knownScene();
  DovsConfig c;
  c.grid_size = 10;
  const VelocitySpace small = buildDovs(obs, RobotLimits{}, c);
  EXPECT_THROW(buildState(small, obs, StateNormalization{}), StateError);
  const VelocitySpace d = buildDovs(obs, RobotLimits{}, DovsConfig{});
  Observation bad = obs;
  bad.goal.x() = std::nan("");
  EXPECT_THROW(buildState(d, bad, StateNormalization{}), StateError);
  bad = obs;
  bad.robot_twist.w = std::numeric_limits<double>::infinity();
  EXPECT_THROW(computeFeatures(d, bad, StateNormalization{}), StateError);
  StateNormalization n;
  n.obstacle_speed_scale_mps = 0.0f;
  try {
    computeFeatures(d, obs, n);
    FAIL();
  } catch (const StateError& e) {
    EXPECT_NE(std::string(e.what()).find("obstacle_speed_scale_mps"), std::string::npos);
  }
}

TEST(StateNormalization, FieldsRoundTripInAStableOrder) {
  StateNormalization n;
  n.goal_distance_scale_m = 12.5f;
  n.far_bearing = -1.0f;
  const auto fields = n.fields();
  ASSERT_EQ(fields.size(), static_cast<size_t>(StateNormalization::kNumFields));
  EXPECT_EQ(fields.front().first, "v_scale_mps");
  EXPECT_EQ(fields.back().first, "clip");
  const StateNormalization back = StateNormalization::fromFields(fields);
  EXPECT_EQ(back.goal_distance_scale_m, 12.5f);
  EXPECT_EQ(back.far_bearing, -1.0f);
  EXPECT_EQ(back.validate(), "");
  auto renamed = fields;
  renamed[2].first = "goal_scale";
  EXPECT_THROW(StateNormalization::fromFields(renamed), StateError);
  auto shorter = fields;
  shorter.pop_back();
  EXPECT_THROW(StateNormalization::fromFields(shorter), StateError);
  StateNormalization bad;
  bad.far_clearance = 2.0f;
  EXPECT_NE(bad.validate().find("far_clearance"), std::string::npos);
}

}  // namespace
}  // namespace dqn_dovs
