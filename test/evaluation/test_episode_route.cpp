// The route of an episode (docs/simulator.md, "Routes in episodes"): in the doorway the route takes the planners
// through the door to a goal they miss without it; the DOVS, the state and the planners see the route's subgoal until
// the goal replaces it; the reward counts progress along the route; the paper's room, without walls of its own, runs
// exactly as without routes; and the evaluation's `route` option is checked.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "dqn_dovs/evaluation/episode.h"
#include "dqn_dovs/evaluation/eval.h"
#include "dqn_dovs/planning/route.h"
#include "source_paths.h"

namespace dqn_dovs {
namespace {

/// The evaluation's setup of generated `world` episodes (seed, N = obstacles, episodes 1..episodes), with or
/// without routes.
EvalConfig evalConfig(const std::string& world, uint64_t seed, int obstacles, int episodes, bool route) {
  EvalConfig c;
  c.world = world;
  c.seed = seed;
  c.obstacles_min = c.obstacles_max = obstacles;
  c.episodes = episodes;
  c.route = route ? "on" : "off";
  c.model_path = std::string(DQN_DOVS_SOURCE_DIR) + "/models/dqn_dovs.dqnw";
  applyWorldOptions(c);
  return c;
}

EpisodeRecord run(const std::string& method, const EvalConfig& config, const EvalScenario& scenario) {
  std::unique_ptr<Planner> planner = makeEvalPlanner(method, config);
  Episode episode(config.episode);
  return runEpisode(*planner, episode, method, scenario);
}

// Doorway, seed 14101, no people, episode 2: the goal lies behind the wall beside the door; driving at it, every
// planner stops in front of the wall until the episode times out.
TEST(EpisodeRoute, TheRouteTakesThePlannersThroughTheDoorToAGoalTheyMissWithoutIt) {
  for (const std::string method : {"s_dovs", "dqn_dovs"}) {
    const EvalConfig with = evalConfig("doorway", 14101, 0, 2, true);
    const EvalConfig without = evalConfig("doorway", 14101, 0, 2, false);
    const EvalScenario s = loadEvalScenarios(with).back();
    ASSERT_FALSE(s.scenario.static_segments.empty());
    const EpisodeRecord off = run(method, without, s);
    const EpisodeRecord on = run(method, with, s);
    EXPECT_EQ(off.outcome, Outcome::kTimeout) << method << ": " << off.last_decision;
    EXPECT_EQ(on.outcome, Outcome::kSuccess) << method << ": " << on.last_decision;
  }
}

TEST(EpisodeRoute, TheContextIsBuiltForTheRoutesSubgoalUntilTheGoalReplacesIt) {
  const EvalConfig config = evalConfig("doorway", 14101, 0, 2, true);
  const EvalScenario s = loadEvalScenarios(config).back();
  Episode episode(config.episode);
  episode.reset(s.scenario, s.seed);
  ASSERT_TRUE(episode.hasRoute()) << episode.routeError();
  EXPECT_EQ(episode.routeError(), "");
  const Route& route = episode.routeGuide().route();
  const Vec2 goal = s.scenario.goal;
  EXPECT_EQ(route.points.back(), goal);
  // The straight line runs into the wall beside the door; the route goes through the door.
  const Vec2 start = s.scenario.robot_start.position();
  bool straight_hits_a_wall = false;
  for (const Segment& w : s.scenario.static_segments) straight_hits_a_wall |= segmentsCross(start, goal, w);
  EXPECT_TRUE(straight_hits_a_wall);
  EXPECT_GT(route.length_m, (goal - start).norm() + 0.2);
  const double lookahead = config.episode.route.guide.lookahead_m;
  EXPECT_EQ(lookahead, RouteGuideConfig().lookahead_m);
  std::unique_ptr<Planner> planner = makeEvalPlanner("s_dovs", config);
  int subgoals = 0, finals = 0;
  bool final_seen = false;
  while (!episode.done()) {
    const RouteGuidance& g = episode.routeGuidance();
    const Observation& o = episode.observation();
    // What the DOVS, the state, the action set and the planners are given is the guidance's point.
    ASSERT_TRUE(g.on_route);
    ASSERT_EQ(o.goal, g.local_goal);
    const Vec2 local = o.robot_pose.toLocal(g.local_goal);
    const float distance = episode.state()[kStateGridCells + kFeatureGoalDistance];
    EXPECT_FLOAT_EQ(distance, std::min(static_cast<float>(local.norm() / episode.normalization().goal_distance_scale_m),
                                       episode.normalization().clip));
    EXPECT_EQ(g.replan, RouteReplan::kNone) << "no people: the route is never planned again";
    if (g.final_goal) {
      // The rule of planner_node: the goal itself once the subgoal is the route's end, and from then on.
      EXPECT_EQ(g.local_goal, goal);
      EXPECT_LE(g.remaining_m, lookahead + 1e-9);
      final_seen = true;
      ++finals;
    } else {
      EXPECT_FALSE(final_seen) << "the subgoal came back after the goal had replaced it";
      // On the route, no farther than the lookahead along it, and closer than the goal along it.
      double off_route = 1e9;
      for (size_t k = 1; k < route.points.size(); ++k) {
        off_route = std::min(off_route, pointSegmentDistance(g.local_goal, {route.points[k - 1], route.points[k]}));
      }
      EXPECT_LT(off_route, 1e-6);
      EXPECT_LE((g.local_goal - o.robot_pose.position()).norm(), lookahead + g.off_route_m + 1e-6);
      EXPECT_GT(g.remaining_m, 0.0);
      ++subgoals;
    }
    episode.stepDecision(planner->decide(episode.plannerInput()));
  }
  EXPECT_EQ(episode.outcome(), Outcome::kSuccess);
  EXPECT_GT(subgoals, 10);
  EXPECT_GT(finals, 3);
}

// The state's route points (dovs/route_points, docs/dovs.md "The route ahead") lie on the route, every 0.5 m along it
// from the robot's place, in the robot frame; the rest of the state is what it is without them.
TEST(EpisodeRoute, TheStatesRoutePointsLieOnTheRouteAhead) {
  EvalConfig config = evalConfig("doorway", 14101, 0, 2, true);
  const EvalScenario s = loadEvalScenarios(config).back();
  EpisodeConfig with_points = config.episode;
  with_points.dovs.route_points = 6;
  Episode plain(config.episode), episode(with_points);
  plain.reset(s.scenario, s.seed);
  episode.reset(s.scenario, s.seed);
  ASSERT_TRUE(episode.hasRoute()) << episode.routeError();
  const Route& route = episode.routeGuide().route();
  const int at = kStateGridCells + kNumFeatures;
  ASSERT_EQ(episode.state().size(), plain.state().size() + 12);
  std::unique_ptr<Planner> planner = makeEvalPlanner("s_dovs", config);
  int steps = 0;
  while (!episode.done() && steps < 40) {
    const Observation& o = episode.observation();
    EXPECT_EQ(episode.state().head(at), plain.state().head(at));
    double previous_arc = -1.0;
    for (int k = 0; k < 6; ++k) {
      const Vec2 local(episode.state()[at + 2 * k] * episode.normalization().obstacle_clearance_scale_m,
                       episode.state()[at + 2 * k + 1] * episode.normalization().obstacle_clearance_scale_m);
      const Vec2 p = o.robot_pose.toWorld(local);
      double off = 1e9, arc = 0.0;
      for (size_t i = 1; i < route.points.size(); ++i) {
        const double d = pointSegmentDistance(p, {route.points[i - 1], route.points[i]});
        if (d < off) {
          off = d;
          arc = route.arc_m[i - 1] + (p - route.points[i - 1]).norm();
        }
      }
      EXPECT_LT(off, 1e-4) << "route point " << k << " at step " << steps;
      if (previous_arc >= 0.0 && arc < route.length_m - 1e-3) {
        EXPECT_NEAR(arc - previous_arc, 0.5, 1e-3);
      }
      previous_arc = arc;
    }
    const PlannerDecision d = planner->decide(plain.plannerInput());
    plain.stepDecision(d);
    episode.stepDecision(d);
    ++steps;
  }
  EXPECT_EQ(steps, 40);
}

TEST(EpisodeRoute, TheRewardCountsProgressAlongTheRouteNotTheStraightLine) {
  const EvalConfig config = evalConfig("doorway", 14101, 0, 2, true);
  const EvalScenario s = loadEvalScenarios(config).back();
  Episode episode(config.episode);
  episode.reset(s.scenario, s.seed);
  ASSERT_TRUE(episode.hasRoute());
  const Vec2 start = s.scenario.robot_start.position(), goal = s.scenario.goal;
  // At the start the distance to go is the route's length, longer than the straight line by the way to the door.
  EXPECT_NEAR(episode.routeGuide().distanceToGo(start, goal), episode.routeGuide().route().length_m, 1e-9);
  EXPECT_GT(episode.routeGuide().distanceToGo(start, goal), (goal - start).norm() + 0.2);
  std::unique_ptr<Planner> planner = makeEvalPlanner("s_dovs", config);
  const RewardConfig& rc = config.episode.reward;
  int checked = 0;
  while (!episode.done()) {
    const RouteGuide before = episode.routeGuide();  // the route in force during the coming period
    const Vec2 p0 = episode.world().robotPose().position();
    const StepResult r = episode.stepDecision(planner->decide(episode.plannerInput()));
    if (r.terminated) break;
    if (episode.world().minClearance_m() < rc.safe_distance_m) continue;  // the safety term adds to it
    const Vec2 p1 = episode.world().robotPose().position();
    const double along = before.distanceToGo(p1, goal) - before.distanceToGo(p0, goal);
    EXPECT_EQ(r.reward, -rc.distance_weight * along) << "step " << episode.steps();
    ++checked;
  }
  EXPECT_EQ(episode.outcome(), Outcome::kSuccess);
  EXPECT_GT(checked, 20);
  // Without a route the distance to go is the straight one.
  EXPECT_EQ(RouteGuide().distanceToGo(start, goal), (start - goal).norm());
}

TEST(EpisodeRoute, ThePapersRoomRunsExactlyAsWithoutRoutes) {
  for (const std::string method : {"s_dovs", "dqn_dovs"}) {
    const EvalConfig with = evalConfig("room", 14102, 8, 3, true);
    const EvalConfig without = evalConfig("room", 14102, 8, 3, false);
    ASSERT_TRUE(with.episode.route.enabled);
    for (const EvalScenario& s : loadEvalScenarios(with)) {
      ASSERT_TRUE(s.scenario.static_segments.empty());
      Episode episode(with.episode);
      episode.reset(s.scenario, s.seed);
      EXPECT_FALSE(episode.hasRoute());
      EXPECT_EQ(episode.observation().goal, s.scenario.goal);
      const EpisodeRecord a = run(method, with, s), b = run(method, without, s);
      EXPECT_EQ(a.actions, b.actions) << method << " " << s.scenario.name;
      EXPECT_EQ(a.outcome, b.outcome);
      EXPECT_EQ(a.steps, b.steps);
      EXPECT_EQ(a.time_s, b.time_s);
      EXPECT_EQ(a.path_length_m, b.path_length_m);
      EXPECT_EQ(a.min_clearance_m, b.min_clearance_m);
    }
  }
}

TEST(EpisodeRoute, TheRouteOptionIsOnOrOff) {
  EvalConfig c;
  EXPECT_EQ(c.route, "on");
  EXPECT_EQ(c.episode.route.enabled, true) << "EvalConfig::route and EpisodeRouteConfig::enabled agree";
  c.route = "off";
  applyWorldOptions(c);
  EXPECT_FALSE(c.episode.route.enabled);
  c.route = "maybe";
  EXPECT_NE(c.validate().find("route = 'maybe': must be on or off"), std::string::npos) << c.validate();
  try {
    applyWorldOptions(c);
    FAIL() << "no error for route 'maybe'";
  } catch (const EvalError& e) {
    EXPECT_STREQ(e.what(), "route 'maybe' is not one of on, off");
  }
  EpisodeConfig e;
  e.route.resolution_m = 0.0;
  EXPECT_NE(e.validate().find("route.resolution_m"), std::string::npos) << e.validate();
  e = EpisodeConfig();
  e.route.guide.lookahead_m = -1.0;
  EXPECT_NE(e.validate().find("lookahead_m"), std::string::npos) << e.validate();
}

}  // namespace
}  // namespace dqn_dovs
