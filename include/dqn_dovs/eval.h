// The benchmark runner of DESIGN §11: the same episodes for every method, for each obstacle count, run across a
// thread pool with deterministic results; per-episode records, the paper-layout summary and its files.
// ROS-free (plots are in eval_plots.h).
#pragma once

#include <cstdint>
#include <functional>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "dqn_dovs/action_shield.h"
#include "dqn_dovs/episode.h"
#include "dqn_dovs/sim/scenario.h"

namespace dqn_dovs {

/// Bad evaluation configuration, unreadable scenario folder, failed episode or unwritable output; the message
/// names the item (flag, file, job) and the reason.
class EvalError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// What to evaluate and how. Defaults live here only.
struct EvalConfig {
  /// Planner names (makePlanner), in the order of the tables.
  std::vector<std::string> methods = {"s_dovs"};
  /// Folder laid out like scenarios/rumor (`1-N/K.dovs`); empty: scenarios come from the seeded generator.
  std::string scenarios_dir;
  /// Seed of the generator (ignored with scenarios_dir); also mixed into every episode's sensor-noise seed.
  uint64_t seed = 0;
  /// Obstacle counts obstacles_min..obstacles_max, each evaluated on episodes 1..episodes.
  int obstacles_min = 1;
  /// See obstacles_min.
  int obstacles_max = 15;
  /// Episodes per obstacle count.
  int episodes = 100;
  /// Fraction of moving obstacles (scenarios README convention for files, per-obstacle probability for the
  /// generator), in [0, 1].
  double dynamic_fraction = 0.85;
  /// Goal distance of generated scenarios: at least this far from the robot, as in the evaluation files, m.
  double generated_goal_distance_min_m = 4.0;
  /// Worker threads (each with its own planners and episode); results do not depend on it.
  int threads = 1;
  /// Weight file of the `dqn_dovs` method.
  std::string model_path = "models/dqn_dovs.dqnw";
  /// The action shield of the DQN-DOVS methods (each variant still applies its own change to it).
  ActionShieldConfig shield;
  /// Everything about one episode: simulator, tracker, DOVS, reward, perfect_info (false: tracker in the loop).
  EpisodeConfig episode;
  /// Jobs (obstacle count, episode) whose robot and obstacle paths are kept in the records, for plots.
  std::vector<std::pair<int, int>> keep_paths;

  /// Empty when consistent, otherwise a message naming the offending field and why.
  std::string validate() const;
};

/// Collisions split by who could have avoided them (passive safety): hitting static geometry (walls, furniture,
/// static obstacles) is never necessary; a robot at rest (speed below kRestSpeedMps) was walked into; a moving
/// robot drove into a moving obstacle.
enum class CollisionKind { kNone = 0, kStatic = 1, kRest = 2, kMoving = 3 };
/// "", "static", "rest", "moving".
const char* collisionKindName(CollisionKind kind);
/// The robot counts as at rest at a contact below this linear speed, m/s.
constexpr double kRestSpeedMps = 0.05;
/// The kind of a simulator collision.
CollisionKind classifyCollision(const sim::CollisionInfo& collision);

/// One episode's scenario with its place in the protocol.
struct EvalScenario {
  int obstacles = 0;  ///< obstacle count N
  int episode = 0;    ///< episode index K, from 1
  uint64_t seed = 0;  ///< sensor-noise seed: depends only on (seed, N, K), the same for every method
  sim::Scenario scenario;
};

/// The result of one (method, scenario) episode.
struct EpisodeRecord {
  std::string method;
  int obstacles = 0;
  int episode = 0;
  std::string scenario;  ///< the scenario's name (file or generator seed)
  Outcome outcome = Outcome::Running;
  double time_s = 0.0;           ///< episode time after the sensor warm-up, s
  double path_length_m = 0.0;    ///< distance the robot drove, m
  double min_clearance_m = 0.0;  ///< smallest surface-to-surface clearance to an obstacle or wall, m
  int danger_steps = 0;          ///< steps ending with clearance below the reward's safe distance
  int steps = 0;                 ///< decisions taken
  int planner_errors = 0;        ///< decisions where the planner threw and the robot decelerated instead
  /// Collisions only: what kind (collisionKindName: static geometry, robot at rest, robot moving) and the robot's
  /// linear speed at the contact (m/s; NaN without a collision).
  CollisionKind collision_kind = CollisionKind::kNone;
  double contact_speed_mps = std::numeric_limits<double>::quiet_NaN();
  /// The planner's note on its last decision (PlannerDecision::note, e.g. the shield level or the escape tier that
  /// drove the robot into a collision); "planner error" when it threw.
  std::string last_decision;
  /// Robot poses at every step (only for jobs listed in EvalConfig::keep_paths).
  std::vector<Pose2> robot_path;
  /// Per obstacle, its centre at every step (same jobs).
  std::vector<std::vector<Vec2>> obstacle_paths;
};

/// The episodes of the protocol for `config`: files `scenarios_dir/1-N/K.dovs` with the dynamic fraction applied,
/// or generated ones (N obstacles, moving with probability dynamic_fraction). Ordered by N, then K.
/// Throws EvalError naming the file or the generator failure.
std::vector<EvalScenario> loadEvalScenarios(const EvalConfig& config);

/// Progress report: the record just finished, how many are done and the total.
using EvalProgress = std::function<void(const EpisodeRecord& record, size_t done, size_t total)>;

/// Runs every method on every scenario across config.threads threads (each thread builds its own planners and
/// episode). Records come back ordered by method, then N, then K, identical for any thread count. `progress` is
/// called from the worker threads, one call at a time. Throws EvalError when the configuration is invalid, a
/// planner cannot be built or an episode fails (naming the method and the scenario).
std::vector<EpisodeRecord> runEvaluation(const EvalConfig& config, const std::vector<EvalScenario>& scenarios,
                                         const EvalProgress& progress = nullptr);

/// One method at one obstacle count (or over all counts, obstacles = 0).
struct EvalCell {
  int episodes = 0;
  int successes = 0;
  int collisions = 0;
  int timeouts = 0;
  double success_rate = 0.0;
  double collision_rate = 0.0;
  double timeout_rate = 0.0;
  double mean_time_success_s = 0.0;  ///< NaN when no episode succeeded
  /// Sum of this method's times over the sum of the reference's times, on episodes both solved; NaN when none.
  double time_ratio = 0.0;
  int both_solved = 0;                  ///< episodes behind time_ratio
  double danger_frequency = 0.0;        ///< danger steps / steps, over all episodes
  double mean_min_clearance_m = 0.0;    ///< mean over episodes of the smallest clearance
  int static_collisions = 0;            ///< collisions with static geometry (must be 0)
  int rest_collisions = 0;              ///< collisions with the robot at rest
  int moving_collisions = 0;            ///< collisions with the robot moving into a moving obstacle
  double mean_contact_speed_mps = 0.0;  ///< robot speed at contact over the collisions; NaN when none
  double p95_contact_speed_mps = 0.0;   ///< its 95th percentile (nearest rank); NaN when none
};

struct EvalSummary {
  std::vector<std::string> methods;
  std::vector<int> obstacle_counts;  ///< ascending
  std::string reference;             ///< method of the time ratios
  /// cells[m][c]: methods[m] at obstacle_counts[c].
  std::vector<std::vector<EvalCell>> cells;
  /// Per method over every count; its success/collision/timeout rates are the means of the per-count rates
  /// (the paper's mean row), its time ratio pools every episode both solved.
  std::vector<EvalCell> overall;

  const EvalCell& cell(const std::string& method, int obstacles) const;
};

/// The summary of `records`. `reference` must be one of the records' methods (throws EvalError otherwise).
/// Episodes are matched across methods by (obstacles, episode).
EvalSummary summarize(const std::vector<EpisodeRecord>& records, const std::string& reference);

/// results.csv: a header, then one row per record (method, obstacles, episode, scenario, outcome, time_s,
/// path_length_m, min_clearance_m, danger_steps, steps, planner_errors). Throws EvalError naming the file.
void writeResultsCsv(const std::vector<EpisodeRecord>& records, const std::string& path);
/// summary.md in the paper's layout: success rate per count per method with the time ratio in brackets and a
/// mean row; then collision and timeout tables. `header` is free text put above the tables.
void writeSummaryMarkdown(const EvalSummary& summary, const std::string& path, const std::string& header = "");
/// The flat figures (string -> number): success_mean, success_N, collision_mean, timeout_mean, time_ratio_mean,
/// episodes; keys prefixed with "method." when there are several methods.
std::vector<std::pair<std::string, double>> summaryFigures(const EvalSummary& summary);
/// summaryFigures as a flat JSON object; figures that are NaN (e.g. no time ratio) are left out. Throws EvalError
/// naming the file.
void writeSummaryJson(const EvalSummary& summary, const std::string& path);

}  // namespace dqn_dovs
