#include "dqn_dovs/eval.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <limits>
#include <map>
#include <mutex>
#include <sstream>
#include <thread>

#include "dqn_dovs/planner.h"
#include "dqn_dovs/sim/random.h"

namespace dqn_dovs {

std::string EvalConfig::validate() const {
  std::ostringstream os;
  if (methods.empty()) return "methods is empty";
  for (size_t i = 0; i < methods.size(); ++i) {
    if (methods[i].empty()) return "methods[" + std::to_string(i) + "] is empty";
    for (size_t j = 0; j < i; ++j) {
      if (methods[j] == methods[i]) return "methods lists '" + methods[i] + "' twice";
    }
  }
  if (obstacles_min < 0) {
    os << "obstacles_min = " << obstacles_min << ": must be >= 0";
  } else if (obstacles_max < obstacles_min) {
    os << "obstacles_max = " << obstacles_max << ": must be >= obstacles_min (" << obstacles_min << ")";
  } else if (episodes < 1) {
    os << "episodes = " << episodes << ": must be >= 1";
  } else if (!(dynamic_fraction >= 0.0 && dynamic_fraction <= 1.0)) {
    os << "dynamic_fraction = " << dynamic_fraction << ": must be in [0, 1]";
  } else if (!(std::isfinite(generated_goal_distance_min_m) && generated_goal_distance_min_m >= 0.0)) {
    os << "generated_goal_distance_min_m = " << generated_goal_distance_min_m << ": must be finite and >= 0";
  } else if (threads < 1 || threads > 256) {
    os << "threads = " << threads << ": must be in [1, 256]";
  } else if (const std::string e = episode.validate(); !e.empty()) {
    os << "episode: " << e;
  } else if (const std::string e = shield.validate(); !e.empty()) {
    os << "shield: " << e;
  }
  return os.str();
}

namespace {

uint64_t episodeSeed(uint64_t base, int obstacles, int episode) {
  return sim::mixSeed(sim::mixSeed(base) ^ (static_cast<uint64_t>(obstacles) << 32 | static_cast<uint32_t>(episode)));
}

}  // namespace

std::vector<EvalScenario> loadEvalScenarios(const EvalConfig& config) {
  if (const std::string e = config.validate(); !e.empty()) throw EvalError("evaluation configuration: " + e);
  std::vector<EvalScenario> out;
  for (int n = config.obstacles_min; n <= config.obstacles_max; ++n) {
    for (int k = 1; k <= config.episodes; ++k) {
      EvalScenario s;
      s.obstacles = n;
      s.episode = k;
      s.seed = episodeSeed(config.seed, n, k);
      if (!config.scenarios_dir.empty()) {
        const std::string path = config.scenarios_dir + "/1-" + std::to_string(n) + "/" + std::to_string(k) + ".dovs";
        try {
          s.scenario = sim::loadDovsScenario(path);
          sim::applyDynamicFraction(s.scenario, config.dynamic_fraction);
        } catch (const std::exception& e) {
          throw EvalError("scenario " + path + ": " + e.what());
        }
        if (static_cast<int>(s.scenario.obstacles.size()) != n) {
          throw EvalError("scenario " + path + ": holds " + std::to_string(s.scenario.obstacles.size()) +
                          " obstacles, the folder 1-" + std::to_string(n) + " promises " + std::to_string(n));
        }
        s.scenario.name = "1-" + std::to_string(n) + "/" + std::to_string(k);
      } else {
        sim::GeneratorConfig g;
        g.obstacle_count_min = n;
        g.obstacle_count_max = n;
        g.obstacle_type = sim::ObstacleType::Both;
        g.dynamic_fraction = config.dynamic_fraction;
        g.goal_distance_min_m = config.generated_goal_distance_min_m;
        g.random_robot_heading = false;  // as in the evaluation files
        const uint64_t scenario_seed = episodeSeed(config.seed ^ 0x5CE7A210ULL, n, k);
        try {
          s.scenario = sim::generateScenario(g, scenario_seed);
        } catch (const std::exception& e) {
          throw EvalError("generated scenario (seed " + std::to_string(config.seed) + ", " + std::to_string(n) +
                          " obstacles, episode " + std::to_string(k) + "): " + e.what());
        }
        s.scenario.name =
            "generated/" + std::to_string(config.seed) + "/" + std::to_string(n) + "/" + std::to_string(k);
      }
      out.push_back(std::move(s));
    }
  }
  return out;
}

namespace {

/// One worker's tools: a planner per method and one episode, built once and reused for every job it runs.
struct Worker {
  std::vector<std::unique_ptr<Planner>> planners;
  std::unique_ptr<Episode> episode;
};

EpisodeRecord runOne(Worker& w, size_t method_index, const std::string& method, const EvalScenario& s,
                     bool keep_paths) {
  Planner& planner = *w.planners[method_index];
  Episode& ep = *w.episode;
  planner.reset();
  ep.reset(s.scenario, s.seed);
  EpisodeRecord r;
  r.method = method;
  r.obstacles = s.obstacles;
  r.episode = s.episode;
  r.scenario = s.scenario.name;
  if (keep_paths) r.obstacle_paths.resize(ep.world().obstacles().size());
  auto recordObstacles = [&]() {
    if (!keep_paths) return;
    const auto& obs = ep.world().obstacles();
    for (size_t i = 0; i < obs.size() && i < r.obstacle_paths.size(); ++i)
      r.obstacle_paths[i].push_back(obs[i].body.center);
  };
  recordObstacles();
  const RobotLimits& limits = ep.config().world.robot;
  while (!ep.done()) {
    const PlannerInput in = ep.plannerInput();
    PlannerDecision decision;
    try {
      decision = planner.decide(in);
    } catch (const PlannerError&) {
      // The interface's contract: the caller decelerates when a planner cannot decide.
      ++r.planner_errors;
      decision = PlannerDecision{};
      decision.command = decelerationCommand(ep.observation().robot_twist, limits);
      decision.note = "planner error";
    }
    r.last_decision = decision.note;
    ep.stepDecision(decision);  // holonomic baselines move the robot holonomically
    recordObstacles();
  }
  r.outcome = ep.outcome();
  r.time_s = ep.time_s();
  r.path_length_m = ep.pathLength_m();
  r.min_clearance_m = ep.minClearance_m();
  r.danger_steps = ep.dangerSteps();
  r.steps = ep.steps();
  if (r.outcome == Outcome::Collision && ep.world().collided()) {
    r.collision_kind = classifyCollision(ep.world().collision());
    r.contact_speed_mps = ep.world().collision().robot_speed_mps;
  }
  if (keep_paths) r.robot_path = ep.trajectory();
  return r;
}

}  // namespace

std::vector<EpisodeRecord> runEvaluation(const EvalConfig& config, const std::vector<EvalScenario>& scenarios,
                                         const EvalProgress& progress) {
  if (const std::string e = config.validate(); !e.empty()) throw EvalError("evaluation configuration: " + e);
  const size_t num_methods = config.methods.size();
  const size_t total = num_methods * scenarios.size();
  std::vector<EpisodeRecord> records(total);
  // Jobs run scenario-major (every method on a scenario before the next) so that partial progress is
  // comparable across methods; records are stored method-major.
  std::atomic<size_t> next{0};
  std::atomic<bool> failed{false};
  std::mutex mutex;
  size_t done = 0;
  std::string first_error;

  auto work = [&]() {
    Worker w;
    try {
      for (const std::string& m : config.methods)
        w.planners.push_back(makePlanner(m, config.model_path, &config.shield));
      w.episode = std::make_unique<Episode>(config.episode);
    } catch (const std::exception& e) {
      std::lock_guard<std::mutex> lock(mutex);
      if (first_error.empty()) first_error = std::string("cannot set up a worker: ") + e.what();
      failed = true;
      return;
    }
    while (!failed) {
      const size_t job = next.fetch_add(1);
      if (job >= total) break;
      const size_t si = job / num_methods, mi = job % num_methods;
      const EvalScenario& s = scenarios[si];
      const bool keep = std::find(config.keep_paths.begin(), config.keep_paths.end(),
                                  std::make_pair(s.obstacles, s.episode)) != config.keep_paths.end();
      try {
        EpisodeRecord r = runOne(w, mi, config.methods[mi], s, keep);
        std::lock_guard<std::mutex> lock(mutex);
        records[mi * scenarios.size() + si] = std::move(r);
        ++done;
        if (progress) progress(records[mi * scenarios.size() + si], done, total);
      } catch (const std::exception& e) {
        std::lock_guard<std::mutex> lock(mutex);
        if (first_error.empty()) {
          first_error = "method '" + config.methods[mi] + "' on scenario " + s.scenario.name + ": " + e.what();
        }
        failed = true;
      }
    }
  };

  const int threads = std::min<int>(config.threads, static_cast<int>(std::max<size_t>(total, 1)));
  if (threads <= 1) {
    work();
  } else {
    std::vector<std::thread> pool;
    for (int t = 0; t < threads; ++t) pool.emplace_back(work);
    for (std::thread& t : pool) t.join();
  }
  if (failed) throw EvalError("evaluation failed: " + first_error);
  return records;
}

const char* collisionKindName(CollisionKind kind) {
  switch (kind) {
    case CollisionKind::kNone:
      return "";
    case CollisionKind::kStatic:
      return "static";
    case CollisionKind::kRest:
      return "rest";
    case CollisionKind::kMoving:
      return "moving";
  }
  return "";
}

CollisionKind classifyCollision(const sim::CollisionInfo& collision) {
  if (collision.kind == sim::CollisionInfo::Kind::None) return CollisionKind::kNone;
  if (collision.static_contact) return CollisionKind::kStatic;
  return collision.robot_speed_mps < kRestSpeedMps ? CollisionKind::kRest : CollisionKind::kMoving;
}

const EvalCell& EvalSummary::cell(const std::string& method, int obstacles) const {
  const auto m = std::find(methods.begin(), methods.end(), method);
  const auto c = std::find(obstacle_counts.begin(), obstacle_counts.end(), obstacles);
  if (m == methods.end()) throw EvalError("summary: no method '" + method + "'");
  if (c == obstacle_counts.end()) throw EvalError("summary: no obstacle count " + std::to_string(obstacles));
  return cells[static_cast<size_t>(m - methods.begin())][static_cast<size_t>(c - obstacle_counts.begin())];
}

namespace {

struct Accumulator {
  int episodes = 0, successes = 0, collisions = 0, timeouts = 0, both = 0;
  int static_collisions = 0, rest_collisions = 0, moving_collisions = 0;
  std::vector<double> contact_speeds;
  double time_success = 0.0, time_mine = 0.0, time_ref = 0.0, clearance = 0.0;
  long danger = 0, steps = 0;

  void add(const EpisodeRecord& r, const EpisodeRecord* ref) {
    ++episodes;
    if (r.outcome == Outcome::Success) {
      ++successes;
      time_success += r.time_s;
      if (ref != nullptr && ref->outcome == Outcome::Success) {
        ++both;
        time_mine += r.time_s;
        time_ref += ref->time_s;
      }
    } else if (r.outcome == Outcome::Collision) {
      ++collisions;
      static_collisions += r.collision_kind == CollisionKind::kStatic ? 1 : 0;
      rest_collisions += r.collision_kind == CollisionKind::kRest ? 1 : 0;
      moving_collisions += r.collision_kind == CollisionKind::kMoving ? 1 : 0;
      if (std::isfinite(r.contact_speed_mps)) contact_speeds.push_back(r.contact_speed_mps);
    } else if (r.outcome == Outcome::Timeout) {
      ++timeouts;
    }
    danger += r.danger_steps;
    steps += r.steps;
    clearance += r.min_clearance_m;
  }

  EvalCell cell() const {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    EvalCell c;
    c.episodes = episodes;
    c.successes = successes;
    c.collisions = collisions;
    c.timeouts = timeouts;
    const double n = std::max(episodes, 1);
    c.success_rate = successes / n;
    c.collision_rate = collisions / n;
    c.timeout_rate = timeouts / n;
    c.mean_time_success_s = successes > 0 ? time_success / successes : nan;
    c.both_solved = both;
    c.time_ratio = both > 0 && time_ref > 0.0 ? time_mine / time_ref : nan;
    c.danger_frequency = steps > 0 ? static_cast<double>(danger) / static_cast<double>(steps) : 0.0;
    c.mean_min_clearance_m = episodes > 0 ? clearance / episodes : nan;
    c.static_collisions = static_collisions;
    c.rest_collisions = rest_collisions;
    c.moving_collisions = moving_collisions;
    c.mean_contact_speed_mps = nan;
    c.p95_contact_speed_mps = nan;
    if (!contact_speeds.empty()) {
      std::vector<double> sorted = contact_speeds;
      std::sort(sorted.begin(), sorted.end());
      double sum = 0.0;
      for (double v : sorted) sum += v;
      c.mean_contact_speed_mps = sum / static_cast<double>(sorted.size());
      const size_t rank = static_cast<size_t>(std::ceil(0.95 * static_cast<double>(sorted.size())));
      c.p95_contact_speed_mps = sorted[std::max<size_t>(rank, 1) - 1];
    }
    return c;
  }
};

}  // namespace

EvalSummary summarize(const std::vector<EpisodeRecord>& records, const std::string& reference) {
  EvalSummary s;
  s.reference = reference;
  for (const EpisodeRecord& r : records) {
    if (std::find(s.methods.begin(), s.methods.end(), r.method) == s.methods.end()) s.methods.push_back(r.method);
    if (std::find(s.obstacle_counts.begin(), s.obstacle_counts.end(), r.obstacles) == s.obstacle_counts.end()) {
      s.obstacle_counts.push_back(r.obstacles);
    }
  }
  std::sort(s.obstacle_counts.begin(), s.obstacle_counts.end());
  if (std::find(s.methods.begin(), s.methods.end(), reference) == s.methods.end()) {
    std::string list;
    for (const std::string& m : s.methods) list += (list.empty() ? "" : ", ") + m;
    throw EvalError("summary: reference method '" + reference + "' has no records (methods: " + list + ")");
  }
  std::map<std::pair<int, int>, const EpisodeRecord*> ref;
  for (const EpisodeRecord& r : records) {
    if (r.method != reference) continue;
    if (!ref.emplace(std::make_pair(r.obstacles, r.episode), &r).second) {
      throw EvalError("summary: method '" + reference + "' has two records for " + std::to_string(r.obstacles) +
                      " obstacles, episode " + std::to_string(r.episode));
    }
  }
  const size_t nm = s.methods.size(), nc = s.obstacle_counts.size();
  std::vector<std::vector<Accumulator>> acc(nm, std::vector<Accumulator>(nc));
  std::vector<Accumulator> all(nm);
  for (const EpisodeRecord& r : records) {
    const size_t m = static_cast<size_t>(std::find(s.methods.begin(), s.methods.end(), r.method) - s.methods.begin());
    const size_t c = static_cast<size_t>(std::find(s.obstacle_counts.begin(), s.obstacle_counts.end(), r.obstacles) -
                                         s.obstacle_counts.begin());
    const auto it = ref.find({r.obstacles, r.episode});
    const EpisodeRecord* rr = it == ref.end() ? nullptr : it->second;
    acc[m][c].add(r, rr);
    all[m].add(r, rr);
  }
  s.cells.assign(nm, std::vector<EvalCell>(nc));
  s.overall.assign(nm, EvalCell{});
  for (size_t m = 0; m < nm; ++m) {
    double succ = 0.0, coll = 0.0, tout = 0.0;
    for (size_t c = 0; c < nc; ++c) {
      s.cells[m][c] = acc[m][c].cell();
      succ += s.cells[m][c].success_rate;
      coll += s.cells[m][c].collision_rate;
      tout += s.cells[m][c].timeout_rate;
    }
    s.overall[m] = all[m].cell();
    if (nc > 0) {
      s.overall[m].success_rate = succ / nc;
      s.overall[m].collision_rate = coll / nc;
      s.overall[m].timeout_rate = tout / nc;
    }
  }
  return s;
}

namespace {

std::ofstream openOut(const std::string& path) {
  std::ofstream out(path, std::ios::trunc);
  if (!out) throw EvalError("cannot open '" + path + "' for writing");
  out << std::setprecision(6);
  return out;
}

void closeOut(std::ofstream& out, const std::string& path) {
  out.close();
  if (!out) throw EvalError("cannot write '" + path + "'");
}

std::string fixed(double x, int digits) {
  if (!std::isfinite(x)) return "-";
  std::ostringstream os;
  os << std::fixed << std::setprecision(digits) << x;
  return os.str();
}

}  // namespace

void writeResultsCsv(const std::vector<EpisodeRecord>& records, const std::string& path) {
  std::ofstream out = openOut(path);
  out << "method,obstacles,episode,scenario,outcome,time_s,path_length_m,min_clearance_m,danger_steps,steps,"
         "planner_errors,collision_kind,contact_speed_mps,last_decision\n";
  for (const EpisodeRecord& r : records) {
    out << r.method << ',' << r.obstacles << ',' << r.episode << ',' << r.scenario << ',' << outcomeName(r.outcome)
        << ',' << r.time_s << ',' << r.path_length_m << ',' << r.min_clearance_m << ',' << r.danger_steps << ','
        << r.steps << ',' << r.planner_errors << ',' << collisionKindName(r.collision_kind) << ',';
    if (std::isfinite(r.contact_speed_mps)) out << r.contact_speed_mps;
    // The note is free text: commas become semicolons and quotes and line breaks spaces, so the row stays plain.
    std::string note = r.last_decision;
    for (char& ch : note) {
      if (ch == ',')
        ch = ';';
      else if (ch == '"' || ch == '\n' || ch == '\r')
        ch = ' ';
    }
    out << ',' << note << '\n';
  }
  closeOut(out, path);
}

void writeSummaryMarkdown(const EvalSummary& summary, const std::string& path, const std::string& header) {
  std::ofstream out = openOut(path);
  out << "# Evaluation summary\n\n";
  if (!header.empty()) out << header << "\n\n";
  auto table = [&](const std::string& title, const std::string& note, auto value) {
    out << "## " << title << "\n\n" << note << "\n\n| Obs |";
    for (const std::string& m : summary.methods) out << ' ' << m << " |";
    out << "\n|---|";
    for (size_t m = 0; m < summary.methods.size(); ++m) out << "---|";
    out << '\n';
    for (size_t c = 0; c < summary.obstacle_counts.size(); ++c) {
      out << "| " << summary.obstacle_counts[c] << " |";
      for (size_t m = 0; m < summary.methods.size(); ++m) out << ' ' << value(summary.cells[m][c], m) << " |";
      out << '\n';
    }
    out << "| mean |";
    for (size_t m = 0; m < summary.methods.size(); ++m) out << ' ' << value(summary.overall[m], m) << " |";
    out << "\n\n";
  };
  const size_t ref = static_cast<size_t>(std::find(summary.methods.begin(), summary.methods.end(), summary.reference) -
                                         summary.methods.begin());
  table("Success rate",
        "Reached the goal and stopped on it. In brackets: total time of the method over total time of `" +
            summary.reference + "` on the episodes both solved.",
        [&](const EvalCell& c, size_t m) {
          std::string s = fixed(c.success_rate, 2);
          if (m != ref) s += " (" + fixed(c.time_ratio, 2) + ")";
          return s;
        });
  table("Collision rate", "Episodes ending in contact with an obstacle or a wall.",
        [](const EvalCell& c, size_t) { return fixed(c.collision_rate, 2); });
  table("Collisions by kind",
        "Counts: static geometry (walls, static obstacles; must be 0) / robot at rest (below " +
            fixed(kRestSpeedMps, 2) + " m/s: walked into) / robot moving.",
        [](const EvalCell& c, size_t) {
          return std::to_string(c.static_collisions) + " / " + std::to_string(c.rest_collisions) + " / " +
                 std::to_string(c.moving_collisions);
        });
  table("Robot speed at contact (m/s)", "Mean over the collisions, 95th percentile in brackets.",
        [](const EvalCell& c, size_t) {
          return fixed(c.mean_contact_speed_mps, 3) + " (" + fixed(c.p95_contact_speed_mps, 3) + ")";
        });
  table("Timeout rate", "Episodes still running after the step limit.",
        [](const EvalCell& c, size_t) { return fixed(c.timeout_rate, 2); });
  table("Mean time on success (s)", "Over each method's own successful episodes.",
        [](const EvalCell& c, size_t) { return fixed(c.mean_time_success_s, 1); });
  table("Danger frequency", "Fraction of steps ending closer than the reward's safe distance to anything.",
        [](const EvalCell& c, size_t) { return fixed(c.danger_frequency, 3); });
  closeOut(out, path);
}

std::vector<std::pair<std::string, double>> summaryFigures(const EvalSummary& summary) {
  std::vector<std::pair<std::string, double>> f;
  const bool prefix = summary.methods.size() > 1;
  for (size_t m = 0; m < summary.methods.size(); ++m) {
    const std::string p = prefix ? summary.methods[m] + "." : "";
    const EvalCell& o = summary.overall[m];
    f.emplace_back(p + "success_mean", o.success_rate);
    f.emplace_back(p + "collision_mean", o.collision_rate);
    f.emplace_back(p + "timeout_mean", o.timeout_rate);
    if (summary.methods[m] != summary.reference) f.emplace_back(p + "time_ratio_mean", o.time_ratio);
    f.emplace_back(p + "mean_time_success_s", o.mean_time_success_s);
    f.emplace_back(p + "danger_frequency", o.danger_frequency);
    f.emplace_back(p + "episodes", o.episodes);
    f.emplace_back(p + "collisions", o.collisions);
    f.emplace_back(p + "collisions_static", o.static_collisions);
    f.emplace_back(p + "collisions_rest", o.rest_collisions);
    f.emplace_back(p + "collisions_moving", o.moving_collisions);
    f.emplace_back(p + "contact_speed_mean", o.mean_contact_speed_mps);
    f.emplace_back(p + "contact_speed_p95", o.p95_contact_speed_mps);
    for (size_t c = 0; c < summary.obstacle_counts.size(); ++c) {
      f.emplace_back(p + "success_" + std::to_string(summary.obstacle_counts[c]), summary.cells[m][c].success_rate);
    }
  }
  return f;
}

void writeSummaryJson(const EvalSummary& summary, const std::string& path) {
  std::ofstream out = openOut(path);
  out << std::setprecision(10) << "{";
  bool first = true;
  for (const auto& [key, value] : summaryFigures(summary)) {
    if (!std::isfinite(value)) continue;
    out << (first ? "\n  \"" : ",\n  \"") << key << "\": " << value;
    first = false;
  }
  out << "\n}\n";
  closeOut(out, path);
}

}  // namespace dqn_dovs
