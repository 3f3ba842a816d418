// Simulator throughput: world steps per second with one LIDAR scan per step, 15 moving obstacles (the published
// 1-15 scenarios), the 360 deg / 720-beam simulation LIDAR and a 0.05 s physics step. The robot follows a
// simple go-to-goal law so that it moves through the crowd; episodes restart on collision, arrival or 500 steps.
// Then the same per world family with 15 people (social force, legs in the scan; <family>_steps_per_s), and in the
// crowd with every LIDAR profile (crowd_<profile>_steps_per_s), and the crowd whose people notice the robot
// (attentive=0.6,impassive=0.2,oblivious=0.2: crowd_mix_steps_per_s).
//
// Usage: bench_sim [--scenarios DIR] [--out FILE] [--steps N]
#include <sys/stat.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <map>
#include <string>
#include <vector>

#include "dqn_dovs/sim/world.h"
#include "dqn_dovs/sim/worlds.h"

namespace {

using Clock = std::chrono::steady_clock;
using dqn_dovs::Twist2;
namespace sim = dqn_dovs::sim;

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(p * static_cast<double>(v.size() - 1) + 0.5));
  std::nth_element(v.begin(), v.begin() + static_cast<long>(k), v.end());
  return v[k];
}

Twist2 goToGoal(const sim::World& w) {
  const dqn_dovs::Vec2 to_goal = w.goal() - w.robotPose().position();
  const double error = dqn_dovs::angleDiff(std::atan2(to_goal.y(), to_goal.x()), w.robotPose().theta);
  return {0.5 * std::max(0.0, std::cos(error)) * std::min(1.0, to_goal.norm()), std::clamp(1.5 * error, -2.0, 2.0)};
}

void makeParentDirs(const std::string& path) {
  for (size_t pos = path.find('/', 1); pos != std::string::npos; pos = path.find('/', pos + 1)) {
    ::mkdir(path.substr(0, pos).c_str(), 0755);
  }
}

/// Steps (each one world step of dt_s and one scan) over the scenarios in turn, restarting an episode on a
/// collision, arrival or 500 steps.
struct Run {
  double elapsed_s = 0.0;
  std::vector<double> scan_us, step_us;
  long episodes = 1, collisions = 0, arrivals = 0;
};

Run measure(const std::vector<sim::Scenario>& scenarios, const sim::WorldConfig& config, long total_steps,
            double dt_s) {
  Run run;
  sim::World world(scenarios[0], config, 1);
  dqn_dovs::LaserScan2 scan;
  run.scan_us.reserve(static_cast<size_t>(total_steps));
  run.step_us.reserve(static_cast<size_t>(total_steps));
  size_t episode = 0;
  long episode_steps = 0;
  const Clock::time_point start = Clock::now();
  for (long k = 0; k < total_steps; ++k) {
    const Clock::time_point t0 = Clock::now();
    world.step(goToGoal(world), dt_s);
    const Clock::time_point t1 = Clock::now();
    world.scanInto(scan);
    const Clock::time_point t2 = Clock::now();
    run.step_us.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
    run.scan_us.push_back(std::chrono::duration<double, std::micro>(t2 - t1).count());
    ++episode_steps;
    const bool arrived = (world.goal() - world.robotPose().position()).norm() < 0.15;
    if (world.collided() || arrived || episode_steps >= 500) {
      run.collisions += world.collided() ? 1 : 0;
      run.arrivals += arrived ? 1 : 0;
      episode = (episode + 1) % scenarios.size();
      world.reset(scenarios[episode], episode + 1);
      episode_steps = 0;
      ++run.episodes;
    }
  }
  run.elapsed_s = std::chrono::duration<double>(Clock::now() - start).count();
  return run;
}

}  // namespace

int main(int argc, char** argv) {
  std::string scenario_dir = dqn_dovs::sim::kDefaultScenariosDir;
  std::string out_path = "bench/results/sim.json";
  long total_steps = 30000;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if ((arg == "--scenarios" || arg == "--out" || arg == "--steps") && i + 1 < argc) {
      const std::string value = argv[++i];
      if (arg == "--scenarios") scenario_dir = value;
      if (arg == "--out") out_path = value;
      if (arg == "--steps") total_steps = std::max(1L, std::atol(value.c_str()));
    } else {
      std::cerr << "bench_sim: unknown or incomplete argument '" << arg
                << "'\nusage: bench_sim [--scenarios DIR] [--out FILE] [--steps N]\n";
      return 2;
    }
  }

  std::vector<sim::Scenario> scenarios;
  try {
    for (int k = 1; k <= 100; ++k) {
      const std::string path = scenario_dir + "/1-15/" + std::to_string(k) + ".dovs";
      if (std::ifstream(path).good() || k == 1) scenarios.push_back(sim::loadDovsScenario(path));
    }
  } catch (const std::exception& e) {
    std::cerr << "bench_sim: " << e.what() << "\n";
    return 1;
  }

  const double dt_s = 0.05;
  sim::WorldConfig config;  // simulation LIDAR profile: 360 deg, 720 beams
  const Run room = measure(scenarios, config, total_steps, dt_s);
  const std::vector<double>& scan_us = room.scan_us;
  const std::vector<double>& step_us = room.step_us;
  const long episodes = room.episodes, collisions = room.collisions, arrivals = room.arrivals;
  const double elapsed_s = room.elapsed_s;

  std::map<std::string, double> results = {
      {"steps_per_s", static_cast<double>(total_steps) / elapsed_s},
      {"scan_us_median", percentile(scan_us, 0.5)},
      {"scan_us_p95", percentile(scan_us, 0.95)},
      {"step_us_median", percentile(step_us, 0.5)},
      {"step_us_p95", percentile(step_us, 0.95)},
      {"steps", static_cast<double>(total_steps)},
      {"dt_s", dt_s},
      {"beams", static_cast<double>(config.lidar.beams)},
      {"obstacles", static_cast<double>(scenarios[0].obstacles.size())},
      {"episodes", static_cast<double>(episodes)},
  };

  // World families with 15 people, then the crowd with every LIDAR profile: a third of the steps each.
  const long family_steps = std::max(1L, total_steps / 3);
  for (const std::string& family : sim::worldFamilyNames()) {
    if (family == "room") continue;
    sim::WorldFamilyConfig f;
    f.family = sim::parseWorldFamily(family);
    f.people = 15;
    std::vector<sim::Scenario> worlds;
    for (uint64_t seed = 1; seed <= 20; ++seed) worlds.push_back(sim::generateWorld(f, seed));
    const std::vector<std::string> sensors =
        family == "crowd" ? sim::LidarConfig::profileNames() : std::vector<std::string>{"sim"};
    for (const std::string& sensor : sensors) {
      sim::WorldConfig c;
      c.lidar = sim::LidarConfig::profile(sensor);
      const Run r = measure(worlds, c, family_steps, dt_s);
      const std::string key = family + (family == "crowd" && sensor != "sim" ? "_" + sensor : "");
      results[key + "_steps_per_s"] = static_cast<double>(family_steps) / r.elapsed_s;
    }
    if (family == "crowd") {
      // The crowd again with people who notice the robot (each behaviour present): crowd_mix_steps_per_s.
      sim::WorldConfig c;
      c.people.mix = sim::PeopleMix::parse("attentive=0.6,impassive=0.2,oblivious=0.2");
      const Run r = measure(worlds, c, family_steps, dt_s);
      results["crowd_mix_steps_per_s"] = static_cast<double>(family_steps) / r.elapsed_s;
    }
  }

  std::printf("bench_sim: %zu scenarios from %s/1-15, dt %.2f s, %d beams, one scan per step\n", scenarios.size(),
              scenario_dir.c_str(), dt_s, config.lidar.beams);
  std::printf("  %-16s %12s\n", "figure", "value");
  for (const auto& [name, value] : results) std::printf("  %-16s %12.2f\n", name.c_str(), value);
  std::printf("  (episodes ended by collision %ld, arrival %ld; the go-to-goal law ignores obstacles)\n", collisions,
              arrivals);

  makeParentDirs(out_path);
  std::ofstream out(out_path);
  if (!out) {
    std::cerr << "bench_sim: cannot write '" << out_path << "'\n";
    return 1;
  }
  out << "{";
  bool first = true;
  for (const auto& [name, value] : results) {
    out << (first ? "" : ", ") << "\"" << name << "\": " << value;
    first = false;
  }
  out << "}\n";
  std::printf("wrote %s\n", out_path.c_str());
  return 0;
}
