// Q-network decision latency on one core: qValues + masked argmax of the full-size network, loaded from a
// .dqnw file written with random weights through the same writer the unit tests use.
//
//   bench_inference [--out FILE] [--scenarios DIR] [--decisions N]
//
// Writes decision_us_median, decision_us_p99 (and a few more figures) to bench/results/inference.json.
#include <unistd.h>

#include <Eigen/Core>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "dqn_dovs/dovs/state.h"
#include "dqn_dovs/policy/qnetwork.h"
#include "dqn_dovs/policy/weight_file.h"

namespace {

using Clock = std::chrono::steady_clock;

double percentile(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  const double idx = p * static_cast<double>(v.size() - 1);
  const auto lo = static_cast<std::size_t>(idx);
  const std::size_t hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (idx - static_cast<double>(lo)) * (v[hi] - v[lo]);
}

}  // namespace

int main(int argc, char** argv) {
  std::string out_path = "bench/results/inference.json";
  std::string scenarios = "data/scenarios/room";  // accepted for a uniform interface; not needed here
  int decisions = 20000;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if ((arg == "--out" || arg == "--scenarios" || arg == "--decisions") && i + 1 < argc) {
      const std::string value = argv[++i];
      if (arg == "--out")
        out_path = value;
      else if (arg == "--scenarios")
        scenarios = value;
      else
        decisions = std::max(100, std::atoi(value.c_str()));
    } else {
      std::cerr << "usage: bench_inference [--out FILE] [--scenarios DIR] [--decisions N]\n";
      return 2;
    }
  }
  (void)scenarios;

  try {
    const std::string weights_path =
        (std::filesystem::temp_directory_path() / ("bench_inference_" + std::to_string(::getpid()) + ".dqnw")).string();
    const std::vector<std::pair<std::string, float>> normalization = {{"v_max", 0.7f}, {"w_max", 3.14159265f}};
    dqn_dovs::writeWeightFile(weights_path,
                              dqn_dovs::makeRandomWeights(dqn_dovs::DuelingArchitecture{}, 42, normalization, "bench"));
    const auto load_start = Clock::now();
    const dqn_dovs::QNetwork net = dqn_dovs::QNetwork::load(weights_path);
    const double load_ms = std::chrono::duration<double, std::milli>(Clock::now() - load_start).count();
    const auto file_bytes = std::filesystem::file_size(weights_path);
    std::filesystem::remove(weights_path);

    // A pool of realistic-looking states (mostly free grid, a few unsafe blobs) and masks, cycled through.
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    std::bernoulli_distribution goal_actions_valid(0.7);
    constexpr int kPool = 256;
    std::vector<Eigen::VectorXf> states;
    std::vector<dqn_dovs::QNetwork::ActionMask> masks;
    for (int i = 0; i < kPool; ++i) {
      Eigen::VectorXf s(dqn_dovs::QNetwork::kStateSize);
      for (int k = 0; k < 400; ++k) s[k] = u(rng) < 0.5f ? -1.0f : 1.0f;
      for (int k = 400; k < dqn_dovs::QNetwork::kStateSize; ++k) s[k] = u(rng);
      states.push_back(s);
      dqn_dovs::QNetwork::ActionMask m;
      m.fill(true);
      const bool goal_ok = goal_actions_valid(rng);
      m[5] = m[6] = m[7] = goal_ok;
      masks.push_back(m);
    }

    // Times `decisions` choices of `network` on `pool` (cycled); returns every time in microseconds.
    int checksum = 0;
    auto time_choices = [&](const dqn_dovs::QNetwork& network, const std::vector<Eigen::VectorXf>& pool,
                            double& total_s) {
      for (int i = 0; i < 500; ++i)
        checksum += network.selectAction(pool[static_cast<size_t>(i % kPool)], masks[i % kPool]);  // warm-up
      std::vector<double> times;
      times.reserve(static_cast<size_t>(decisions));
      const auto total_start = Clock::now();
      for (int i = 0; i < decisions; ++i) {
        const auto t0 = Clock::now();
        checksum += network.selectAction(pool[static_cast<size_t>(i % kPool)], masks[i % kPool]);
        times.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count());
      }
      total_s = std::chrono::duration<double>(Clock::now() - total_start).count();
      return times;
    };
    double total_s = 0.0;
    std::vector<double> times_us = time_choices(net, states, total_s);

    // The version 3 network of experiments (b) and (c) together: 8 wall rays, 6 person tokens (all present, the
    // slowest case) pooled by attention, and 16 quantiles acted on by their CVaR (mean of the lowest 4).
    dqn_dovs::DuelingArchitecture wide;
    wide.wall_rays = 8;
    wide.person_tokens = 6;
    wide.quantiles = 16;
    wide.cvar_count = 4;
    const dqn_dovs::QNetwork token_net = dqn_dovs::QNetwork::fromContents(
        dqn_dovs::makeRandomWeights(wide, 43, normalization, "bench tokens"), "bench tokens");
    std::vector<Eigen::VectorXf> token_states;
    for (const Eigen::VectorXf& s : states) {
      Eigen::VectorXf t(token_net.stateSize());
      t.head(s.size()) = s;
      for (int k = static_cast<int>(s.size()); k < t.size(); ++k) t[k] = u(rng);
      for (int k = 0; k < 6; ++k) t[static_cast<int>(s.size()) + 8 + k * dqn_dovs::kPersonTokenSize] = 1.0f;
      token_states.push_back(t);
    }
    double token_total_s = 0.0;
    const std::vector<double> token_times_us = time_choices(token_net, token_states, token_total_s);

    std::map<std::string, double> figures;
    figures["decision_us_median"] = percentile(times_us, 0.5);
    figures["decision_us_p99"] = percentile(times_us, 0.99);
    figures["decision_us_p90"] = percentile(times_us, 0.9);
    figures["decision_us_min"] = *std::min_element(times_us.begin(), times_us.end());
    figures["decision_us_max"] = *std::max_element(times_us.begin(), times_us.end());
    figures["decisions_per_s"] = decisions / total_s;
    figures["tokens_cvar_decision_us_median"] = percentile(token_times_us, 0.5);
    figures["tokens_cvar_decision_us_p99"] = percentile(token_times_us, 0.99);
    figures["tokens_cvar_decisions_per_s"] = decisions / token_total_s;
    figures["decisions"] = decisions;
    figures["load_ms"] = load_ms;
    figures["weight_file_bytes"] = static_cast<double>(file_bytes);

    std::cout << "Q-network inference (one thread, random weights, 20x20 grid + 8 features -> 8 actions)\n";
    std::cout << net.describe();
    std::cout << std::left << std::setw(32) << "figure"
              << "value\n";
    for (const auto& [name, value] : figures) {
      std::cout << std::left << std::setw(32) << name << std::fixed << std::setprecision(2) << value << "\n";
    }
    std::cout << "(action checksum " << checksum << ")\n";

    const std::filesystem::path out(out_path);
    if (out.has_parent_path()) std::filesystem::create_directories(out.parent_path());
    std::ofstream json(out_path);
    if (!json) {
      std::cerr << "bench_inference: cannot write '" << out_path << "'\n";
      return 1;
    }
    json << "{";
    bool first = true;
    for (const auto& [name, value] : figures) {
      json << (first ? "" : ", ") << "\"" << name << "\": " << std::setprecision(6) << value;
      first = false;
    }
    json << "}\n";
    std::cout << "wrote " << out_path << "\n";
  } catch (const std::exception& e) {
    std::cerr << "bench_inference: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
