// Obstacle tracker accuracy and latency on the published scenarios, with the robot driving.
//
// For N = 1..15 obstacles, episodes 1..K (default 3) of rumor/1-N are loaded, made 85 % dynamic (the last
// round(0.15 N) obstacles static, scenarios/README.md), and simulated for 20 s with the 360 deg / 720-beam
// simulation LIDAR (1 cm noise) at 10 Hz. The robot drives at 0.5 m/s toward a goal, steering gently, and
// takes a new goal inside [-2.5, 2.5]^2 on arrival, so it keeps away from the walls; collisions do not stop it
// (this measures the tracker, not a planner). Each scan goes through ObstacleTracker::update with the laser
// pose at the scan's stamp; only update() is timed.
//
// Metrics (docs/tracker.md, TrackingEvaluator): each scan, confirmed tracks are matched one-to-one to the true
// obstacles by minimum total centre distance, pairs closer than 0.5 m only.
//   pos_rmse_m             RMS centre error over all matched pairs.
//   speed_rmse_mps         RMS speed error, matched pairs with track age >= 1 s and a true speed >= 0.1 m/s.
//   heading_err_deg_median median |heading error| over the same pairs.
//   turn_rate_rmse_rps   RMS turn-rate error over the same pairs.
//   id_switches_per_min    matched track id of a true obstacle differs from its previous matched id, per
//                          obstacle-minute of simulated time.
//   false_tracks_per_scan  confirmed tracks matched to no true obstacle, per scan.
//   missed_rate            unmatched fraction of the true obstacles that were clearly visible (>= 5 beams hit
//                          what the LIDAR sees of them first: a disc, a person's legs) in each of the last 5 scans.
//   static_speed_mps_p95   95th percentile of the reported speed of tracks (age >= 1 s) matched to static
//                          obstacles.
//   latency_ms_median/p99  CPU time of one update() call on one core (thread CPU clock: time spent waiting
//                          for a core held by other processes is not counted); latency_wall_ms_p99 is the
//                          wall-clock p99 for reference.
// Extra figures: id_switches_crowded (switches while another true obstacle's centre was within 0.6 m: nearly
// touching discs, or simulated discs passing through each other), speed_abs_err_median_mps.
//
// People in buildings (people_<family>_<sensor>_*): every world family but the room with 10 social-force people seen
// by their legs (the tracker pairs them), with the sim and urg04lx profiles, K worlds of seed 12000 + k each, the
// robot driving at 0.5 m/s between its start and goal (crowd, corridor, clutter: a straight path) or parked at its
// start (doorway, junction: the straight path would cross walls). The same metrics against the people's bodies
// (and the clutter's chairs), plus wall_moving_tracks_per_scan: confirmed tracks matched to nobody, within 0.3 m of
// a wall or piece of furniture, reported moving (>= 0.1 m/s), and the centre and speed RMSE split by the track's
// state (pos_rmse_young_m / _observed_m / _coasting_m, speed_rmse_observed_mps / _coasting_mps,
// coasting_pair_fraction; speed_rmse_young_mps and young_pair_fraction for tracks younger than 1 s; the reported
// radius against the body's, radius_rmse_m and radius_bias_m; what constant-velocity coasting could give at best,
// pos_rmse_cv_bound_m, speed_rmse_cv_bound_mps and their coasting pairs alone, pos_rmse_coasting_cv_bound_m and
// speed_rmse_coasting_cv_bound_mps; TrackingSummary).
//
// --only original|people runs one part; --people-seed B takes the people's worlds from seeds B + k (default 12000);
// --families LIST (comma-separated) picks the people part's families (default: every family but the room; `room` adds
// the paper's world generated with 10 discs, pair_legs off, the robot driving, rows people_room_<sensor>_*: a
// check on the paper's world with seeds of its own); every family but the room runs again with the map a robot would
// have (its walls and furniture, KnownStructure) given to the tracker, rows people_<family>_<sensor>_map_*, unless
// --no-map; --tracker NAME=VALUE (repeatable) sets a tracker parameter by its
// config/tracker.yaml name in both parts.
//
// Usage: bench_tracker [--scenarios DIR] [--out FILE] [--episodes K] [--duration S] [--only PART]
//                      [--people-seed B] [--families LIST] [--no-map] [--tracker NAME=VALUE]...
#include <sys/stat.h>
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "dqn_dovs/perception/tracker.h"
#include "dqn_dovs/perception/tracker_metrics.h"
#include "dqn_dovs/sim/world.h"
#include "dqn_dovs/sim/worlds.h"

namespace {

using namespace dqn_dovs;
using Clock = std::chrono::steady_clock;

constexpr double kScanPeriodS = 0.1;
constexpr double kRobotSpeedMps = 0.5;
constexpr int kVisibleBeams = 5;
constexpr int kVisibleScans = 5;

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  return v[static_cast<size_t>(std::lround(q * static_cast<double>(v.size() - 1)))];
}

/// CPU time of this thread (ms): unlike wall time it does not count the time the thread waits for a core
/// that other processes hold, so it measures the tracker's own cost on one core.
double threadCpuMs() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return 1e3 * static_cast<double>(ts.tv_sec) + 1e-6 * static_cast<double>(ts.tv_nsec);
}

void makeParentDirs(const std::string& path) {
  for (size_t pos = path.find('/', 1); pos != std::string::npos; pos = path.find('/', pos + 1)) {
    ::mkdir(path.substr(0, pos).c_str(), 0755);
  }
}

/// Steers toward `goal` at constant speed with a bounded turn rate (a gentle arc).
Twist2 driveToward(const Pose2& robot, const Vec2& goal) {
  const Vec2 d = goal - robot.position();
  const double error = angleDiff(std::atan2(d.y(), d.x()), robot.theta);
  return {kRobotSpeedMps, std::clamp(1.2 * error, -0.6, 0.6)};
}

/// Number of beams of the scan whose first hit is each obstacle (walls occlude too).
std::vector<int> beamsOnObstacles(const sim::World& world, const std::vector<MovingObstacle>& truths) {
  const Pose2 laser = world.laserPose();
  const sim::LidarConfig& lidar = world.config().lidar;
  std::vector<int> counts(truths.size(), 0);
  // What the LIDAR sees of each: a disc, or a person's two legs where the scan cuts them (their body disc is wider
  // than the legs, and a person at the end of the range has legs beyond it).
  std::vector<std::pair<Circle, int>> seen;
  const size_t discs = world.obstacles().size();
  const std::vector<Circle> legs = world.config().scan_legs ? world.crowd().legs() : std::vector<Circle>{};
  for (size_t k = 0; k < truths.size(); ++k) {
    const size_t person = k - discs;
    if (k >= discs && 2 * person + 1 < legs.size()) {
      seen.push_back({legs[2 * person], static_cast<int>(k)});
      seen.push_back({legs[2 * person + 1], static_cast<int>(k)});
    } else {
      seen.push_back({Circle{truths[k].center, truths[k].radius}, static_cast<int>(k)});
    }
  }
  const Vec2 o = laser.position();
  for (int i = 0; i < lidar.beams; ++i) {
    const double a = laser.theta + lidar.angleMin_rad() + i * lidar.angleIncrement_rad();
    const Vec2 d(std::cos(a), std::sin(a));
    double best = lidar.range_max_m;
    int who = -1;
    for (const Segment& w : world.walls()) {
      if (auto t = raySegment(o, d, w)) best = std::min(best, *t);
    }
    for (size_t k = 0; k < seen.size(); ++k) {
      if (auto t = rayCircle(o, d, seen[k].first); t && *t < best) {
        best = *t;
        who = seen[k].second;
      }
    }
    if (who >= 0) ++counts[who];
  }
  return counts;
}

/// Which true obstacles should be reported: those clearly visible (kVisibleBeams beams hit them first) in each of
/// the last kVisibleScans scans; `streak` counts the scans in a row each has been visible.
std::vector<bool> shouldSee(const sim::World& world, const std::vector<MovingObstacle>& truths,
                            std::vector<int>& streak) {
  const std::vector<int> beams = beamsOnObstacles(world, truths);
  std::vector<bool> out(truths.size());
  for (size_t i = 0; i < truths.size(); ++i) {
    streak[i] = beams[i] >= kVisibleBeams ? streak[i] + 1 : 0;
    out[i] = streak[i] >= kVisibleScans;
  }
  return out;
}

/// Tracking of people in one world family with one LIDAR profile (see the header).
struct PeopleRun {
  TrackingSummary summary;
  double wall_moving_tracks_per_scan = 0.0;
};

PeopleRun trackPeople(const std::string& family, const std::string& sensor, int worlds, double duration_s,
                      uint64_t seed_base, const TrackerConfig& base, bool with_map) {
  sim::WorldFamilyConfig f;
  f.family = sim::parseWorldFamily(family);
  f.people = 10;
  sim::WorldConfig config;
  config.stop_on_collision = false;
  config.lidar = sim::LidarConfig::profile(sensor);
  const double period = config.lidar.scan_period_s;
  const bool drives = family == "room" || family == "crowd" || family == "corridor" || family == "clutter";
  TrackingEvaluator evaluator;
  size_t wall_moving = 0, scans = 0;
  for (int k = 1; k <= worlds; ++k) {
    const sim::Scenario scenario = sim::generateWorld(f, seed_base + static_cast<uint64_t>(k));
    sim::World world(scenario, config, static_cast<uint64_t>(k));
    TrackerConfig tracker_config = base;
    tracker_config.pair_legs = family != "room";  // the paper's discs have no legs
    tracker_config.range_noise_m = config.lidar.noise_std_m;
    tracker_config.range_noise_fraction = config.lidar.noise_std_fraction;
    ObstacleTracker tracker(tracker_config);
    // The map a robot would have: the walls and the furniture (the clutter's chairs), not the people; the tracker
    // works in the world's frame here, so the map's frame is its fixed frame.
    const std::vector<Circle> furniture = sim::furnitureOf(scenario);
    std::optional<KnownStructure> known;
    if (with_map) known.emplace(world.walls(), furniture, tracker_config.map_tolerance_m);
    const MapStructureView map{known ? &*known : nullptr, Pose2{}};
    evaluator.beginEpisode();
    std::vector<int> visible_streak(world.groundTruthObstacles().size(), 0);
    Vec2 goal = scenario.goal;
    LaserScan2 scan;
    for (double t = 0.0; t <= duration_s + 1e-9; t += period) {
      world.scanInto(scan);
      const TrackerResult result = tracker.update(scan, world.laserPose(), map);
      std::vector<MovingObstacle> truths = world.groundTruthObstacles();
      std::vector<bool> see = shouldSee(world, truths, visible_streak);
      if (with_map) {
        // The map's furniture is structure, not an obstacle to track: only the people are.
        size_t kept = 0;
        for (size_t i = 0; i < truths.size(); ++i) {
          if (truths[i].is_static) continue;
          truths[kept] = truths[i];
          see[kept++] = see[i];
        }
        truths.resize(kept);
        see.resize(kept);
      }
      const std::vector<int> matched = evaluator.addScan(result.scene, truths, see, period);
      std::vector<bool> used(result.scene.obstacles.size(), false);
      for (int m : matched) {
        if (m >= 0) used[static_cast<size_t>(m)] = true;
      }
      for (size_t j = 0; j < result.scene.obstacles.size(); ++j) {
        const TrackedObstacle& o = result.scene.obstacles[j];
        if (used[j] || o.speed < 0.1) continue;
        const bool on_wall = std::any_of(world.walls().begin(), world.walls().end(),
                                         [&](const Segment& w) { return pointSegmentDistance(o.center, w) < 0.3; });
        const bool on_furniture = std::any_of(furniture.begin(), furniture.end(), [&](const Circle& c) {
          return (o.center - c.center).norm() - c.radius < 0.3;
        });
        if (on_wall || on_furniture) ++wall_moving;
      }
      ++scans;
      if (drives && (goal - world.robotPose().position()).norm() < 0.4) {
        goal = goal == scenario.goal ? scenario.robot_start.position() : scenario.goal;
      }
      world.step(drives ? driveToward(world.robotPose(), goal) : Twist2{}, period);
    }
  }
  return {evaluator.summary(), static_cast<double>(wall_moving) / static_cast<double>(std::max<size_t>(1, scans))};
}

}  // namespace

int main(int argc, char** argv) {
  std::string scenario_dir = dqn_dovs::sim::kDefaultScenariosDir;
  std::string out_path = "bench/results/tracker.json";
  int episodes = 3;
  double duration_s = 20.0;
  std::string only;
  uint64_t people_seed = 12000;
  bool map_rows = true;
  std::vector<std::string> families;
  for (const std::string& f : sim::worldFamilyNames()) {
    if (f != "room") families.push_back(f);
  }
  TrackerConfig tracker_config;
  const char* usage =
      "usage: bench_tracker [--scenarios DIR] [--out FILE] [--episodes K] [--duration S] [--only original|people] "
      "[--people-seed B] [--families LIST] [--no-map] [--tracker NAME=VALUE]...\n";
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--no-map") {
      map_rows = false;
      continue;
    }
    if ((arg == "--scenarios" || arg == "--out" || arg == "--episodes" || arg == "--duration" || arg == "--only" ||
         arg == "--people-seed" || arg == "--families" || arg == "--tracker") &&
        i + 1 < argc) {
      const std::string value = argv[++i];
      if (arg == "--tracker") {
        const size_t eq = value.find('=');
        const std::string why = eq == std::string::npos
                                    ? "expected NAME=VALUE"
                                    : setTrackerParameter(tracker_config, value.substr(0, eq), value.substr(eq + 1));
        if (!why.empty()) {
          std::cerr << "bench_tracker: --tracker '" << value << "': " << why << "\n" << usage;
          return 2;
        }
        if (const std::string bad = tracker_config.validate(); !bad.empty()) {
          std::cerr << "bench_tracker: --tracker '" << value << "': " << bad << "\n";
          return 2;
        }
      }
      if (arg == "--only") {
        if (value != "original" && value != "people") {
          std::cerr << "bench_tracker: --only '" << value << "': expected original or people\n" << usage;
          return 2;
        }
        only = value;
      }
      if (arg == "--families") {
        families.clear();
        std::stringstream list(value);
        for (std::string f; std::getline(list, f, ',');) {
          const std::vector<std::string> known = sim::worldFamilyNames();
          if (std::find(known.begin(), known.end(), f) == known.end()) {
            std::cerr << "bench_tracker: --families '" << value << "': unknown family '" << f << "'\n" << usage;
            return 2;
          }
          families.push_back(f);
        }
        if (families.empty()) {
          std::cerr << "bench_tracker: --families: empty list\n" << usage;
          return 2;
        }
      }
      if (arg == "--people-seed") people_seed = std::strtoull(value.c_str(), nullptr, 10);
      if (arg == "--scenarios") scenario_dir = value;
      if (arg == "--out") out_path = value;
      if (arg == "--episodes") episodes = std::max(1, std::atoi(value.c_str()));
      if (arg == "--duration") duration_s = std::max(1.0, std::atof(value.c_str()));
    } else {
      std::cerr << "bench_tracker: unknown or incomplete argument '" << arg << "'\n" << usage;
      return 2;
    }
  }

  TrackingEvaluator evaluator;
  std::vector<double> latency_ms, wall_ms;
  size_t resets_or_rejects = 0, run_episodes = 0;
  sim::WorldConfig world_config;
  world_config.stop_on_collision = false;
  try {
    for (int n = 1; only != "people" && n <= 15; ++n) {
      for (int k = 1; k <= episodes; ++k) {
        const std::string path = scenario_dir + "/1-" + std::to_string(n) + "/" + std::to_string(k) + ".dovs";
        sim::Scenario scenario = sim::loadDovsScenario(path);
        sim::applyDynamicFraction(scenario, 0.85);
        sim::World world(scenario, world_config, static_cast<uint64_t>(1000 * n + k));
        ObstacleTracker tracker{tracker_config};
        evaluator.beginEpisode();
        ++run_episodes;
        Vec2 goal = scenario.goal;
        std::vector<int> visible_streak(scenario.obstacles.size(), 0);
        // Goals stay inside [-2.5, 2.5]^2: the robot keeps 1.5 m from the walls.
        goal = goal.cwiseMax(Vec2(-2.5, -2.5)).cwiseMin(Vec2(2.5, 2.5));
        int goal_index = 0;
        LaserScan2 scan;
        for (double t = 0.0; t <= duration_s + 1e-9; t += kScanPeriodS) {
          world.scanInto(scan);
          const Pose2 laser = world.laserPose();
          const auto start = Clock::now();
          const double cpu_start_ms = threadCpuMs();
          const TrackerResult result = tracker.update(scan, laser);
          latency_ms.push_back(threadCpuMs() - cpu_start_ms);
          wall_ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - start).count());
          if (result.status != TrackerStatus::kOk) ++resets_or_rejects;

          const std::vector<MovingObstacle> truths = world.groundTruthObstacles();
          evaluator.addScan(result.scene, truths, shouldSee(world, truths, visible_streak), kScanPeriodS);

          if ((goal - world.robotPose().position()).norm() < 0.4) {
            // Next goal: the corners of a 5 m square in turn, then back to the scenario's goal.
            const Vec2 corners[4] = {{2.5, 2.5}, {-2.5, 2.5}, {-2.5, -2.5}, {2.5, -2.5}};
            goal = corners[goal_index++ % 4];
          }
          world.step(driveToward(world.robotPose(), goal), kScanPeriodS);
        }
      }
    }
  } catch (const std::exception& e) {
    std::cerr << "bench_tracker: " << e.what() << "\n";
    return 1;
  }

  const TrackingSummary s = evaluator.summary();
  std::map<std::string, double> figures{
      {"pos_rmse_m", s.pos_rmse_m},
      {"speed_rmse_mps", s.speed_rmse_mps},
      {"heading_err_deg_median", s.heading_err_deg_median},
      {"turn_rate_rmse_rps", s.turn_rate_rmse_rps},
      {"id_switches_per_min", s.id_switches_per_min},
      {"false_tracks_per_scan", s.false_tracks_per_scan},
      {"missed_rate", s.missed_rate},
      {"static_speed_mps_p95", s.static_speed_mps_p95},
      {"latency_ms_median", percentile(latency_ms, 0.5)},
      {"latency_ms_p99", percentile(latency_ms, 0.99)},
      {"latency_ms_max", percentile(latency_ms, 1.0)},
      {"latency_wall_ms_p99", percentile(wall_ms, 0.99)},
      {"episodes", static_cast<double>(run_episodes)},
      {"scans", static_cast<double>(s.scans)},
      {"matched_pairs", static_cast<double>(s.matched_pairs)},
      {"id_switches", static_cast<double>(s.id_switches)},
      {"id_switches_crowded", static_cast<double>(s.id_switches_crowded)},
      {"id_switches_after_gap", static_cast<double>(s.id_switches_after_gap)},
      {"speed_abs_err_median_mps", s.speed_abs_err_median_mps},
      {"non_ok_updates", static_cast<double>(resets_or_rejects)},
  };
  for (const std::string& family : families) {
    if (only == "original") break;
    for (const std::string sensor : {"sim", "urg04lx"}) {
      for (const bool with_map : {false, true}) {
        if (with_map && (!map_rows || family == "room")) continue;
        PeopleRun r;
        try {
          r = trackPeople(family, sensor, episodes, duration_s, people_seed, tracker_config, with_map);
        } catch (const std::exception& e) {
          std::cerr << "bench_tracker: people in " << family << " with " << sensor << ": " << e.what() << "\n";
          return 1;
        }
        const std::string key = "people_" + family + "_" + sensor + (with_map ? "_map_" : "_");
        figures[key + "pos_rmse_m"] = r.summary.pos_rmse_m;
        figures[key + "speed_rmse_mps"] = r.summary.speed_rmse_mps;
        figures[key + "id_switches_per_min"] = r.summary.id_switches_per_min;
        // The share of the switches that came after the person went unmatched (lost, then found under a new id).
        figures[key + "id_switches_after_gap_per_min"] =
            r.summary.id_switches == 0
                ? 0.0
                : r.summary.id_switches_per_min * static_cast<double>(r.summary.id_switches_after_gap) /
                      static_cast<double>(r.summary.id_switches);
        figures[key + "speed_abs_err_median_mps"] = r.summary.speed_abs_err_median_mps;
        figures[key + "static_speed_mps_p95"] = r.summary.static_speed_mps_p95;
        figures[key + "wall_moving_tracks_per_scan"] = r.wall_moving_tracks_per_scan;
        figures[key + "false_tracks_per_scan"] = r.summary.false_tracks_per_scan;
        figures[key + "missed_rate"] = r.summary.missed_rate;
        figures[key + "heading_err_deg_median"] = r.summary.heading_err_deg_median;
        // The arcs the velocity space is built on bend with it (docs/tracker.md, "Which part of the tracks").
        figures[key + "turn_rate_rmse_rps"] = r.summary.turn_rate_rmse_rps;
        // Where the centre and speed errors come from: tracks younger than 1 s, tracks measured at this scan,
        // tracks coasting without a measurement (docs/tracker.md, "Metrics").
        figures[key + "pos_rmse_young_m"] = r.summary.pos_rmse_young_m;
        figures[key + "pos_rmse_observed_m"] = r.summary.pos_rmse_observed_m;
        figures[key + "pos_rmse_coasting_m"] = r.summary.pos_rmse_coasting_m;
        figures[key + "speed_rmse_observed_mps"] = r.summary.speed_rmse_observed_mps;
        figures[key + "speed_rmse_coasting_mps"] = r.summary.speed_rmse_coasting_mps;
        figures[key + "coasting_pair_fraction"] = r.summary.coasting_pair_fraction;
        // What carrying a hidden person at constant velocity could give at best (docs/tracker.md, "Metrics").
        figures[key + "pos_rmse_coasting_cv_bound_m"] = r.summary.pos_rmse_coasting_cv_bound_m;
        figures[key + "speed_rmse_coasting_cv_bound_mps"] = r.summary.speed_rmse_coasting_cv_bound_mps;
        figures[key + "pos_rmse_cv_bound_m"] = r.summary.pos_rmse_cv_bound_m;
        figures[key + "speed_rmse_cv_bound_mps"] = r.summary.speed_rmse_cv_bound_mps;
        // What a planner reads of tracks just born, left out of speed_rmse_mps (docs/tracker.md, "Metrics").
        figures[key + "speed_rmse_young_mps"] = r.summary.speed_rmse_young_mps;
        figures[key + "young_pair_fraction"] = r.summary.young_pair_fraction;
        // A person's body is not in the scan, only their legs: how far the reported radius is from it.
        figures[key + "radius_rmse_m"] = r.summary.radius_rmse_m;
        figures[key + "radius_bias_m"] = r.summary.radius_bias_m;
      }
    }
  }
  std::map<std::string, std::string> targets{{"pos_rmse_m", "<= 0.05"},           {"speed_rmse_mps", "<= 0.10"},
                                             {"heading_err_deg_median", "<= 10"}, {"id_switches_per_min", "< 1"},
                                             {"static_speed_mps_p95", "< 0.05"},  {"latency_ms_p99", "<= 1"}};
  // People's targets: centre, speed of tracks older than 1 s, switches, nothing moving on walls (docs/tracker.md).
  for (const auto& [name, value] : figures) {
    if (name.rfind("people_", 0) != 0) continue;
    for (const auto& [suffix, target] : std::map<std::string, std::string>{{"pos_rmse_m", "<= 0.08"},
                                                                           {"speed_rmse_mps", "<= 0.15"},
                                                                           {"id_switches_per_min", "<= 1"},
                                                                           {"static_speed_mps_p95", "<= 0.05"},
                                                                           {"wall_moving_tracks_per_scan", "0"}}) {
      if (name.size() > suffix.size() && name.compare(name.size() - suffix.size(), suffix.size(), suffix) == 0)
        targets[name] = target;
    }
  }

  std::cout << "Obstacle tracker: " << run_episodes << " episodes (1..15 obstacles x " << episodes << "), "
            << duration_s << " s each, robot at " << kRobotSpeedMps << " m/s, 720-beam LIDAR at 10 Hz\n\n";
  std::cout << std::left << std::setw(26) << "metric" << std::right << std::setw(12) << "value"
            << "   target\n";
  for (const auto& [name, value] : figures) {
    const auto target = targets.find(name);
    std::cout << std::left << std::setw(26) << name << std::right << std::setw(12) << std::setprecision(4) << value
              << "   " << (target == targets.end() ? "" : target->second) << "\n";
  }

  makeParentDirs(out_path);
  std::ofstream out(out_path);
  if (!out) {
    std::cerr << "bench_tracker: cannot write " << out_path << "\n";
    return 1;
  }
  out << "{";
  bool first = true;
  for (const auto& [name, value] : figures) {
    out << (first ? "" : ",") << "\n  \"" << name << "\": ";
    if (std::isfinite(value)) {
      out << std::setprecision(6) << value;
    } else {
      out << "null";
    }
    first = false;
  }
  out << "\n}\n";
  std::cout << "\nwritten " << out_path << "\n";
  return 0;
}
