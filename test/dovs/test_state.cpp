// The 408-float network state: grid layout, features of known scenes, far-away defaults, normalisation.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "dqn_dovs/dovs/actions.h"
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
  ASSERT_EQ(s.size(), 408);
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

// The earliest time the constant velocity `cell` from the origin comes within `r` of `at(t)`, by 1 ms steps
// (a finer, independent roll-out than gradedGrid's 0.1 s); `horizon` when it does not.
template <class Where>
double fineContact(const Twist2& cell, Where at, double r, double horizon) {
  for (double t = 0.001; t <= horizon; t += 0.001) {
    const Vec2 p = integrateUnicycle(Pose2{0.0, 0.0, 0.0}, cell.v, cell.w, t).position();
    if ((p - at(t)).norm() < r) return t;
  }
  return horizon;
}

Observation emptyScene() {
  Observation obs;
  obs.robot_pose = {0.0, 0.0, 0.0};
  obs.goal = {5.0, 0.0};
  return obs;
}

TEST(GradedGrid, EmptySceneIsOneWhereFeasibleAndMinusOneElsewhere) {
  const Observation obs = emptyScene();
  const VelocitySpace d = buildDovs(obs, RobotLimits{}, DovsConfig{});
  const std::vector<float> g = gradedGrid(d, obs, 5.0);
  ASSERT_EQ(g.size(), d.grid().size());
  int feasible = 0;
  for (int r = 0; r < 20; ++r) {
    for (int c = 0; c < 20; ++c) {
      const bool ok = d.isFeasible(d.gridCellVelocity(r, c));
      feasible += ok;
      EXPECT_EQ(g[static_cast<size_t>(r * 20 + c)], ok ? 1.0f : -1.0f) << r << "," << c;
    }
  }
  EXPECT_GT(feasible, 100);
}

TEST(GradedGrid, StaticDiscAheadGivesItsContactTimeWithTheDovsSign) {
  Observation obs = emptyScene();
  MovingObstacle o;
  o.center = {1.6, 0.1};
  o.radius = 0.25;
  o.is_static = true;
  obs.obstacles.push_back(o);
  const RobotLimits limits;
  const DovsConfig config;
  const VelocitySpace d = buildDovs(obs, limits, config);
  const double horizon = 5.0;
  const std::vector<float> g = gradedGrid(d, obs, horizon);
  const double r = (o.radius + limits.radius) * config.safety_factor;
  int checked = 0, sooner_when_faster = 0;
  for (int c = 0; c < 20; ++c) {
    double previous = -1.0;  // contact time of the row below (slower), same column
    for (int row = 19; row >= 0; --row) {
      const Twist2 cell = d.gridCellVelocity(row, c);
      const float value = g[static_cast<size_t>(row * 20 + c)];
      if (!d.isFeasible(cell)) {
        EXPECT_EQ(value, -1.0f);
        continue;
      }
      const bool free = d.gridCell(row, c) > 0.0f;
      EXPECT_EQ(value > 0.0f, free) << row << "," << c << " value " << value;
      const double t = (free ? value : value + 1.0f) * horizon;
      const double exact = fineContact(
          cell, [&](double) { return o.center; }, r, horizon);
      // The 0.1 s roll-out finds the first step at or after the true contact.
      EXPECT_GE(t, exact - 1e-3) << row << "," << c;
      EXPECT_LE(t, exact + 0.1 + 1e-3) << row << "," << c;
      if (exact < horizon) {
        ++checked;
        if (previous >= 0.0 && t <= previous + 1e-6) ++sooner_when_faster;
        previous = t;
      }
    }
  }
  EXPECT_GT(checked, 12);            // the disc is hit by many velocities, and
  EXPECT_GT(sooner_when_faster, 6);  // the faster, the sooner
}

TEST(GradedGrid, MovingObstacleIsRolledForwardAndWallsCount) {
  Observation obs = emptyScene();
  MovingObstacle o;
  o.center = {3.0, 0.0};
  o.radius = 0.25;
  o.heading = kPi;  // coming straight at the robot
  o.speed = 0.8;
  obs.obstacles.push_back(o);
  const RobotLimits limits;
  const DovsConfig config;
  const VelocitySpace d = buildDovs(obs, limits, config);
  const std::vector<float> g = gradedGrid(d, obs, 5.0);
  const double r = (o.radius + limits.radius) * config.safety_factor;
  const int row = 1, col = 10;  // fast, nearly straight
  const Twist2 cell = d.gridCellVelocity(row, col);
  ASSERT_TRUE(d.isFeasible(cell));
  const double exact = fineContact(
      cell, [&](double t) { return Vec2(o.center.x() - o.speed * t, o.center.y()); }, r, 5.0);
  ASSERT_LT(exact, 2.5);  // closing at about 1.45 m/s from 2.5 m of clearance
  const double t = (g[static_cast<size_t>(row * 20 + col)] + 1.0f) * 5.0;  // unsafe
  EXPECT_GE(t, exact - 1e-3);
  EXPECT_LE(t, exact + 0.1 + 1e-3);

  // A wall 1.5 m ahead, across the robot's way.
  Observation walled = emptyScene();
  walled.segments.push_back(Segment{Vec2(1.5, -3.0), Vec2(1.5, 3.0)});
  const VelocitySpace dw = buildDovs(walled, limits, config);
  const std::vector<float> gw = gradedGrid(dw, walled, 5.0);
  const float value = gw[static_cast<size_t>(row * 20 + col)];
  EXPECT_EQ(value > 0.0f, dw.gridCell(row, col) > 0.0f);                          // free while it can still brake
  const double expected = (1.5 - limits.radius * config.safety_factor) / cell.v;  // nearly straight
  EXPECT_NEAR((value > 0.0f ? value : value + 1.0f) * 5.0, expected, 0.15);
}

TEST(GradedGrid, BuildStateUsesItWhenTheNormalisationAsks) {
  Observation obs = knownScene();
  MovingObstacle ahead;  // 1.5 m ahead of the robot, coming closer
  ahead.center = {1.0, 2.5};
  ahead.radius = 0.3;
  ahead.heading = -kPi / 2;
  ahead.speed = 0.5;
  obs.obstacles.push_back(ahead);
  DovsConfig config;
  const VelocitySpace d = buildDovs(obs, RobotLimits{}, config);
  const StateVector plain = buildState(d, obs, stateNormalization(RobotLimits{}, config));
  for (int i = 0; i < kStateGridCells; ++i) EXPECT_EQ(plain(i), d.grid()[static_cast<size_t>(i)]);
  config.grid_contact_horizon_s = 4.0;
  const StateNormalization graded = stateNormalization(RobotLimits{}, config);
  EXPECT_FLOAT_EQ(graded.grid_contact_horizon_s, 4.0f);
  const StateVector s = buildState(d, obs, graded);
  const std::vector<float> g = gradedGrid(d, obs, 4.0);
  int differ = 0;
  for (int i = 0; i < kStateGridCells; ++i) {
    EXPECT_EQ(s(i), g[static_cast<size_t>(i)]);
    differ += s(i) != plain(i);
    EXPECT_EQ(s(i) > 0.0f, plain(i) > 0.0f) << i;  // same signs
  }
  EXPECT_GT(differ, 0);
  for (int i = kStateGridCells; i < kStateSize; ++i) EXPECT_EQ(s(i), plain(i));  // same features
  EXPECT_THROW(gradedGrid(d, obs, 0.2), StateError);
}

TEST(StateNormalization, GradedGridAddsANamedFourteenthField) {
  StateNormalization n;
  n.grid_contact_horizon_s = 5.0f;
  const auto fields = n.fields();
  ASSERT_EQ(fields.size(), static_cast<size_t>(StateNormalization::kNumFields) + 1);
  EXPECT_EQ(fields.back().first, "grid_contact_horizon_s");
  EXPECT_EQ(StateNormalization::fromFields(fields).grid_contact_horizon_s, 5.0f);
  auto renamed = fields;
  renamed.back().first = "grid_horizon";
  try {
    StateNormalization::fromFields(renamed);
    FAIL();
  } catch (const StateError& e) {
    EXPECT_NE(std::string(e.what()).find("grid_horizon"), std::string::npos) << e.what();
  }
  std::vector<float> values;
  for (const auto& f : fields) values.push_back(f.second);
  StateNormalization back;
  std::string why;
  ASSERT_TRUE(StateNormalization::fromValues(values, back, why)) << why;
  EXPECT_EQ(back.fields(), fields);
  values.pop_back();
  ASSERT_TRUE(StateNormalization::fromValues(values, back, why)) << why;
  EXPECT_EQ(back.grid_contact_horizon_s, 0.0f);  // 13 values: the +1 / -1 grid
  values.pop_back();
  EXPECT_FALSE(StateNormalization::fromValues(values, back, why));
  EXPECT_NE(why.find("12 values"), std::string::npos) << why;
  n.grid_contact_horizon_s = 0.2f;
  EXPECT_NE(n.validate().find("grid_contact_horizon_s"), std::string::npos);
  DovsConfig c;
  EXPECT_EQ(setDovsParameter(c, "grid_contact_horizon", "5"), "");
  EXPECT_EQ(c.grid_contact_horizon_s, 5.0);
  EXPECT_EQ(c.validate(), "");
  c.grid_contact_horizon_s = 40.0;
  EXPECT_NE(c.validate().find("grid_contact_horizon_s"), std::string::npos);
}

// The previous action (docs/dovs.md "The previous action"): a one-hot of the previous choice after the features.
TEST(PreviousAction, TheStateEndsWithAOneHotOfThePreviousChoice) {
  const Observation obs = knownScene();
  DovsConfig config;
  config.previous_action = 1;
  ASSERT_EQ(config.validate(), "");
  const VelocitySpace d = buildDovs(obs, RobotLimits{}, config);
  const StateNormalization norm = stateNormalization(RobotLimits{}, config);
  EXPECT_EQ(norm.previous_action, 1);
  EXPECT_EQ(norm.featureInputs(), 17);
  EXPECT_EQ(norm.fields(), stateNormalization(RobotLimits{}, DovsConfig{}).fields());  // a layout, not an entry
  const StateVector plain = buildState(d, obs, stateNormalization(RobotLimits{}, DovsConfig{}));
  const StateVector none = buildState(d, obs, norm);  // an episode's first decision
  ASSERT_EQ(none.size(), stateSize(1, true));
  ASSERT_EQ(none.size(), 417);
  EXPECT_EQ(none.head(408), plain);
  EXPECT_TRUE(none.tail(9).isZero());
  for (int choice = 0; choice <= kPreviousChoiceOther; ++choice) {
    const StateVector s = buildState(d, obs, norm, nullptr, choice);
    EXPECT_EQ(s.head(408), plain);
    for (int k = 0; k < 9; ++k) EXPECT_EQ(s(408 + k), k == choice ? 1.0f : 0.0f) << choice << " " << k;
  }
  EXPECT_THROW(buildState(d, obs, norm, nullptr, 9), StateError);
  EXPECT_THROW(buildState(d, obs, norm, nullptr, -2), StateError);
  // Without the option the choice is ignored, and the state is the paper's.
  EXPECT_EQ(buildState(d, obs, stateNormalization(RobotLimits{}, DovsConfig{}), nullptr, 3), plain);
  StateNormalization bad = norm;
  bad.previous_action = 2;
  EXPECT_NE(bad.validate().find("previous_action"), std::string::npos);
  config.previous_action = 2;
  EXPECT_NE(config.validate().find("previous_action"), std::string::npos);
}

}  // namespace
}  // namespace dqn_dovs

namespace dqn_dovs {
namespace {

// Row and column of the grid cell holding velocity t (the grid's own convention: row 0 = highest v).
std::pair<int, int> cellOf(const Twist2& t, const RobotLimits& l) {
  const int row = std::clamp(static_cast<int>(std::floor((l.v_max - t.v) / l.v_max * 20.0)), 0, 19);
  const int col = std::clamp(static_cast<int>(std::floor((t.w + l.w_max) / (2.0 * l.w_max) * 20.0)), 0, 19);
  return {row, col};
}

TEST(GridChannels, TheWindowChannelIsTheCellsTheRhombusReaches) {
  const RobotLimits limits;
  for (const Twist2& now : {Twist2{0.35, 0.0}, Twist2{0.0, 0.0}, Twist2{0.6, -0.2}, Twist2{0.2, 2.0}}) {
    Observation obs = knownScene();
    obs.robot_twist = now;
    const VelocitySpace d = buildDovs(obs, limits, DovsConfig{});
    const std::vector<float> ch = windowGoalChannels(d, obs);
    ASSERT_EQ(ch.size(), 800u);
    // Independently: every cell a fine lattice of the rhombus falls in is marked, and nothing else.
    const DynamicWindow win = makeDynamicWindow(limits.clipToFeasible(now), limits);
    std::vector<int> hit(400, 0);
    for (int i = -200; i <= 200; ++i) {
      for (int j = -200; j <= 200; ++j) {
        const double a = i / 200.0, b = j / 200.0;
        if (std::abs(a) + std::abs(b) > 1.0) continue;
        const Twist2 t{win.center.v + a * win.dv, win.center.w + b * win.dw};
        if (t.v < 0.0 || t.v > limits.v_max || std::abs(t.w) > limits.w_max) continue;
        const auto [r, c] = cellOf(t, limits);
        hit[static_cast<size_t>(r * 20 + c)] = 1;
      }
    }
    int marked = 0;
    for (int i = 0; i < 400; ++i) {
      EXPECT_EQ(ch[static_cast<size_t>(i)] > 0.0f, hit[static_cast<size_t>(i)] == 1) << "cell " << i;
      EXPECT_TRUE(ch[static_cast<size_t>(i)] == 1.0f || ch[static_cast<size_t>(i)] == -1.0f);
      marked += ch[static_cast<size_t>(i)] > 0.0f;
    }
    EXPECT_GE(marked, 2);
    // The valid actions are all in the window's cells.
    const ActionSet actions = computeActions(now, obs.robot_pose.toLocal(obs.goal), limits);
    for (int a = 0; a < kNumActions; ++a) {
      if (!actions.valid[static_cast<size_t>(a)]) continue;
      const auto [r, c] = cellOf(actions.velocities[static_cast<size_t>(a)], limits);
      EXPECT_EQ(ch[static_cast<size_t>(r * 20 + c)], 1.0f) << "action " << a;
    }
  }
}

TEST(GridChannels, TheGoalChannelIsTheLineThroughTheGoal) {
  const RobotLimits limits;
  Observation obs = knownScene();  // facing +y from (1, 1)
  for (const Vec2& goal : {Vec2{0.0, 3.0}, Vec2{2.5, 1.8}, Vec2{1.2, 1.3}, Vec2{-0.4, 4.5}}) {
    obs.goal = goal;
    const VelocitySpace d = buildDovs(obs, limits, DovsConfig{});
    const std::vector<float> ch = windowGoalChannels(d, obs);
    const GoalLine line = goalLine(obs.robot_pose.toLocal(goal));
    ASSERT_EQ(line.kind, GoalLine::Kind::kArc);
    // Sampled along w = k v: the cells the line passes through or touches (the line starts at the corner of the
    // two middle columns of the bottom row, so both sides of each sample are looked at), and no others.
    std::vector<int> hit(400, 0);
    for (int i = 0; i <= 100000; ++i) {
      const double v = limits.v_max * i / 100000.0, w = line.curvature_1pm * v;
      if (std::abs(w) > limits.w_max) continue;
      for (const double side : {-1e-10, 1e-10}) {
        const auto [r, c] = cellOf({v, w + side}, limits);
        hit[static_cast<size_t>(r * 20 + c)] = 1;
      }
    }
    int marked = 0, mismatched = 0;
    for (int i = 0; i < 400; ++i) {
      marked += ch[static_cast<size_t>(400 + i)] > 0.0f;
      mismatched += (ch[static_cast<size_t>(400 + i)] > 0.0f) != (hit[static_cast<size_t>(i)] == 1);
    }
    EXPECT_EQ(mismatched, 0) << "goal (" << goal.x() << ", " << goal.y() << ")";
    EXPECT_GE(marked, 1);
  }
  // Straight ahead: the middle columns' boundary (w = 0) from bottom to top.
  obs.goal = {1.0, 4.0};
  std::vector<float> ch = windowGoalChannels(buildDovs(obs, limits, DovsConfig{}), obs);
  for (int r = 0; r < 20; ++r) {
    EXPECT_EQ(ch[static_cast<size_t>(400 + r * 20 + 9)], 1.0f);
    EXPECT_EQ(ch[static_cast<size_t>(400 + r * 20 + 10)], 1.0f);
    EXPECT_EQ(ch[static_cast<size_t>(400 + r * 20 + 3)], -1.0f);
  }
  // Behind on the right: turning in place to the right, the bottom row's w < 0 half only.
  obs.goal = {1.5, -1.0};
  ch = windowGoalChannels(buildDovs(obs, limits, DovsConfig{}), obs);
  for (int i = 0; i < 400; ++i) {
    const bool expected = i / 20 == 19 && i % 20 < 10;
    EXPECT_EQ(ch[static_cast<size_t>(400 + i)] > 0.0f, expected) << i;
  }
  // At the goal: no line.
  obs.goal = obs.robot_pose.position();
  ch = windowGoalChannels(buildDovs(obs, limits, DovsConfig{}), obs);
  for (int i = 400; i < 800; ++i) EXPECT_EQ(ch[static_cast<size_t>(i)], -1.0f);
  obs.goal = {std::nan(""), 0.0};
  EXPECT_THROW(windowGoalChannels(buildDovs(knownScene(), limits, DovsConfig{}), obs), StateError);
}

TEST(GridChannels, BuildStateAppendsThemBeforeTheFeatures) {
  const Observation obs = knownScene();
  DovsConfig config;
  const VelocitySpace d = buildDovs(obs, RobotLimits{}, config);
  const StateVector plain = buildState(d, obs, stateNormalization(RobotLimits{}, config));
  EXPECT_EQ(setDovsParameter(config, "grid_channels", "3"), "");
  EXPECT_EQ(config.validate(), "");
  const StateNormalization norm = stateNormalization(RobotLimits{}, config);
  EXPECT_EQ(norm.grid_channels, 3);
  EXPECT_EQ(norm.fields(), StateNormalization{}.fields());  // a layout, not a normalisation entry
  const StateVector s = buildState(d, obs, norm);
  ASSERT_EQ(s.size(), stateSize(3));
  ASSERT_EQ(s.size(), 1208);
  const std::vector<float> extra = windowGoalChannels(d, obs);
  for (int i = 0; i < 400; ++i) EXPECT_EQ(s(i), plain(i));
  for (int i = 0; i < 800; ++i) EXPECT_EQ(s(400 + i), extra[static_cast<size_t>(i)]);
  for (int i = 0; i < 8; ++i) EXPECT_EQ(s(1200 + i), plain(400 + i));
  // With the graded grid too: the first channel is graded, the others the same.
  config.grid_contact_horizon_s = 5.0;
  const StateVector g = buildState(d, obs, stateNormalization(RobotLimits{}, config));
  ASSERT_EQ(g.size(), 1208);
  for (int i = 400; i < 1208; ++i) EXPECT_EQ(g(i), s(i));

  config.grid_channels = 4;
  EXPECT_NE(config.validate().find("grid_channels"), std::string::npos);
  StateNormalization bad;
  bad.grid_channels = 4;
  EXPECT_NE(bad.validate().find("grid_channels"), std::string::npos);
  EXPECT_THROW(buildState(d, obs, bad), StateError);
  EXPECT_NE(setDovsParameter(config, "grid_channels", "three"), "");
}

TEST(GridChannels, TheHistoryChannelIsThePreviousGrid) {
  const Observation obs = knownScene();
  DovsConfig config;
  config.grid_channels = kHistoryGridChannels;
  ASSERT_EQ(config.validate(), "");
  const VelocitySpace d = buildDovs(obs, RobotLimits{}, config);
  const StateNormalization norm = stateNormalization(RobotLimits{}, config);
  const StateVector first = buildState(d, obs, norm);  // no history yet: the grid itself
  ASSERT_EQ(first.size(), stateSize(2));
  for (int i = 0; i < 400; ++i) EXPECT_EQ(first(400 + i), first(i));
  std::vector<float> previous(400);
  for (int i = 0; i < 400; ++i) previous[static_cast<size_t>(i)] = i % 3 == 0 ? 1.0f : -1.0f;
  const StateVector s = buildState(d, obs, norm, &previous);
  for (int i = 0; i < 400; ++i) {
    EXPECT_EQ(s(i), d.grid()[static_cast<size_t>(i)]);
    EXPECT_EQ(s(400 + i), previous[static_cast<size_t>(i)]);
  }
  for (int i = 0; i < 8; ++i) EXPECT_EQ(s(800 + i), first(800 + i));
  previous.pop_back();
  EXPECT_THROW(buildState(d, obs, norm, &previous), StateError);
  previous.push_back(std::nanf(""));
  EXPECT_THROW(buildState(d, obs, norm, &previous), StateError);
}

// ---- person tokens and wall rays (docs/dovs.md "Person tokens") ------------------------------------------------

MovingObstacle walker(int id, double x, double y, double heading, double speed) {
  MovingObstacle o;
  o.id = id;
  o.center = Vec2(x, y);
  o.radius = 0.3;
  o.heading = heading;
  o.speed = speed;
  o.age_s = 2.5;
  o.position_sigma_m = 0.1;
  return o;
}

StateNormalization tokenLayout(int tokens, int rays) {
  StateNormalization n;
  n.person_tokens = tokens;
  n.wall_rays = rays;
  return n;  // positions over 4 m, speeds over 1.5 m/s
}

TEST(PersonTokens, NearestFirstInTheRobotFrameWithEmptySlotsLast) {
  Observation obs;
  obs.robot_pose = Pose2{1.0, 0.0, M_PI / 2};  // facing +y
  obs.obstacles = {walker(7, 1.0, 3.0, 0.0, 1.5), walker(3, 2.0, 0.0, M_PI, 0.0)};
  const std::vector<float> t = personTokens(obs, tokenLayout(3, 0));
  ASSERT_EQ(t.size(), 3u * kPersonTokenSize);
  // Nearest: the one 1 m to the robot's right (world +x is the robot's -y), standing.
  EXPECT_FLOAT_EQ(t[0], 1.0f);
  EXPECT_NEAR(t[1], 0.0, 1e-6);
  EXPECT_NEAR(t[2], -0.25, 1e-6);
  EXPECT_NEAR(t[3], 0.0, 1e-6);
  EXPECT_NEAR(t[5], 0.3, 1e-6);
  EXPECT_NEAR(t[12], 0.5, 1e-6);  // age 2.5 s over 5 s
  EXPECT_NEAR(t[13], 0.1, 1e-6);
  // Second: 3 m ahead, walking along world +x = the robot's right at 1.5 m/s; in 2 s it is 3 m to the right.
  const float* u = t.data() + kPersonTokenSize;
  EXPECT_FLOAT_EQ(u[0], 1.0f);
  EXPECT_NEAR(u[1], 0.75, 1e-6);
  EXPECT_NEAR(u[3], 0.0, 1e-6);
  EXPECT_NEAR(u[4], -1.0, 1e-6);
  EXPECT_NEAR(u[10], 0.75, 1e-6);
  EXPECT_NEAR(u[11], -0.75, 1e-6);
  // Without history the position 1 s before is the current one.
  EXPECT_NEAR(u[6], u[1], 1e-6);
  EXPECT_NEAR(u[7], u[2], 1e-6);
  for (int i = 2 * kPersonTokenSize; i < 3 * kPersonTokenSize; ++i) EXPECT_EQ(t[static_cast<size_t>(i)], 0.0f);
}

TEST(PersonTokens, HistoryGivesThePositionOneSecondBeforeAndAJumpBackForgetsIt) {
  TrackHistory history;
  Observation obs;
  for (int step = 0; step <= 5; ++step) {  // 0.2 s apart, walking +x at 1 m/s
    obs.obstacles = {walker(4, 1.0 + 0.2 * step, 0.0, 0.0, 1.0)};
    history.update(0.2 * step, obs.obstacles);
  }
  Vec2 before;
  ASSERT_TRUE(history.positionBefore(4, before));
  EXPECT_NEAR(before.x(), 1.0, 1e-9);  // at t = 0, 1 s before t = 1
  EXPECT_FALSE(history.positionBefore(9, before));
  const std::vector<float> t = personTokens(obs, tokenLayout(1, 0), &history);
  EXPECT_NEAR(t[1], 2.0 / 4.0, 1e-6);
  EXPECT_NEAR(t[6], 1.0 / 4.0, 1e-6);
  history.update(0.1, obs.obstacles);  // a new episode: time went back
  ASSERT_TRUE(history.positionBefore(4, before));
  EXPECT_NEAR(before.x(), 2.0, 1e-9);
  EXPECT_THROW(history.update(std::nan(""), obs.obstacles), StateError);
}

TEST(PersonTokens, ValuesAreClippedAndBadObstaclesRefused) {
  Observation obs;
  obs.obstacles = {walker(1, 40.0, 0.0, 0.0, 9.0)};
  const std::vector<float> t = personTokens(obs, tokenLayout(1, 0));
  EXPECT_FLOAT_EQ(t[1], kTokenClip);
  EXPECT_FLOAT_EQ(t[3], kTokenClip);
  obs.obstacles[0].speed = std::nan("");
  try {
    personTokens(obs, tokenLayout(1, 0));
    FAIL() << "a NaN speed was accepted";
  } catch (const StateError& e) {
    EXPECT_NE(std::string(e.what()).find("obstacle 0"), std::string::npos) << e.what();
  }
}

TEST(WallRays, DistanceToTheNearestWallAlongEachDirection) {
  Observation obs;
  obs.robot_pose = Pose2{0.0, 0.0, 0.0};
  obs.segments = {Segment{Vec2(2.0, -5.0), Vec2(2.0, 5.0)}, Segment{Vec2(-5.0, 1.0), Vec2(5.0, 1.0)}};
  const std::vector<float> r = wallRays(obs, tokenLayout(0, 4));
  ASSERT_EQ(r.size(), 4u);
  EXPECT_NEAR(r[0], 0.5, 1e-6);   // ahead: the wall at x = 2
  EXPECT_NEAR(r[1], 0.25, 1e-6);  // left: the wall at y = 1
  EXPECT_NEAR(r[2], 1.0, 1e-6);   // behind: none within 4 m
  EXPECT_NEAR(r[3], 1.0, 1e-6);
}

TEST(PersonTokens, TheStateGrowsByTheRaysAndTokensAfterTheFeatures) {
  StateNormalization n = tokenLayout(6, 8);
  EXPECT_EQ(n.stateSize(), 408 + 8 + 6 * kPersonTokenSize);
  EXPECT_TRUE(n.validate().empty()) << n.validate();
  n.person_tokens = kMaxPersonTokens + 1;
  EXPECT_NE(n.validate().find("person_tokens"), std::string::npos);
}

TEST(RoutePoints, EveryHalfMetreAlongTheRouteInTheRobotFrame) {
  Observation obs;
  obs.robot_pose = Pose2{1.0, 1.0, M_PI / 2};  // facing +y
  obs.goal = Vec2(9.0, 9.0);                   // the route's subgoal, not on the line below
  // Ahead 1 m, then a left turn (towards -x in the world), ending 0.5 m after the turn.
  obs.route_ahead = {Vec2(1.0, 1.0), Vec2(1.0, 2.0), Vec2(0.5, 2.0)};
  StateNormalization n;
  n.route_points = 4;
  const std::vector<float> r = routePoints(obs, n);
  ASSERT_EQ(r.size(), 8u);
  const float q = 1.0f / 4.0f;        // metres over the 4 m obstacle range
  EXPECT_NEAR(r[0], 0.5f * q, 1e-6);  // 0.5 m straight ahead
  EXPECT_NEAR(r[1], 0.0f, 1e-6);
  EXPECT_NEAR(r[2], 1.0f * q, 1e-6);  // 1 m: the corner
  EXPECT_NEAR(r[3], 0.0f, 1e-6);
  EXPECT_NEAR(r[4], 1.0f * q, 1e-6);  // 1.5 m: the end, 0.5 m to the left
  EXPECT_NEAR(r[5], 0.5f * q, 1e-6);
  EXPECT_NEAR(r[6], r[4], 1e-6);  // beyond the end: the end again
  EXPECT_NEAR(r[7], r[5], 1e-6);

  // Without a route: the straight line to the goal (here 45 degrees to the right of the heading).
  obs.route_ahead.clear();
  obs.goal = Vec2(3.0, 3.0);
  const std::vector<float> line = routePoints(obs, n);
  EXPECT_NEAR(line[0], 0.5f * q * std::sqrt(0.5f), 1e-6);
  EXPECT_NEAR(line[1], -0.5f * q * std::sqrt(0.5f), 1e-6);

  obs.route_ahead = {Vec2(1.0, 1.0), Vec2(std::nan(""), 2.0)};
  EXPECT_THROW(routePoints(obs, n), StateError);
}

TEST(RoutePoints, TheStateCarriesThemBetweenTheRaysAndTheTokens) {
  StateNormalization n = tokenLayout(2, 4);
  n.route_points = 3;
  EXPECT_EQ(n.stateSize(), 408 + 4 + 6 + 2 * kPersonTokenSize);
  EXPECT_TRUE(n.validate().empty()) << n.validate();
  Observation obs;
  obs.robot_pose = Pose2{0.0, 0.0, 0.0};
  obs.goal = Vec2(5.0, 0.0);
  const VelocitySpace d = buildDovs(obs, RobotLimits{}, DovsConfig{});
  const StateVector s = buildState(d, obs, n);
  ASSERT_EQ(s.size(), n.stateSize());
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(s(412 + 2 * k), 0.125f * (k + 1), 1e-6);  // 0.5, 1, 1.5 m ahead over 4 m
    EXPECT_NEAR(s(413 + 2 * k), 0.0f, 1e-6);
  }
  EXPECT_EQ(s(418), 0.0f);  // the first token: no obstacle, an empty slot
  n.route_points = kMaxRoutePoints + 1;
  EXPECT_NE(n.validate().find("route_points"), std::string::npos);
  DovsConfig config;
  config.route_points = 3;
  EXPECT_EQ(stateNormalization(RobotLimits{}, config).route_points, 3);
  EXPECT_TRUE(setDovsParameter(config, "route_points", "5").empty());
  EXPECT_EQ(config.route_points, 5);
  config.route_points = 17;
  EXPECT_NE(config.validate().find("route_points"), std::string::npos);
}

TEST(StateParameters, EveryDovsAndRobotParameterIsNamedAndHeldAgainstTheModels) {
  const RobotLimits limits;
  DovsConfig dovs;
  const std::string text = stateParametersText(limits, dovs);
  for (const std::string& name : dovsParameterNames()) {
    EXPECT_NE(text.find("dovs/" + name + "="), std::string::npos) << name;
  }
  EXPECT_NE(text.find("dovs/safety_factor=1.1 "), std::string::npos) << text;
  EXPECT_NE(text.find("robot/a_v=0.5 robot/a_w=2 robot/dt=0.2 robot/radius=0.2"), std::string::npos) << text;
  const std::string metadata = "training command: x\nstate parameters: " + text + "\nnote: y";
  EXPECT_EQ(stateParametersMismatch(metadata, limits, dovs), "");
  EXPECT_EQ(stateParametersMismatch("training command: x", limits, dovs), "") << "an older model names none";
  DovsConfig other = dovs;
  other.safety_factor = 1.5;
  other.num_trajectories = 33;
  const std::string why = stateParametersMismatch(metadata, limits, other);
  EXPECT_NE(why.find("dovs/safety_factor is 1.5 here, the model was trained with 1.1"), std::string::npos) << why;
  EXPECT_NE(why.find("dovs/num_trajectories is 33 here"), std::string::npos) << why;
  RobotLimits slower = limits;
  slower.a_v = 0.4;
  EXPECT_NE(stateParametersMismatch(metadata, slower, dovs).find("robot/a_v is 0.4 here"), std::string::npos);
  EXPECT_NE(stateParametersMismatch("state parameters: dovs/nonsense=3 dovs/safety_factor", limits, dovs)
                .find("'dovs/nonsense=3' cannot be read"),
            std::string::npos);
}

}  // namespace
}  // namespace dqn_dovs
