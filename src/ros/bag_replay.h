// Deterministic offline replay of a recorded bag (scan, odom, tf, goal) through the tracker, the DOVS and
// the planner's network, with the nodes' own per-message steps (pipeline_steps.h): the same bag gives the
// same tracks and decisions on every run. Used by the bag regression test, which compares the result with
// stored expectations (test/data/replay_expected_*.csv, rewritten by scripts/regenerate_bag_expectations.sh).
//
// Differences from the live pipeline, all on the side of determinism: every transform of the bag is loaded
// before the replay (a live lookup waits up to tf_timeout for the same data); the DOVS uses the last odom
// recorded before the scan (live, one more odom may have arrived); the planner's choice is made for every
// velocity space, not on the 0.2 s control timer.
#pragma once

#include <array>
#include <stdexcept>
#include <string>
#include <vector>

#include "dqn_dovs/common/robot_model.h"
#include "dqn_dovs/dovs/dovs.h"
#include "dqn_dovs/perception/tracker.h"
#include "dqn_dovs/policy/action_shield.h"

namespace dqn_dovs {

/// A bag that cannot be read, an expectation file that cannot be read or written; the message names the file.
class ReplayError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// What the replay runs with: the nodes' parameters (loaded by the caller with the nodes' own loaders).
struct ReplayConfig {
  /// obstacle_tracker_node's `tracker/*`.
  TrackerConfig tracker;
  /// dovs_node's `dovs/*`.
  DovsConfig dovs;
  /// dovs_node's `action_shield/*`.
  ActionShieldConfig shield;
  /// Every node's `robot/*`.
  RobotLimits limits;
  /// Frame the tracks and the goal live in (the nodes' `fixed_frame`).
  std::string fixed_frame = "odom";
  /// The robot's frame (dovs_node's `base_frame`).
  std::string base_frame = "base_footprint";
  /// dovs_node's `max_input_age` (s): odom farther than this from the obstacles' stamp -> no DOVS.
  double max_input_age_s = 0.5;
  /// Weight file of the planner's network.
  std::string model_path;
  /// dovs_node's `people_predictor` ("": moving tracks at their present velocity).
  std::string people_predictor;
  /// obstacle_tracker_node's `use_map` and `map_unknown_is_occupied`: the bag's map is what the tracker never tracks.
  bool tracker_map = false;
  bool tracker_map_unknown_is_occupied = false;
  /// dovs_node's `use_map`, `map_range` (m) and `map_unknown_is_occupied`: the map's walls join the scan's.
  bool dovs_map = false;
  double dovs_map_range_m = 4.0;
  bool dovs_map_unknown_is_occupied = false;
  /// Topics in the bag.
  std::string map_topic = "/map";
  std::string scan_topic = "/scan";
  std::string odom_topic = "/odom";
  std::string goal_topic = "/move_base_simple/goal";
  /// planner_node's route ahead (nav_msgs/Path in the fixed frame), for a network with route points
  /// (dovs/route_points); a bag without it gives the straight line to the goal.
  std::string route_ahead_topic = "/planner/route_ahead";
};

/// One confirmed track of one used scan.
struct TrackRow {
  double stamp_s = 0.0;  ///< the scan's stamp
  int id = -1;
  double x = 0.0, y = 0.0, radius = 0.0, heading = 0.0, speed = 0.0, turn_rate = 0.0;
  bool is_static = false;
};

/// One used scan: how many tracks and wall segments it gave.
struct ScanRow {
  double stamp_s = 0.0;
  int tracks = 0;
  int segments = 0;
};

/// The planner's choice for one velocity space.
struct DecisionRow {
  double stamp_s = 0.0;     ///< the scan's (= obstacles' = Dovs') stamp
  double v = 0.0, w = 0.0;  ///< robot velocity the DOVS was built at (clipped odom)
  double goal_distance_m = 0.0;
  std::array<bool, 8> valid{};            ///< action mask
  int action = -1;                        ///< chosen action, -1 none
  double target_v = 0.0, target_w = 0.0;  ///< the chosen action's velocity
  double q_gap = 0.0;                     ///< best minus second-best valid Q-value (how firm the choice is)
  int free_cells = 0;                     ///< free cells of the 20 x 20 grid
  std::array<float, 8> features{};        ///< the 8 normalised features of the network state
};

struct ReplayResult {
  std::vector<ScanRow> scans;
  std::vector<TrackRow> tracks;
  std::vector<DecisionRow> decisions;
  int scans_dropped = 0;         ///< malformed, no transform, or rejected by the tracker
  int scans_with_map = 0;        ///< scans tracked with the map (tracker_map, a map and its transform at hand)
  int steps_with_map_walls = 0;  ///< velocity spaces built with the map's walls (dovs_map)
};

/// Replays `bag_path`. Throws ReplayError when the bag cannot be read, WeightFileError for a bad model,
/// PeoplePredictorError for a bad people predictor, TrackerConfigError / DovsError for bad configurations.
ReplayResult replayBag(const std::string& bag_path, const ReplayConfig& config);

/// Writes the scans and tracks (one CSV) and the decisions (another), fixed precision.
void writeReplayCsv(const ReplayResult& result, const std::string& tracks_csv, const std::string& decisions_csv);
/// Reads what writeReplayCsv wrote (scans_dropped is not stored).
ReplayResult readReplayCsv(const std::string& tracks_csv, const std::string& decisions_csv);

/// Tolerances of the comparison.
struct ReplayTolerance {
  double position_m = 0.02;
  double radius_m = 0.02;
  double speed_mps = 0.05;
  double heading_rad = 0.1;  ///< checked only for tracks faster than 0.2 m/s (slow headings are noise)
  double turn_rate_rps = 0.1;
  double velocity = 1e-4;  ///< robot and target velocities (m/s, rad/s)
  double feature = 1e-3;   ///< normalised features
  int free_cells = 2;
  /// A different action is accepted only where the expected choice was this close (Q-value gap).
  double q_tie = 1e-3;
};

/// Every difference between `expected` and `actual` beyond the tolerances, one line each (empty: equal).
std::vector<std::string> compareReplay(const ReplayResult& expected, const ReplayResult& actual,
                                       const ReplayTolerance& tolerance = ReplayTolerance());

}  // namespace dqn_dovs
