// The evaluation runner: complete and deterministic records, and the record files it writes (results.csv,
// run.json, paths.json; the summaries made from them are tested with the Python reporter, test/python/test_report.py).
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>
#include <string>

#include "dqn_dovs/evaluation/eval.h"
#include "sim_test_helpers.h"

namespace dqn_dovs {
namespace {

EvalConfig tinyConfig(int threads) {
  EvalConfig c;
  c.methods = {"s_dovs", "dqn_dovs"};
  c.model_path = std::string(DQN_DOVS_SOURCE_DIR) + "/models/dqn_dovs.dqnw";
  c.seed = 11;
  c.obstacles_min = 3;
  c.obstacles_max = 4;
  c.episodes = 2;
  c.threads = threads;
  c.keep_paths = {{4, 2}};
  return c;
}

std::string readAll(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

TEST(Eval, TinyRunIsCompleteAndIndependentOfThreadCount) {
  const EvalConfig one = tinyConfig(1), two = tinyConfig(2);
  const std::vector<EvalScenario> scenarios = loadEvalScenarios(one);
  ASSERT_EQ(scenarios.size(), 4u);
  EXPECT_EQ(scenarios[0].obstacles, 3);
  EXPECT_EQ(scenarios[3].episode, 2);
  EXPECT_EQ(scenarios[3].scenario.obstacles.size(), 4u);
  // Same protocol, same scenarios: the loader is deterministic.
  const std::vector<EvalScenario> again = loadEvalScenarios(two);
  for (size_t i = 0; i < scenarios.size(); ++i) {
    EXPECT_EQ(scenarios[i].seed, again[i].seed);
    EXPECT_EQ(scenarios[i].scenario.goal, again[i].scenario.goal);
  }

  size_t calls = 0, last_done = 0;
  const std::vector<EpisodeRecord> a =
      runEvaluation(one, scenarios, [&](const EpisodeRecord&, size_t done, size_t total) {
        ++calls;
        EXPECT_EQ(total, 8u);
        EXPECT_EQ(done, last_done + 1);
        last_done = done;
      });
  const std::vector<EpisodeRecord> b = runEvaluation(two, scenarios);
  EXPECT_EQ(calls, 8u);
  ASSERT_EQ(a.size(), 8u);
  ASSERT_EQ(b.size(), 8u);
  for (size_t i = 0; i < a.size(); ++i) {
    const EpisodeRecord& r = a[i];
    EXPECT_EQ(r.method, i < 4 ? "s_dovs" : "dqn_dovs");
    EXPECT_EQ(r.obstacles, 3 + static_cast<int>((i % 4) / 2));
    EXPECT_EQ(r.episode, 1 + static_cast<int>(i % 2));
    EXPECT_NE(r.outcome, Outcome::kRunning);
    EXPECT_GT(r.steps, 0);
    EXPECT_GT(r.time_s, 0.0);
    EXPECT_TRUE(std::isfinite(r.min_clearance_m));
    EXPECT_EQ(r.robot_path.empty(), !(r.obstacles == 4 && r.episode == 2));
    // Bit-identical whatever the thread count.
    EXPECT_EQ(r.outcome, b[i].outcome);
    EXPECT_EQ(r.steps, b[i].steps);
    EXPECT_EQ(r.time_s, b[i].time_s);
    EXPECT_EQ(r.path_length_m, b[i].path_length_m);
    EXPECT_EQ(r.min_clearance_m, b[i].min_clearance_m);
    EXPECT_EQ(r.danger_steps, b[i].danger_steps);
  }
  const EpisodeRecord& kept = a[3];
  ASSERT_EQ(kept.obstacle_paths.size(), 4u);
  EXPECT_EQ(kept.obstacle_paths[0].size(), kept.robot_path.size());

  test::TempDir dir;
  const std::string csv = dir.file("results.csv"), run = dir.file("run.json"), paths = dir.file("paths.json");
  writeResultsCsv(a, csv);
  EvalRunInfo info{"dqn_dovs_eval --say \"hi\"\tthere", 1.5, "dqn_dovs"};
  writeRunJson(one, info, run);
  writePathsJson(a, scenarios, 0.15, paths);
  const std::string csv_text = readAll(csv);
  EXPECT_EQ(csv_text.rfind("method,obstacles,episode,scenario,outcome,time_s,path_length_m,min_clearance_m", 0), 0u);
  EXPECT_EQ(std::count(csv_text.begin(), csv_text.end(), '\n'), 9);
  const std::string run_text = readAll(run);
  // Strings are escaped (quote, tab), the methods keep their order, numbers are plain.
  EXPECT_NE(run_text.find("\"command\": \"dqn_dovs_eval --say \\\"hi\\\"\\u0009there\""), std::string::npos)
      << run_text;
  EXPECT_NE(run_text.find("\"methods\": [\"s_dovs\", \"dqn_dovs\"]"), std::string::npos) << run_text;
  EXPECT_NE(run_text.find("\"scenarios\": \"generated\""), std::string::npos) << run_text;
  EXPECT_NE(run_text.find("\"seed\": 11,"), std::string::npos) << run_text;
  EXPECT_NE(run_text.find("\"obstacles_min\": 3,"), std::string::npos) << run_text;
  EXPECT_NE(run_text.find("\"reference\": \"dqn_dovs\""), std::string::npos) << run_text;
  EXPECT_NE(run_text.find("\"perfect_info\": false"), std::string::npos) << run_text;
  // paths.json: only the kept job (N = 4, episode 2), once per method, with every step of the robot and obstacles.
  const std::string paths_text = readAll(paths);
  size_t episodes = 0;
  for (size_t at = paths_text.find("\"method\""); at != std::string::npos; at = paths_text.find("\"method\"", at + 1))
    ++episodes;
  EXPECT_EQ(episodes, 2u) << paths_text.substr(0, 400);
  EXPECT_NE(paths_text.find("\"obstacles\": 4, \"episode\": 2"), std::string::npos);
  EXPECT_EQ(paths_text.find("\"episode\": 1,"), std::string::npos);
  const size_t points = static_cast<size_t>(std::count(paths_text.begin(), paths_text.end(), '['));
  EXPECT_GT(points, kept.robot_path.size() + 4 * kept.obstacle_paths[0].size());
  EXPECT_EQ(paths_text.find("nan"), std::string::npos);
  // A record whose scenario is missing is named.
  try {
    writePathsJson(a, {}, 0.15, dir.file("none.json"));
    FAIL() << "no error for a record without its scenario";
  } catch (const EvalError& e) {
    EXPECT_NE(std::string(e.what()).find("N=4, episode 2"), std::string::npos) << e.what();
  }
  EXPECT_THROW(writeRunJson(one, info, "/nonexistent/dir/run.json"), EvalError);
}

TEST(Eval, LoadsTheSharedScenariosWithTheDynamicFraction) {
  EvalConfig c;
  c.scenarios_dir = std::string(DQN_DOVS_SHARED_DIR) + "/scenarios/rumor";
  c.obstacles_min = 15;
  c.obstacles_max = 15;
  c.episodes = 3;
  const std::vector<EvalScenario> s = loadEvalScenarios(c);
  ASSERT_EQ(s.size(), 3u);
  int statics = 0;
  for (const MovingObstacle& o : s[0].scenario.obstacles) statics += o.is_static ? 1 : 0;
  EXPECT_EQ(statics, 2);  // round(0.15 * 15)
  EXPECT_EQ(s[2].scenario.name, "1-15/3");
}

TEST(Eval, BadConfigurationAndMissingFilesAreNamed) {
  EvalConfig c;
  c.scenarios_dir = "/nonexistent/scenarios";
  c.obstacles_min = c.obstacles_max = 2;
  c.episodes = 1;
  try {
    loadEvalScenarios(c);
    FAIL() << "no error for a missing scenario file";
  } catch (const EvalError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/scenarios/1-2/1.dovs"), std::string::npos) << e.what();
  }
  c = EvalConfig();
  c.threads = 0;
  EXPECT_NE(c.validate().find("threads"), std::string::npos);
  c = EvalConfig();
  c.methods = {"s_dovs", "s_dovs"};
  EXPECT_NE(c.validate().find("twice"), std::string::npos);
  c = EvalConfig();
  c.dynamic_fraction = std::nan("");
  EXPECT_NE(c.validate().find("dynamic_fraction"), std::string::npos);
  // An unknown method fails the run with the method's name, not a crash.
  c = EvalConfig();
  c.methods = {"teleport"};
  c.obstacles_min = c.obstacles_max = 1;
  c.episodes = 1;
  try {
    runEvaluation(c, loadEvalScenarios(c));
    FAIL() << "no error for an unknown method";
  } catch (const EvalError& e) {
    EXPECT_NE(std::string(e.what()).find("teleport"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace dqn_dovs
