// The benchmark runner of DESIGN §11: the same episodes for every method, for each obstacle count, run across a
// thread pool with deterministic results, and its records (results.csv, run.json, paths.json). Summaries, tables
// and plots are made from those records by the Python reporter (python/dqn_dovs_py/report.py).
#pragma once

#include <cstdint>
#include <deque>
#include <functional>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "dqn_dovs/evaluation/episode.h"
#include "dqn_dovs/evaluation/oracle.h"
#include "dqn_dovs/evaluation/reach_bound.h"
#include "dqn_dovs/evaluation/yardstick.h"
#include "dqn_dovs/policy/action_shield.h"
#include "dqn_dovs/sim/scenario.h"

namespace dqn_dovs {

/// Bad evaluation configuration, unreadable scenario folder, failed episode or unwritable output; the message
/// names the item (flag, file, job) and the reason.
class EvalError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The people predictor the launch files give dovs_node where legs are paired (launch/pipeline.launch), relative to
/// the package's root: dqn_dovs_eval's `--predict-people auto` in every world with people.
constexpr const char* kDefaultPeoplePredictor = "models/people_predictor_tracks.dqnp";
/// The predictor learned from the people's true paths: `--predict-people auto` with perfect information, whose
/// histories are true paths too (docs/tracker.md, "Which part of the tracks costs the planners").
constexpr const char* kTruePathPeoplePredictor = "models/people_predictor.dqnp";

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
  /// World family of generated episodes (sim/worlds.h): "room" is the paper's room of N disc obstacles; the
  /// others hold N people. Only "room" reads scenario files.
  std::string world = "room";
  /// LIDAR profile (sim/lidar.h LidarConfig::profile): applied to episode.world.lidar by applyWorldOptions.
  std::string sensor = "sim";
  /// How people move ("constant", "social_force") and whether they see the robot and give way.
  std::string people_model = "social_force";
  bool people_see_robot = false;
  /// How people treat the robot (sim::PeopleMix text, e.g. "attentive=0.6,impassive=0.2,oblivious=0.2"); empty:
  /// everybody oblivious, or attentive with people_see_robot (which wins).
  std::string people_mix;
  /// Wheel-odometry drift (sim::OdometryConfig::level): "none", "low" or "high".
  std::string odom_noise = "none";
  /// "on": in worlds with walls (static segments; not the paper's room) the robot follows a route on the known
  /// static geometry, as planner_node does (episode.route); "off": it drives at the goal itself.
  std::string route = "on";
  /// Goal distance of generated scenarios: at least this far from the robot, as in the evaluation files, m.
  double generated_goal_distance_min_m = 4.0;
  /// Generated room scenarios: no moving obstacle reaches the robot's start sooner than this on its own arc (s;
  /// sim::GeneratorConfig::start_clear_s; 0: no such rule, the paper's distribution).
  double generated_start_clear_s = 0.0;
  /// Worker threads (each with its own planners and episode); results do not depend on it.
  int threads = 1;
  /// Weight file of the `dqn_dovs` method.
  std::string model_path = "models/dqn_dovs.dqnw";
  /// The action shield of the DQN-DOVS methods (each variant still applies its own change to it).
  ActionShieldConfig shield;
  /// The oracle's search (method `oracle`); its success rule and stepping come from `episode`.
  OracleConfig oracle;
  /// The oracle's further searches on an episode its first one does not solve (defaultOracleRetries; each
  /// NAME=VALUE,... applied to `oracle`); empty: one search only. Not used when the oracle reads a prediction
  /// (true_future_periods >= 0), where the best of several runs would be hindsight.
  std::vector<std::string> oracle_retries = defaultOracleRetries();
  /// The reachability bound's grid (method `bound`); its success rule, step limit and stepping come from `episode`.
  ReachBoundConfig bound;
  /// Everything about one episode: simulator, tracker, DOVS, reward, perfect_info (false: tracker in the loop).
  EpisodeConfig episode;
  /// Jobs (obstacle count, episode) whose robot and obstacle paths are kept in the records, for plots.
  std::vector<std::pair<int, int>> keep_paths;

  /// Empty when consistent, otherwise a message naming the offending field and why.
  std::string validate() const;
};

/// Puts config.sensor, people_model, people_see_robot, odom_noise and route into config.episode (the LIDAR profile,
/// the scan period: the scanner's, or the next slower one that divides the control period, the people model, and
/// the tracker's leg pairing in worlds with people; the odometry; whether there are routes). Throws EvalError
/// naming the unknown name.
void applyWorldOptions(EvalConfig& config);

/// What the planners knew of the body that walked or drove into the robot (collisions with a moving body only;
/// docs/planners.md, "What the planners knew of what hit them"). At each decision the bodies the planners were
/// shown (the observation's obstacles, placed in the world through the robot's true and believed poses) are paired
/// with the true bodies one to one within kTrackTruthMatch_m, as --track-truth pairs them (matchWithin).
enum class HitCause {
  kNone = 0,          ///< no collision with a moving body
  kUnseen = 1,        ///< not among what the planners were shown at the last decision before the contact
  kLate = 2,          ///< shown at the last decision, not kHitForesight_s before the contact
  kMispredicted = 3,  ///< shown then, but its motion as shown put it more than kHitPredictionMiss_m from where it was
  kForeseen = 4,      ///< shown then, and its motion as shown put it within kHitPredictionMiss_m of where it was
};
/// "", "unseen", "late", "mispredicted", "foreseen".
const char* hitCauseName(HitCause cause);
/// How long before the contact a body must have been shown for its prediction to be judged, s.
constexpr double kHitForesight_s = 1.0;
/// The same figure is also given from this long before the contact, s (2 s: about what the robot needs to get out
/// of a person's way at its acceleration limits).
constexpr double kHitLongForesight_s = 2.0;
/// A prediction this far (m) or more from the body's true centre at the contact missed it (a person's diameter
/// is 0.4-0.6 m: the planners were avoiding someone elsewhere).
constexpr double kHitPredictionMiss_m = 0.3;

/// What the planners were shown at one decision, placed in the world's frame, beside the truth.
struct DecisionView {
  double time_s = 0.0;                ///< world time of the decision
  Pose2 robot;                        ///< the robot's true pose
  std::vector<MovingObstacle> shown;  ///< the observation's obstacles (with their motion as shown), in the world
  std::vector<Vec2> truth;            ///< every body's true centre (obstacles, then people)
};
/// The view of the episode's current decision: its observation placed in the world through the robot's true and
/// believed (odometry) poses.
DecisionView decisionView(const Episode& episode);

/// What the planners knew of one body that hit the robot.
struct HitAttribution {
  HitCause cause = HitCause::kNone;
  double seen_s = std::numeric_limits<double>::quiet_NaN();              ///< shown without a break up to the contact, s
  double prediction_error_m = std::numeric_limits<double>::quiet_NaN();  ///< of its motion as shown then, m
  /// The same from kHitLongForesight_s before the contact (NaN when it was not shown then), m.
  double prediction_error_long_m = std::numeric_limits<double>::quiet_NaN();
  double bearing_deg = std::numeric_limits<double>::quiet_NaN();  ///< from the robot's heading at the last view
};
/// Attributes the contact of `body` (an index into the views' truth) at `contact_time_s`, where it was at
/// `at_contact`, from the decisions before it (`views`, oldest first, each before the contact). kNone when there is
/// no view or the body is unknown.
HitAttribution attributeHit(const std::deque<DecisionView>& views, size_t body, const Vec2& at_contact,
                            double contact_time_s);

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
  Outcome outcome = Outcome::kRunning;
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
  /// Collisions only: who hit whom (classifyContact) and whether the robot was at fault (robotAtFault).
  ContactClass contact = ContactClass::kNone;
  bool at_fault = false;
  /// Comfort: the time (s, counted per decision period) with a person's body within kIntimateDistance_m, and within
  /// kPersonalDistance_m, of the robot's (surface to surface) while the robot moves (kRestSpeedMps or faster).
  double intimate_s = 0.0;
  double personal_s = 0.0;
  /// Cost to others: the time (s, per decision period) the robot blocked a passage (kPassageWidth_m), and the
  /// delay it caused the attentive people who noticed it: the sum over them of how far behind their plans they are
  /// at the end against the same people with the robot absent (WorldConfig::shadow_people), each divided by its
  /// preferred speed (s; negative when they came out ahead; NaN when no attentive person noticed the robot). A crowd
  /// amplifies small differences, so one episode's figure is noisy: compare means over many episodes.
  double blocking_s = 0.0;
  double delay_s = std::numeric_limits<double>::quiet_NaN();
  /// Efficiency: successes only (NaN otherwise), the time to the goal over the time the start's route length
  /// (along the route in worlds with walls, else the straight line) takes at v_max.
  double time_ratio = std::numeric_limits<double>::quiet_NaN();
  /// pathIrregularity of the robot's path (rad/m).
  double path_irregularity = 0.0;
  /// Collisions with a moving body only (NaN / kNone otherwise): what the planners knew of it (HitCause); how long it
  /// had been shown without a break up to the contact (s, looking at most 3 s back; 0 when unseen); how far from its
  /// true centre at the contact its motion as shown kHitForesight_s, and kHitLongForesight_s, before put it (m; NaN
  /// when not shown then); and its bearing from the robot's heading at the last decision (deg, 0 ahead, 180 behind).
  HitCause hit_cause = HitCause::kNone;
  double hit_seen_s = std::numeric_limits<double>::quiet_NaN();
  double hit_prediction_error_m = std::numeric_limits<double>::quiet_NaN();
  double hit_prediction_error_2s_m = std::numeric_limits<double>::quiet_NaN();
  double hit_bearing_deg = std::numeric_limits<double>::quiet_NaN();
  /// The planner's note on its last decision (PlannerDecision::note, e.g. the shield level or the escape tier that
  /// drove the robot into a collision); "planner error" when it threw.
  std::string last_decision;
  /// The planner's action at every decision: an index into the 8 actions, or -1 for a velocity that is not one of
  /// them (the shield's escape, a deceleration, a baseline's own command).
  std::vector<int> actions;
  /// Robot poses at every step (only for jobs listed in EvalConfig::keep_paths).
  std::vector<Pose2> robot_path;
  /// Per obstacle, then per person, its centre at every step (same jobs).
  std::vector<std::vector<Vec2>> obstacle_paths;
  /// The tracker's confirmed tracks at every step (same jobs, tracker in the loop only; aligned with obstacle_paths).
  std::vector<std::vector<TrackedObstacle>> tracks;
};

/// The episodes of the protocol for `config`: files `scenarios_dir/1-N/K.dovs` with the dynamic fraction applied,
/// or generated ones (N obstacles, moving with probability dynamic_fraction). Ordered by N, then K.
/// Throws EvalError naming the file or the generator failure.
std::vector<EvalScenario> loadEvalScenarios(const EvalConfig& config);

/// The methods the evaluation runs: every planner of makePlanner, plus `oracle` (evaluation/oracle.h: the physical
/// limit from below, a search reading the simulator's future) and `bound` (evaluation/reach_bound.h: the limit from
/// above, what no robot within the limits can do).
std::vector<std::string> evalMethodNames();

/// Builds the planner of one method for `config` (the oracle with the episode's success rule). Throws PlannerError
/// for an unknown name.
std::unique_ptr<Planner> makeEvalPlanner(const std::string& method, const EvalConfig& config);

/// Runs one episode of `scenario` with `planner` in `episode` (both reset first) as runEvaluation does: the
/// planner decides every control period, and a planner that throws PlannerError makes the robot decelerate.
/// Paths are kept when `keep_paths`.
EpisodeRecord runEpisode(Planner& planner, Episode& episode, const std::string& method, const EvalScenario& scenario,
                         bool keep_paths = false);

/// Progress report: the record just finished, how many are done and the total.
using EvalProgress = std::function<void(const EpisodeRecord& record, size_t done, size_t total)>;

/// Runs every method on every scenario across config.threads threads (each thread builds its own planners and
/// episode). Records come back ordered by method, then N, then K, identical for any thread count. `progress` is
/// called from the worker threads, one call at a time. Throws EvalError when the configuration is invalid, a
/// planner cannot be built or an episode fails (naming the method and the scenario).
std::vector<EpisodeRecord> runEvaluation(const EvalConfig& config, const std::vector<EvalScenario>& scenarios,
                                         const EvalProgress& progress = nullptr);

/// results.csv: a header, then one row per record (method, obstacles, episode, scenario, outcome, time_s,
/// path_length_m, min_clearance_m, danger_steps, steps, planner_errors, collision_kind, contact_speed_mps,
/// last_decision, hit_cause, hit_seen_s, hit_prediction_error_m, hit_prediction_error_2s_m, hit_bearing_deg,
/// contact, at_fault: 1 or 0 with a collision, empty without, intimate_s, personal_s, verdict: verdictName). Throws
/// EvalError naming the file.
void writeResultsCsv(const std::vector<EpisodeRecord>& records, const std::string& path);

/// An episode's outcome judged by who caused a collision: "success", "collision_robot_at_fault", "hit_at_rest" (a
/// collision the robot was not at fault for: robotAtFault) or "timeout".
const char* verdictName(const EpisodeRecord& record);

/// How the run went, for run.json.
struct EvalRunInfo {
  std::string command;    ///< the command line that ran the evaluation
  double wall_s = 0.0;    ///< wall time of runEvaluation, s
  std::string reference;  ///< the method the summaries' time ratios compare against
};

/// run.json: the configuration and how the run went (command, scenarios ("generated" or the folder), seed, obstacle
/// range, episodes, dynamic fraction, world options and route, perception, step and step limit, wall time, threads,
/// methods in table order, the reference method, the goal tolerance). Throws EvalError naming the file.
void writeRunJson(const EvalConfig& config, const EvalRunInfo& info, const std::string& path);

/// paths.json: every record that kept its paths (EvalConfig::keep_paths), with its figures and its scenario's goal,
/// room, extra walls and obstacle radii, for the trajectory plots. Throws EvalError naming the file or a record
/// without a scenario.
void writePathsJson(const std::vector<EpisodeRecord>& records, const std::vector<EvalScenario>& scenarios,
                    double goal_tolerance_m, const std::string& path);

}  // namespace dqn_dovs
