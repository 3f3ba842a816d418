// dqn_dovs_py._core: the C++ core as a vectorised training environment for the Python trainer.
// Each environment is an Episode (simulator -> LIDAR -> tracker -> DOVS -> state), so training runs the
// code the robot runs. Environments are stepped in parallel threads with the GIL released.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <future>
#include <limits>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "dqn_dovs/common/random.h"
#include "dqn_dovs/evaluation/episode.h"
#include "dqn_dovs/evaluation/eval.h"
#include "dqn_dovs/evaluation/oracle.h"
#include "dqn_dovs/policy/action_shield.h"
#include "dqn_dovs/policy/dovs_decision.h"
#include "dqn_dovs/sim/errors.h"
#include "dqn_dovs/sim/scenario.h"
#include "dqn_dovs/sim/worlds.h"

namespace py = pybind11;
using namespace dqn_dovs;

namespace {

sim::ObstacleType parseObstacleType(const std::string& s) {
  if (s == "none") return sim::ObstacleType::kNone;
  if (s == "static") return sim::ObstacleType::kStatic;
  if (s == "dynamic") return sim::ObstacleType::kDynamic;
  if (s == "both") return sim::ObstacleType::kBoth;
  throw std::invalid_argument("obstacle_type '" + s + "' is not one of none, static, dynamic, both");
}

std::map<std::string, std::string> shieldParameterMap(const ActionShieldConfig& config) {
  std::map<std::string, std::string> out;
  for (const std::string& name : shieldParameterNames()) out[name] = shieldParameter(config, name);
  return out;
}

/// One world of the training mixture: its family and the Episode configuration its options give.
struct WorldVariant {
  sim::WorldFamily family = sim::WorldFamily::kRoom;
  EpisodeConfig config;
  double weight = 1.0;
};

class VecEnv {
 public:
  VecEnv(int num_envs, uint64_t seed, bool perfect_info, int threads, bool action_shield,
         const std::map<std::string, std::string>& shield_parameters,
         const std::map<std::string, std::string>& world_options,
         const std::map<std::string, std::string>& dovs_parameters,
         const std::map<std::string, std::string>& reward_parameters)
      : seed_(seed),
        perfect_info_(perfect_info),
        dovs_parameters_(dovs_parameters),
        reward_parameters_(reward_parameters) {
    // The shield as the robot runs it: the named parameters of config/dovs.yaml and config/static_safety.yaml
    // (python/dqn_dovs_py/decision_config.py reads them), then `action_shield` switches it on or off.
    for (const auto& [name, value] : shield_parameters) {
      if (const std::string e = setShieldParameter(shield_, name, value); !e.empty()) {
        throw std::invalid_argument("shield_parameters: " + e);
      }
    }
    shield_.enabled = action_shield;
    if (const std::string e = shield_.validate(); !e.empty()) throw std::invalid_argument("shield_parameters: " + e);
    if (num_envs < 1 || num_envs > 4096) throw std::invalid_argument("num_envs must be in [1, 4096]");
    variants_.push_back(parseWorld(world_options, "world_options", 1.0));
    // Every world shares the DOVS parameters, so every state has the same grid channels and size.
    state_size_ = stateNormalization(variants_.front().config.world.robot, variants_.front().config.dovs).stateSize();
    for (int i = 0; i < num_envs; ++i) {
      envs_.push_back(std::make_unique<Env>());
      envs_.back()->built = {std::make_shared<Episode>(variants_.front().config)};
      envs_.back()->active = envs_.back()->built.front();
    }
    const int hw = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
    threads_ = std::clamp(threads > 0 ? threads : hw, 1, num_envs);
    generator_.obstacle_count_min = 0;
    generator_.obstacle_count_max = 0;
    generator_.obstacle_type = sim::ObstacleType::kNone;
  }

  void setStage(double goal_min, double goal_max, int obstacles_min, int obstacles_max, const std::string& type) {
    sim::GeneratorConfig g = generator_;
    g.goal_distance_min_m = goal_min;
    g.goal_distance_max_m = goal_max;
    g.obstacle_count_min = obstacles_min;
    g.obstacle_count_max = obstacles_max;
    g.obstacle_type = parseObstacleType(type);
    const std::string error = g.validate();
    if (!error.empty()) throw std::invalid_argument("set_stage: " + error);
    generator_ = g;
  }

  /// The mixture of worlds that episodes reset from now on are drawn from: each entry is a world_options mapping
  /// (world, sensor, people_model, people_see_robot, people_mix, odom_noise, route, people_predictor), drawn with
  /// probability weight / sum of weights. With one world no draw is made, so a single world replays the same scenarios
  /// as before.
  void setWorlds(const std::vector<std::map<std::string, std::string>>& worlds, const std::vector<double>& weights) {
    if (worlds.empty()) throw std::invalid_argument("set_worlds: at least one world is needed");
    if (weights.size() != worlds.size()) {
      throw std::invalid_argument("set_worlds: " + std::to_string(weights.size()) + " weights for " +
                                  std::to_string(worlds.size()) + " worlds");
    }
    std::vector<WorldVariant> variants;
    for (size_t k = 0; k < worlds.size(); ++k) {
      const std::string where = "set_worlds: world " + std::to_string(k);
      if (!std::isfinite(weights[k]) || weights[k] <= 0.0) {
        throw std::invalid_argument(where + ": weight must be finite and positive, got " + std::to_string(weights[k]));
      }
      variants.push_back(parseWorld(worlds[k], where, weights[k]));
    }
    variants_ = std::move(variants);
    // Episodes built for the previous mixture are dropped; each environment builds one per world when first drawn.
    for (auto& e : envs_) e->built.assign(variants_.size(), nullptr);
  }

  void seed(uint64_t s) {
    seed_ = s;
    for (auto& e : envs_) e->episodes = 0;
  }

  py::tuple reset() {
    const size_t n = envs_.size();
    {
      py::gil_scoped_release release;
      parallelFor([&](size_t i) { resetEnv(i); });
    }
    py::array_t<float> state({n, static_cast<size_t>(state_size_)});
    py::array_t<bool> mask({n, static_cast<size_t>(kNumActions)});
    for (size_t i = 0; i < n; ++i) {
      copyState(envs_[i]->ep(), state.mutable_data(i, 0));
      copyMask(*envs_[i], mask.mutable_data(i, 0));
    }
    return py::make_tuple(state, mask);
  }

  py::dict step(py::array_t<int64_t, py::array::c_style | py::array::forcecast> actions) {
    const size_t n = envs_.size();
    if (actions.ndim() != 1 || static_cast<size_t>(actions.shape(0)) != n) {
      throw std::invalid_argument("step: actions must have shape (" + std::to_string(n) + ",)");
    }
    std::vector<int64_t> a(actions.data(), actions.data() + n);
    for (size_t i = 0; i < n; ++i) {
      if (a[i] < 0 || a[i] >= kNumActions) {
        throw std::invalid_argument("step: action " + std::to_string(a[i]) + " of environment " + std::to_string(i) +
                                    " is not in [0, 8)");
      }
    }
    py::array_t<float> next_state({n, static_cast<size_t>(state_size_)}), state({n, static_cast<size_t>(state_size_)});
    py::array_t<bool> next_mask({n, static_cast<size_t>(kNumActions)}), mask({n, static_cast<size_t>(kNumActions)});
    const std::vector<py::ssize_t> shape1{static_cast<py::ssize_t>(n)};
    py::array_t<float> reward(shape1);
    py::array_t<bool> terminated(shape1), truncated(shape1);
    py::array_t<int8_t> outcome(shape1);
    py::array_t<int32_t> episode_steps(shape1);
    py::array_t<bool> escaped(shape1);
    bool* esc = escaped.mutable_data();
    py::array_t<int64_t> executed_action(shape1);
    py::array_t<int32_t> world(shape1);
    int32_t* wd = world.mutable_data();
    int64_t* ex = executed_action.mutable_data();
    float* ns = next_state.mutable_data();
    float* st = state.mutable_data();
    bool* nm = next_mask.mutable_data();
    bool* mk = mask.mutable_data();
    float* rw = reward.mutable_data();
    bool* te = terminated.mutable_data();
    bool* tr = truncated.mutable_data();
    int8_t* oc = outcome.mutable_data();
    int32_t* es = episode_steps.mutable_data();
    std::vector<std::string> errors(n);
    {
      py::gil_scoped_release release;
      parallelFor([&](size_t i) {
        Env& env = *envs_[i];
        Episode& ep = env.ep();
        try {
          const int act = static_cast<int>(a[i]);
          // Boxed in, the shield's escape velocity is what runs (as the planner does on the robot), whatever
          // the action; otherwise a masked action falls back to "keep" (always valid; the trainer never sends one).
          esc[i] = env.has_escape;
          ex[i] = executedAction(ep.actions(), act, env.has_escape ? &env.escape : nullptr, ep.config().world.robot);
          const StepResult r = env.has_escape                                 ? ep.step(env.escape)
                               : ep.actions().valid[static_cast<size_t>(act)] ? ep.stepAction(act)
                                                                              : ep.stepAction(kActionKeep);
          rw[i] = static_cast<float>(r.reward);
          te[i] = r.terminated;
          tr[i] = r.truncated;
          oc[i] = static_cast<int8_t>(r.outcome);
          es[i] = ep.steps();
          wd[i] = static_cast<int32_t>(env.variant);
          copyState(ep, ns + i * state_size_);
          copyMask(env, nm + i * kNumActions);
          if (ep.done()) {
            resetEnv(i);
            copyState(env.ep(), st + i * state_size_);
            copyMask(env, mk + i * kNumActions);
          } else {
            // The episode goes on: what to act on next is the successor just copied (shielded once, not twice).
            std::memcpy(st + i * state_size_, ns + i * state_size_, sizeof(float) * state_size_);
            std::memcpy(mk + i * kNumActions, nm + i * kNumActions, sizeof(bool) * kNumActions);
          }
        } catch (const std::exception& e) {
          errors[i] = e.what();
        }
      });
    }
    for (size_t i = 0; i < n; ++i) {
      if (!errors[i].empty()) throw std::runtime_error("environment " + std::to_string(i) + ": " + errors[i]);
    }
    py::dict out;
    out["next_state"] = next_state;
    out["next_mask"] = next_mask;
    out["reward"] = reward;
    out["terminated"] = terminated;
    out["truncated"] = truncated;
    out["outcome"] = outcome;
    out["state"] = state;
    out["mask"] = mask;
    out["episode_steps"] = episode_steps;
    out["escaped"] = escaped;
    out["executed_action"] = executed_action;
    out["world"] = world;
    return out;
  }

  /// The 8 action velocities of every environment's current state: float64 [n, 8, 2] (v m/s, w rad/s).
  py::array_t<double> actionVelocities() const {
    const size_t n = envs_.size();
    py::array_t<double> out({n, static_cast<size_t>(kNumActions), size_t{2}});
    double* d = out.mutable_data();
    for (size_t i = 0; i < n; ++i) {
      const ActionSet& a = envs_[i]->ep().actions();
      for (int k = 0; k < kNumActions; ++k) {
        d[(i * kNumActions + static_cast<size_t>(k)) * 2] = a.velocities[static_cast<size_t>(k)].v;
        d[(i * kNumActions + static_cast<size_t>(k)) * 2 + 1] = a.velocities[static_cast<size_t>(k)].w;
      }
    }
    return out;
  }

  /// A teacher's choice for every environment's current state (the one the agent acts on next), where `which` is
  /// true: the teacher planner decides on the episode as it stands and its command is mapped to the nearest action
  /// the agent may choose (the shielded mask), in the window's units (dv, dw), ties to the lowest index. -1 where
  /// `which` is false, or where the shield's escape will run whatever the agent chooses (boxed in). Teachers:
  /// `oracle` (evaluation/oracle.h: it reads the simulator's future, so it is a privileged teacher that no robot
  /// has) and `s_dovs` (the heuristic, on the same observation the agent sees).
  py::array_t<int64_t> teacherActions(const std::string& teacher,
                                      py::array_t<bool, py::array::c_style | py::array::forcecast> which) {
    const size_t n = envs_.size();
    if (teacher != "oracle" && teacher != "s_dovs") {
      throw std::invalid_argument("teacher_actions: teacher '" + teacher + "' is not one of oracle, s_dovs");
    }
    if (which.ndim() != 1 || static_cast<size_t>(which.shape(0)) != n) {
      throw std::invalid_argument("teacher_actions: which must have shape (" + std::to_string(n) + ",)");
    }
    const std::vector<bool> ask(which.data(), which.data() + n);
    py::array_t<int64_t> out(std::vector<py::ssize_t>{static_cast<py::ssize_t>(n)});
    int64_t* o = out.mutable_data();
    std::vector<std::string> errors(n);
    {
      py::gil_scoped_release release;
      parallelFor([&](size_t i) {
        o[i] = -1;
        Env& env = *envs_[i];
        if (!ask[i] || env.has_escape) return;
        try {
          Episode& ep = env.ep();
          if (!env.teacher || env.teacher_name != teacher) {
            // Built as the evaluation builds it: the oracle with this episode's success rule, S-DOVS with the shield.
            EvalConfig setup;
            setup.episode = ep.config();
            setup.shield = shield_;
            env.teacher = makeEvalPlanner(teacher, setup);
            env.teacher_name = teacher;
            env.teacher_stale = true;
          }
          if (env.teacher_stale) {  // a new episode since the teacher last decided
            env.teacher->reset();
            env.teacher_stale = false;
          }
          if (auto* oracle = dynamic_cast<OraclePlanner*>(env.teacher.get())) oracle->setWorld(&ep.world());
          const PlannerDecision d = env.teacher->decide(ep.plannerInput());
          o[i] = nearestAction(ep.actions(), env.mask, d.command, ep.config().world.robot);
        } catch (const std::exception& e) {
          errors[i] = e.what();
        }
      });
    }
    for (size_t i = 0; i < n; ++i) {
      if (!errors[i].empty())
        throw std::runtime_error("teacher_actions: environment " + std::to_string(i) + ": " + errors[i]);
    }
    return out;
  }

  int stateSizeOf() const { return state_size_; }
  int gridChannels() const { return (state_size_ - kNumFeatures) / kStateGridCells; }

  /// Everything the state depends on beyond its normalisation and layout (stateParametersText): the trainer writes it
  /// into every exported network, and planner_node refuses a network trained with other values.
  std::string stateParameters() const {
    const EpisodeConfig& c = variants_.front().config;
    return stateParametersText(c.world.robot, c.dovs);
  }

  py::dict normalization() const {
    py::dict d;
    for (const auto& [name, value] : envs_.front()->ep().normalization().fields()) d[py::str(name)] = value;
    return d;
  }

  /// The evaluation path on environment `i`'s current episode: the named planner (makePlanner, with this
  /// environment's shield) runs the same scenario with the same sensor noise in a fresh Episode, as dqn_dovs_eval
  /// runs it. Returns {"actions": the planner's action per decision (-1: not one of the 8, e.g. the escape),
  /// "outcome": int, "steps": int}.
  py::dict plannerEpisode(int i, const std::string& method, const std::string& model_path) const {
    if (i < 0 || i >= numEnvs()) throw std::invalid_argument("planner_episode: no environment " + std::to_string(i));
    const Env& env = *envs_[static_cast<size_t>(i)];
    EpisodeRecord r;
    {
      py::gil_scoped_release release;
      std::unique_ptr<Planner> planner = makePlanner(method, model_path, &shield_, &env.ep().normalization());
      Episode episode(env.ep().config());
      r = runEpisode(*planner, episode, method, env.current);
    }
    py::dict d;
    d["actions"] = r.actions;
    d["outcome"] = static_cast<int>(r.outcome);
    d["steps"] = r.steps;
    return d;
  }

  int numEnvs() const { return static_cast<int>(envs_.size()); }
  int threads() const { return threads_; }

 private:
  struct Env {
    /// The episode being run.
    Episode& ep() { return *active; }
    const Episode& ep() const { return *active; }
    // One Episode per world of the mixture, built when the world is first drawn (worlds differ in sensor, people
    // and odometry, which an Episode fixes at construction). `active` is the running one: a new mixture replaces
    // `built` but lets the running episode finish in its own world.
    std::vector<std::shared_ptr<Episode>> built;
    std::shared_ptr<Episode> active;
    // The running episode's world: its index in the mixture in force when it began.
    size_t variant = 0;
    uint64_t episodes = 0;
    // The current episode's scenario and sensor-noise seed (what planner_episode replays).
    EvalScenario current;
    // The shield's escape for the state the agent acts on next (set by copyMask).
    bool has_escape = false;
    Twist2 escape;
    // The mask the agent chooses under for that state (set by copyMask).
    std::array<bool, kNumActions> mask{};
    // teacher_actions' planner, made on first use; stale once a new episode starts (resetEnv).
    std::unique_ptr<Planner> teacher;
    std::string teacher_name;
    bool teacher_stale = true;
  };

  void resetEnv(size_t i) {
    Env& env = *envs_[i];
    // Scenario seeds depend on (seed, environment, episode count) only: deterministic whatever the threads.
    // A drawn scenario can end during the sensor warm-up (an obstacle runs into the still robot): such
    // episodes teach nothing, so the next scenario of the sequence is drawn instead. So is one the world
    // generator cannot lay out (a crowded clutter room where a person has no reachable destination).
    std::string unplaceable;
    for (int attempt = 0; attempt < 100; ++attempt) {
      const uint64_t s = sim::mixSeed(seed_ ^ sim::mixSeed(i * 0x100000001B3ULL + env.episodes++));
      const size_t variant = drawWorld(s);
      try {
        env.current.scenario = generate(variants_[variant].family, s);
      } catch (const sim::ScenarioError& e) {
        unplaceable = e.what();
        continue;
      }
      env.variant = variant;
      if (!env.built[env.variant]) env.built[env.variant] = std::make_shared<Episode>(variants_[env.variant].config);
      env.active = env.built[env.variant];
      env.current.seed = sim::mixSeed(s);
      env.ep().reset(env.current.scenario, env.current.seed);
      env.teacher_stale = true;
      if (!env.ep().done()) return;
    }
    throw std::runtime_error("100 scenarios in a row ended before their first step or could not be laid out (last: " +
                             (unplaceable.empty() ? std::string("none") : unplaceable) + "): check the stage settings");
  }

  /// The world of the episode of seed s: the only one, or one drawn from the mixture by weight.
  size_t drawWorld(uint64_t s) const {
    if (variants_.size() == 1) return 0;
    double total = 0.0;
    for (const auto& v : variants_) total += v.weight;
    const double u = static_cast<double>(sim::mixSeed(s ^ 0x9E3779B97F4A7C15ULL) >> 11) * 0x1.0p-53 * total;
    double cumulative = 0.0;
    for (size_t k = 0; k < variants_.size(); ++k) {
      cumulative += variants_[k].weight;
      if (u < cumulative) return k;
    }
    return variants_.size() - 1;
  }

  /// The world options as dqn_dovs_eval sets them up (applyWorldOptions): family, LIDAR profile, people, odometry.
  WorldVariant parseWorld(const std::map<std::string, std::string>& options, const std::string& where,
                          double weight) const {
    EvalConfig world;
    for (const auto& [key, value] : options) {
      if (key == "world") {
        world.world = value;
      } else if (key == "sensor") {
        world.sensor = value;
      } else if (key == "people_model") {
        world.people_model = value;
      } else if (key == "people_see_robot") {
        if (value != "true" && value != "false")
          throw std::invalid_argument(where + ": people_see_robot must be true or false, got '" + value + "'");
        world.people_see_robot = value == "true";
      } else if (key == "people_mix") {
        world.people_mix = value;  // applyWorldOptions names a mix it cannot read
      } else if (key == "odom_noise") {
        world.odom_noise = value;
      } else if (key == "route") {
        world.route = value;  // applyWorldOptions names a value other than on or off
      } else if (key == "people_predictor") {
        world.episode.people_predictor = value;  // the Episode names a missing or unusable file
      } else {
        throw std::invalid_argument(where + ": unknown key '" + key +
                                    "' (world, sensor, people_model, people_see_robot, people_mix, odom_noise, "
                                    "route, people_predictor)");
      }
    }
    WorldVariant v;
    v.weight = weight;
    try {
      v.family = sim::parseWorldFamily(world.world);
      applyWorldOptions(world);
    } catch (const std::exception& e) {
      throw std::invalid_argument(where + ": " + e.what());
    }
    v.config = world.episode;
    v.config.perfect_info = perfect_info_;
    if (!v.config.people_predictor.empty()) {
      try {  // a missing or unusable file is named now, not when the first episode of this world resets
        PeoplePredictor::load(v.config.people_predictor);
      } catch (const PeoplePredictorError& e) {
        throw std::invalid_argument(where + ": people_predictor: " + e.what());
      }
    }
    // The DOVS as the robot's dovs.yaml would set it (names of setDovsParameter), in every world.
    for (const auto& [name, value] : dovs_parameters_) {
      if (const std::string e = setDovsParameter(v.config.dovs, name, value); !e.empty())
        throw std::invalid_argument("dovs_parameters: " + e);
    }
    if (const std::string e = v.config.dovs.validate(); !e.empty())
      throw std::invalid_argument("dovs_parameters: " + e);
    // The reward by name (the trainer's config, `reward:`), in every world.
    for (const auto& [name, value] : reward_parameters_) {
      if (const std::string e = setRewardParameter(v.config.reward, name, value); !e.empty())
        throw std::invalid_argument("reward_parameters: " + e);
    }
    if (const std::string e = v.config.reward.validate(); !e.empty())
      throw std::invalid_argument("reward_parameters: " + e);
    return v;
  }

  /// The scenario of seed s: the stage's room, or a world of the family with the stage's count of people.
  sim::Scenario generate(sim::WorldFamily family, uint64_t s) const {
    if (family == sim::WorldFamily::kRoom) return sim::generateScenario(generator_, s);
    sim::WorldFamilyConfig w;
    w.family = family;
    const int span = generator_.obstacle_count_max - generator_.obstacle_count_min + 1;
    w.people = generator_.obstacle_type == sim::ObstacleType::kNone
                   ? 0
                   : generator_.obstacle_count_min + static_cast<int>(s % static_cast<uint64_t>(std::max(span, 1)));
    return sim::generateWorld(w, s);
  }

  /// The action that stands for what ran: the chosen one when valid, "keep" for a masked one (what step runs);
  /// for the shield's escape, the action whose velocity is nearest to it in the window's units (dv, dw), equal
  /// distances to the chosen action, then to the lowest index. Replay stores it under a one-action mask.
  static int64_t executedAction(const ActionSet& actions, int chosen, const Twist2* escape, const RobotLimits& limits) {
    const bool chosen_ok = chosen >= 0 && chosen < kNumActions && actions.valid[static_cast<size_t>(chosen)];
    if (escape == nullptr) return chosen_ok ? chosen : kActionKeep;
    std::array<bool, kNumActions> every;
    every.fill(true);
    return nearestAction(actions, every, *escape, limits, chosen >= 0 && chosen < kNumActions ? chosen : 0);
  }

  /// The allowed action whose velocity is nearest to `command` in the window's units (dv, dw); equal distances go
  /// to `preferred` (when allowed), then to the lowest index. -1 when none is allowed.
  static int64_t nearestAction(const ActionSet& actions, const std::array<bool, kNumActions>& allowed,
                               const Twist2& command, const RobotLimits& limits, int preferred = -1) {
    const double dv = std::max(limits.dv(), 1e-9), dw = std::max(limits.dw(), 1e-9);
    auto distance = [&](int k) {
      const Twist2& u = actions.velocities[static_cast<size_t>(k)];
      return std::hypot((u.v - command.v) / dv, (u.w - command.w) / dw);
    };
    int64_t best = -1;
    double best_d = std::numeric_limits<double>::infinity();
    if (preferred >= 0 && preferred < kNumActions && allowed[static_cast<size_t>(preferred)]) {
      best = preferred;
      best_d = distance(preferred);
    }
    for (int k = 0; k < kNumActions; ++k) {
      if (!allowed[static_cast<size_t>(k)]) continue;
      const double d = distance(k);
      if (d < best_d - 1e-12) {
        best = k;
        best_d = d;
      }
    }
    return best;
  }

  void copyState(const Episode& ep, float* dst) const {
    std::memcpy(dst, ep.state().data(), sizeof(float) * static_cast<size_t>(state_size_));
  }
  // The mask the agent chooses under: the validity mask, narrowed by the action shield when it is on (the same
  // function the DQN-DOVS planner applies on the robot and in evaluation), and the shield's escape if boxed in.
  void copyMask(Env& env, bool* dst) const {
    const Episode& ep = env.ep();
    const ShieldedMask m = shieldStep(ep.actions(), ep.dovs(), ep.observation(), shield_);
    for (int k = 0; k < kNumActions; ++k) dst[k] = m.mask[static_cast<size_t>(k)];
    env.mask = m.mask;
    env.has_escape = m.has_escape;
    env.escape = m.escape;
  }

  template <typename F>
  void parallelFor(F&& f) {
    const size_t n = envs_.size();
    if (threads_ <= 1) {
      for (size_t i = 0; i < n; ++i) f(i);
      return;
    }
    std::vector<std::future<void>> jobs;
    for (int t = 0; t < threads_; ++t) {
      jobs.push_back(std::async(std::launch::async, [&, t] {
        for (size_t i = static_cast<size_t>(t); i < n; i += static_cast<size_t>(threads_)) f(i);
      }));
    }
    for (auto& j : jobs) j.get();
  }

  std::vector<std::unique_ptr<Env>> envs_;
  sim::GeneratorConfig generator_;
  ActionShieldConfig shield_;
  std::vector<WorldVariant> variants_;
  uint64_t seed_ = 0;
  bool perfect_info_ = false;
  std::map<std::string, std::string> dovs_parameters_;    // applied to every world's DovsConfig
  std::map<std::string, std::string> reward_parameters_;  // applied to every world's RewardConfig
  int state_size_ = kStateSize;                           // floats per state (stateSize of the grid channels)
  int threads_ = 1;

 public:
  /// The shield's parameters as the environments run them (name -> value as text).
  std::map<std::string, std::string> shieldParameters() const { return shieldParameterMap(shield_); }
};

}  // namespace

PYBIND11_MODULE(_core, m) {
  m.doc() = "dqn_dovs C++ core: vectorised training environment (simulator -> LIDAR -> tracker -> DOVS -> state)";
  m.attr("STATE_SIZE") = kStateSize;
  m.attr("NUM_ACTIONS") = kNumActions;
  m.def(
      "state_parameters",
      [](const std::map<std::string, std::string>& dovs_parameters) {
        DovsConfig dovs;
        for (const auto& [name, value] : dovs_parameters) {
          if (const std::string e = setDovsParameter(dovs, name, value); !e.empty()) throw std::invalid_argument(e);
        }
        if (const std::string e = dovs.validate(); !e.empty()) throw std::invalid_argument("dovs: " + e);
        return stateParametersText(RobotLimits{}, dovs);
      },
      py::arg("dovs_parameters") = std::map<std::string, std::string>{},
      "The `state parameters:` metadata line's text for the robot's default limits and these DOVS parameters by "
      "name (config/dovs.yaml's dovs/* names) over the defaults.");
  m.def("reward_parameter_names", &rewardParameterNames,
        "Every reward parameter name (RewardConfig; the trainer config's reward: section).");
  m.def("dovs_parameter_names", &dovsParameterNames,
        "Every DOVS parameter name (config/dovs.yaml dovs/*, setDovsParameter), in config-file order.");
  m.def("shield_parameter_names", &shieldParameterNames,
        "Every action shield parameter name (config/dovs.yaml action_shield/*, config/static_safety.yaml).");
  m.def(
      "default_shield_parameters", [] { return shieldParameterMap(ActionShieldConfig{}); },
      "The C++ defaults of the shield's parameters (what dqn_dovs_eval runs without --shield).");
  py::class_<VecEnv>(m, "VecEnv")
      .def(py::init<int, uint64_t, bool, int, bool, const std::map<std::string, std::string>&,
                    const std::map<std::string, std::string>&, const std::map<std::string, std::string>&,
                    const std::map<std::string, std::string>&>(),
           py::arg("num_envs"), py::arg("seed"), py::arg("perfect_info") = false, py::arg("threads") = 0,
           py::arg("action_shield") = false, py::arg("shield_parameters") = std::map<std::string, std::string>{},
           py::arg("world_options") = std::map<std::string, std::string>{},
           py::arg("dovs_parameters") = std::map<std::string, std::string>{},
           py::arg("reward_parameters") = std::map<std::string, std::string>{},
           "world_options: the evaluation's world flags by name (world: room, crowd, corridor, doorway, clutter, "
           "junction, with the stage's obstacle counts as people; sensor; people_model; people_see_robot: true or "
           "false; people_mix: attentive=A,impassive=I,oblivious=O shares or headline; odom_noise; route: on (default: "
           "routes in "
           "worlds with walls, as the robot follows them) or off; "
           "people_predictor: a people predictor file whose predicted arcs the DOVS takes, as --predict-people). "
           "dovs_parameters: the DOVS model's parameters by name (config/dovs.yaml dovs/*, e.g. grid_contact_horizon), "
           "applied in every world. reward_parameters: the reward's parameters by name (RewardConfig: goal_reward, "
           "collision_reward, distance_weight, ..., hit_at_rest_reward, shaping_gamma, intimate_weight, "
           "blocking_weight), applied in every world.")
      .def("shield_parameters", &VecEnv::shieldParameters,
           "The action shield's parameters as the environments run them (name -> value as text).")
      .def("set_stage", &VecEnv::setStage, py::arg("goal_distance_min"), py::arg("goal_distance_max"),
           py::arg("obstacles_min"), py::arg("obstacles_max"), py::arg("obstacle_type"))
      .def("set_worlds", &VecEnv::setWorlds, py::arg("worlds"), py::arg("weights"),
           "The mixture of worlds for the episodes reset from now on: world_options mappings and their weights "
           "(running episodes finish in their own world). step()'s 'world' gives each step's index in it.")
      .def("seed", &VecEnv::seed, py::arg("seed"), "Restarts the scenario sequence from a new seed.")
      .def("reset", &VecEnv::reset)
      .def("step", &VecEnv::step, py::arg("actions"))
      .def("normalization", &VecEnv::normalization)
      .def("state_parameters", &VecEnv::stateParameters,
           "The parameters the state depends on beyond its normalisation (dovs/*, robot/a_v, a_w, dt, radius), as "
           "the `state parameters:` metadata line holds them.")
      .def("action_velocities", &VecEnv::actionVelocities,
           "The 8 action velocities of each environment's current state, float64 [n, 8, 2] (v, w).")
      .def("teacher_actions", &VecEnv::teacherActions, py::arg("teacher"), py::arg("which"),
           "A teacher's choice (oracle: reads the simulator's future; s_dovs: the heuristic) for each environment's "
           "current state where `which` is true, as the nearest action the agent may choose; -1 elsewhere and "
           "where the shield's escape runs.")
      .def("planner_episode", &VecEnv::plannerEpisode, py::arg("env_index"), py::arg("method"),
           py::arg("model_path") = std::string(),
           "The evaluation path (dqn_dovs_eval's Episode + planner) on an environment's current episode: "
           "{'actions', 'outcome', 'steps'}.")
      .def_property_readonly("num_envs", &VecEnv::numEnvs)
      .def_property_readonly("state_size", &VecEnv::stateSizeOf,
                             "Floats per state: grid channels x 400 grid values, then 8 features.")
      .def_property_readonly("grid_channels", &VecEnv::gridChannels,
                             "Channels of the state's grid (dovs_parameters grid_channels: 1, or 3 with the dynamic "
                             "window and the goal line).")
      .def_property_readonly("threads", &VecEnv::threads);
}
