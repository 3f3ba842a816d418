// dovs_node's and planner_node's per-message steps around the action shield's escape: the Dovs message carries
// it when the robot is boxed in, and the planner's choice then is the escape velocity, not the network's.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>

#include "conversions.h"
#include "dqn_dovs/dovs/dovs.h"
#include "dqn_dovs/dovs/state.h"
#include "dqn_dovs/evaluation/episode.h"
#include "dqn_dovs/planning/dqn_dovs_planner.h"
#include "dqn_dovs/policy/action_shield.h"
#include "dqn_dovs/policy/qnetwork.h"
#include "dqn_dovs/policy/weight_file.h"
#include "dqn_dovs/sim/scenario.h"
#include "obstacle_test_helpers.h"
#include "pipeline_steps.h"
#include "source_paths.h"

namespace dqn_dovs {
namespace {

using test::movingDisc;

struct Step {
  DovsStep step;
  VelocitySpace space;
};

/// One dovs_node step at the origin, goal 4 m ahead, with dovs_node's DOVS configured as `config`.
Step build(const Twist2& current, const std::vector<MovingObstacle>& obstacles, const DovsConfig& config = {}) {
  const RobotLimits limits;
  DovsBuilder builder(limits, config);
  TrackedObstacleArray msg = movingObstaclesToMsg(obstacles, {});
  msg.header.stamp = ros::Time(10.0);
  msg.header.frame_id = "odom";
  Step s;
  const std::string error =
      buildDovsStep(msg, Pose2{}, current, Vec2(4.0, 0.0), limits, stateNormalization(limits, config),
                    ActionShieldConfig{}, "base_footprint", builder, s.space, s.step);
  EXPECT_EQ(error, "");
  return s;
}

TEST(PipelineSteps, TheMessageCarriesTheStaticGeometryForThePlannersLastCheck) {
  const RobotLimits limits;
  const DovsConfig config;
  DovsBuilder builder(limits, config);
  TrackedObstacleArray msg =
      movingObstaclesToMsg({movingDisc(0.9, 0.3), movingDisc(1.0, -0.5, kPi, 0.8)}, {Segment{{0.0, 0.8}, {2.0, 0.8}}});
  msg.header.stamp = ros::Time(10.0);
  msg.header.frame_id = "odom";
  Step s;
  const Pose2 robot{0.2, 0.0, 0.5};
  ASSERT_EQ(buildDovsStep(msg, robot, {0.3, 0.0}, Vec2(4.0, 0.0), limits, stateNormalization(limits, config),
                          ActionShieldConfig{}, "base_footprint", builder, s.space, s.step),
            "");
  const Dovs& d = s.step.msg;
  EXPECT_EQ(d.static_frame, "odom");
  ASSERT_EQ(d.static_segments.size(), 4u);    // the wall
  ASSERT_EQ(d.static_discs.size(), 3u);       // the static disc only
  EXPECT_NEAR(d.static_discs[0], 0.9, 1e-6);  // in the fixed frame, as tracked
  EXPECT_NEAR(d.static_discs[1], 0.3, 1e-6);
  // The planner sees the same geometry from where the robot is now.
  Observation seen;
  ASSERT_EQ(staticObservationFromDovs(d, "odom", robot, {0.3, 0.0}, seen), "");
  ASSERT_EQ(seen.segments.size(), 1u);
  ASSERT_EQ(seen.obstacles.size(), 1u);
  EXPECT_TRUE(seen.obstacles[0].is_static);
  const StaticScene from_msg(seen, limits, StaticSafetyConfig{});
  const StaticScene from_step(s.step.observation, limits, StaticSafetyConfig{});
  EXPECT_NEAR(from_msg.clearance(Vec2(0.3, 0.1)), from_step.clearance(Vec2(0.3, 0.1)), 1e-5);
  // Bad geometry is refused with a reason.
  EXPECT_NE(staticObservationFromDovs(d, "map", robot, {}, seen).find("'map'"), std::string::npos);
  Dovs odd = d;
  odd.static_segments.pop_back();
  EXPECT_NE(staticObservationFromDovs(odd, "odom", robot, {}, seen).find("multiple of 4"), std::string::npos);
  Dovs nan = d;
  nan.static_discs[2] = std::numeric_limits<float>::quiet_NaN();
  EXPECT_NE(staticObservationFromDovs(nan, "odom", robot, {}, seen).find("NaN"), std::string::npos);
}

QNetwork shippedNetwork() { return QNetwork::load(std::string(DQN_DOVS_SOURCE_DIR) + "/models/dqn_dovs.dqnw"); }

TEST(PipelineSteps, BoxedInTheMessageCarriesTheEscapeAndThePlannerHoldsIt) {
  // A disc coming head-on at 1 m/s, nearly touching: every velocity of the window is in its DOV.
  const Step s = build({0.3, 0.0}, {movingDisc(0.9, 0.0, kPi, 1.0)});
  ASSERT_EQ(s.step.shield_level, ShieldLevel::kLatest);
  const Dovs& d = s.step.msg;
  ASSERT_TRUE(d.escape);
  const Twist2 expected =
      escapeVelocity(s.step.observation, RobotLimits{}, DovsConfig{}.safety_factor, ActionShieldConfig{});
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

TEST(PipelineSteps, ThePlannerRefusesStatesNormalisedOtherwiseThanItsModel) {
  // dovs_node configured with another obstacle range builds states the network was not trained on.
  DovsConfig wider;
  wider.obstacle_range_m = 5.0;
  const Step s = build({0.3, 0.0}, {movingDisc(2.5, 1.5, 0.0, 0.3)}, wider);
  const Dovs& d = s.step.msg;
  ASSERT_EQ(d.state_normalization.size(), static_cast<size_t>(StateNormalization::kNumFields));
  EXPECT_FLOAT_EQ(d.state_normalization[7], 5.0f);  // obstacle_clearance_scale_m
  const QNetwork net = shippedNetwork();
  std::string why;
  EXPECT_EQ(chooseAction(net, d, why), -1);
  EXPECT_NE(why.find("obstacle_clearance_scale_m"), std::string::npos) << why;
  EXPECT_NE(why.find("dovs/obstacle_range"), std::string::npos) << why;
  // The configuration it was trained with is accepted; a message without the normalisation is not.
  Dovs same = d;
  same.state_normalization[7] = 4.0f;
  EXPECT_GE(chooseAction(net, same, why), 0) << why;
  Dovs none = d;
  none.state_normalization.clear();
  EXPECT_EQ(chooseAction(net, none, why), -1);
  EXPECT_NE(why.find("state_normalization has 0 values"), std::string::npos) << why;
}

TEST(PipelineSteps, AGradedGridIsCarriedAndRefusedByAPlusMinusOneModel) {
  // dovs_node configured for the graded grid (dovs/grid_contact_horizon) publishes graded states and says so in
  // state_normalization; the shipped network, trained on the +1 / -1 grid, is not run on them.
  DovsConfig graded;
  graded.grid_contact_horizon_s = 5.0;
  const Step s = build({0.3, 0.0}, {movingDisc(2.5, 0.2, kPi, 0.5)}, graded);  // coming closer
  const Dovs& d = s.step.msg;
  ASSERT_EQ(d.state_normalization.size(), static_cast<size_t>(StateNormalization::kNumFields) + 1);
  EXPECT_FLOAT_EQ(d.state_normalization.back(), 5.0f);
  int graded_cells = 0;
  for (int i = 0; i < kStateGridCells; ++i) graded_cells += std::abs(d.state[static_cast<size_t>(i)]) < 1.0f;
  EXPECT_GT(graded_cells, 0);  // the disc's cells hold contact times, not +-1
  std::string why;
  EXPECT_EQ(chooseAction(shippedNetwork(), d, why), -1);
  EXPECT_NE(why.find("grid_contact_horizon_s"), std::string::npos) << why;
  EXPECT_NE(why.find("dovs/grid_contact_horizon"), std::string::npos) << why;
}

TEST(PipelineSteps, GridChannelsAreCarriedAndAModelOfOtherChannelsIsNotRun) {
  // dovs_node with dovs/grid_channels = 3 publishes 1,208-float states (the DOVS grid, the dynamic window and the
  // goal line, then the features); the shipped one-channel network is not run on them, and the reason names the
  // channels on both sides. A 3-channel network (the shipped one widened with zero weights) runs them and chooses
  // what the shipped network chooses on the one-channel message of the same scene.
  DovsConfig wide;
  wide.grid_channels = 3;
  const Step one = build({0.3, 0.0}, {movingDisc(2.5, 0.2, kPi, 0.5)});
  const Step three = build({0.3, 0.0}, {movingDisc(2.5, 0.2, kPi, 0.5)}, wide);
  const Dovs& d = three.step.msg;
  ASSERT_EQ(d.state.size(), 1208u);
  EXPECT_EQ(d.state_normalization, one.step.msg.state_normalization);
  for (int i = 0; i < kStateGridCells; ++i)
    EXPECT_EQ(d.state[static_cast<size_t>(i)], one.step.msg.state[static_cast<size_t>(i)]);
  for (int i = 0; i < kNumFeatures; ++i)
    EXPECT_EQ(d.state[static_cast<size_t>(1200 + i)], one.step.msg.state[static_cast<size_t>(400 + i)]);
  std::string why;
  EXPECT_EQ(chooseAction(shippedNetwork(), d, why), -1);
  EXPECT_NE(why.find("1208 values, the model reads 408 (1 grid channels, 8 features)"), std::string::npos) << why;
  EXPECT_NE(why.find("dovs_node builds 3 grid channels"), std::string::npos) << why;

  WeightFileContents c = readWeightFile(std::string(DQN_DOVS_SOURCE_DIR) + "/models/dqn_dovs.dqnw");
  LayerRecord& first = c.layers.front();  // grid conv2d 1 -> 8: the new channels read with zero weights
  std::vector<float> widened;
  const std::uint32_t taps = first.kernel_h * first.kernel_w;
  for (std::uint32_t o = 0; o < first.out_channels; ++o) {
    widened.insert(widened.end(), first.weight.begin() + o * taps, first.weight.begin() + (o + 1) * taps);
    widened.insert(widened.end(), 2 * taps, 0.0f);
  }
  first.weight = widened;
  first.in_channels = 3;
  c.grid_channels = 3;
  c.format_version = weightFormatVersionFor(3);
  const QNetwork net3 = QNetwork::fromContents(c, "<widened shipped network>");
  const int choice3 = chooseAction(net3, d, why);
  EXPECT_GE(choice3, 0) << why;
  std::string why1;
  EXPECT_EQ(choice3, chooseAction(shippedNetwork(), one.step.msg, why1)) << why1;
  EXPECT_EQ(chooseAction(net3, one.step.msg, why), -1);
  EXPECT_NE(why.find("dovs_node builds 1 grid channels"), std::string::npos) << why;
}

TEST(PipelineSteps, TheRouteAheadFromThePlannerJoinsTheState) {
  // dovs_node with dovs/route_points = 2 puts the points 0.5 m and 1 m along planner/route_ahead into the state,
  // after the features; without a route ahead, the points along the straight line to the goal.
  const RobotLimits limits;
  DovsConfig config;
  config.route_points = 2;
  DovsBuilder builder(limits, config);
  TrackedObstacleArray msg = movingObstaclesToMsg({}, {});
  msg.header.stamp = ros::Time(10.0);
  msg.header.frame_id = "odom";
  const std::vector<Vec2> route = {Vec2(0.0, 0.0), Vec2(0.0, 2.0)};  // to the left of the robot
  Step with, without;
  ASSERT_EQ(
      buildDovsStep(msg, Pose2{}, {0.0, 0.0}, Vec2(4.0, 0.0), limits, stateNormalization(limits, config),
                    ActionShieldConfig{}, "base_footprint", builder, with.space, with.step, nullptr, nullptr, &route),
      "");
  ASSERT_EQ(buildDovsStep(msg, Pose2{}, {0.0, 0.0}, Vec2(4.0, 0.0), limits, stateNormalization(limits, config),
                          ActionShieldConfig{}, "base_footprint", builder, without.space, without.step),
            "");
  ASSERT_EQ(with.step.msg.state.size(), 412u);
  const std::vector<float> left(with.step.msg.state.begin() + 408, with.step.msg.state.end());
  const std::vector<float> ahead(without.step.msg.state.begin() + 408, without.step.msg.state.end());
  EXPECT_EQ(left, (std::vector<float>{0.0f, 0.125f, 0.0f, 0.25f}));
  EXPECT_EQ(ahead, (std::vector<float>{0.125f, 0.0f, 0.25f, 0.0f}));
}

// The decision step through the robot's path (the Dovs message dovs_node builds, then the planner's choice on it)
// and through the evaluation's (DqnDovsPlanner on the Episode's context) makes the same choices, step by step, on
// the same inputs: whole episodes with the LIDAR and the tracker in the loop, driven by the evaluation's choices.
TEST(PipelineSteps, TheRobotsPathChoosesAsTheEvaluationDoes) {
  const QNetwork net = shippedNetwork();
  EpisodeConfig config;
  Episode episode(config);
  const RobotLimits& limits = config.world.robot;
  DqnDovsConfig planner_config;
  planner_config.model_path = std::string(DQN_DOVS_SOURCE_DIR) + "/models/dqn_dovs.dqnw";
  planner_config.normalization = stateNormalization(limits, config.dovs);
  DqnDovsPlanner planner(planner_config);
  DovsBuilder builder(limits, config.dovs);
  sim::GeneratorConfig generator;
  generator.obstacle_count_min = 8;
  generator.obstacle_count_max = 14;
  int steps = 0, escapes = 0;
  for (uint64_t seed = 1; seed <= 6; ++seed) {
    episode.reset(sim::generateScenario(generator, seed), seed);
    planner.reset();
    while (!episode.done()) {
      const PlannerDecision d = planner.decide(episode.plannerInput());
      const Observation& obs = episode.observation();
      TrackedObstacleArray msg = movingObstaclesToMsg(obs.obstacles, obs.segments);
      msg.header.stamp = ros::Time(10.0 + 0.2 * steps);
      msg.header.frame_id = "odom";
      Step node;
      ASSERT_EQ(
          buildDovsStep(msg, obs.robot_pose, obs.robot_twist, obs.goal, limits, stateNormalization(limits, config.dovs),
                        planner_config.shield, "base_footprint", builder, node.space, node.step),
          "");
      // The same network input ...
      ASSERT_EQ(node.step.msg.state.size(), static_cast<size_t>(episode.state().size()));
      for (int i = 0; i < episode.state().size(); ++i) {
        ASSERT_EQ(node.step.msg.state[static_cast<size_t>(i)], episode.state()[i]) << "seed " << seed << " input " << i;
      }
      // ... and the same choice: an action, or the shield's escape velocity.
      std::string why;
      const int a = chooseAction(net, node.step.msg, why);
      ASSERT_EQ(why, "") << "seed " << seed << " step " << episode.steps();
      if (d.action >= 0) {
        ASSERT_EQ(a, d.action) << "seed " << seed << " step " << episode.steps() << ": " << d.note;
      } else {
        ASSERT_EQ(a, kEscapeChoice) << "seed " << seed << " step " << episode.steps() << ": " << d.note;
        const Twist2 u = choiceVelocity(node.step.msg, a);
        ASSERT_EQ(u.v, d.command.v);
        ASSERT_EQ(u.w, d.command.w);
        ++escapes;
      }
      episode.stepDecision(d);
      ++steps;
    }
  }
  EXPECT_GT(steps, 200);
  EXPECT_GT(escapes, 0) << "the episodes never reached the escape: the comparison missed a path";
}

}  // namespace
}  // namespace dqn_dovs

namespace dqn_dovs {
namespace {

TEST(PipelineSteps, ThePlannerActsOnlyOnVelocitySpacesBuiltForItsGoal) {
  Dovs d;
  EXPECT_NE(dovsGoalFault(d, 0.0, Vec2::Zero()).find("no goal"), std::string::npos);
  d.has_goal = true;
  d.goal_stamp = ros::Time(100.0);
  d.goal_x = 4.0;
  d.goal_y = -1.0;
  EXPECT_EQ(dovsGoalFault(d, 100.0, Vec2(4.0, -1.0)), "");
  EXPECT_EQ(dovsGoalFault(d, 100.0, Vec2(4.1, -1.05)), "") << "the same goal, transformed a little differently";
  // A new goal message (a later stamp), even at the same place: the space in flight is the old goal's.
  const std::string later = dovsGoalFault(d, 101.5, Vec2(4.0, -1.0));
  EXPECT_NE(later.find("another goal"), std::string::npos) << later;
  EXPECT_NE(later.find("101.5"), std::string::npos) << later;
  // Unstamped goals (rostopic pub): told apart by where they are.
  d.goal_stamp = ros::Time();
  EXPECT_EQ(dovsGoalFault(d, 0.0, Vec2(4.0, -1.0)), "");
  EXPECT_NE(dovsGoalFault(d, 0.0, Vec2(-3.0, 2.0)).find("another goal"), std::string::npos);
  d.goal_x = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(dovsGoalFault(d, 0.0, Vec2(4.0, -1.0)), "");
}

}  // namespace
}  // namespace dqn_dovs

namespace dqn_dovs {
namespace {

TEST(PlannerDiagnostics, LevelFollowsTheStateAndWhatGrew) {
  PlannerStatus s;
  s.state = PlannerStatus::ACTIVE;
  s.reason = "active";
  const PlannerStatus before = s;
  diagnostic_msgs::DiagnosticStatus d = plannerDiagnostics(s, before, "planner", "base_footprint");
  EXPECT_EQ(d.level, diagnostic_msgs::DiagnosticStatus::OK);
  ASSERT_FALSE(d.values.empty());
  EXPECT_EQ(d.values.front().key, "state");
  EXPECT_EQ(d.values.front().value, "active");

  s.state = PlannerStatus::STOPPED;
  s.reason = "scan is stale or missing";
  d = plannerDiagnostics(s, before, "planner", "base_footprint");
  EXPECT_EQ(d.level, diagnostic_msgs::DiagnosticStatus::WARN);
  EXPECT_EQ(d.message, "stopped: scan is stale or missing");

  s = before;
  s.recovery = "wait";
  s.last_trigger = "no progress: 8 m left";
  d = plannerDiagnostics(s, before, "planner", "base_footprint");
  EXPECT_EQ(d.level, diagnostic_msgs::DiagnosticStatus::WARN);
  EXPECT_NE(d.message.find("no progress"), std::string::npos) << d.message;

  s = before;
  s.deadline_misses = 3;
  d = plannerDiagnostics(s, before, "planner", "base_footprint");
  EXPECT_EQ(d.level, diagnostic_msgs::DiagnosticStatus::WARN);
  EXPECT_NE(d.message.find("3 control periods"), std::string::npos) << d.message;
  // The same count again is no news.
  EXPECT_EQ(plannerDiagnostics(s, s, "planner", "base_footprint").level, diagnostic_msgs::DiagnosticStatus::OK);

  s = before;
  s.state = PlannerStatus::ABORTED;
  s.reason = "cliff sensor sees no floor";
  d = plannerDiagnostics(s, before, "planner", "base_footprint");
  EXPECT_EQ(d.level, diagnostic_msgs::DiagnosticStatus::WARN);
  EXPECT_EQ(d.message, "goal aborted: cliff sensor sees no floor");
}

}  // namespace
}  // namespace dqn_dovs
