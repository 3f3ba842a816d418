// The oracle (evaluation/oracle.h): the physical limit of an episode, searched with the simulator's future.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "dqn_dovs/evaluation/eval.h"
#include "dqn_dovs/evaluation/oracle.h"
#include "dqn_dovs/sim/worlds.h"

namespace dqn_dovs {
namespace {

EvalScenario scenarioOf(const sim::Scenario& s, uint64_t seed = 1) {
  EvalScenario e;
  e.scenario = s;
  e.obstacles = static_cast<int>(s.obstacles.size() + s.people.size());
  e.episode = 1;
  e.seed = seed;
  return e;
}

EpisodeConfig perfectInformation() {
  EpisodeConfig c;
  c.perfect_info = true;
  return c;
}

EpisodeRecord run(const std::string& method, const sim::Scenario& s,
                  const EpisodeConfig& config = perfectInformation()) {
  EvalConfig eval;
  eval.episode = config;
  std::unique_ptr<Planner> planner = makeEvalPlanner(method, eval);
  Episode episode(config);
  return runEpisode(*planner, episode, method, scenarioOf(s), false);
}

sim::Scenario emptyRoom(const Pose2& start, const Vec2& goal) {
  sim::Scenario s;
  s.name = "test";
  s.robot_start = start;
  s.goal = goal;
  return s;
}

TEST(Oracle, IsAnEvaluationMethodAndNeedsTheWorld) {
  const std::vector<std::string> names = evalMethodNames();
  EXPECT_NE(std::find(names.begin(), names.end(), "oracle"), names.end());
  OraclePlanner oracle;
  EXPECT_THROW(oracle.decide(PlannerInput{}), PlannerError);
  OracleConfig bad;
  bad.beam_width = 0;
  EXPECT_THROW(OraclePlanner{bad}, PlannerError);
}

TEST(Oracle, ReachesAFreeGoalNearTheKinematicMinimumTime) {
  // 5 m straight ahead: accelerate to 0.7 m/s (1.4 s), cruise, brake below 0.2 m/s inside 0.15 m of the goal.
  const EpisodeRecord r = run("oracle", emptyRoom({-2.5, 0.0, 0.0}, {2.5, 0.0}));
  EXPECT_EQ(r.outcome, Outcome::kSuccess) << r.last_decision;
  const double cruise = 5.0 / 0.7;  // a lower bound: v_max all the way
  EXPECT_GT(r.time_s, cruise);
  EXPECT_LT(r.time_s, cruise + 2.5) << "acceleration and braking cost about 1.4 s in all";
}

TEST(Oracle, PassesADiscComingHeadOnAndATrafficOfCrossingDiscs) {
  sim::Scenario s = emptyRoom({-3.0, 0.0, 0.0}, {3.0, 0.0});
  MovingObstacle head_on;
  head_on.center = Vec2(3.0, 0.05);
  head_on.heading = kPi;
  head_on.speed = 0.8;
  s.obstacles.push_back(head_on);
  for (int k = 0; k < 4; ++k) {
    MovingObstacle crossing;
    crossing.center = Vec2(-1.5 + 1.0 * k, k % 2 ? 3.0 : -3.0);
    crossing.heading = k % 2 ? -kPi / 2 : kPi / 2;
    crossing.speed = 0.6 + 0.1 * k;
    s.obstacles.push_back(crossing);
  }
  const EpisodeRecord r = run("oracle", s);
  EXPECT_EQ(r.outcome, Outcome::kSuccess)
      << r.last_decision << " t " << r.time_s << " steps " << r.steps << " kind " << static_cast<int>(r.collision_kind);
  EXPECT_GT(r.min_clearance_m, 0.0);
}

TEST(Oracle, FindsTheDoorAroundTheWall) {
  // Two rooms joined by a door, nobody around: the straight line crosses the wall; the path length to go does not.
  sim::WorldFamilyConfig w;
  w.family = sim::WorldFamily::kDoorway;
  w.people = 0;
  const EpisodeRecord r = run("oracle", sim::generateWorld(w, 3));
  EXPECT_EQ(r.outcome, Outcome::kSuccess) << r.last_decision;
}

TEST(Oracle, SaysWhenEveryTrajectoryCollides) {
  // A fast disc coming straight at a robot at rest that cannot reverse, 0.75 m between their surfaces: contact
  // 0.5 s after the start, 0.2 s after the first decision (the episode senses 0.3 s first). No command avoids it.
  sim::Scenario s = emptyRoom({0.0, 0.0, 0.0}, {3.0, 0.0});
  MovingObstacle fast;
  fast.center = Vec2(1.15, 0.0);
  fast.heading = kPi;
  fast.speed = 1.5;
  s.obstacles.push_back(fast);
  const EpisodeRecord r = run("oracle", s);
  EXPECT_EQ(r.outcome, Outcome::kCollision);
  EXPECT_NE(r.last_decision.find("collides"), std::string::npos) << r.last_decision;
}

TEST(Oracle, ReadsOnlyAsMuchOfTheFutureAsItIsTold) {
  // Ten walking people who ignore the robot: searched against a constant-velocity prediction from now, the same
  // search collides where the true future lets it through (generated crowds at seeds 1-8).
  EvalConfig eval;
  eval.episode = perfectInformation();
  sim::WorldFamilyConfig w;
  w.family = sim::WorldFamily::kCrowd;
  w.people = 10;
  const auto successes = [&](const OracleConfig& oracle) {
    eval.oracle = oracle;
    int n = 0;
    for (uint64_t seed = 1; seed <= 8; ++seed) {
      std::unique_ptr<Planner> planner = makeEvalPlanner("oracle", eval);
      Episode episode(eval.episode);
      n += runEpisode(*planner, episode, "oracle", scenarioOf(sim::generateWorld(w, seed), seed), false).outcome ==
           Outcome::kSuccess;
    }
    return n;
  };
  OracleConfig predicted;
  predicted.true_future_periods = 0;
  const int exact = successes(OracleConfig{}), constant_velocity = successes(predicted);
  EXPECT_GE(exact, 6);
  EXPECT_LE(constant_velocity, exact - 3);
}

TEST(Oracle, PredictionParametersAreNamedAndChecked) {
  OracleConfig c;
  EXPECT_EQ(setOracleParameter(c, "true_future_periods", "3"), "");
  EXPECT_EQ(setOracleParameter(c, "social_prediction", "1"), "");
  EXPECT_EQ(setOracleParameter(c, "prediction_growth_mps", "0.2"), "");
  EXPECT_EQ(c.true_future_periods, 3);
  EXPECT_TRUE(c.social_prediction);
  EXPECT_DOUBLE_EQ(c.prediction_growth_mps, 0.2);
  EXPECT_EQ(c.validate(), "");
  EXPECT_NE(setOracleParameter(c, "social_prediction", "2").find("not 0 or 1"), std::string::npos);
  c.true_future_periods = -2;
  EXPECT_NE(c.validate().find("true_future_periods"), std::string::npos);
  c = OracleConfig{};
  c.prediction_growth_mps = -0.1;
  EXPECT_NE(c.validate().find("prediction_growth_mps"), std::string::npos);
}

}  // namespace
}  // namespace dqn_dovs
