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

    int checksum = 0;
    for (int i = 0; i < 500; ++i) checksum += net.selectAction(states[i % kPool], masks[i % kPool]);  // warm-up
    std::vector<double> times_us;
    times_us.reserve(decisions);
    const auto total_start = Clock::now();
    for (int i = 0; i < decisions; ++i) {
      const auto t0 = Clock::now();
      checksum += net.selectAction(states[i % kPool], masks[i % kPool]);
      times_us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count());
    }
    const double total_s = std::chrono::duration<double>(Clock::now() - total_start).count();

    std::map<std::string, double> figures;
    figures["decision_us_median"] = percentile(times_us, 0.5);
    figures["decision_us_p99"] = percentile(times_us, 0.99);
    figures["decision_us_p90"] = percentile(times_us, 0.9);
    figures["decision_us_min"] = *std::min_element(times_us.begin(), times_us.end());
    figures["decision_us_max"] = *std::max_element(times_us.begin(), times_us.end());
    figures["decisions_per_s"] = decisions / total_s;
    figures["decisions"] = decisions;
    figures["load_ms"] = load_ms;
    figures["weight_file_bytes"] = static_cast<double>(file_bytes);

    std::cout << "Q-network inference (one thread, random weights, 20x20 grid + 8 features -> 8 actions)\n";
    std::cout << net.describe();
    std::cout << std::left << std::setw(22) << "figure"
              << "value\n";
    for (const auto& [name, value] : figures) {
      std::cout << std::left << std::setw(22) << name << std::fixed << std::setprecision(2) << value << "\n";
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
