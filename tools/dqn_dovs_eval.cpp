// Evaluation CLI (DESIGN §11): runs planners over the fixed or generated scenarios, 1..15 obstacles, writes the
// records (results.csv, run.json, paths.json) into --out, then hands them to the Python reporter
// (python -m dqn_dovs_py.report: summary.md in the paper's layout, summary.json, plots, the table on stdout).
// Run with --help for the flags.
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "dqn_dovs/evaluation/eval.h"
#include "dqn_dovs/planning/planner.h"
#include "dqn_dovs/sim/lidar.h"
#include "dqn_dovs/sim/people.h"
#include "dqn_dovs/sim/world.h"
#include "dqn_dovs/sim/worlds.h"

namespace {

using dqn_dovs::EvalConfig;

const char* kUsage =
    "usage: dqn_dovs_eval [--methods M1,M2,...] [--scenarios DIR | --generate SEED] [--obstacles A-B]\n"
    "                     [--episodes K] [--dynamic-fraction F] [--perfect-info | --track-truth WHAT]\n"
    "                     [--predict-people F] [--tracker-map] [--dovs-map] [--sensor-warmup S]\n"
    "                     [--threads N] [--out DIR]\n"
    "                     [--model PATH] [--shield NAME=VALUE,...] [--reference METHOD] [--trajectories N]\n"
    "                     [--dovs NAME=VALUE,...] [--tracker NAME=VALUE,...] [--oracle NAME=VALUE,...]\n"
    "                     [--oracle-retries none|N=V,...;N=V,...] [--bound NAME=VALUE,...]\n"
    "                     [--world FAMILY] [--sensor PROFILE] [--people-model MODEL] [--people-see-robot]\n"
    "                     [--people-mix MIX]\n"
    "                     [--odom-noise LEVEL] [--route on|off] [--start-clear S]\n"
    "                     [--no-report] [--write-scenarios DIR]\n"
    "  --methods           planners to evaluate, comma-separated (default s_dovs); oracle: the physical limit\n"
    "                      from below, a search that reads the simulator's future (not deployable); bound: the\n"
    "                      limit from above, where no robot within the limits can get (success: the goal may\n"
    "                      be reachable, at the earliest at time_s; collision: unavoidable; timeout: out of\n"
    "                      reach in time); the bound refuses people who see the robot (their future is not\n"
    "                      fixed by the seed then)\n"
    "  --scenarios DIR     folder laid out as 1-N/K.dovs (default data/scenarios/room: the package's own set, drawn\n"
    "                      by this generator; data/scenarios/README.md). An external set such as the authors'\n"
    "                      RUMOR test scenarios is named here (docs/external_benchmark.md)\n"
    "  --generate SEED     seeded random scenarios instead of a folder\n"
    "  --obstacles A-B     obstacle counts A..B, or a single count (default 1-15)\n"
    "  --episodes K        episodes 1..K per obstacle count (default 100)\n"
    "  --dynamic-fraction  fraction of moving obstacles in [0, 1] (default 0.85)\n"
    "  --perfect-info      planners see the simulator's ground truth instead of the tracker's output\n"
    "  --sensor-warmup S   the robot senses S s standing still before each episode starts, while everything\n"
    "                      else moves (default 0.3; tracks are then 0.3 s old at the start)\n"
    "  --track-truth WHAT  diagnostic of what the tracker costs: each track within 0.5 m of a true body takes\n"
    "                      its true motion (motion: speed, heading, turn rate) or its whole true state (state);\n"
    "                      false tracks stay, untracked bodies stay unseen (default none)\n"
    "  --predict-people F  the people the planners see move on the arc that fits a learned prediction (a\n"
    "                      people predictor file; only people, never the room's discs). Default auto: as the\n"
    "                      launch files do, models/people_predictor_tracks.dqnp in worlds with people (every\n"
    "                      --world but room; with --perfect-info models/people_predictor.dqnp, learned from\n"
    "                      true paths), none in the room; none: their present velocity everywhere\n"
    "  --tracker-map       the tracker is given the map a robot would have (walls and furniture, not people)\n"
    "                      placed by a perfect localisation; what lies on it is never tracked\n"
    "  --dovs-map          the velocity space also takes that map's walls and furniture outlines within 4 m\n"
    "                      (dovs_node use_map); both flags: a robot localised on its map\n"
    "  --threads N         worker threads (default 1); results do not depend on it\n"
    "  --out DIR           output folder (default eval_results)\n"
    "  --model PATH        weight file of dqn_dovs (default models/dqn_dovs.dqnw)\n"
    "  --shield N=V,...    action shield parameters of the dqn_dovs methods, named as in config/dovs.yaml\n"
    "                      action_shield/* and config/static_safety.yaml (static_safety/margin=0.1, ...)\n"
    "  --dovs N=V,...      the DOVS model of every planner, named as in config/dovs.yaml dovs/* (time_horizon=3,\n"
    "                      prediction_growth=0.2, ...)\n"
    "  --tracker N=V,...   the obstacle tracker, named as in config/tracker.yaml tracker/* (person_radius=0.3,\n"
    "                      ...); applied after --sensor and --world, which set range_noise and pair_legs\n"
    "  --oracle N=V,...    the oracle's search: horizon_periods (20), beam_width (160), window_samples (2),\n"
    "                      grid_cell_m (0.1), clearance_margin_m (0.02); as a diagnostic, true_future_periods\n"
    "                      (-1: all; K: K periods of the true future, then constant velocity), social_prediction\n"
    "                      (0/1: people by the social force model instead), prediction_growth_mps (0),\n"
    "                      acceleration_prediction_s (0), learned_prediction (a people predictor file,\n"
    "                      models/people_predictor.dqnp; with true_future_periods=0), terminal_periods (0:\n"
    "                      a sequence's end must have a way on for this many periods more)\n"
    "  --oracle-retries R  the oracle's further searches, each a whole episode of its own, on an episode its\n"
    "                      first search does not solve, until one does: none, or ;-separated N=V,... lists\n"
    "                      applied to --oracle's (default 'terminal_periods=10;horizon_periods=30,beam_width=320;\n"
    "                      horizon_periods=30,beam_width=320,terminal_periods=10'); only where it reads\n"
    "                      the whole future (no true_future_periods)\n"
    "  --bound N=V,...     the bound's grid: cell_m (0.01; each period adds a cell diagonal to the robot's reach),\n"
    "                      body_margin_m (0.02: bodies shrunk by it), grid_margin_m (1: the grid around the walls)\n"
    "  --reference METHOD  method of the time ratios (default dqn_dovs when evaluated, else the first method)\n"
    "  --trajectories N    episodes drawn as trajectories_*.png per method (default 3)\n"
    "  --world FAMILY      generated worlds: room (the paper's discs, default), crowd, corridor, doorway,\n"
    "                      clutter, junction (N = people; needs --generate)\n"
    "  --sensor PROFILE    LIDAR profile: sim (default), hokuyo, urg04lx, rplidar_a1\n"
    "  --people-model M    how people move: social_force (default), orca or constant\n"
    "  --people-see-robot  every person attentive (--people-mix attentive=1; default: the robot is invisible to them)\n"
    "  --people-mix MIX    how people treat the robot, each drawing a behaviour at spawn: shares of attentive\n"
    "                      (notices it ahead after a reaction delay, then gives way), impassive (walks around it,\n"
    "                      never slower for it) and oblivious (does not see it), e.g.\n"
    "                      attentive=0.6,impassive=0.2,oblivious=0.2, or 'headline' (the benchmark's main mix,\n"
    "                      attentive=0.7,impassive=0.2,oblivious=0.1; default oblivious=1; docs/simulator.md)\n"
    "  --odom-noise LEVEL  wheel-odometry drift: none (default), low, high; the robot plans in its odom frame\n"
    "  --route on|off      on (default): in worlds with walls (not the room) the robot follows a route on the\n"
    "                      known walls and furniture, as planner_node does; off: it drives at the goal itself\n"
    "  --start-clear S     --generate, room: no moving obstacle reaches the robot's start on its own arc in the\n"
    "                      first S s (default 0: the paper's distribution); the demo's episodes use 3\n"
    "  --write-scenarios DIR  write the episodes as DIR/1-N/K.dovs (the format of --scenarios) and stop; with\n"
    "                      --generate, the room family only (use --dynamic-fraction 1: files keep every obstacle\n"
    "                      moving, and --dynamic-fraction makes the last ones static when they are read)\n"
    "  --no-report         write the records only (results.csv, run.json, paths.json), not the summaries\n"
    "The summaries and plots come from the Python reporter, python -m dqn_dovs_py.report OUT (interpreter\n"
    "$DQN_DOVS_PYTHON, package folder $DQN_DOVS_PYTHON_DIR; defaults: the build's venv and source tree).\n";

/// A bad command line: the message names the flag.
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

long parseInt(const std::string& flag, const std::string& text, long lo, long hi) {
  size_t used = 0;
  long v = 0;
  try {
    v = std::stol(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != text.size() || text.empty()) throw UsageError(flag + " expects an integer, got '" + text + "'");
  if (v < lo || v > hi) {
    throw UsageError(flag + " = " + text + " is out of range [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
  }
  return v;
}

double parseDouble(const std::string& flag, const std::string& text, double lo, double hi) {
  size_t used = 0;
  double v = 0.0;
  try {
    v = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != text.size() || text.empty() || !(v >= lo && v <= hi)) {
    std::ostringstream os;
    os << flag << " expects a number in [" << lo << ", " << hi << "], got '" << text << "'";
    throw UsageError(os.str());
  }
  return v;
}

/// Throws a UsageError naming the flag, the value and the accepted names unless `value` is one of them.
void checkName(const std::string& flag, const std::string& value, const std::vector<std::string>& names) {
  if (std::find(names.begin(), names.end(), value) != names.end()) return;
  std::string list;
  for (const std::string& n : names) list += (list.empty() ? "" : ", ") + n;
  throw UsageError(flag + ": '" + value + "' is not one of " + list);
}

std::vector<std::string> splitList(const std::string& flag, const std::string& text) {
  std::vector<std::string> out;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    if (item.empty()) throw UsageError(flag + " has an empty entry in '" + text + "'");
    out.push_back(item);
  }
  if (out.empty()) throw UsageError(flag + " needs at least one method");
  return out;
}

/// NAME=VALUE,... of `flag`, each given to `set` (which returns why it refuses a pair, "" when it takes it).
template <typename Set>
void setNamedValues(const std::string& flag, const std::string& text, Set set) {
  for (const std::string& kv : splitList(flag, text)) {
    const size_t eq = kv.find('=');
    if (eq == std::string::npos) throw UsageError(flag + ": '" + kv + "' is not NAME=VALUE");
    if (const std::string e = set(kv.substr(0, eq), kv.substr(eq + 1)); !e.empty()) throw UsageError(flag + ": " + e);
  }
}

/// The people predictor file of --predict-people: `auto` is what the launch files give dovs_node (the package's
/// predictor learned from tracks wherever legs are paired into people, i.e. every world but the paper's room), or
/// with perfect information the one learned from true paths, what it then reads; `none` nothing. A missing default
/// file is named with the way to run without it.
std::string resolvePeoplePredictor(const std::string& choice, const std::string& world, bool perfect_info) {
  if (choice == "none") return "";
  if (choice != "auto") return choice;
  if (world == "room") return "";
  const std::string file = perfect_info ? dqn_dovs::kTruePathPeoplePredictor : dqn_dovs::kDefaultPeoplePredictor;
  if (!std::filesystem::is_regular_file(file)) {
    throw UsageError("--predict-people auto: the default people predictor '" + file + "' is not there " +
                     "(run from the package's root, name a file, or pass --predict-people none)");
  }
  return file;
}

struct Options {
  EvalConfig eval;
  std::string out_dir = "eval_results";
  std::string write_scenarios;  ///< --write-scenarios DIR: write the episodes' scenario files there and stop
  std::string reference;
  std::string predict_people = "auto";  ///< a file, auto or none (resolved after the world options)
  int trajectories = 3;
  bool help = false;
  bool report = true;
};

Options parse(int argc, char** argv) {
  Options o;
  o.eval.scenarios_dir = dqn_dovs::sim::kDefaultScenariosDir;
  bool have_scenarios = false, have_generate = false;
  std::vector<std::string> tracker_overrides;
  for (int i = 1; i < argc; ++i) {
    const std::string flag = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw UsageError(flag + " needs a value");
      return argv[++i];
    };
    if (flag == "--help" || flag == "-h") {
      o.help = true;
    } else if (flag == "--methods") {
      o.eval.methods = splitList(flag, value());
      const std::vector<std::string> known = dqn_dovs::evalMethodNames();
      for (const std::string& m : o.eval.methods) {
        if (std::find(known.begin(), known.end(), m) == known.end()) {
          std::string list;
          for (const std::string& k : known) list += (list.empty() ? "" : ", ") + k;
          throw UsageError("--methods: unknown method '" + m + "' (known: " + list + ")");
        }
      }
    } else if (flag == "--scenarios") {
      o.eval.scenarios_dir = value();
      have_scenarios = true;
    } else if (flag == "--generate") {
      o.eval.seed = static_cast<uint64_t>(parseInt(flag, value(), 0, 0x7FFFFFFFL));
      have_generate = true;
    } else if (flag == "--obstacles") {
      const std::string v = value();
      const size_t dash = v.find('-');
      if (dash == std::string::npos) {
        o.eval.obstacles_min = o.eval.obstacles_max = static_cast<int>(parseInt(flag, v, 0, 100));
      } else {
        o.eval.obstacles_min = static_cast<int>(parseInt(flag, v.substr(0, dash), 0, 100));
        o.eval.obstacles_max = static_cast<int>(parseInt(flag, v.substr(dash + 1), 0, 100));
        if (o.eval.obstacles_max < o.eval.obstacles_min) throw UsageError("--obstacles range '" + v + "' is empty");
      }
    } else if (flag == "--episodes") {
      o.eval.episodes = static_cast<int>(parseInt(flag, value(), 1, 100000));
    } else if (flag == "--dynamic-fraction") {
      o.eval.dynamic_fraction = parseDouble(flag, value(), 0.0, 1.0);
    } else if (flag == "--perfect-info") {
      o.eval.episode.perfect_info = true;
    } else if (flag == "--sensor-warmup") {
      o.eval.episode.sensor_warmup_s = parseDouble(flag, value(), 0.0, 5.0);
    } else if (flag == "--track-truth") {
      const std::string what = value();
      try {
        o.eval.episode.track_truth = dqn_dovs::parseTrackTruth(what);
      } catch (const std::invalid_argument& e) {
        throw UsageError(std::string("--track-truth: ") + e.what());
      }
    } else if (flag == "--predict-people") {
      o.predict_people = value();
      if (o.predict_people.empty()) throw UsageError("--predict-people needs a file, auto or none");
    } else if (flag == "--tracker-map") {
      o.eval.episode.tracker_map = true;
    } else if (flag == "--dovs-map") {
      o.eval.episode.dovs_map = true;
    } else if (flag == "--threads") {
      o.eval.threads = static_cast<int>(parseInt(flag, value(), 1, 256));
    } else if (flag == "--out") {
      o.out_dir = value();
      if (o.out_dir.empty()) throw UsageError("--out needs a non-empty folder");
    } else if (flag == "--model") {
      o.eval.model_path = value();
    } else if (flag == "--shield") {
      setNamedValues(flag, value(), [&](const std::string& n, const std::string& v) {
        return dqn_dovs::setShieldParameter(o.eval.shield, n, v);
      });
      if (const std::string e = o.eval.shield.validate(); !e.empty()) throw UsageError("--shield: " + e);
    } else if (flag == "--dovs") {
      setNamedValues(flag, value(), [&](const std::string& n, const std::string& v) {
        return dqn_dovs::setDovsParameter(o.eval.episode.dovs, n, v);
      });
      if (const std::string e = o.eval.episode.dovs.validate(); !e.empty()) throw UsageError("--dovs: " + e);
    } else if (flag == "--tracker") {
      tracker_overrides.push_back(value());  // applied after the world options, which set some tracker fields
    } else if (flag == "--oracle") {
      setNamedValues(flag, value(), [&](const std::string& n, const std::string& v) {
        return dqn_dovs::setOracleParameter(o.eval.oracle, n, v);
      });
      if (const std::string e = o.eval.oracle.validate(); !e.empty()) throw UsageError("--oracle: " + e);
    } else if (flag == "--oracle-retries") {
      const std::string v = value();
      o.eval.oracle_retries.clear();
      if (v != "none") {
        size_t begin = 0;
        while (begin <= v.size()) {
          const size_t end = std::min(v.find(';', begin), v.size());
          o.eval.oracle_retries.push_back(v.substr(begin, end - begin));
          begin = end + 1;
        }
      }
    } else if (flag == "--bound") {
      setNamedValues(flag, value(), [&](const std::string& n, const std::string& v) {
        return dqn_dovs::setReachBoundParameter(o.eval.bound, n, v);
      });
      if (const std::string e = o.eval.bound.validate(); !e.empty()) throw UsageError("--bound: " + e);
    } else if (flag == "--reference") {
      o.reference = value();
    } else if (flag == "--world") {
      o.eval.world = value();
      checkName(flag, o.eval.world, dqn_dovs::sim::worldFamilyNames());
    } else if (flag == "--sensor") {
      o.eval.sensor = value();
      checkName(flag, o.eval.sensor, dqn_dovs::sim::LidarConfig::profileNames());
    } else if (flag == "--people-model") {
      o.eval.people_model = value();
      checkName(flag, o.eval.people_model, dqn_dovs::sim::peopleModelNames());
    } else if (flag == "--odom-noise") {
      o.eval.odom_noise = value();
      checkName(flag, o.eval.odom_noise, dqn_dovs::sim::OdometryConfig::levelNames());
    } else if (flag == "--route") {
      o.eval.route = value();
      checkName(flag, o.eval.route, {"on", "off"});
    } else if (flag == "--people-mix") {
      o.eval.people_mix = value();
      try {
        dqn_dovs::sim::PeopleMix::parse(o.eval.people_mix);
      } catch (const dqn_dovs::sim::SimError& e) {
        throw UsageError(std::string("--people-mix: ") + e.what());
      }
    } else if (flag == "--people-see-robot") {
      o.eval.people_see_robot = true;
    } else if (flag == "--start-clear") {
      o.eval.generated_start_clear_s = parseDouble(flag, value(), 0.0, 60.0);
    } else if (flag == "--write-scenarios") {
      o.write_scenarios = value();
      if (o.write_scenarios.empty()) throw UsageError("--write-scenarios needs a non-empty folder");
    } else if (flag == "--no-report") {
      o.report = false;
    } else if (flag == "--trajectories") {
      o.trajectories = static_cast<int>(parseInt(flag, value(), 0, 1000));
    } else {
      throw UsageError("unknown flag '" + flag + "'");
    }
  }
  if (have_scenarios && have_generate) throw UsageError("--scenarios and --generate exclude each other");
  if (o.eval.episode.perfect_info && o.eval.episode.track_truth != dqn_dovs::TrackTruth::kNone)
    throw UsageError("--track-truth corrects the tracker's tracks; with --perfect-info there is no tracker");
  if (have_generate) o.eval.scenarios_dir.clear();
  if (o.eval.generated_start_clear_s > 0.0 && (!have_generate || o.eval.world != "room"))
    throw UsageError("--start-clear applies to generated room scenarios: it needs --generate SEED and --world room");
  if (!o.write_scenarios.empty() && o.eval.world != "room")
    throw UsageError("--write-scenarios writes .dovs files, which hold the room's discs only (--world room)");
  if (o.eval.world != "room" && !have_generate) throw UsageError("--world " + o.eval.world + " needs --generate SEED");
  dqn_dovs::applyWorldOptions(o.eval);
  o.eval.episode.people_predictor = resolvePeoplePredictor(o.predict_people, o.eval.world, o.eval.episode.perfect_info);
  for (const std::string& text : tracker_overrides) {
    setNamedValues("--tracker", text, [&](const std::string& n, const std::string& v) {
      return dqn_dovs::setTrackerParameter(o.eval.episode.tracker, n, v);
    });
  }
  if (const std::string e = o.eval.episode.tracker.validate(); !e.empty()) throw UsageError("--tracker: " + e);
  std::vector<dqn_dovs::OracleConfig> retries;  // each applies to the first search's parameters
  if (const std::string e = dqn_dovs::oracleRetrySearches(o.eval.oracle, o.eval.oracle_retries, retries); !e.empty())
    throw UsageError("--oracle-retries: " + e);
  if (o.reference.empty()) {
    const auto& m = o.eval.methods;
    o.reference = std::find(m.begin(), m.end(), "dqn_dovs") != m.end() ? "dqn_dovs" : m.front();
  } else if (std::find(o.eval.methods.begin(), o.eval.methods.end(), o.reference) == o.eval.methods.end()) {
    throw UsageError("--reference '" + o.reference + "' is not one of --methods");
  }
  if (!o.help && !o.eval.scenarios_dir.empty() && !std::filesystem::is_directory(o.eval.scenarios_dir)) {
    throw UsageError("--scenarios: '" + o.eval.scenarios_dir + "' is not a folder" +
                     (have_scenarios ? "" : " (the default, relative to the package's root: run from there)"));
  }
  return o;
}

/// The (obstacle count, episode) pairs drawn as trajectories: counts spread over the range, episode 1 first.
std::vector<std::pair<int, int>> trajectoryJobs(const EvalConfig& c, int n) {
  std::vector<std::pair<int, int>> out;
  const int counts = c.obstacles_max - c.obstacles_min + 1;
  for (int i = 0; i < n && i < counts * c.episodes; ++i) {
    const int round = i / counts, slot = i % counts;
    const int per_round = std::min(n - round * counts, counts);
    const int count =
        per_round <= 1 ? c.obstacles_min + (counts - 1) / 2
                       : c.obstacles_min +
                             static_cast<int>(std::lround(static_cast<double>(slot) * (counts - 1) / (per_round - 1)));
    out.emplace_back(count, 1 + round);
  }
  return out;
}

std::string commandLine(int argc, char** argv) {
  std::string s;
  for (int i = 0; i < argc; ++i) s += (i ? " " : "") + std::string(argv[i]);
  return s;
}

const char* envOr(const char* name, const char* fallback) {
  const char* v = std::getenv(name);
  return v != nullptr && *v != '\0' ? v : fallback;
}

/// Runs python -m dqn_dovs_py.report OUT_DIR (its table goes to stdout); returns its exit status, or 1 with the
/// reason when it cannot run.
int runReporter(const std::string& out_dir) {
  const std::string python = envOr("DQN_DOVS_PYTHON", DQN_DOVS_REPORT_PYTHON);
  const std::string package_dir = envOr("DQN_DOVS_PYTHON_DIR", DQN_DOVS_REPORT_PYTHON_DIR);
  std::cout.flush();
  const pid_t pid = fork();
  if (pid < 0) {
    std::cerr << "dqn_dovs_eval: cannot start the reporter: fork failed\n";
    return 1;
  }
  if (pid == 0) {
    const char* old = std::getenv("PYTHONPATH");
    const std::string path = package_dir + (old != nullptr && *old != '\0' ? ":" + std::string(old) : "");
    setenv("PYTHONPATH", path.c_str(), 1);
    setenv("MPLBACKEND", "Agg", 0);
    execlp(python.c_str(), python.c_str(), "-m", "dqn_dovs_py.report", out_dir.c_str(), static_cast<char*>(nullptr));
    std::cerr << "dqn_dovs_eval: cannot run the reporter '" << python
              << " -m dqn_dovs_py.report': " << std::strerror(errno) << " (set DQN_DOVS_PYTHON, or pass --no-report)\n";
    _exit(127);
  }
  int status = 0;
  if (waitpid(pid, &status, 0) < 0) {
    std::cerr << "dqn_dovs_eval: lost the reporter: " << std::strerror(errno) << "\n";
    return 1;
  }
  if (WIFEXITED(status) && WEXITSTATUS(status) == 0) return 0;
  std::cerr << "dqn_dovs_eval: the reporter failed (" << python << " -m dqn_dovs_py.report " << out_dir
            << "); the records are in " << out_dir << "\n";
  return 1;
}

/// --write-scenarios: every episode's scenario as DIR/1-N/K.dovs; returns the exit status.
int writeScenarios(const Options& o) {
  namespace fs = std::filesystem;
  const std::vector<dqn_dovs::EvalScenario> scenarios = dqn_dovs::loadEvalScenarios(o.eval);
  for (const dqn_dovs::EvalScenario& s : scenarios) {
    const fs::path dir = fs::path(o.write_scenarios) / ("1-" + std::to_string(s.obstacles));
    std::error_code ec;
    fs::create_directories(dir, ec);
    if (ec || !fs::is_directory(dir)) {
      std::cerr << "dqn_dovs_eval: --write-scenarios: cannot create folder '" << dir.string() << "': " << ec.message()
                << "\n";
      return 1;
    }
    dqn_dovs::sim::saveDovsScenario(s.scenario, (dir / (std::to_string(s.episode) + ".dovs")).string());
  }
  std::cerr << "dqn_dovs_eval: wrote " << scenarios.size() << " scenario files into " << o.write_scenarios << "\n";
  return 0;
}

int run(const Options& o, const std::string& command) {
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::create_directories(o.out_dir, ec);
  if (ec || !fs::is_directory(o.out_dir)) {
    std::cerr << "dqn_dovs_eval: --out: cannot create folder '" << o.out_dir << "': " << ec.message() << "\n";
    return 1;
  }
  EvalConfig config = o.eval;
  config.keep_paths = trajectoryJobs(config, o.trajectories);
  const std::vector<dqn_dovs::EvalScenario> scenarios = dqn_dovs::loadEvalScenarios(config);

  const auto t0 = std::chrono::steady_clock::now();
  std::map<std::string, std::pair<int, int>> running;  // method -> (successes, episodes)
  const size_t total = scenarios.size() * config.methods.size();
  const size_t every = std::max<size_t>(1, total / 40);
  std::cerr << "dqn_dovs_eval: " << total << " episodes (" << config.methods.size() << " method(s) x "
            << scenarios.size() << " scenarios), "
            << (config.episode.perfect_info ? "perfect information" : "tracker in the loop") << ", " << config.threads
            << " thread(s)\n";
  auto progress = [&](const dqn_dovs::EpisodeRecord& r, size_t done, size_t all) {
    auto& [succ, eps] = running[r.method];
    succ += r.outcome == dqn_dovs::Outcome::kSuccess ? 1 : 0;
    ++eps;
    if (done % every != 0 && done != all) return;
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::cerr << "  [" << std::setw(6) << done << "/" << all << "] " << std::fixed << std::setprecision(0) << elapsed
              << " s  success so far:";
    for (const std::string& m : config.methods) {
      const auto it = running.find(m);
      if (it == running.end() || it->second.second == 0) continue;
      std::cerr << " " << m << " " << std::setprecision(3) << static_cast<double>(it->second.first) / it->second.second;
    }
    std::cerr << "\n";
  };
  const std::vector<dqn_dovs::EpisodeRecord> records = dqn_dovs::runEvaluation(config, scenarios, progress);
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  const std::string out = o.out_dir + "/";
  dqn_dovs::writeResultsCsv(records, out + "results.csv");
  dqn_dovs::writeRunJson(config, {command, wall_s, o.reference}, out + "run.json");
  const std::string paths = out + "paths.json";
  std::filesystem::remove(paths, ec);
  if (std::any_of(records.begin(), records.end(), [](const auto& r) { return !r.robot_path.empty(); })) {
    dqn_dovs::writePathsJson(records, scenarios, config.episode.reward.goal_tolerance_m, paths);
  }
  std::cerr << "dqn_dovs_eval: wrote " << out << "{results.csv,run.json" << (fs::exists(paths) ? ",paths.json" : "")
            << "} in " << std::fixed << std::setprecision(1) << wall_s << " s\n";
  return o.report ? runReporter(o.out_dir) : 0;
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  try {
    options = parse(argc, argv);
  } catch (const UsageError& e) {
    std::cerr << "dqn_dovs_eval: " << e.what() << "\n" << kUsage;
    return 2;
  }
  if (options.help) {
    std::cout << kUsage;
    return 0;
  }
  try {
    if (!options.write_scenarios.empty()) return writeScenarios(options);
    return run(options, commandLine(argc, argv));
  } catch (const std::exception& e) {
    std::cerr << "dqn_dovs_eval: " << e.what() << "\n";
    return 1;
  }
}
