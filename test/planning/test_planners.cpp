// S-DOVS, DQN-DOVS planner wrapper, the planner factory and the deceleration fallback.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include "dqn_dovs/evaluation/episode.h"
#include "dqn_dovs/planning/dqn_dovs_planner.h"
#include "dqn_dovs/planning/planner.h"
#include "dqn_dovs/planning/s_dovs.h"
#include "dqn_dovs/policy/action_shield.h"
#include "dqn_dovs/sim/scenario.h"
#include "source_paths.h"

namespace dqn_dovs {
namespace {

const std::string kModel = std::string(DQN_DOVS_SOURCE_DIR) + "/models/dqn_dovs.dqnw";

EpisodeConfig perfectInfo() {
  EpisodeConfig c;
  c.perfect_info = true;
  return c;
}

sim::Scenario emptyRoom(const Pose2& start, const Vec2& goal) {
  sim::Scenario s;
  s.name = "empty room";
  s.robot_start = start;
  s.goal = goal;
  return s;
}

/// Drives `ep` with `planner` to the end; returns the number of decisions.
int drive(Episode& ep, Planner& planner) {
  int n = 0;
  while (!ep.done()) {
    ep.step(planner.decide(ep.plannerInput()).command);
    ++n;
  }
  return n;
}

TEST(SDovs, ReachesAndStopsOnTheGoalInAnEmptyRoom) {
  struct Case {
    Pose2 start;
    Vec2 goal;
  };
  // Ahead, to the side, and behind the robot (it must turn first).
  const Case cases[] = {
      {{-3.0, 0.0, 0.0}, {3.0, 0.5}}, {{-2.0, -2.0, 0.0}, {-1.0, 2.5}}, {{2.0, 0.0, 0.0}, {-2.5, -1.0}}};
  for (const Case& c : cases) {
    Episode ep(perfectInfo());
    ep.reset(emptyRoom(c.start, c.goal), 1);
    SDovsPlanner planner;
    drive(ep, planner);
    ASSERT_EQ(ep.outcome(), Outcome::kSuccess)
        << "goal (" << c.goal.transpose() << ") after " << ep.steps() << " steps";
    EXPECT_LT((ep.world().robotPose().position() - c.goal).norm(), 0.15);
    EXPECT_LT(ep.world().robotTwist().v, 0.2);
    // Straight-line distance at top speed is a lower bound; a sensible path takes well under twice that plus turning.
    const double d = (c.start.position() - c.goal).norm();
    EXPECT_LT(ep.time_s(), 2.0 * d / 0.7 + 4.0);
    EXPECT_LT(ep.pathLength_m(), 1.4 * d);
  }
}

TEST(SDovs, BrakingCapAllowsStoppingOnTheGoal) {
  SDovsPlanner planner;
  RobotLimits limits;
  EXPECT_NEAR(planner.brakingSpeedCap(10.0, limits), limits.v_max, 1e-12);
  EXPECT_LE(planner.brakingSpeedCap(0.12, limits), 0.15 + 1e-12);
  EXPECT_LT(planner.brakingSpeedCap(0.05, limits), 0.15);
  // Braking at the planned fraction of a_v from the cap ends at the arrival speed.
  const double d = 0.5, v = planner.brakingSpeedCap(d, limits);
  ASSERT_LT(v, limits.v_max);
  const SDovsConfig& c = planner.config();
  EXPECT_NEAR(v * v - c.arrival_speed_mps * c.arrival_speed_mps,
              2.0 * c.braking_fraction * limits.a_v * (d - c.arrival_distance_m), 1e-9);
  EXPECT_EQ(planner.brakingSpeedCap(std::numeric_limits<double>::quiet_NaN(), limits), 0.0);
}

TEST(SDovs, NeverPicksAnUnsafeVelocityWhenTheWindowHasAFreeOne) {
  SDovsPlanner planner;
  sim::GeneratorConfig g;
  g.goal_distance_min_m = 4.0;
  int checked_with_free = 0, decisions = 0;
  for (int n : {4, 10, 15}) {
    g.obstacle_count_min = g.obstacle_count_max = n;
    for (uint64_t seed = 1; seed <= 4; ++seed) {
      Episode ep(perfectInfo());
      ep.reset(sim::generateScenario(g, seed * 97 + static_cast<uint64_t>(n)), seed);
      while (!ep.done()) {
        const PlannerInput in = ep.plannerInput();
        const PlannerDecision d = planner.decide(in);
        const Twist2 current = in.limits.clipToFeasible(ep.observation().robot_twist);
        const DynamicWindow dw = makeDynamicWindow(current, in.limits);
        ASSERT_TRUE(dw.contains(d.command, in.limits, 1e-6))
            << "command (" << d.command.v << ", " << d.command.w << ") outside the window, note " << d.note;
        bool any_free = false;
        for (const Twist2& s : planner.windowSamples(current, in.limits)) any_free = any_free || ep.dovs().isFree(s);
        if (any_free) {
          ++checked_with_free;
          ASSERT_TRUE(ep.dovs().isFree(d.command)) << "strategy " << d.note << " picked an unsafe velocity";
        }
        EXPECT_FALSE(d.note.empty());
        ++decisions;
        ep.step(d.command);
      }
    }
  }
  EXPECT_GT(checked_with_free, 200);
  EXPECT_GT(decisions, checked_with_free - 1);
}

TEST(SDovs, BadInputAndConfigurationAreNamed) {
  SDovsPlanner planner;
  PlannerInput empty;
  try {
    planner.decide(empty);
    FAIL() << "no error for a missing observation";
  } catch (const PlannerError& e) {
    EXPECT_NE(std::string(e.what()).find("observation"), std::string::npos) << e.what();
  }
  Episode ep(perfectInfo());
  ep.reset(emptyRoom({0.0, 0.0, 0.0}, {2.0, 0.0}), 1);
  Observation obs = ep.observation();
  obs.goal.x() = std::numeric_limits<double>::quiet_NaN();
  PlannerInput in = ep.plannerInput();
  in.observation = &obs;
  EXPECT_THROW(planner.decide(in), PlannerError);

  SDovsConfig bad;
  bad.braking_fraction = 0.0;
  EXPECT_NE(bad.validate().find("braking_fraction"), std::string::npos);
  bad = SDovsConfig();
  bad.rollout_step_s = std::numeric_limits<double>::infinity();
  EXPECT_NE(bad.validate().find("rollout_step_s"), std::string::npos);
  EXPECT_THROW(SDovsPlanner{bad}, PlannerError);
  EXPECT_TRUE(SDovsConfig().validate().empty());
}

TEST(SDovs, StopsOnTheGoalWhenAlreadyThere) {
  Episode ep(perfectInfo());
  ep.reset(emptyRoom({0.0, 0.0, 0.0}, {0.1, 0.0}), 1);
  SDovsPlanner planner;
  const PlannerDecision d = planner.decide(ep.plannerInput());
  EXPECT_EQ(d.note, "stop_on_goal");
  EXPECT_NEAR(d.command.v, 0.0, 1e-12);
}

TEST(PlannerFactory, BuildsKnownNamesAndRejectsOthers) {
  const std::vector<std::string> names = plannerNames();
  ASSERT_NE(std::find(names.begin(), names.end(), "s_dovs"), names.end());
  ASSERT_NE(std::find(names.begin(), names.end(), "dqn_dovs"), names.end());
  EXPECT_EQ(makePlanner("s_dovs")->name(), "s_dovs");
  EXPECT_EQ(makePlanner("dqn_dovs", kModel)->name(), "dqn_dovs");
  try {
    makePlanner("teleport");
    FAIL() << "no error for an unknown planner";
  } catch (const PlannerError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("teleport"), std::string::npos) << what;
    EXPECT_NE(what.find("s_dovs"), std::string::npos) << what;
    EXPECT_NE(what.find("dqn_dovs"), std::string::npos) << what;
  }
  try {
    makePlanner("dqn_dovs", "/nonexistent/model.dqnw");
    FAIL() << "no error for a missing weight file";
  } catch (const PlannerError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/model.dqnw"), std::string::npos) << e.what();
  }
}

TEST(DqnDovsPlanner, ChoosesAValidActionAndDeceleratesOnBadState) {
  DqnDovsConfig config;
  config.model_path = kModel;
  DqnDovsPlanner planner(config);
  Episode ep(perfectInfo());
  ep.reset(emptyRoom({-2.0, 0.0, 0.0}, {2.0, 1.0}), 1);
  ep.step(Twist2{0.1, 0.0});
  ep.step(Twist2{0.2, 0.0});
  PlannerInput in = ep.plannerInput();
  const PlannerDecision d = planner.decide(in);
  ASSERT_GE(d.action, 0);
  ASSERT_LT(d.action, kNumActions);
  EXPECT_TRUE(ep.actions().valid[static_cast<size_t>(d.action)]);
  EXPECT_DOUBLE_EQ(d.command.v, ep.actions().velocities[static_cast<size_t>(d.action)].v);
  EXPECT_DOUBLE_EQ(d.command.w, ep.actions().velocities[static_cast<size_t>(d.action)].w);

  const Twist2 slow = decelerationCommand(ep.observation().robot_twist, in.limits);
  Eigen::VectorXf nan_state = ep.state();
  nan_state[3] = std::numeric_limits<float>::quiet_NaN();
  in.state = &nan_state;
  PlannerDecision bad = planner.decide(in);
  EXPECT_EQ(bad.action, -1);
  EXPECT_DOUBLE_EQ(bad.command.v, slow.v);
  EXPECT_NE(bad.note.find("decelerate"), std::string::npos);

  in = ep.plannerInput();
  ActionSet none = ep.actions();
  none.valid.fill(false);
  in.actions = &none;
  bad = planner.decide(in);
  EXPECT_EQ(bad.action, -1);
  EXPECT_NE(bad.note.find("masked"), std::string::npos) << bad.note;

  in = ep.plannerInput();
  Eigen::VectorXf short_state = Eigen::VectorXf::Zero(10);
  in.state = &short_state;
  EXPECT_EQ(planner.decide(in).action, -1);
  in.state = nullptr;
  EXPECT_EQ(planner.decide(in).action, -1);
}

TEST(DqnDovsPlanner, ChoosesOnlyAmongShieldedActionsAndTheAblationDoesNot) {
  DqnDovsConfig config;
  config.model_path = kModel;
  DqnDovsPlanner shielded(config);
  config.shield.enabled = false;
  DqnDovsPlanner unshielded(config);
  EXPECT_EQ(shielded.name(), "dqn_dovs");
  EXPECT_EQ(unshielded.name(), "dqn_dovs_unshielded");
  sim::GeneratorConfig g;
  g.goal_distance_min_m = 4.0;
  g.obstacle_count_min = g.obstacle_count_max = 12;
  int decisions = 0, narrowed = 0, outside_shield = 0, escapes = 0;
  for (uint64_t seed = 1; seed <= 6; ++seed) {
    Episode ep(EpisodeConfig{});
    ep.reset(sim::generateScenario(g, seed), seed);
    while (!ep.done() && ep.steps() < 150) {
      const PlannerInput in = ep.plannerInput();
      const ShieldedMask m = shieldActions(ep.actions(), ep.dovs(), ep.observation(), ActionShieldConfig{});
      const PlannerDecision d = shielded.decide(in);
      if (m.has_escape) {
        // Boxed in: the shield's escape velocity, not an action.
        ASSERT_TRUE(m.level == ShieldLevel::kLatest || m.level == ShieldLevel::kStatic) << shieldLevelName(m.level);
        EXPECT_EQ(d.action, -1);
        EXPECT_EQ(d.note, std::string("escape (shield: ") + shieldLevelName(m.level) + ", " +
                              escapeTierName(m.escape_tier) + ")");
        EXPECT_EQ(d.command.v, m.escape.v);
        EXPECT_EQ(d.command.w, m.escape.w);
        ++escapes;
        ++decisions;
        ep.step(d.command);
        continue;
      }
      ASSERT_GE(d.action, 0) << d.note;
      ASSERT_TRUE(m.mask[static_cast<size_t>(d.action)]) << "seed " << seed << " step " << ep.steps() << ": " << d.note;
      EXPECT_NE(d.note.find(std::string("shield: ") + shieldLevelName(m.level)), std::string::npos) << d.note;
      const PlannerDecision u = unshielded.decide(in);
      ASSERT_GE(u.action, 0) << u.note;
      ASSERT_TRUE(ep.actions().valid[static_cast<size_t>(u.action)]);
      outside_shield += m.mask[static_cast<size_t>(u.action)] ? 0 : 1;
      narrowed += m.numAllowed() < ep.actions().numValid() ? 1 : 0;
      ++decisions;
      ep.step(d.command);
    }
  }
  EXPECT_GT(decisions, 100);
  EXPECT_GT(narrowed, 0) << "12 moving obstacles and the shield never removed an action";
  EXPECT_GT(escapes, 0) << "12 moving obstacles and the robot was never boxed in";
  // Without the shield, the network does pick actions the shield forbids (that is what the shield is for).
  EXPECT_GT(outside_shield, 0);
}

TEST(DqnDovsPlanner, RejectsANetworkTrainedWithAnotherNormalisation) {
  DqnDovsConfig config;
  config.model_path = kModel;
  config.normalization.goal_distance_scale_m = 3.0f;
  try {
    DqnDovsPlanner planner(config);
    FAIL() << "no error for a normalisation mismatch";
  } catch (const PlannerError& e) {
    EXPECT_NE(std::string(e.what()).find("goal_distance_scale_m"), std::string::npos) << e.what();
  }
}

TEST(DecelerationCommand, SlowsDownFastestInsideTheWindow) {
  const RobotLimits limits;
  const Twist2 a = decelerationCommand({0.5, 0.5}, limits);
  EXPECT_NEAR(a.v, 0.4, 1e-12);
  EXPECT_NEAR(a.w, 0.5, 1e-12);
  // Less than dv of speed left: the rest of the window's budget stops the turning.
  const Twist2 b = decelerationCommand({0.05, 1.0}, limits);
  EXPECT_NEAR(b.v, 0.0, 1e-12);
  EXPECT_NEAR(b.w, 1.0 - 0.5 * limits.dw(), 1e-12);
  const Twist2 c = decelerationCommand({0.0, -0.3}, limits);
  EXPECT_NEAR(c.w, 0.0, 1e-12);
  for (const Twist2& from : {Twist2{0.5, 0.5}, Twist2{0.05, 1.0}, Twist2{0.0, -0.3}, Twist2{0.7, 0.0}}) {
    const Twist2 to = decelerationCommand(from, limits);
    EXPECT_TRUE(makeDynamicWindow(from, limits).contains(to, limits, 1e-9));
  }
  const Twist2 n = decelerationCommand({std::numeric_limits<double>::quiet_NaN(), 0.0}, limits);
  EXPECT_EQ(n.v, 0.0);
  EXPECT_EQ(n.w, 0.0);
}

}  // namespace
}  // namespace dqn_dovs
