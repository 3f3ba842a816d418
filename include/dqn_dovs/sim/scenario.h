// Simulation scenarios: the robot's start and goal, the obstacles' initial states and the room.
// Two sources: the fixed `.dovs` evaluation files (see scenarios/README.md) and a seeded generator for training.
#pragma once

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "dqn_dovs/common/geometry.h"
#include "dqn_dovs/common/types.h"
#include "dqn_dovs/sim/errors.h"
#include "dqn_dovs/sim/people.h"

namespace dqn_dovs::sim {

/// One episode's initial conditions. The room is a square of side 2 * room_half_size_m centred on the origin,
/// with walls on its four sides.
struct Scenario {
  std::string name;                       ///< Human-readable origin, e.g. "1-5/1" or "generated/seed=7".
  Pose2 robot_start;                      ///< Robot start pose in the room frame (m, m, rad).
  Vec2 goal = Vec2::Zero();               ///< Goal position in the room frame (m).
  std::vector<MovingObstacle> obstacles;  ///< Initial obstacle states; speed/turn_rate are their nominal motion.
  std::vector<Segment> static_segments;   ///< Optional extra static walls inside the room (not stored in .dovs).
  std::vector<PersonSpec> people;         ///< People walking between destinations (not stored in .dovs).
  double room_half_size_m = 4.0;          ///< Half the side of the square room (m): walls at x, y = +-room_half_size_m.
  TrafficRule traffic;                    ///< Which side people keep to (none: no rule).
  std::vector<Door> doors;                ///< Doors people pass one at a time (not junction centres).
};

/// Default disc radius of the obstacles of the `.dovs` files (m); the format does not store radii.
constexpr double kDefaultObstacleRadius = 0.2;

/// Largest obstacle speed |v| (m/s) and turn rate |w| (rad/s) a `.dovs` file may hold: far above the
/// evaluation files (v <= 1.2, |w| <= 0.53), low enough that the world's tunnelling guard keeps a step to a few
/// dozen sub-steps (an obstacle at 1e183 m/s made every step run the 100000-sub-step cap).
constexpr double kMaxScenarioSpeedMps = 10.0;
constexpr double kMaxScenarioTurnRateRadps = 10.0;

/// The package's own room scenarios, laid out as 1-N/K.dovs (data/scenarios/README.md: drawn by this generator,
/// the seed and the command there), relative to the package's root: the default of dqn_dovs_eval --scenarios
/// and of the benchmarks.
constexpr const char* kDefaultScenariosDir = "data/scenarios/room";

/// Reads a `.dovs` scenario (little-endian float64 rows of 5; row 0 robot x, y, theta, goal_x, goal_y; rows
/// 1..N obstacles x, y, theta, v, w). Every obstacle gets `obstacle_radius_m`; an obstacle with v = w = 0 is
/// marked static; a negative v is stored as the equivalent forward motion (heading + pi, speed |v|).
/// Throws ScenarioError naming the file and the reason when the file is missing or unreadable, its size is
/// not a positive multiple of 40 bytes, a value is NaN/inf, a position (robot, goal, obstacle centre)
/// is not strictly inside the room, or an obstacle's |v| or |w| exceeds kMaxScenarioSpeedMps /
/// kMaxScenarioTurnRateRadps.
Scenario loadDovsScenario(const std::string& path, double obstacle_radius_m = kDefaultObstacleRadius,
                          double room_half_size_m = 4.0);

/// The same checks and result as loadDovsScenario on the file's bytes already in memory (`size` bytes at
/// `data`); `path` names the source in the errors and gives the scenario its name. loadDovsScenario reads
/// the file and calls this.
Scenario parseDovsScenario(const unsigned char* data, size_t size, const std::string& path,
                           double obstacle_radius_m = kDefaultObstacleRadius, double room_half_size_m = 4.0);

/// Writes `scenario` in the `.dovs` format so that loadDovsScenario reads back the same poses and motions
/// (obstacle radii and the room size are not part of the format). Throws ScenarioError naming the file when
/// it cannot be written, a value is not finite, or the scenario has static segments (which the format cannot
/// carry, so saving them would lose them silently).
void saveDovsScenario(const Scenario& scenario, const std::string& path);

/// The evaluation protocol's "85% dynamic" convention (scenarios/README.md): with N obstacles the last
/// round((1 - dynamic_fraction) * N) become static (speed = turn_rate = 0, is_static = true, same position);
/// the others are left unchanged. Throws ScenarioError unless dynamic_fraction is in [0, 1].
void applyDynamicFraction(Scenario& scenario, double dynamic_fraction);

/// The scenario's furniture as a map would show it: its static discs (not the moving ones, not the people).
std::vector<Circle> furnitureOf(const Scenario& scenario);

/// Which obstacles the generator creates.
enum class ObstacleType {
  kNone,     ///< no obstacles at all
  kStatic,   ///< only static obstacles
  kDynamic,  ///< only moving obstacles
  kBoth,     ///< each obstacle moving with probability GeneratorConfig::dynamic_fraction, otherwise static
};

/// Parameters of the random scenario generator. Defaults follow the training arena of the paper and the
/// generator that produced the evaluation files (scenarios/README.md).
struct GeneratorConfig {
  /// Half the side of the square room (m); walls at +-room_half_size_m.
  double room_half_size_m = 4.0;
  /// Robot, goal and obstacle centres are drawn uniformly in [-spawn_half_size_m, spawn_half_size_m]^2 (m).
  double spawn_half_size_m = 3.0;
  /// Smallest straight-line distance from the robot start to the goal (m). The evaluation files use 4 m;
  /// the curriculum starts with 1 m goals.
  double goal_distance_min_m = 1.0;
  /// Largest start-to-goal distance (m); +inf means any distance the spawn square allows.
  double goal_distance_max_m = std::numeric_limits<double>::infinity();
  /// Smallest centre-to-centre distance between any two of robot, goal and obstacles at the start (m);
  /// discs are in addition never placed overlapping, whatever their radii.
  double min_separation_m = 0.66;
  /// Robot radius used to keep obstacles from spawning on the robot (m).
  double robot_radius_m = 0.2;
  /// Number of obstacles, drawn uniformly in [obstacle_count_min, obstacle_count_max] (ignored for None).
  int obstacle_count_min = 0;
  /// See obstacle_count_min.
  int obstacle_count_max = 12;
  /// Which obstacles to create.
  ObstacleType obstacle_type = ObstacleType::kBoth;
  /// For ObstacleType::kBoth: probability that an obstacle moves (the rest are static). In [0, 1].
  double dynamic_fraction = 0.85;
  /// Moving obstacles' speed is uniform in [speed_min_mps, speed_max_mps] (m/s).
  double speed_min_mps = 0.2;
  /// See speed_min_mps.
  double speed_max_mps = 1.2;
  /// Moving obstacles' turn rate is uniform in [-turn_rate_max_rps, turn_rate_max_rps] (rad/s). pi / 6:
  /// the evaluation files reach |w| = 0.5236 (the README's "0.52" is this value rounded).
  double turn_rate_max_rps = kPi / 6.0;
  /// Obstacle radius is uniform in [radius_min_m, radius_max_m] (m).
  double radius_min_m = 0.2;
  /// See radius_min_m.
  double radius_max_m = 0.2;
  /// true: robot start heading uniform in [-pi, pi); false: heading 0 as in the evaluation files.
  bool random_robot_heading = true;
  /// A moving obstacle whose own (v, w) arc, followed from the start, would come within start_clear_margin_m of
  /// the robot's disc at its start before this many seconds is drawn again (position and motion), so that the
  /// robot has this long to act before anything can reach it standing still (s; 0: no such rule, and a seed
  /// draws exactly what it drew before the rule existed). The arc is followed while it stays in the room.
  double start_clear_s = 0.0;
  /// See start_clear_s (m, surface to surface).
  double start_clear_margin_m = 0.1;
  /// Rejection-sampling budget per placed item (goal or obstacle) before giving up with a ScenarioError.
  int max_attempts = 2000;

  /// Empty string when consistent, otherwise a message naming the offending field and why.
  std::string validate() const;
};

/// Draws a scenario from `config`, fully determined by `seed` (same seed, same scenario on every platform).
/// Throws ScenarioError when the configuration is invalid or the constraints cannot be met within
/// max_attempts draws (e.g. too many obstacles for the spawn square).
Scenario generateScenario(const GeneratorConfig& config, uint64_t seed);

/// The text scenario format, version 2 (docs/simulator.md, "Scenario files"): a first line
/// `dqn_dovs scenario 2`, then one item per line, `#` comments:
///   name NAME | room HALF_SIZE | robot X Y THETA | goal X Y
///   obstacle X Y HEADING SPEED TURN_RATE RADIUS [static]
///   wall X1 Y1 X2 Y2 | polygon X1 Y1 X2 Y2 X3 Y3 ... (closed) | map FILE.yaml (its walls; path relative to the file)
///   person X Y HEADING RADIUS SPEED WAIT GROUP [[via] DX DY ...] (destinations, walked in turn; `via` marks a
///   waypoint passed on the way, PersonSpec::pass_through)
///   traffic none|right|left STRENGTH (Scenario::traffic; absent: none) | door X Y ACROSS_X ACROSS_Y WIDTH
///   (Scenario::doors); both written only when set, so a scenario without them is written as before
/// Units: m, rad, m/s, rad/s, s; GROUP -1 for none. Throws ScenarioError naming the file, the line and the reason
/// (an unknown item, a missing or non-numeric value, NaN/inf, a non-positive radius or room size, a map that cannot
/// be read; the robot, goal, obstacles and people must lie strictly inside the room).
Scenario parseScenarioText(const std::string& text, const std::string& path);

/// Writes `scenario` in the text format so that parseScenarioText reads back the same scenario (walls as `wall`
/// lines). Throws ScenarioError naming the file when it cannot be written or a value is not finite.
void saveScenarioText(const Scenario& scenario, const std::string& path);

/// A scenario file of either format: the text format when its first line is `dqn_dovs scenario 2`, else a `.dovs`
/// file (loadDovsScenario with `obstacle_radius_m` and `room_half_size_m`). Throws ScenarioError naming the file.
Scenario loadScenarioFile(const std::string& path, double obstacle_radius_m = kDefaultObstacleRadius,
                          double room_half_size_m = 4.0);

}  // namespace dqn_dovs::sim
