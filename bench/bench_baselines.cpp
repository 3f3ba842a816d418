// The classic baselines (orca_holonomic, orca_diffdrive, dwa) on the published scenarios: success, collision and
// timeout rates, mean time on success and the planners' decision time, with the LIDAR + tracker in the loop (or
// the ground truth with --perfect-info). Each planner's decision is executed with Episode::stepDecision, so
// orca_holonomic drives a holonomic robot. A subset of the protocol (the first --episodes files of every obstacle
// count 1..15) keeps the run under two minutes on one core; dqn_dovs_eval runs the full protocol.
//
// Usage: bench_baselines [--scenarios DIR] [--out FILE] [--episodes K] [--perfect-info]
#include <sys/stat.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "dqn_dovs/evaluation/episode.h"
#include "dqn_dovs/evaluation/eval.h"
#include "dqn_dovs/planning/dwa.h"
#include "dqn_dovs/planning/orca.h"

namespace {

using Clock = std::chrono::steady_clock;
using namespace dqn_dovs;

void makeParentDirs(const std::string& path) {
  for (size_t pos = path.find('/', 1); pos != std::string::npos; pos = path.find('/', pos + 1)) {
    ::mkdir(path.substr(0, pos).c_str(), 0755);
  }
}

struct Tally {
  int episodes = 0, success = 0, collision = 0, timeout = 0;
  double success_time_s = 0.0;
  long decisions = 0;
  double decide_s = 0.0;
  std::map<int, std::pair<int, int>> per_count;  // N -> (successes, episodes)
};

}  // namespace

int main(int argc, char** argv) {
  EvalConfig config;
  config.scenarios_dir = dqn_dovs::sim::kDefaultScenariosDir;
  config.episodes = 20;
  std::string out_path = "bench/results/baselines.json";
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--perfect-info") {
      config.episode.perfect_info = true;
    } else if ((arg == "--scenarios" || arg == "--out" || arg == "--episodes") && i + 1 < argc) {
      const std::string value = argv[++i];
      if (arg == "--scenarios") config.scenarios_dir = value;
      if (arg == "--out") out_path = value;
      if (arg == "--episodes") config.episodes = std::atoi(value.c_str());
    } else {
      std::cerr << "bench_baselines: unknown or incomplete argument '" << arg
                << "' (usage: bench_baselines [--scenarios DIR] [--out FILE] [--episodes K] [--perfect-info])\n";
      return 2;
    }
  }
  if (config.episodes < 1 || config.episodes > 100) {
    std::cerr << "bench_baselines: --episodes must be in [1, 100]\n";
    return 2;
  }

  std::vector<EvalScenario> scenarios;
  try {
    scenarios = loadEvalScenarios(config);
  } catch (const std::exception& e) {
    std::cerr << "bench_baselines: " << e.what() << "\n";
    return 1;
  }

  std::vector<std::unique_ptr<Planner>> planners;
  planners.push_back(makeOrcaHolonomicPlanner());
  planners.push_back(makeOrcaDiffDrivePlanner());
  planners.push_back(makeDwaPlanner());

  Episode ep(config.episode);
  std::map<std::string, Tally> tallies;
  const auto t_start = Clock::now();
  for (auto& planner : planners) {
    Tally& tally = tallies[planner->name()];
    for (const EvalScenario& s : scenarios) {
      planner->reset();
      ep.reset(s.scenario, s.seed);
      while (!ep.done()) {
        const PlannerInput in = ep.plannerInput();
        PlannerDecision d;
        const auto t0 = Clock::now();
        try {
          d = planner->decide(in);
        } catch (const PlannerError&) {
          d.command = decelerationCommand(ep.observation().robot_twist, in.limits);
        }
        tally.decide_s += std::chrono::duration<double>(Clock::now() - t0).count();
        ++tally.decisions;
        ep.stepDecision(d);
      }
      ++tally.episodes;
      auto& cell = tally.per_count[s.obstacles];
      ++cell.second;
      switch (ep.outcome()) {
        case Outcome::kSuccess:
          ++tally.success;
          ++cell.first;
          tally.success_time_s += ep.time_s();
          break;
        case Outcome::kCollision:
          ++tally.collision;
          break;
        default:
          ++tally.timeout;
          break;
      }
    }
  }
  const double wall_s = std::chrono::duration<double>(Clock::now() - t_start).count();

  std::printf("Baselines on %s, %d episodes per obstacle count (N = 1..15), %s\n\n", config.scenarios_dir.c_str(),
              config.episodes, config.episode.perfect_info ? "perfect information" : "LIDAR + tracker in the loop");
  std::printf("| planner | success | collision | timeout | mean time on success (s) | decide (us, mean) |\n");
  std::printf("|---|---|---|---|---|---|\n");
  std::map<std::string, double> json;
  for (const auto& planner : planners) {
    const std::string name = planner->name();
    const Tally& t = tallies[name];
    const double n = std::max(1, t.episodes);
    const double mean_time = t.success > 0 ? t.success_time_s / t.success : std::nan("");
    const double decide_us = t.decisions > 0 ? 1e6 * t.decide_s / static_cast<double>(t.decisions) : 0.0;
    std::printf("| %s | %.3f | %.3f | %.3f | %.2f | %.1f |\n", name.c_str(), t.success / n, t.collision / n,
                t.timeout / n, mean_time, decide_us);
    json[name + ".success_mean"] = t.success / n;
    json[name + ".collision_mean"] = t.collision / n;
    json[name + ".timeout_mean"] = t.timeout / n;
    if (t.success > 0) json[name + ".mean_time_success_s"] = mean_time;
    json[name + ".decide_us_mean"] = decide_us;
    for (const auto& [count, cell] : t.per_count) {
      json[name + ".success_" + std::to_string(count)] = static_cast<double>(cell.first) / std::max(1, cell.second);
    }
  }
  std::printf("\nsuccess per obstacle count:\n| planner |");
  for (int n = config.obstacles_min; n <= config.obstacles_max; ++n) std::printf(" %d |", n);
  std::printf("\n|---|");
  for (int n = config.obstacles_min; n <= config.obstacles_max; ++n) std::printf("---|");
  std::printf("\n");
  for (const auto& planner : planners) {
    std::printf("| %s |", planner->name().c_str());
    for (const auto& [count, cell] : tallies[planner->name()].per_count) {
      std::printf(" %.2f |", static_cast<double>(cell.first) / std::max(1, cell.second));
    }
    std::printf("\n");
  }
  std::printf("\nwall time %.1f s\n", wall_s);
  json["episodes_per_count"] = config.episodes;
  json["perfect_info"] = config.episode.perfect_info ? 1.0 : 0.0;
  json["wall_s"] = wall_s;

  makeParentDirs(out_path);
  std::ofstream out(out_path);
  if (!out) {
    std::cerr << "bench_baselines: cannot write '" << out_path << "'\n";
    return 1;
  }
  out << "{\n";
  size_t k = 0;
  for (const auto& [key, value] : json) {
    out << "  \"" << key << "\": " << (std::isfinite(value) ? value : 0.0) << (++k < json.size() ? ",\n" : "\n");
  }
  out << "}\n";
  std::printf("wrote %s\n", out_path.c_str());
  return 0;
}
