// The limits of an episode: the oracle (evaluation/oracle.h), a search with the simulator's future, and the
// reachability bound (evaluation/reach_bound.h).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "dqn_dovs/evaluation/episode.h"
#include "dqn_dovs/evaluation/eval.h"
#include "dqn_dovs/evaluation/oracle.h"
#include "dqn_dovs/evaluation/reach_bound.h"
#include "dqn_dovs/sim/worlds.h"
#include "source_paths.h"

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

EpisodeRecord run(const std::string& method, const sim::Scenario& s, const EpisodeConfig& config = perfectInformation(),
                  const ReachBoundConfig& bound = {}) {
  EvalConfig eval;
  eval.episode = config;
  eval.bound = bound;
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

TEST(Oracle, GoesRoundAGapItCannotPassAndAChairInADoor) {
  // A wall across the room with a way round through a wide door near its end. In its middle: a gap the robot's disc
  // passes with 10 cm a side, less than the search's check of a pose keeps (a grid cell's half diagonal beyond the
  // clearance margin), or a door with a chair in it. The path to the goal must not lead through either, or the
  // search presses against them until the episode times out.
  for (const bool chair : {false, true}) {
    sim::Scenario s = emptyRoom({-2.0, 0.0, 0.0}, {2.0, 0.0});
    const double half = chair ? 0.5 : 0.3;  // the middle opening's half width
    s.static_segments = {
        {Vec2(0.0, -4.0), Vec2(0.0, -half)}, {Vec2(0.0, half), Vec2(0.0, 2.2)}, {Vec2(0.0, 3.4), Vec2(0.0, 4.0)}};
    if (chair) {
      MovingObstacle c;
      c.center = Vec2(0.0, 0.0);
      c.radius = 0.3;
      c.is_static = true;
      s.obstacles = {c};
    }
    const EpisodeRecord r = run("oracle", s);
    EXPECT_EQ(r.outcome, Outcome::kSuccess) << (chair ? "chair: " : "gap: ") << r.last_decision;
    EXPECT_GT(r.path_length_m, 6.0) << "round through the wide door";
  }
}

TEST(Oracle, TriesFurtherSearchesOnAnEpisodeItsFirstSearchDoesNotSolve) {
  // The door world without people: a first search that keeps 0.45 m beyond the robot's radius cannot fit through
  // the 0.9-1.2 m door; a retry that keeps 2 cm goes through, and its record stands.
  sim::WorldFamilyConfig w;
  w.family = sim::WorldFamily::kDoorway;
  w.people = 0;
  const EvalScenario s = scenarioOf(sim::generateWorld(w, 3), 3);
  EvalConfig eval;
  eval.episode = perfectInformation();
  eval.episode.reward.max_steps = 150;
  eval.oracle.horizon_periods = 5;
  eval.oracle.beam_width = 20;
  eval.oracle.clearance_margin_m = 0.45;
  const auto run = [&](const std::vector<std::string>& retries) {
    eval.oracle_retries = retries;
    EXPECT_EQ(eval.validate(), "");
    std::unique_ptr<Planner> planner = makeEvalPlanner("oracle", eval);
    Episode episode(eval.episode);
    return runEpisode(*planner, episode, "oracle", s, false);
  };
  const EpisodeRecord alone = run({});
  ASSERT_NE(alone.outcome, Outcome::kSuccess) << alone.last_decision;
  EXPECT_EQ(alone.last_decision.find("(search"), std::string::npos) << alone.last_decision;
  EXPECT_EQ(alone.last_decision.find("searches failed"), std::string::npos) << alone.last_decision;

  const EpisodeRecord retried = run({"clearance_margin_m=0.3", "clearance_margin_m=0.02"});
  EXPECT_EQ(retried.outcome, Outcome::kSuccess) << retried.last_decision;
  EXPECT_NE(retried.last_decision.find("(search 3 of 3)"), std::string::npos) << retried.last_decision;
  EXPECT_GT(retried.min_clearance_m, 0.0);

  // Every search fails: the first one's record, saying how many were tried.
  const EpisodeRecord failed = run({"clearance_margin_m=0.4"});
  EXPECT_EQ(failed.outcome, alone.outcome);
  EXPECT_EQ(failed.time_s, alone.time_s);
  EXPECT_NE(failed.last_decision.find("(2 searches failed)"), std::string::npos) << failed.last_decision;

  // Over a prediction the best of several whole runs would be hindsight: no retries there.
  eval.oracle.true_future_periods = 0;
  const EpisodeRecord predicted = run({"clearance_margin_m=0.02"});
  EXPECT_NE(predicted.outcome, Outcome::kSuccess) << predicted.last_decision;
  EXPECT_EQ(predicted.last_decision.find("(search"), std::string::npos) << predicted.last_decision;

  // A retry that names no parameter, or a bad value, is refused naming the retry.
  eval.oracle.true_future_periods = -1;
  eval.oracle_retries = {"beam_width=40", "clearance"};
  EXPECT_NE(eval.validate().find("oracle retry 'clearance': 'clearance' is not NAME=VALUE"), std::string::npos)
      << eval.validate();
  eval.oracle_retries = {"terminal_periods=-1"};
  EXPECT_NE(eval.validate().find("terminal_periods"), std::string::npos) << eval.validate();
  EXPECT_THROW(makeEvalPlanner("oracle", eval), EvalError);
}

/// A fast disc coming straight at a robot at rest that cannot reverse, 0.75 m between their surfaces: contact 0.5 s
/// after the start, 0.2 s after the first decision (the episode senses 0.3 s first).
sim::Scenario fastDiscHeadOn() {
  sim::Scenario s = emptyRoom({0.0, 0.0, 0.0}, {3.0, 0.0});
  MovingObstacle fast;
  fast.center = Vec2(1.15, 0.0);
  fast.heading = kPi;
  fast.speed = 1.5;
  s.obstacles.push_back(fast);
  return s;
}

TEST(Oracle, AmongPeopleWhoReactItChecksItsCandidatesInTheTrueSimulator) {
  // Half the people give way to the robot once they notice it, half walk around it: their future depends on what
  // the robot does, so the oracle steps each candidate in a copy of the true simulator before taking it.
  sim::WorldFamilyConfig w;
  w.family = sim::WorldFamily::kCrowd;
  w.people = 10;
  EpisodeConfig config = perfectInformation();
  config.world.people.mix = sim::PeopleMix::parse("attentive=0.5,impassive=0.5");
  for (uint64_t seed = 1; seed <= 3; ++seed) {
    const EpisodeRecord r = run("oracle", sim::generateWorld(w, seed), config);
    EXPECT_EQ(r.outcome, Outcome::kSuccess) << "seed " << seed << ": " << r.last_decision;
    EXPECT_NE(r.last_decision.find("in the true simulator"), std::string::npos) << r.last_decision;
  }
  // Among people who never notice the robot the search alone decides, as before.
  const EpisodeRecord oblivious = run("oracle", sim::generateWorld(w, 1));
  EXPECT_EQ(oblivious.last_decision.find("true simulator"), std::string::npos) << oblivious.last_decision;
}

TEST(Oracle, SaysWhenEveryTrajectoryCollides) {
  // No command avoids the fast disc.
  const EpisodeRecord r = run("oracle", fastDiscHeadOn());
  EXPECT_EQ(r.outcome, Outcome::kCollision);
  EXPECT_NE(r.last_decision.find("collides"), std::string::npos) << r.last_decision;
}

TEST(Oracle, ChecksTheEndOfASequenceForAWayOnWhenToldTo) {
  // terminal_periods: the bodies are rolled that much further than the horizon, for the check of each end.
  OracleConfig c;
  EXPECT_EQ(setOracleParameter(c, "terminal_periods", "10"), "");
  EXPECT_EQ(c.terminal_periods, 10);
  sim::World world(fastDiscHeadOn(), sim::WorldConfig{}, 1);
  EXPECT_EQ(OraclePlanner(c).futureBodies(world).size(), static_cast<size_t>((20 + 10) * 4));
  c.terminal_periods = 81;
  EXPECT_NE(c.validate().find("terminal_periods 81"), std::string::npos) << c.validate();
  EXPECT_EQ(defaultOracleRetries().front(), "terminal_periods=10");
  // With the check on, the fast disc is still unavoidable, and a free goal still reached.
  EvalConfig eval;
  eval.episode = perfectInformation();
  eval.oracle.terminal_periods = 10;
  eval.oracle_retries = {};
  for (const auto& [scenario, outcome] : {std::make_pair(fastDiscHeadOn(), Outcome::kCollision),
                                          std::make_pair(emptyRoom({-2.5, 0.0, 0.0}, {2.5, 0.0}), Outcome::kSuccess)}) {
    std::unique_ptr<Planner> planner = makeEvalPlanner("oracle", eval);
    Episode episode(eval.episode);
    EXPECT_EQ(runEpisode(*planner, episode, "oracle", scenarioOf(scenario), false).outcome, outcome);
  }
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

/// A disc crossing at constant velocity and a person speeding up toward a destination straight ahead of them.
sim::Scenario discAndWalkingPerson() {
  sim::Scenario s = emptyRoom({-3.0, -3.0, 0.0}, {3.0, -3.0});
  MovingObstacle disc;
  disc.center = Vec2(-2.0, 1.0);
  disc.speed = 0.5;
  s.obstacles.push_back(disc);
  sim::PersonSpec person;
  person.position = Vec2(0.0, 2.5);
  person.heading_rad = -kPi / 2;
  person.preferred_speed_mps = 1.2;
  person.destinations = {Vec2(0.0, -3.5)};
  s.people.push_back(person);
  return s;
}

TEST(Oracle, PredictsFromThePresentWhenToldTo) {
  const sim::Scenario s = discAndWalkingPerson();
  const MovingObstacle& disc = s.obstacles[0];
  const sim::PersonSpec& person = s.people[0];
  sim::World world(s, sim::WorldConfig{}, 1);
  world.step(Twist2{}, 0.2);  // the person is on the way up to their preferred speed
  OracleConfig c;
  c.true_future_periods = 0;
  c.acceleration_prediction_s = 0.5;
  OraclePlanner accelerating(c);
  accelerating.futureBodies(world);  // it remembers the velocities of this decision ...
  world.step(Twist2{}, 0.2);         // ... for the next one
  const double sub_dt = world.config().robot.dt / 4.0;
  const Vec2 person_now = world.groundTruthObstacles()[1].center;
  const Vec2 person_velocity = world.crowd().people()[0].velocity;
  ASSERT_GT(person_velocity.norm(), 0.1);

  OraclePlanner exact;
  const std::vector<std::vector<Circle>> truth = exact.futureBodies(world);
  c.acceleration_prediction_s = 0.0;
  OraclePlanner constant(c);
  const std::vector<std::vector<Circle>> cv = constant.futureBodies(world);
  ASSERT_EQ(cv.size(), truth.size());
  const size_t half_second = 9;  // index k is (k + 1) quarter periods ahead: 0.5 s
  for (size_t k = 0; k < cv.size(); ++k) {
    ASSERT_EQ(cv[k].size(), 2u);
    EXPECT_NEAR((cv[k][0].center - truth[k][0].center).norm(), 0.0, 1e-6) << "the disc keeps its velocity";
    const Vec2 straight = person_now + (k + 1) * sub_dt * person_velocity;
    EXPECT_NEAR((cv[k][1].center - straight).norm(), 0.0, 1e-6) << "the person goes on at their present velocity";
  }
  // The person speeds up: the truth is ahead of the constant-velocity prediction; the acceleration of the last
  // period, carried on, comes closer.
  const double cv_lag = (truth[half_second][1].center - cv[half_second][1].center).norm();
  EXPECT_GT(cv_lag, 0.03);
  const std::vector<std::vector<Circle>> ca = accelerating.futureBodies(world);
  EXPECT_LT((truth[half_second][1].center - ca[half_second][1].center).norm(), 0.8 * cv_lag);
  EXPECT_NEAR((ca[half_second][0].center - truth[half_second][0].center).norm(), 0.0, 1e-6);

  c = OracleConfig{};
  c.true_future_periods = 0;
  c.prediction_growth_mps = 0.2;
  OraclePlanner growing(c);
  const std::vector<std::vector<Circle>> grown = growing.futureBodies(world);
  EXPECT_NEAR(grown[half_second][0].radius, disc.radius + 0.2 * 0.5, 1e-9);
  EXPECT_NEAR(grown[half_second][1].radius, person.body_radius_m + 0.2 * 0.5, 1e-9);

  c = OracleConfig{};
  c.true_future_periods = 2;
  c.social_prediction = true;
  OraclePlanner social(c);
  const std::vector<std::vector<Circle>> sf = social.futureBodies(world);
  for (size_t k = 0; k < 8; ++k) EXPECT_EQ((sf[k][1].center - truth[k][1].center).norm(), 0.0) << "true for 0.4 s";
  // Then the social force model, toward no destination: the person walks on alone, near the straight line.
  EXPECT_LT((sf[half_second][1].center - truth[half_second][1].center).norm(), 0.1);
  EXPECT_GT((sf[half_second][1].center - truth[half_second][1].center).norm(), 0.0);
}

/// Writes a people predictor file (people_predictor.h) with one layer: zero weights and `lateral` as the bias of every
/// step's sideways offset (the person's left), so it predicts constant velocity shifted sideways.
std::string writeLinearPredictor(const std::string& name, float lateral, uint32_t inputs = 49,
                                 const char* magic = "DQNDPPv2") {
  const std::string path = ::testing::TempDir() + name;
  std::ofstream out(path, std::ios::binary);
  out.write(magic, 8);
  auto u32 = [&](uint32_t v) { out.write(reinterpret_cast<const char*>(&v), 4); };
  auto f32 = [&](float v) { out.write(reinterpret_cast<const char*>(&v), 4); };
  for (uint32_t v : {5u, 10u, 6u, 200u, 1u, 20u, inputs}) u32(v);
  for (uint32_t k = 0; k < inputs; ++k) f32(0.0f);
  for (uint32_t k = 0; k < inputs; ++k) f32(1.0f);
  for (uint32_t k = 0; k < 20 * inputs; ++k) f32(0.0f);
  for (int step = 0; step < 10; ++step) {
    f32(0.0f);
    f32(lateral);
  }
  return path;
}

TEST(Oracle, PredictsPeopleWithALearnedNetwork) {
  const sim::Scenario s = discAndWalkingPerson();
  const sim::PersonSpec& person = s.people[0];
  sim::World world(s, sim::WorldConfig{}, 1);
  world.step(Twist2{}, 0.2);
  OracleConfig c;
  c.true_future_periods = 0;
  const std::vector<std::vector<Circle>> cv = OraclePlanner(c).futureBodies(world);
  // A network that adds nothing predicts constant velocity (at the first decision its past is its velocity of now).
  c.learned_prediction = writeLinearPredictor("zero.dqnp", 0.0f);
  const std::vector<std::vector<Circle>> zero = OraclePlanner(c).futureBodies(world);
  ASSERT_EQ(zero.size(), cv.size());
  for (size_t k = 0; k < cv.size(); ++k) {
    ASSERT_EQ(zero[k].size(), 2u);
    EXPECT_NEAR((zero[k][0].center - cv[k][0].center).norm(), 0.0, 1e-9) << "the disc is not a person";
    EXPECT_NEAR((zero[k][1].center - cv[k][1].center).norm(), 0.0, 1e-6) << k;
    EXPECT_DOUBLE_EQ(zero[k][1].radius, person.body_radius_m);
  }
  // 0.1 m to the person's left at every step: the person walks south, so 0.1 m east, reached after one step.
  c.learned_prediction = writeLinearPredictor("left.dqnp", 0.1f);
  const std::vector<std::vector<Circle>> left = OraclePlanner(c).futureBodies(world);
  const size_t half_step = 1, half_second = 9, three_seconds = 59;
  EXPECT_NEAR((left[half_step][1].center - cv[half_step][1].center - Vec2(0.05, 0.0)).norm(), 0.0, 1e-6);
  EXPECT_NEAR((left[half_second][1].center - cv[half_second][1].center - Vec2(0.1, 0.0)).norm(), 0.0, 1e-6);
  EXPECT_NEAR((left[three_seconds][1].center - cv[three_seconds][1].center - Vec2(0.1, 0.0)).norm(), 0.0, 1e-6);

  // Bad files are refused, naming the file and what is wrong.
  auto refusal = [&](const std::string& path) {
    OracleConfig bad;
    bad.true_future_periods = 0;
    bad.learned_prediction = path;
    try {
      OraclePlanner planner(bad);
    } catch (const PlannerError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_NE(refusal(::testing::TempDir() + "missing.dqnp").find("missing.dqnp': cannot be opened"), std::string::npos);
  const std::string wrong_inputs = writeLinearPredictor("inputs.dqnp", 0.0f, 48);
  EXPECT_NE(refusal(wrong_inputs).find("takes 48 inputs where 49 come"), std::string::npos) << refusal(wrong_inputs);
  std::vector<char> bytes;
  {
    std::ifstream in(c.learned_prediction, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  auto variant = [&](const std::string& name, std::vector<char> b) {
    const std::string path = ::testing::TempDir() + name;
    std::ofstream(path, std::ios::binary).write(b.data(), static_cast<std::streamsize>(b.size()));
    return refusal(path);
  };
  EXPECT_NE(variant("short.dqnp", std::vector<char>(bytes.begin(), bytes.end() - 3)).find("truncated at layer biases"),
            std::string::npos);
  std::vector<char> longer = bytes;
  longer.push_back('x');
  EXPECT_NE(variant("long.dqnp", longer).find("1 bytes follow the last layer"), std::string::npos);
  std::vector<char> magic = bytes;
  magic[0] = 'X';
  EXPECT_NE(variant("magic.dqnp", magic).find("magic.dqnp': not a people predictor file"), std::string::npos);
  std::vector<char> nan = bytes;
  const float not_a_number = std::nanf("");
  std::memcpy(nan.data() + bytes.size() - 4, &not_a_number, 4);
  EXPECT_NE(variant("nan.dqnp", nan).find("layer biases holds a non-finite number"), std::string::npos);
}

TEST(PeoplePrediction, AnArcIsRecoveredFromItsPath) {
  const Pose2 start{1.0, -2.0, 0.7};
  for (const double w : {0.0, 0.4, -1.1}) {
    std::vector<Vec2> path;
    for (int k = 1; k <= 10; ++k) path.push_back(integrateUnicycle(start, 0.9, w, 0.2 * k).position());
    const ArcMotion a = fitArc(start.position(), path, 0.2);
    EXPECT_NEAR(a.turn_rate_rps, w, 1e-9);
    EXPECT_NEAR(a.speed_mps, 0.9, 1e-9);
    EXPECT_NEAR(angleDiff(a.heading_rad, 0.7), 0.0, 1e-9);
  }
}

/// The walls of the square room of half size h (x, y = +-h).
std::vector<Segment> squareRoom(double h) {
  return {{{-h, -h}, {h, -h}}, {{h, -h}, {h, h}}, {{h, h}, {-h, h}}, {{-h, h}, {-h, -h}}};
}

TEST(PeoplePrediction, WallsAreSeenAlongRaysFromThePerson) {
  // A person at (1, 0.5) walking north at 1 m/s in the room of half size 4: the last 8 inputs are the walls.
  std::vector<Vec2> track;
  for (int s = 0; s <= 5; ++s) track.push_back(Vec2(1.0, 0.5 - 0.2 * (5 - s)));
  const std::vector<std::vector<Vec2>> tracks{track};
  const PeoplePredictor v2 = PeoplePredictor::load(writeLinearPredictor("walls_v2.dqnp", 0.0f));
  const PeoplePredictor v1 = PeoplePredictor::load(writeLinearPredictor("walls_v1.dqnp", 0.0f, 49, "DQNDPPv1"));
  EXPECT_EQ(v2.version(), 2);
  EXPECT_EQ(v1.version(), 1);
  const Eigen::VectorXf room2 = v2.features(tracks, 0, squareRoom(4.0)).tail(8);
  // v2: every 45 deg from the direction of motion (north), counter-clockwise; beyond 5 m the reach.
  const double expected2[8] = {3.5, std::sqrt(2.0) * 3.5, 5.0, 5.0,
                               4.5, std::sqrt(2.0) * 3.0, 3.0, std::sqrt(2.0) * 3.0};
  for (int r = 0; r < 8; ++r) EXPECT_NEAR(room2(r), expected2[r], 1e-5) << "ray " << r;
  const Eigen::VectorXf open2 = v2.features(tracks, 0, {}).tail(8);
  EXPECT_TRUE((open2.array() == 5.0f).all()) << "no wall: every ray at its reach";
  // v1: the offsets to the walls along the room's axes, in the person's frame (x north, y west), as it was learned.
  const Eigen::VectorXf room1 = v1.features(tracks, 0, squareRoom(4.0)).tail(8);
  const float expected1[8] = {0.0f, -3.0f, 0.0f, 5.0f, 3.5f, 0.0f, -4.5f, 0.0f};
  for (int k = 0; k < 8; ++k) EXPECT_NEAR(room1(k), expected1[k], 1e-5) << k;
  // A corridor wall 1 m to the person's right (east) is seen by v2's right ray only.
  const std::vector<Segment> corridor{{{2.0, -10.0}, {2.0, 10.0}}};
  const Eigen::VectorXf side = v2.features(tracks, 0, corridor).tail(8);
  EXPECT_NEAR(side(6), 1.0, 1e-5);
  EXPECT_NEAR(side(7), std::sqrt(2.0), 1e-5);
  EXPECT_NEAR(side(2), 5.0, 1e-5);
}

TEST(PeoplePrediction, TheHistoryIsReadAtThePredictorsStepWhateverTheCallRate) {
  // A person on a 0.5 rad/s turn at 1 m/s. The zero network predicts its last step's velocity, so the arc it gets says
  // which past position the history held.
  const Pose2 start{-1.0, 0.0, 0.3};
  auto seen_at = [&](double t) {
    MovingObstacle o;
    const Pose2 p = integrateUnicycle(start, 1.0, 0.5, t);
    o.center = p.position();
    o.heading = p.theta;
    o.speed = 1.0;
    return std::vector<MovingObstacle>{o};
  };
  const auto predictor =
      std::make_shared<const PeoplePredictor>(PeoplePredictor::load(writeLinearPredictor("rate.dqnp", 0.0f)));
  auto arc_after = [&](PredictedArcs& arcs, double period, double until) {
    std::vector<MovingObstacle> seen;
    for (int k = 0; k * period <= until + 1e-9; ++k) {
      seen = seen_at(k * period);
      arcs.apply(seen, {4}, k * period, {});
    }
    return seen[0];
  };
  PredictedArcs every_step(predictor), every_scan(predictor), odd(predictor);
  const MovingObstacle a = arc_after(every_step, 0.2, 2.0), b = arc_after(every_scan, 0.1, 2.0);
  EXPECT_NEAR(a.heading, b.heading, 1e-9) << "calls at 10 Hz read the same history as calls every 0.2 s";
  EXPECT_NEAR(a.speed, b.speed, 1e-9);
  // The last step's chord: the heading half a step (0.05 rad) behind the present one.
  EXPECT_NEAR(angleDiff(a.heading, seen_at(2.0)[0].heading), -0.05, 0.01);
  // Calls 0.15 s apart: the history is interpolated between them, close to the path.
  const MovingObstacle c = arc_after(odd, 0.15, 2.1);
  EXPECT_NEAR(angleDiff(c.heading, seen_at(2.1)[0].heading), -0.05, 0.01);
  // A stamp earlier than the last forgets everything: as a fresh start (walked back at the present velocity, so the
  // present heading itself).
  std::vector<MovingObstacle> again = seen_at(0.4);
  every_step.apply(again, {4}, 0.4, {});
  EXPECT_NEAR(angleDiff(again[0].heading, seen_at(0.4)[0].heading), 0.0, 1e-6);
  EXPECT_THROW(every_step.apply(again, {4}, std::nan(""), {}), PeoplePredictorError);
}

TEST(PeoplePrediction, PlannersSeeTheArcOfThePrediction) {
  // A person walking east at 1 m/s, seen at six decisions 0.2 s apart, and a chair.
  auto scene = [](int decision) {
    MovingObstacle person;
    person.center = Vec2(-2.0 + 0.2 * decision, 1.0);
    person.speed = 1.0;
    MovingObstacle chair;
    chair.center = Vec2(2.0, 2.0);
    chair.is_static = true;
    return std::vector<MovingObstacle>{person, chair};
  };
  auto run = [&](const std::string& file) {
    PredictedArcs arcs(std::make_shared<const PeoplePredictor>(PeoplePredictor::load(file)));
    std::vector<MovingObstacle> seen;
    for (int decision = 0; decision < 6; ++decision) {
      seen = scene(decision);
      arcs.apply(seen, {7, 3}, 0.2 * decision, squareRoom(4.0));
    }
    return seen;
  };
  const std::vector<MovingObstacle> straight = run(writeLinearPredictor("arc_zero.dqnp", 0.0f));
  EXPECT_NEAR(straight[0].speed, 1.0, 1e-6);
  EXPECT_NEAR(straight[0].heading, 0.0, 1e-6);
  EXPECT_NEAR(straight[0].turn_rate, 0.0, 1e-9);
  EXPECT_EQ(straight[1].speed, 0.0) << "a static obstacle keeps its motion";
  EXPECT_TRUE(straight[1].is_static);
  // Predicted 0.1 m to the left at every step: the arc bends that way (a left turn), and keeps the pace.
  const std::vector<MovingObstacle> left = run(writeLinearPredictor("arc_left.dqnp", 0.1f));
  EXPECT_GT(left[0].heading, 0.0);
  EXPECT_NEAR(left[0].speed, 1.0, 0.2);
  EXPECT_EQ(left[0].center, straight[0].center) << "where it is stays where it is";
  PredictedArcs arcs(
      std::make_shared<const PeoplePredictor>(PeoplePredictor::load(::testing::TempDir() + "arc_zero.dqnp")));
  std::vector<MovingObstacle> two = scene(0);
  EXPECT_THROW(arcs.apply(two, {1}, 0.0, squareRoom(4.0)), PeoplePredictorError);
  // The history is kept by id, as test_people_predictor.py's track_histories keeps it: the tracker says 0.5 m/s while
  // the person walks 1 m/s. Seen for the first time, it is walked back at 0.5 m/s (so the zero network predicts
  // 0.5 m/s); at the next decision its own last step says 1 m/s; not a moving track once, it starts afresh.
  arcs.reset();
  const double speeds[] = {0.5, 1.0, 1.0, -1.0, 0.5, 1.0};
  for (int decision = 0; decision < 6; ++decision) {
    std::vector<MovingObstacle> seen = scene(decision);
    seen[0].speed = 0.5;
    if (speeds[decision] < 0.0) seen[0].is_static = true;
    arcs.apply(seen, {7, 3}, 0.2 * decision, squareRoom(4.0));
    if (speeds[decision] > 0.0) {
      EXPECT_NEAR(seen[0].speed, speeds[decision], 1e-6) << decision;
    }
  }
  // An episode told to use a file that is not one says which and why.
  EpisodeConfig config;
  config.people_predictor = ::testing::TempDir() + "nothing_here.dqnp";
  try {
    Episode episode(config);
    FAIL() << "accepted a missing predictor file";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("nothing_here.dqnp': cannot be opened"), std::string::npos) << e.what();
  }
}

TEST(PeoplePrediction, EpisodesPredictPeopleNotDiscs) {
  // Perfect information in a room with a disc and a walking person, the predictor shifting everyone 0.1 m to the left:
  // after a few decisions the person's arc bends, the disc keeps its true (speed, turn rate).
  const sim::Scenario s = discAndWalkingPerson();
  auto observed = [&](const std::string& file) {
    EpisodeConfig config;
    config.perfect_info = true;
    config.people_predictor = file;
    Episode episode(config);
    episode.reset(s, 3);
    for (int k = 0; k < 5; ++k) episode.step(Twist2{});
    return episode.observation().obstacles;
  };
  const std::vector<MovingObstacle> plain = observed(""), left = observed(writeLinearPredictor("ep_left.dqnp", 0.1f));
  ASSERT_EQ(plain.size(), 2u);
  ASSERT_EQ(left.size(), 2u);
  EXPECT_EQ(left[0].speed, plain[0].speed) << "the disc is not a person";
  EXPECT_EQ(left[0].heading, plain[0].heading);
  EXPECT_EQ(left[0].turn_rate, plain[0].turn_rate);
  EXPECT_GT(std::abs(angleDiff(left[1].heading, plain[1].heading)), 0.02) << "the person's arc bends to its left";
  EXPECT_EQ(left[1].center, plain[1].center);
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
  EXPECT_EQ(setOracleParameter(c, "acceleration_prediction_s", "0.5"), "");
  EXPECT_DOUBLE_EQ(c.acceleration_prediction_s, 0.5);
  EXPECT_NE(c.validate().find("needs true_future_periods = 0"), std::string::npos);
  c.true_future_periods = 0;
  EXPECT_NE(c.validate().find("choose one"), std::string::npos);  // social_prediction is on too
  c.social_prediction = false;
  EXPECT_EQ(c.validate(), "");
  EXPECT_NE(setOracleParameter(c, "social_prediction", "2").find("not 0 or 1"), std::string::npos);
  c.true_future_periods = -2;
  EXPECT_NE(c.validate().find("true_future_periods"), std::string::npos);
  c = OracleConfig{};
  c.prediction_growth_mps = -0.1;
  EXPECT_NE(c.validate().find("prediction_growth_mps"), std::string::npos);
  c = OracleConfig{};
  c.acceleration_prediction_s = -1.0;
  EXPECT_NE(c.validate().find("acceleration_prediction_s"), std::string::npos);
  c = OracleConfig{};
  EXPECT_EQ(setOracleParameter(c, "learned_prediction", "models/people_predictor.dqnp"), "");
  EXPECT_EQ(c.learned_prediction, "models/people_predictor.dqnp");
  EXPECT_NE(c.validate().find("learned_prediction needs true_future_periods = 0"), std::string::npos);
  c.true_future_periods = 0;
  EXPECT_EQ(c.validate(), "");
  c.prediction_growth_mps = 0.1;
  EXPECT_EQ(c.validate(), "");  // growth applies to any prediction
  c.social_prediction = true;
  EXPECT_NE(c.validate().find("no other prediction of the people"), std::string::npos);
  EXPECT_NE(setOracleParameter(c, "learned_prediction", "").find("is empty"), std::string::npos);
}

// The reachability bound (evaluation/reach_bound.h): where no robot within the limits can get.

TEST(ReachBound, IsAnEvaluationMethodNotAPlanner) {
  const std::vector<std::string> names = evalMethodNames();
  EXPECT_NE(std::find(names.begin(), names.end(), "bound"), names.end());
  ReachBoundPlanner bound;
  EXPECT_EQ(bound.name(), "bound");
  EXPECT_THROW(bound.decide(PlannerInput{}), PlannerError);
}

TEST(ReachBound, AFreeGoalIsReachedNoSoonerThanTheRobotCouldGetThere) {
  // 5 m straight ahead from rest: no robot at 0.7 m/s that starts from rest at 0.5 m/s^2 arrives within 0.15 m
  // before (4.85 + 0.49) / 0.7 = 7.63 s; the bound's own slack (a cell) keeps it within a period of that.
  const EpisodeRecord r = run("bound", emptyRoom({-2.5, 0.0, 0.0}, {2.5, 0.0}));
  ASSERT_EQ(r.outcome, Outcome::kSuccess) << r.last_decision;
  const double earliest = (5.0 - 0.15 + 0.7 * 0.7 / (2.0 * 0.5)) / 0.7;
  EXPECT_GE(r.time_s, earliest - 0.2 - 1e-9);
  EXPECT_LE(r.time_s, earliest + 0.2 + 1e-9);
  EXPECT_EQ(r.steps, static_cast<int>(std::lround(r.time_s / 0.2)));
  EXPECT_NE(r.last_decision.find("reachable"), std::string::npos) << r.last_decision;
  // A coarser grid is more optimistic, never less.
  ReachBoundConfig coarse;
  coarse.cell_m = 0.1;
  EXPECT_LE(run("bound", emptyRoom({-2.5, 0.0, 0.0}, {2.5, 0.0}), perfectInformation(), coarse).time_s, r.time_s);
}

TEST(ReachBound, AGoalBehindAClosedWallIsOutOfReach) {
  // The room's wall across its middle, no door: the set fills the near half and never the goal's.
  sim::Scenario s = emptyRoom({-2.5, 0.0, 0.0}, {2.5, 0.0});
  s.static_segments.push_back(Segment{Vec2(0.0, -4.0), Vec2(0.0, 4.0)});
  const EpisodeRecord r = run("bound", s);
  EXPECT_EQ(r.outcome, Outcome::kTimeout) << r.last_decision;
  EXPECT_EQ(r.steps, EpisodeConfig{}.reward.max_steps);
  // With a door in that wall it is reachable again, later than straight across.
  sim::Scenario door = emptyRoom({-2.5, 0.0, 0.0}, {2.5, 0.0});
  door.static_segments.push_back(Segment{Vec2(0.0, -4.0), Vec2(0.0, 2.0)});
  door.static_segments.push_back(Segment{Vec2(0.0, 3.0), Vec2(0.0, 4.0)});
  const EpisodeRecord through = run("bound", door);
  EXPECT_EQ(through.outcome, Outcome::kSuccess) << through.last_decision;
  EXPECT_GT(through.time_s, run("bound", emptyRoom({-2.5, 0.0, 0.0}, {2.5, 0.0})).time_s + 1.0);
}

TEST(ReachBound, AFastDiscFromCloseByMakesTheCollisionCertain) {
  // The oracle's fast disc: even a robot that could move sideways at once cannot get clear.
  sim::Scenario s = fastDiscHeadOn();
  const EpisodeRecord r = run("bound", s);
  EXPECT_EQ(r.outcome, Outcome::kCollision) << r.last_decision;
  EXPECT_LE(r.time_s, 0.4 + 1e-9);
  EXPECT_NE(r.last_decision.find("unavoidable"), std::string::npos) << r.last_decision;
  // The same disc slower and farther: clear.
  s.obstacles[0].center = Vec2(2.5, 1.0);
  s.obstacles[0].speed = 0.3;
  EXPECT_EQ(run("bound", s).outcome, Outcome::kSuccess);
}

TEST(ReachBound, NoPlannerDoesWhatTheBoundRulesOut) {
  // Generated episodes of the paper's room, tracker in the loop; at seed 16103 one of them starts with a disc too
  // close to escape (N = 12) and one in contact (N = 14). Every method's successes must be the bound's successes,
  // none sooner, and where the bound says a collision is certain every method collides, none later.
  EvalConfig eval;
  eval.methods = {"bound", "oracle", "s_dovs", "dqn_dovs"};
  eval.seed = 16103;
  eval.obstacles_min = 12;
  eval.obstacles_max = 14;
  eval.episodes = 1;
  eval.threads = 2;
  eval.model_path = std::string(DQN_DOVS_SOURCE_DIR) + "/models/dqn_dovs.dqnw";
  const std::vector<EpisodeRecord> records = runEvaluation(eval, loadEvalScenarios(eval), nullptr);
  std::map<std::pair<int, int>, const EpisodeRecord*> bound;
  for (const EpisodeRecord& r : records) {
    if (r.method == "bound") bound[{r.obstacles, r.episode}] = &r;
  }
  ASSERT_EQ(bound.size(), 3u);
  int certain = 0, others_solved = 0;
  for (const auto& [key, b] : bound) certain += b->outcome == Outcome::kCollision;
  EXPECT_GE(certain, 1);
  for (const EpisodeRecord& r : records) {
    if (r.method == "bound") continue;
    const EpisodeRecord& b = *bound.at({r.obstacles, r.episode});
    if (r.outcome == Outcome::kSuccess) {
      ++others_solved;
      EXPECT_EQ(b.outcome, Outcome::kSuccess) << r.method << " N " << r.obstacles << ": " << b.last_decision;
      EXPECT_GE(r.time_s + 1e-9, b.time_s) << r.method << " N " << r.obstacles;
    }
    if (b.outcome == Outcome::kCollision) {
      EXPECT_EQ(r.outcome, Outcome::kCollision) << r.method << " N " << r.obstacles;
      EXPECT_LE(r.time_s, b.time_s + 1e-9) << r.method << " N " << r.obstacles;
    }
  }
  EXPECT_GE(others_solved, 1);
}

TEST(ReachBound, ParametersAreNamedAndChecked) {
  ReachBoundConfig c;
  EXPECT_EQ(setReachBoundParameter(c, "cell_m", "0.05"), "");
  EXPECT_DOUBLE_EQ(c.cell_m, 0.05);
  EXPECT_EQ(setReachBoundParameter(c, "body_margin_m", "0"), "");
  EXPECT_EQ(setReachBoundParameter(c, "grid_margin_m", "2"), "");
  EXPECT_EQ(c.validate(), "");
  EXPECT_NE(setReachBoundParameter(c, "cell", "0.05").find("unknown bound parameter 'cell'"), std::string::npos);
  EXPECT_NE(setReachBoundParameter(c, "cell_m", "fine").find("not a number"), std::string::npos);
  c.cell_m = 0.0;
  EXPECT_NE(c.validate().find("cell_m"), std::string::npos);
  EXPECT_THROW(ReachBoundPlanner{c}, PlannerError);
  // People who see the robot have no future of their own: the evaluation refuses the bound with them.
  EvalConfig eval;
  eval.methods = {"bound", "s_dovs"};
  eval.people_see_robot = true;
  EXPECT_NE(eval.validate().find("bound needs people who ignore the robot"), std::string::npos) << eval.validate();
  sim::WorldConfig seeing;
  seeing.people.see_robot = true;
  sim::World world(emptyRoom({0.0, 0.0, 0.0}, {3.0, 0.0}), seeing, 1);
  EXPECT_THROW(reachBound(world, ReachBoundConfig{}), PlannerError);
}

}  // namespace
}  // namespace dqn_dovs
