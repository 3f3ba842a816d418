// The evaluation runner: complete and deterministic records, the summary maths, and the files it writes.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <string>

#include "dqn_dovs/eval.h"
#include "dqn_dovs/eval_plots.h"
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
    EXPECT_NE(r.outcome, Outcome::Running);
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
  const EvalSummary s = summarize(a, "dqn_dovs");
  const std::string csv = dir.file("results.csv"), md = dir.file("summary.md"), json = dir.file("summary.json"),
                    plot = dir.file("success.png"), traj = dir.file("traj.png");
  writeResultsCsv(a, csv);
  writeSummaryMarkdown(s, md, "tiny run");
  writeSummaryJson(s, json);
  plotSuccessVsObstacles(s, plot);
  plotTrajectory(kept, scenarios[3].scenario, 0.15, traj);
  const std::string csv_text = readAll(csv);
  EXPECT_EQ(csv_text.rfind("method,obstacles,episode,scenario,outcome,time_s,path_length_m,min_clearance_m", 0), 0u);
  EXPECT_EQ(std::count(csv_text.begin(), csv_text.end(), '\n'), 9);
  const std::string md_text = readAll(md);
  EXPECT_NE(md_text.find("| Obs | s_dovs | dqn_dovs |"), std::string::npos) << md_text;
  EXPECT_NE(md_text.find("| 3 |"), std::string::npos);
  EXPECT_NE(md_text.find("| mean |"), std::string::npos);
  EXPECT_NE(md_text.find("## Collision rate"), std::string::npos);
  EXPECT_NE(md_text.find("## Timeout rate"), std::string::npos);
  const std::string json_text = readAll(json);
  EXPECT_NE(json_text.find("\"s_dovs.success_mean\""), std::string::npos) << json_text;
  EXPECT_NE(json_text.find("\"dqn_dovs.success_4\""), std::string::npos) << json_text;
  EXPECT_GT(readAll(plot).size(), 1000u);
  EXPECT_GT(readAll(traj).size(), 1000u);
  EpisodeRecord no_paths = a[0];
  EXPECT_THROW(plotTrajectory(no_paths, scenarios[0].scenario, 0.15, dir.file("none.png")), EvalError);
}

EpisodeRecord rec(const std::string& m, int n, int k, Outcome o, double t, int danger = 0, int steps = 10) {
  EpisodeRecord r;
  r.method = m;
  r.obstacles = n;
  r.episode = k;
  r.outcome = o;
  r.time_s = t;
  r.danger_steps = danger;
  r.steps = steps;
  r.min_clearance_m = 0.5;
  return r;
}

TEST(Eval, SummaryMathsOnHandBuiltRecords) {
  const std::vector<EpisodeRecord> records = {
      rec("ref", 1, 1, Outcome::Success, 10.0),       rec("ref", 1, 2, Outcome::Success, 20.0),
      rec("ref", 1, 3, Outcome::Collision, 3.0),      rec("ref", 1, 4, Outcome::Timeout, 100.0),
      rec("ref", 2, 1, Outcome::Success, 8.0),        rec("m", 1, 1, Outcome::Success, 15.0, 2, 10),
      rec("m", 1, 2, Outcome::Collision, 5.0, 4, 10), rec("m", 1, 3, Outcome::Success, 30.0, 0, 20),
      rec("m", 1, 4, Outcome::Success, 40.0, 0, 10),  rec("m", 2, 1, Outcome::Timeout, 100.0, 0, 500)};
  const EvalSummary s = summarize(records, "ref");
  ASSERT_EQ(s.methods, (std::vector<std::string>{"ref", "m"}));
  ASSERT_EQ(s.obstacle_counts, (std::vector<int>{1, 2}));
  const EvalCell& m1 = s.cell("m", 1);
  EXPECT_EQ(m1.episodes, 4);
  EXPECT_DOUBLE_EQ(m1.success_rate, 0.75);
  EXPECT_DOUBLE_EQ(m1.collision_rate, 0.25);
  EXPECT_DOUBLE_EQ(m1.timeout_rate, 0.0);
  EXPECT_DOUBLE_EQ(m1.mean_time_success_s, (15.0 + 30.0 + 40.0) / 3.0);
  // Both solved only episode 1: 15 / 10.
  EXPECT_EQ(m1.both_solved, 1);
  EXPECT_DOUBLE_EQ(m1.time_ratio, 1.5);
  EXPECT_DOUBLE_EQ(m1.danger_frequency, 6.0 / 50.0);
  const EvalCell& m2 = s.cell("m", 2);
  EXPECT_DOUBLE_EQ(m2.timeout_rate, 1.0);
  EXPECT_TRUE(std::isnan(m2.time_ratio));
  EXPECT_TRUE(std::isnan(m2.mean_time_success_s));
  const EvalCell& r1 = s.cell("ref", 1);
  EXPECT_DOUBLE_EQ(r1.success_rate, 0.5);
  EXPECT_DOUBLE_EQ(r1.time_ratio, 1.0);
  // Mean row: the mean of the per-count rates (0.75 and 0), not the pooled rate (3 / 5).
  EXPECT_DOUBLE_EQ(s.overall[1].success_rate, 0.375);
  EXPECT_DOUBLE_EQ(s.overall[1].timeout_rate, 0.5);
  EXPECT_DOUBLE_EQ(s.overall[1].time_ratio, 1.5);
  EXPECT_DOUBLE_EQ(s.overall[0].success_rate, 0.75);  // (0.5 + 1) / 2

  const auto figures = summaryFigures(s);
  auto figure = [&](const std::string& key) {
    for (const auto& [k, v] : figures) {
      if (k == key) return v;
    }
    ADD_FAILURE() << "no figure " << key;
    return std::nan("");
  };
  EXPECT_DOUBLE_EQ(figure("m.success_mean"), 0.375);
  EXPECT_DOUBLE_EQ(figure("m.success_1"), 0.75);
  EXPECT_DOUBLE_EQ(figure("ref.success_2"), 1.0);

  EXPECT_THROW(summarize(records, "nobody"), EvalError);
  EXPECT_THROW(s.cell("m", 7), EvalError);
  // One method alone: unprefixed figures, as the benchmark reads them.
  const std::vector<EpisodeRecord> only(records.begin() + 5, records.end());
  const auto single = summaryFigures(summarize(only, "m"));
  EXPECT_EQ(single.front().first, "success_mean");
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

TEST(EvalPlots, TheSuccessLegendIsNeverCutOff) {
  // Eight methods with long names: every label lies inside the picture, whose right edge stays blank.
  std::vector<EpisodeRecord> records;
  std::vector<std::string> names;
  for (int m = 0; m < 8; ++m) {
    names.push_back("a_rather_long_method_name_number_" + std::to_string(m) + "_with_variant");
    for (int n = 1; n <= 3; ++n)
      records.push_back(rec(names.back(), n, 1, m % 2 ? Outcome::Success : Outcome::Collision, 5.0));
  }
  test::TempDir dir;
  const std::string plot = dir.file("success.png");
  plotSuccessVsObstacles(summarize(records, names[0]), plot);
  const cv::Mat img = cv::imread(plot, cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(img.empty());
  EXPECT_GT(img.cols, 900);  // grown for the labels
  int dark_near_right = 0, dark_in_legend = 0;
  for (int y = 0; y < img.rows; ++y) {
    for (int x = img.cols - 6; x < img.cols; ++x) dark_near_right += img.at<uint8_t>(y, x) < 128;
    for (int x = 700; x < img.cols; ++x) dark_in_legend += img.at<uint8_t>(y, x) < 128;
  }
  EXPECT_EQ(dark_near_right, 0) << "a label reaches the right edge";
  EXPECT_GT(dark_in_legend, 500) << "no legend drawn";
}

}  // namespace
}  // namespace dqn_dovs
