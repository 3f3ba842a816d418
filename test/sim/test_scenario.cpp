#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <set>
#include <string>

#include "dqn_dovs/sim/scenario.h"
#include "sim_test_helpers.h"
#include "source_paths.h"

namespace dqn_dovs::sim {
namespace {

const std::string kRoom = std::string(DQN_DOVS_SCENARIOS_DIR) + "/room";

// Loads `path` expecting a ScenarioError whose message names the file and contains `reason`.
void expectLoadError(const std::string& path, const std::string& reason) {
  try {
    loadDovsScenario(path);
    FAIL() << "loading " << path << " must throw";
  } catch (const ScenarioError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(path), std::string::npos) << what;
    EXPECT_NE(what.find(reason), std::string::npos) << what;
  }
}

TEST(LoadDovsScenario, ReadsACarriedEpisode) {
  const Scenario s = loadDovsScenario(kRoom + "/1-5/1.dovs");
  EXPECT_EQ(s.name, "1-5/1");
  EXPECT_DOUBLE_EQ(s.room_half_size_m, 4.0);
  EXPECT_NEAR(s.robot_start.x, 2.9528, 1e-4);
  EXPECT_NEAR(s.robot_start.y, 2.5631, 1e-4);
  EXPECT_EQ(s.robot_start.theta, 0.0);
  EXPECT_NEAR(s.goal.x(), 1.5938, 1e-4);
  EXPECT_NEAR(s.goal.y(), -2.8249, 1e-4);
  ASSERT_EQ(s.obstacles.size(), 5u);
  const MovingObstacle& o = s.obstacles[0];
  EXPECT_NEAR(o.center.x(), 0.3174, 1e-4);
  EXPECT_NEAR(o.center.y(), 0.5875, 1e-4);
  EXPECT_NEAR(o.heading, -1.1106, 1e-4);
  EXPECT_NEAR(o.speed, 0.3518, 1e-4);
  EXPECT_NEAR(o.turn_rate, -0.4117, 1e-4);
  EXPECT_DOUBLE_EQ(o.radius, 0.2);
  EXPECT_FALSE(o.is_static);
  EXPECT_NEAR(s.obstacles[4].center.x(), 2.4924, 1e-4);
  EXPECT_NEAR(s.obstacles[4].heading, 0.9013, 1e-4);
  EXPECT_NEAR(s.obstacles[4].turn_rate, 0.2474, 1e-4);
  EXPECT_TRUE(s.static_segments.empty());
  // The radius is a parameter.
  EXPECT_DOUBLE_EQ(loadDovsScenario(kRoom + "/1-5/1.dovs", 0.35).obstacles[2].radius, 0.35);
}

TEST(LoadDovsScenario, EveryCarriedFileMatchesTheDocumentedDistribution) {
  for (int n = 1; n <= 15; ++n) {
    for (int k = 1; k <= 100; ++k) {
      const std::string path = kRoom + "/1-" + std::to_string(n) + "/" + std::to_string(k) + ".dovs";
      const Scenario s = loadDovsScenario(path);
      ASSERT_EQ(s.obstacles.size(), static_cast<size_t>(n)) << path;
      ASSERT_GE((s.goal - s.robot_start.position()).norm(), 4.0) << path;
      for (const MovingObstacle& o : s.obstacles) {
        ASSERT_GE(o.speed, 0.2) << path;
        ASSERT_LE(o.speed, 1.2) << path;
        ASSERT_LE(std::abs(o.turn_rate), kPi / 6 + 1e-9) << path;
        ASSERT_LE(std::abs(o.center.x()), 3.0) << path;
        ASSERT_LE(std::abs(o.center.y()), 3.0) << path;
        ASSERT_GE((o.center - s.robot_start.position()).norm(), 0.66) << path;
      }
    }
  }
}

TEST(LoadDovsScenario, MalformedFilesNameTheFileAndTheReason) {
  test::TempDir dir;
  const std::vector<double> good = {0.0, 0.0, 0.0, 2.0, 2.0, 1.0, 1.0, 0.5, 0.6, 0.1};
  const std::string ok = dir.file("ok.dovs");
  test::writeDoubles(ok, good);
  EXPECT_EQ(loadDovsScenario(ok).obstacles.size(), 1u);

  expectLoadError(dir.path() + "/does_not_exist.dovs", "cannot open");

  const std::string empty = dir.file("empty.dovs");
  test::writeBytes(empty, {});
  expectLoadError(empty, "empty");

  // Truncated: the last obstacle row lost its final byte.
  const std::string truncated = dir.file("truncated.dovs");
  std::vector<unsigned char> bytes(good.size() * 8);
  std::memcpy(bytes.data(), good.data(), bytes.size());
  bytes.pop_back();
  test::writeBytes(truncated, bytes);
  expectLoadError(truncated, "not a multiple of 40");

  // Wrong size: a stray 6th value.
  const std::string wrong = dir.file("wrong_size.dovs");
  std::vector<double> six = good;
  six.push_back(1.0);
  test::writeDoubles(wrong, six);
  expectLoadError(wrong, "not a multiple of 40");

  const std::string nan = dir.file("nan.dovs");
  std::vector<double> with_nan = good;
  with_nan[8] = std::nan("");
  test::writeDoubles(nan, with_nan);
  expectLoadError(nan, "row 1 (obstacle 1) column 3");

  const std::string inf = dir.file("inf.dovs");
  std::vector<double> with_inf = good;
  with_inf[3] = std::numeric_limits<double>::infinity();
  test::writeDoubles(inf, with_inf);
  expectLoadError(inf, "finite");

  const std::string outside = dir.file("outside.dovs");
  std::vector<double> far = good;
  far[5] = 4.5;
  test::writeDoubles(outside, far);
  expectLoadError(outside, "outside the room");

  const std::string robot_out = dir.file("robot_outside.dovs");
  std::vector<double> robot_far = good;
  robot_far[1] = -4.0;  // on the wall counts as outside
  test::writeDoubles(robot_out, robot_far);
  expectLoadError(robot_out, "robot position");
}

TEST(LoadDovsScenario, NegativeSpeedBecomesTheSameForwardMotionAndZeroMotionIsStatic) {
  test::TempDir dir;
  const std::string path = dir.file("neg.dovs");
  test::writeDoubles(path, {0.0, 0.0, 0.0, 2.0, 2.0, 1.0, 1.0, 0.5, -0.6, 0.1, -1.0, -1.0, 0.0, 0.0, 0.0});
  const Scenario s = loadDovsScenario(path);
  ASSERT_EQ(s.obstacles.size(), 2u);
  EXPECT_NEAR(s.obstacles[0].speed, 0.6, 1e-12);
  EXPECT_NEAR(s.obstacles[0].heading, normalizeAngle(0.5 + kPi), 1e-12);
  EXPECT_NEAR(s.obstacles[0].turn_rate, 0.1, 1e-12);
  EXPECT_FALSE(s.obstacles[0].is_static);
  EXPECT_TRUE(s.obstacles[1].is_static);
}

TEST(SaveDovsScenario, RoundTripsExactly) {
  test::TempDir dir;
  Scenario s = loadDovsScenario(kRoom + "/1-12/37.dovs");
  applyDynamicFraction(s, 0.85);
  const std::string path = dir.file("copy.dovs");
  saveDovsScenario(s, path);
  const Scenario r = loadDovsScenario(path);
  EXPECT_EQ(r.robot_start.x, s.robot_start.x);
  EXPECT_EQ(r.robot_start.y, s.robot_start.y);
  EXPECT_EQ(r.goal, s.goal);
  ASSERT_EQ(r.obstacles.size(), s.obstacles.size());
  for (size_t i = 0; i < s.obstacles.size(); ++i) {
    EXPECT_EQ(r.obstacles[i].center, s.obstacles[i].center);
    EXPECT_EQ(r.obstacles[i].heading, s.obstacles[i].heading);
    EXPECT_EQ(r.obstacles[i].speed, s.obstacles[i].speed);
    EXPECT_EQ(r.obstacles[i].turn_rate, s.obstacles[i].turn_rate);
    EXPECT_EQ(r.obstacles[i].is_static, s.obstacles[i].is_static);
  }

  Scenario with_walls = s;
  with_walls.static_segments.push_back({Vec2(0, 0), Vec2(1, 0)});
  const std::string lost = dir.file("walls.dovs");
  try {
    saveDovsScenario(with_walls, lost);
    FAIL() << "static segments cannot be stored";
  } catch (const ScenarioError& e) {
    EXPECT_NE(std::string(e.what()).find(lost), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("static segments"), std::string::npos);
  }
  EXPECT_THROW(saveDovsScenario(s, dir.path() + "/no/such/dir/x.dovs"), ScenarioError);
}

TEST(ApplyDynamicFraction, MakesTheLastRoundedShareStatic) {
  // round(0.15 * N): N = 1 -> 0, 3 -> 0, 4 -> 1, 10 -> 2 (1.5 rounds up), 15 -> 2.
  const std::pair<int, size_t> cases[] = {{1, 0}, {3, 0}, {4, 1}, {7, 1}, {10, 2}, {14, 2}, {15, 2}};
  for (const auto& [n, expected_static] : cases) {
    Scenario s = loadDovsScenario(kRoom + "/1-" + std::to_string(n) + "/3.dovs");
    const Scenario original = s;
    applyDynamicFraction(s, 0.85);
    size_t n_static = 0;
    for (size_t i = 0; i < s.obstacles.size(); ++i) {
      const bool should_be_static = i >= s.obstacles.size() - expected_static;
      EXPECT_EQ(s.obstacles[i].is_static, should_be_static) << "N = " << n << ", obstacle " << i;
      EXPECT_EQ(s.obstacles[i].center, original.obstacles[i].center);
      if (should_be_static) {
        EXPECT_EQ(s.obstacles[i].speed, 0.0);
        EXPECT_EQ(s.obstacles[i].turn_rate, 0.0);
        ++n_static;
      } else {
        EXPECT_EQ(s.obstacles[i].speed, original.obstacles[i].speed);
      }
    }
    EXPECT_EQ(n_static, expected_static) << "N = " << n;
  }
  Scenario s = loadDovsScenario(kRoom + "/1-6/1.dovs");
  Scenario all_static = s;
  applyDynamicFraction(all_static, 0.0);
  for (const auto& o : all_static.obstacles) EXPECT_TRUE(o.is_static);
  Scenario none_static = s;
  applyDynamicFraction(none_static, 1.0);
  for (const auto& o : none_static.obstacles) EXPECT_FALSE(o.is_static);
  EXPECT_THROW(applyDynamicFraction(s, 1.5), ScenarioError);
  EXPECT_THROW(applyDynamicFraction(s, std::nan("")), ScenarioError);
}

TEST(GeneratorConfig, ValidateNamesTheBadField) {
  EXPECT_EQ(GeneratorConfig().validate(), "");
  GeneratorConfig c;
  c.spawn_half_size_m = 5.0;
  EXPECT_NE(c.validate().find("spawn_half_size_m"), std::string::npos);
  c = GeneratorConfig();
  c.obstacle_count_max = -1;
  EXPECT_NE(c.validate().find("obstacle_count_max"), std::string::npos);
  c = GeneratorConfig();
  c.goal_distance_max_m = 0.5;
  EXPECT_NE(c.validate().find("goal_distance_max_m"), std::string::npos);
  c = GeneratorConfig();
  c.dynamic_fraction = std::nan("");
  EXPECT_NE(c.validate().find("dynamic_fraction"), std::string::npos);
  c = GeneratorConfig();
  c.speed_max_mps = 0.1;
  EXPECT_NE(c.validate().find("speed_max_mps"), std::string::npos);
  try {
    generateScenario(c, 1);
    FAIL() << "an invalid config must throw";
  } catch (const ScenarioError& e) {
    EXPECT_NE(std::string(e.what()).find("speed_max_mps"), std::string::npos);
  }
}

TEST(GenerateScenario, IsDeterministicBySeed) {
  GeneratorConfig c;
  c.obstacle_count_min = 5;
  c.obstacle_count_max = 12;
  const Scenario a = generateScenario(c, 1234), b = generateScenario(c, 1234), d = generateScenario(c, 1235);
  EXPECT_EQ(a.name, "generated/seed=1234");
  EXPECT_EQ(a.robot_start.x, b.robot_start.x);
  EXPECT_EQ(a.robot_start.theta, b.robot_start.theta);
  EXPECT_EQ(a.goal, b.goal);
  ASSERT_EQ(a.obstacles.size(), b.obstacles.size());
  for (size_t i = 0; i < a.obstacles.size(); ++i) {
    EXPECT_EQ(a.obstacles[i].center, b.obstacles[i].center);
    EXPECT_EQ(a.obstacles[i].heading, b.obstacles[i].heading);
    EXPECT_EQ(a.obstacles[i].speed, b.obstacles[i].speed);
    EXPECT_EQ(a.obstacles[i].turn_rate, b.obstacles[i].turn_rate);
    EXPECT_EQ(a.obstacles[i].is_static, b.obstacles[i].is_static);
  }
  EXPECT_NE(a.robot_start.x, d.robot_start.x);
}

TEST(GenerateScenario, RespectsEveryConstraint) {
  GeneratorConfig c;
  c.obstacle_count_min = 3;
  c.obstacle_count_max = 12;
  c.goal_distance_min_m = 2.0;
  c.goal_distance_max_m = 5.0;
  c.radius_min_m = 0.15;
  c.radius_max_m = 0.3;
  std::set<size_t> counts;
  size_t dynamic = 0, total = 0;
  for (uint64_t seed = 0; seed < 400; ++seed) {
    const Scenario s = generateScenario(c, seed);
    counts.insert(s.obstacles.size());
    ASSERT_GE(s.obstacles.size(), 3u);
    ASSERT_LE(s.obstacles.size(), 12u);
    const Vec2 robot = s.robot_start.position();
    const double d_goal = (s.goal - robot).norm();
    ASSERT_GE(d_goal, 2.0);
    ASSERT_LE(d_goal, 5.0);
    ASSERT_LE(std::abs(s.goal.x()), 3.0);
    ASSERT_LE(std::abs(robot.y()), 3.0);
    for (size_t i = 0; i < s.obstacles.size(); ++i) {
      const MovingObstacle& o = s.obstacles[i];
      ASSERT_LE(std::abs(o.center.x()), 3.0);
      ASSERT_LE(std::abs(o.center.y()), 3.0);
      ASSERT_GE(o.radius, 0.15);
      ASSERT_LE(o.radius, 0.3);
      ASSERT_GE((o.center - robot).norm(), 0.66);
      ASSERT_GE((o.center - s.goal).norm(), 0.66);
      for (size_t j = 0; j < i; ++j) ASSERT_GE((o.center - s.obstacles[j].center).norm(), 0.66);
      ++total;
      if (o.is_static) {
        ASSERT_EQ(o.speed, 0.0);
        ASSERT_EQ(o.turn_rate, 0.0);
      } else {
        ++dynamic;
        ASSERT_GE(o.speed, 0.2);
        ASSERT_LE(o.speed, 1.2);
        ASSERT_LE(std::abs(o.turn_rate), kPi / 6);
      }
    }
  }
  EXPECT_EQ(counts.size(), 10u);  // every count 3..12 occurs
  EXPECT_NEAR(static_cast<double>(dynamic) / total, 0.85, 0.03);
}

TEST(GenerateScenario, AClearStartKeepsEveryArcOffTheRobotForItsTime) {
  GeneratorConfig g;
  g.obstacle_count_min = g.obstacle_count_max = 12;
  g.dynamic_fraction = 1.0;
  g.goal_distance_min_m = 4.0;
  int reached_without = 0;
  for (uint64_t seed = 1; seed <= 40; ++seed) {
    g.start_clear_s = 0.0;
    const Scenario plain = generateScenario(g, seed);
    g.start_clear_s = 3.0;
    const Scenario clear = generateScenario(g, seed);
    const Vec2 robot = clear.robot_start.position();
    // Reached within 3 s: robot radius + obstacle radius + margin, while inside the room.
    auto reaches = [&](const Scenario& s) {
      for (const MovingObstacle& o : s.obstacles) {
        for (double t = 0.0; t <= 3.0; t += 0.01) {
          // Where the obstacle is after t s on its own (v, w) arc (no walls).
          const Vec2 p = integrateUnicycle({o.center.x(), o.center.y(), o.heading}, o.speed, o.turn_rate, t).position();
          if (std::abs(p.x()) > 4.0 - o.radius || std::abs(p.y()) > 4.0 - o.radius) break;
          if ((p - robot).norm() < g.robot_radius_m + o.radius + g.start_clear_margin_m - 0.01) return true;
        }
      }
      return false;
    };
    EXPECT_FALSE(reaches(clear)) << "seed " << seed;
    reached_without += reaches(plain) ? 1 : 0;
    // The robot and the goal do not depend on the rule.
    EXPECT_EQ(clear.robot_start.position(), plain.robot_start.position());
    EXPECT_EQ(clear.goal, plain.goal);
  }
  EXPECT_GT(reached_without, 5);  // the rule has something to do: 12 obstacles often reach the start
  g.start_clear_s = -0.5;
  EXPECT_NE(g.validate().find("start_clear_s"), std::string::npos);
  g.start_clear_s = 0.0;
  g.start_clear_margin_m = std::nan("");
  EXPECT_NE(g.validate().find("start_clear_margin_m"), std::string::npos);
}

TEST(GenerateScenario, ObstacleTypes) {
  GeneratorConfig c;
  c.obstacle_count_min = c.obstacle_count_max = 8;
  c.obstacle_type = ObstacleType::kNone;
  EXPECT_TRUE(generateScenario(c, 3).obstacles.empty());
  c.obstacle_type = ObstacleType::kStatic;
  const Scenario st = generateScenario(c, 3);
  ASSERT_EQ(st.obstacles.size(), 8u);
  for (const auto& o : st.obstacles) EXPECT_TRUE(o.is_static);
  c.obstacle_type = ObstacleType::kDynamic;
  const Scenario dy = generateScenario(c, 3);
  for (const auto& o : dy.obstacles) EXPECT_FALSE(o.is_static);
  // The type does not change where things are.
  for (size_t i = 0; i < 8; ++i) EXPECT_EQ(st.obstacles[i].center, dy.obstacles[i].center);
  c.random_robot_heading = false;
  EXPECT_EQ(generateScenario(c, 3).robot_start.theta, 0.0);
}

TEST(GenerateScenario, ImpossibleRequestsFailWithAReason) {
  GeneratorConfig c;
  c.spawn_half_size_m = 1.0;
  c.obstacle_count_min = c.obstacle_count_max = 40;
  c.max_attempts = 200;
  try {
    generateScenario(c, 9);
    FAIL() << "40 obstacles 0.66 m apart do not fit in a 2 x 2 m square";
  } catch (const ScenarioError& e) {
    EXPECT_NE(std::string(e.what()).find("could not place obstacle"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("seed 9"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace dqn_dovs::sim
