// DOVS accuracy against brute force, build time, the shield's escape search, the whole decision (DOVS build,
// actions, state, shield, network) and the learned people prediction's arcs (what dovs_node adds with
// people_predictor). Prints a table; writes bench/results/dovs.json.
//   bench_dovs [--scenarios DIR] [--out FILE] [--scenes N] [--seed S] [--model FILE] [--people-predictor FILE]
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "dovs_bruteforce.h"
#include "dqn_dovs/dovs/actions.h"
#include "dqn_dovs/dovs/state.h"
#include "dqn_dovs/perception/people_predictor.h"
#include "dqn_dovs/planning/dqn_dovs_planner.h"
#include "dqn_dovs/policy/action_shield.h"
#include "dqn_dovs/policy/qnetwork.h"
#include "dqn_dovs/sim/scenario.h"

namespace {

using namespace dqn_dovs;

struct Args {
  std::string scenarios = dqn_dovs::sim::kDefaultScenariosDir;
  std::string out = "bench/results/dovs.json";
  int scenes = 1500;
  unsigned long seed = 7;
  std::string model = "models/dqn_dovs.dqnw";
  std::string people_predictor = "models/people_predictor_tracks.dqnp";
};

Args parse(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    const std::string k = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "bench_dovs: option %s needs a value\n", k.c_str());
        std::exit(2);
      }
      return argv[++i];
    };
    if (k == "--scenarios")
      a.scenarios = value();
    else if (k == "--out")
      a.out = value();
    else if (k == "--scenes")
      a.scenes = std::atoi(value().c_str());
    else if (k == "--seed")
      a.seed = std::strtoul(value().c_str(), nullptr, 10);
    else if (k == "--model")
      a.model = value();
    else if (k == "--people-predictor")
      a.people_predictor = value();
    else {
      std::fprintf(stderr,
                   "bench_dovs: unknown option %s (known: --scenarios --out --scenes --seed --model "
                   "--people-predictor)\n",
                   k.c_str());
      std::exit(2);
    }
  }
  if (a.scenes < 1) {
    std::fprintf(stderr, "bench_dovs: --scenes must be positive\n");
    std::exit(2);
  }
  return a;
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const size_t i = std::min(v.size() - 1, static_cast<size_t>(p * static_cast<double>(v.size() - 1) + 0.5));
  return v[i];
}

std::vector<Segment> roomWalls(double half) {
  return {{{-half, -half}, {half, -half}},
          {{half, -half}, {half, half}},
          {{half, half}, {-half, half}},
          {{-half, half}, {-half, -half}}};
}

}  // namespace

int main(int argc, char** argv) {
  const Args args = parse(argc, argv);
  const RobotLimits limits;
  const DovsConfig config;
  DovsBuilder builder(limits, config);
  VelocitySpace dovs;

  // --- accuracy against brute force -------------------------------------------------------------------------
  constexpr int kLatticeV = 40, kLatticeW = 80;
  std::mt19937_64 rng(args.seed);
  bruteforce::SceneOptions opt;
  bruteforce::Tally all, moving;
  long scenes_with_miss = 0;
  const auto t_acc0 = std::chrono::steady_clock::now();
  for (int k = 0; k < args.scenes; ++k) {
    const Observation obs = bruteforce::randomScene(rng, builder, opt);
    builder.build(obs, dovs);
    const bruteforce::Reference ref(builder, obs);
    const bruteforce::Tally t = bruteforce::compareOnLattice(
        dovs, [&](const Twist2& tw) { return ref.unsafe(tw); }, kLatticeV, kLatticeW);
    all.add(t);
    scenes_with_miss += t.missed > 0;
    const Observation dyn = bruteforce::dynamicOnly(obs, builder);
    builder.build(dyn, dovs);
    const bruteforce::Reference ref_dyn(builder, dyn);
    moving.add(bruteforce::compareOnLattice(
        dovs, [&](const Twist2& tw) { return ref_dyn.dynamicUnsafe(tw); }, kLatticeV, kLatticeW));
  }
  const double acc_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_acc0).count();

  // --- build time: 15 obstacles + the room's 4 walls -----------------------------------------------------------
  std::vector<Observation> timed;
  std::string timing_source;
  for (int k = 1; k <= 100; ++k) {
    const std::filesystem::path p = std::filesystem::path(args.scenarios) / "1-15" / (std::to_string(k) + ".dovs");
    if (!std::filesystem::exists(p)) continue;
    sim::Scenario sc = sim::loadDovsScenario(p.string());
    sim::applyDynamicFraction(sc, 0.85);
    Observation obs;
    obs.robot_pose = sc.robot_start;
    obs.goal = sc.goal;
    obs.obstacles = sc.obstacles;
    obs.segments = roomWalls(sc.room_half_size_m);
    timed.push_back(obs);
  }
  timing_source = timed.empty() ? "random scenes (no scenario files found in " + args.scenarios + ")"
                                : std::to_string(timed.size()) + " scenarios " + args.scenarios + "/1-15 (85% dynamic)";
  bruteforce::SceneOptions timing_opt;
  timing_opt.min_obstacles = timing_opt.max_obstacles = 15;
  timing_opt.max_extra_walls = 0;
  std::mt19937_64 rng_time(args.seed + 1);
  while (timed.size() < 200) timed.push_back(bruteforce::randomScene(rng_time, builder, timing_opt));
  // Each scene is built kRepeats times; a scene's time is the median of its builds, so that a build preempted
  // by another process on a shared machine does not count as the scene's cost. The raw per-build p99 is
  // reported as well.
  std::vector<double> all_builds_ms, scene_ms;
  constexpr int kRepeats = 11;
  for (const Observation& obs : timed) {
    std::vector<double> runs;
    for (int rep = 0; rep < kRepeats; ++rep) {
      const auto t0 = std::chrono::steady_clock::now();
      builder.build(obs, dovs);
      runs.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    }
    all_builds_ms.insert(all_builds_ms.end(), runs.begin(), runs.end());
    scene_ms.push_back(percentile(runs, 0.5));
  }

  // The action shield's escape search on the same scenes (what dovs_node adds when the robot is boxed in),
  // from a velocity in the middle of the triangle; each scene's time is the median of its searches, as above.
  std::vector<double> escape_ms;
  const ActionShieldConfig shield;
  for (Observation obs : timed) {
    obs.robot_twist = {0.3, 0.2};
    std::vector<double> runs;
    for (int rep = 0; rep < 5; ++rep) {
      const auto t0 = std::chrono::steady_clock::now();
      const Twist2 u = escapeVelocity(obs, limits, config.safety_factor, shield);
      runs.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
      if (!std::isfinite(u.v)) std::abort();
    }
    escape_ms.push_back(percentile(runs, 0.5));
  }

  // The whole decision as the robot makes it, from the scene to the command: DOVS build, the 8 actions, the
  // network's state, then the DQN-DOVS planner (shield, escape search when boxed in, network, masked argmax).
  // Each scene's time is the median of 5 decisions; the scenes where the planner ran the escape are also
  // reported on their own.
  DqnDovsConfig planner_config;
  planner_config.model_path = args.model;
  planner_config.shield = shield;
  // One scene's whole decision with `planner` on states of `norm` (with person tokens, `history` remembers the
  // scene's obstacles by index across the repeats): the median of 5, and whether the escape ran.
  auto time_decision = [&](DqnDovsPlanner& planner, const StateNormalization& norm, Observation obs,
                           TrackHistory* history, bool& escaped) {
    obs.robot_twist = {0.3, 0.2};
    for (size_t k = 0; k < obs.obstacles.size(); ++k) obs.obstacles[k].id = static_cast<int>(k);
    if (history) history->clear();
    std::vector<double> runs;
    for (int rep = 0; rep < 5; ++rep) {
      const auto t0 = std::chrono::steady_clock::now();
      builder.build(obs, dovs);
      const ActionSet actions = computeActions(obs.robot_twist, obs.robot_pose.toLocal(obs.goal), limits);
      if (history) history->update(0.2 * rep, obs.obstacles);
      const Eigen::VectorXf state = buildState(dovs, obs, norm, nullptr, kNoPreviousChoice, history);
      PlannerInput input;
      input.observation = &obs;
      input.dovs = &dovs;
      input.actions = &actions;
      input.state = &state;
      input.limits = limits;
      const PlannerDecision d = planner.decide(input);
      runs.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
      if (!std::isfinite(d.command.v)) std::abort();
      escaped = d.action < 0;
    }
    return percentile(runs, 0.5);
  };
  DqnDovsPlanner planner(planner_config);
  std::vector<double> decision_ms, decision_escape_ms;
  for (const Observation& obs : timed) {
    bool escaped = false;
    decision_ms.push_back(time_decision(planner, StateNormalization{}, obs, nullptr, escaped));
    if (escaped) decision_escape_ms.push_back(decision_ms.back());
  }

  // The same whole decision with the version 3 network of the experiments (random weights: 8 wall rays, 6 person
  // tokens pooled by attention, 16 quantiles acted on by their CVaR), its state's rays and tokens built from the
  // scene and a track history included (docs/dovs.md "Person tokens").
  std::vector<double> token_decision_ms;
  {
    DuelingArchitecture arch;
    arch.wall_rays = 8;
    arch.person_tokens = 6;
    arch.quantiles = 16;
    arch.cvar_count = 4;
    StateNormalization token_norm;
    token_norm.wall_rays = 8;
    token_norm.person_tokens = 6;
    const std::string token_model =
        (std::filesystem::temp_directory_path() / ("bench_dovs_tokens_" + std::to_string(::getpid()) + ".dqnw"))
            .string();
    writeWeightFile(token_model, makeRandomWeights(arch, 11, token_norm.fields(), "bench tokens"));
    DqnDovsConfig token_config = planner_config;
    token_config.model_path = token_model;
    token_config.normalization = token_norm;
    DqnDovsPlanner token_planner(token_config);
    std::filesystem::remove(token_model);
    TrackHistory history;
    for (const Observation& obs : timed) {
      bool escaped = false;
      token_decision_ms.push_back(time_decision(token_planner, token_norm, obs, &history, escaped));
    }
  }

  // The learned people prediction as dovs_node applies it: every moving obstacle of a scene (its id its index) on
  // the arc of its predicted path, at decisions 0.2 s apart while they move on (so the history fills), among the
  // room's walls. A scene's time is the median of its last 5 of 10 decisions.
  std::shared_ptr<const PeoplePredictor> predictor;
  try {
    predictor = std::make_shared<const PeoplePredictor>(PeoplePredictor::load(args.people_predictor));
  } catch (const PeoplePredictorError& e) {
    std::fprintf(stderr, "bench_dovs: --people-predictor: %s\n", e.what());
    return 2;
  }
  PredictedArcs arcs(predictor);
  std::vector<double> predicted_ms;
  double predicted_people = 0.0;
  for (const Observation& obs : timed) {
    arcs.reset();
    std::vector<int> ids(obs.obstacles.size());
    for (size_t k = 0; k < ids.size(); ++k) ids[k] = static_cast<int>(k);
    std::vector<double> runs;
    for (int decision = 0; decision < 10; ++decision) {
      std::vector<MovingObstacle> seen = obs.obstacles;
      for (MovingObstacle& o : seen) {
        if (!o.is_static) o.center += 0.2 * decision * o.speed * Vec2(std::cos(o.heading), std::sin(o.heading));
      }
      const auto t0 = std::chrono::steady_clock::now();
      arcs.apply(seen, ids, 0.2 * decision, obs.segments);
      runs.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    }
    predicted_ms.push_back(percentile(std::vector<double>(runs.begin() + 5, runs.end()), 0.5));
    predicted_people += static_cast<double>(std::count_if(obs.obstacles.begin(), obs.obstacles.end(),
                                                          [](const MovingObstacle& o) { return !o.is_static; }));
  }

  std::map<std::string, double> figures;
  figures["predicted_arcs_ms_median"] = percentile(predicted_ms, 0.5);
  figures["predicted_arcs_ms_p99"] = percentile(predicted_ms, 0.99);
  figures["predicted_arcs_people_mean"] = predicted_people / static_cast<double>(timed.size());
  figures["decision_ms_median"] = percentile(decision_ms, 0.5);
  figures["decision_ms_p99"] = percentile(decision_ms, 0.99);
  figures["decision_ms_max"] = percentile(decision_ms, 1.0);
  figures["decision_escape_scenes"] = static_cast<double>(decision_escape_ms.size());
  figures["decision_escape_ms_median"] = percentile(decision_escape_ms, 0.5);
  figures["decision_escape_ms_p99"] = percentile(decision_escape_ms, 0.99);
  figures["tokens_cvar_decision_ms_median"] = percentile(token_decision_ms, 0.5);
  figures["tokens_cvar_decision_ms_p99"] = percentile(token_decision_ms, 0.99);
  figures["escape_ms_median"] = percentile(escape_ms, 0.5);
  figures["escape_ms_p99"] = percentile(escape_ms, 0.99);
  figures["escape_ms_max"] = percentile(escape_ms, 1.0);
  figures["missed_unsafe_rate"] = all.missedRate();
  figures["missed_unsafe_near_border_rate"] =
      all.reference_unsafe > 0 ? static_cast<double>(all.missed_near_border) / all.reference_unsafe : 0.0;
  figures["excess_unsafe_ratio"] = all.excessRatio();
  figures["excess_unsafe_ratio_moving_only"] = moving.excessRatio();
  figures["missed_unsafe_rate_moving_only"] = moving.missedRate();
  figures["scenes"] = args.scenes;
  figures["scenes_with_miss"] = static_cast<double>(scenes_with_miss);
  figures["lattice_points"] = static_cast<double>(all.feasible);
  figures["reference_unsafe_fraction"] = all.feasible ? static_cast<double>(all.reference_unsafe) / all.feasible : 0.0;
  figures["build_ms_median"] = percentile(scene_ms, 0.5);
  figures["build_ms_p99"] = percentile(scene_ms, 0.99);
  figures["build_ms_max"] = percentile(scene_ms, 1.0);
  figures["build_ms_p99_all_builds"] = percentile(all_builds_ms, 0.99);
  figures["num_trajectories"] = config.num_trajectories;

  std::printf("DOVS vs brute force: %d random scenes, %dx%d lattice (%ld feasible points), %.1f s\n", args.scenes,
              kLatticeV, kLatticeW, all.feasible, acc_s);
  std::printf("  %-34s %12s %12s\n", "", "all", "moving only");
  std::printf("  %-34s %12ld %12ld\n", "brute-force unsafe points", all.reference_unsafe, moving.reference_unsafe);
  std::printf("  %-34s %12ld %12ld\n", "DOVS unsafe points", all.dovs_unsafe, moving.dovs_unsafe);
  std::printf("  %-34s %12ld %12ld\n", "missed (away from border)", all.missed, moving.missed);
  std::printf("  %-34s %12ld %12ld\n", "missed (within one grid cell)", all.missed_near_border,
              moving.missed_near_border);
  std::printf("  %-34s %12.4f %12.4f\n", "excess unsafe ratio", all.excessRatio(), moving.excessRatio());
  std::printf("build time (15 obstacles + 4 walls), %zu scenes: %s + random scenes\n", scene_ms.size(),
              timing_source.c_str());
  std::printf("  per-scene median of %d builds: median %.3f ms, p99 %.3f ms, max %.3f ms; all builds p99 %.3f ms\n",
              kRepeats, figures["build_ms_median"], figures["build_ms_p99"], figures["build_ms_max"],
              figures["build_ms_p99_all_builds"]);
  std::printf("action shield escape search (median of 5 per scene): median %.3f ms, p99 %.3f ms, max %.3f ms\n",
              figures["escape_ms_median"], figures["escape_ms_p99"], figures["escape_ms_max"]);

  std::printf(
      "whole decision (DOVS build + actions + state + shield + network; median of 5 per scene): median %.3f ms, "
      "p99 %.3f ms, max %.3f ms; the %zu scenes where the escape ran: median %.3f ms, p99 %.3f ms\n",
      figures["decision_ms_median"], figures["decision_ms_p99"], figures["decision_ms_max"], decision_escape_ms.size(),
      figures["decision_escape_ms_median"], figures["decision_escape_ms_p99"]);

  std::printf(
      "whole decision with the version 3 network (8 wall rays, 6 person tokens, 16 quantiles, CVaR): median %.3f ms, "
      "p99 %.3f ms\n",
      figures["tokens_cvar_decision_ms_median"], figures["tokens_cvar_decision_ms_p99"]);

  std::printf(
      "learned people prediction's arcs (%s, %.1f moving obstacles per scene; median of the last 5 of 10 decisions): "
      "median %.3f ms, p99 %.3f ms\n",
      args.people_predictor.c_str(), figures["predicted_arcs_people_mean"], figures["predicted_arcs_ms_median"],
      figures["predicted_arcs_ms_p99"]);

  const std::filesystem::path out(args.out);
  if (out.has_parent_path()) std::filesystem::create_directories(out.parent_path());
  std::ofstream f(out);
  if (!f) {
    std::fprintf(stderr, "bench_dovs: cannot write %s\n", args.out.c_str());
    return 1;
  }
  f << "{\n";
  size_t i = 0;
  for (const auto& [k, v] : figures) f << "  \"" << k << "\": " << v << (++i < figures.size() ? ",\n" : "\n");
  f << "}\n";
  std::printf("wrote %s\n", args.out.c_str());
  return 0;
}
