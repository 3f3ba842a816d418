// The network input of DQN-DOVS (DESIGN §5): the DOVS grid followed by 8 normalised features. The layout and
// every normalisation constant are documented in docs/dovs.md; the weight file carries StateNormalization so a
// network is always fed the way it was trained. ROS-free.
#pragma once

#include <Eigen/Core>
#include <array>
#include <string>
#include <utility>
#include <vector>

#include "dqn_dovs/common/types.h"
#include "dqn_dovs/dovs/actions.h"
#include "dqn_dovs/dovs/dovs.h"

namespace dqn_dovs {

constexpr int kStateGridSize = 20;
constexpr int kStateGridCells = kStateGridSize * kStateGridSize;
constexpr int kNumFeatures = 8;
constexpr int kStateSize = kStateGridCells + kNumFeatures;  // 408, the one-channel state
/// Grid channels of the state with the previous decision's grid (DovsConfig::grid_channels; training and
/// evaluation only: the nodes do not keep it).
constexpr int kHistoryGridChannels = 2;
/// Grid channels of the state with the dynamic window and the goal line (DovsConfig::grid_channels).
constexpr int kWindowGoalGridChannels = 3;

/// Inputs after the features that hold the previous choice (DovsConfig::previous_action, docs/dovs.md "The previous
/// action"): one per action (kNumActions of actions.h, 8), then one for any other command (kPreviousChoiceOther).
constexpr int kPreviousChoiceInputs = 9;
/// The previous choice that was not one of the 8 actions: the shield's escape, or a command of another planner.
constexpr int kPreviousChoiceOther = 8;
/// The previous choice at an episode's first decision: none (every previous-choice input is 0).
constexpr int kNoPreviousChoice = -1;

/// Floats of one person token (docs/dovs.md "Person tokens"), in this order: present (1, or 0 for an empty slot,
/// whose other values are 0); position x, y in the robot frame; velocity x, y in the robot frame; radius; the
/// position 1 s before, x, y (in the robot frame of now); the predicted position 1 s and 2 s ahead along the
/// obstacle's motion model, x, y each; the track's age; its position's standard deviation.
constexpr int kPersonTokenSize = 14;
/// The most person tokens (DovsConfig::person_tokens) and wall rays (DovsConfig::wall_rays) a state carries.
constexpr int kMaxPersonTokens = 16;
constexpr int kMaxWallRays = 32;
/// The most route points (DovsConfig::route_points), their spacing along the route (m), and the inputs of each (x, y).
constexpr int kMaxRoutePoints = 16;
constexpr double kRoutePointSpacing_m = 0.5;
constexpr int kRoutePointInputs = 2;
/// Fixed scales of the token entries that no StateNormalization field scales: the age (s), the position's standard
/// deviation (m), the radius (m); and the clip of every token entry (positions beyond 2 obstacle ranges are clipped).
constexpr float kTokenAgeScale_s = 5.0f;
constexpr float kTokenSigmaScale_m = 1.0f;
constexpr float kTokenRadiusScale_m = 1.0f;
constexpr float kTokenClip = 2.0f;
/// How far back a token's history reaches (s), and how long TrackHistory keeps a position.
constexpr double kTokenHistory_s = 1.0;

/// Floats in a state with `grid_channels` grid channels: grid_channels x 400 grid values, then the 8 features, then
/// with `previous_action` the 9 previous-choice inputs, then `wall_rays` ray lengths, then `route_points` x 2 route
/// coordinates, then `person_tokens` tokens of kPersonTokenSize floats.
constexpr int stateSize(int grid_channels, bool previous_action = false, int wall_rays = 0, int person_tokens = 0,
                        int route_points = 0) {
  return grid_channels * kStateGridCells + kNumFeatures + (previous_action ? kPreviousChoiceInputs : 0) + wall_rays +
         route_points * kRoutePointInputs + person_tokens * kPersonTokenSize;
}

/// The network input (stateSize(grid_channels) floats).
using StateVector = Eigen::VectorXf;
using FeatureVector = std::array<float, kNumFeatures>;

/// Feature indices in the state, after the grid.
enum FeatureIndex : int {
  kFeatureV = 0,                 ///< robot linear speed
  kFeatureW = 1,                 ///< robot turn rate
  kFeatureGoalDistance = 2,      ///< distance to the goal
  kFeatureGoalAngle = 3,         ///< bearing of the goal in the robot frame
  kFeatureObstacleHeading = 4,   ///< closest obstacle's heading relative to the robot's
  kFeatureObstacleSpeed = 5,     ///< closest obstacle's speed
  kFeatureObstacleBearing = 6,   ///< bearing of the closest obstacle's centre in the robot frame
  kFeatureObstacleClearance = 7  ///< centre distance minus both radii
};

/// Normalisation of the 8 features: feature = clamp(raw / scale, -clip, clip); with no obstacle in range the four
/// obstacle features take the fixed "far away" values (already normalised). Plain floats in a stable order
/// (fields() / fromFields()) because the weight file stores them.
struct StateNormalization {
  float v_scale_mps = 0.7f;                        ///< linear speed scale (v_max), m/s
  float w_scale_rps = 3.14159265f;                 ///< turn rate scale (w_max), rad/s
  float goal_distance_scale_m = 10.0f;             ///< goal distance scale (about the diagonal of the 8 m room), m
  float goal_angle_scale_rad = 3.14159265f;        ///< goal bearing scale, rad
  float obstacle_heading_scale_rad = 3.14159265f;  ///< relative heading scale, rad
  float obstacle_speed_scale_mps = 1.5f;           ///< obstacle speed scale (fastest expected pedestrian), m/s
  float obstacle_bearing_scale_rad = 3.14159265f;  ///< obstacle bearing scale, rad
  float obstacle_clearance_scale_m = 4.0f;         ///< clearance scale (the DOVS obstacle range), m
  float far_heading = 0.0f;                        ///< normalised heading when no obstacle is in range
  float far_speed = 0.0f;                          ///< normalised speed when no obstacle is in range
  float far_bearing = 1.0f;                        ///< normalised bearing when no obstacle is in range (behind)
  float far_clearance = 1.0f;                      ///< normalised clearance when no obstacle is in range
  float clip = 1.0f;                               ///< every normalised feature is clamped to [-clip, clip]
  /// The grid's encoding (DovsConfig::grid_contact_horizon_s): 0 is the +1 / -1 grid; T > 0 grades every feasible
  /// cell by the earliest contact of its constant velocity within T seconds (docs/dovs.md, "The graded grid").
  float grid_contact_horizon_s = 0.0f;
  /// The grid's channels (DovsConfig::grid_channels, docs/dovs.md "Grid channels"): 1 is the DOVS grid alone, 2
  /// adds the previous decision's grid (one step of history), 3 the dynamic window and the goal line. Part of the
  /// state's layout, not a normalisation entry: the weight file stores it in its header (`state layout: grid channels`,
  /// format version 2), and fields() leaves it out.
  int grid_channels = 1;
  /// The previous choice after the features (DovsConfig::previous_action, docs/dovs.md "The previous action"): 0 or
  /// 1. Part of the state's layout, not a normalisation entry: the weight file's `state layout: feature count` is 17
  /// with it (8 without), and fields() leaves it out.
  int previous_action = 0;
  /// Wall rays after the features and the previous choice (DovsConfig::wall_rays, docs/dovs.md "Person tokens"):
  /// the distance to the nearest wall along that many directions evenly spread from straight ahead, over the
  /// obstacle range, clipped to 1. Layout, not normalisation: the weight file's `state layout: wall rays` (version 3).
  int wall_rays = 0;
  /// Person tokens after the wall rays and the route points (DovsConfig::person_tokens): one per obstacle for the
  /// nearest ones, empty slots at the end. Layout, not normalisation: the weight file's `state layout: person
  /// tokens` (version 3).
  int person_tokens = 0;
  /// Route points after the wall rays (DovsConfig::route_points, docs/dovs.md "The route ahead"): x, y of each in
  /// the robot frame over the obstacle range. Layout, not normalisation: the weight file's `state layout: route
  /// points` (version 4).
  int route_points = 0;
  /// Inputs after the grid: the 8 features, and the 9 previous-choice inputs with previous_action.
  int featureInputs() const { return kNumFeatures + (previous_action != 0 ? kPreviousChoiceInputs : 0); }
  /// Floats in a state of this layout (stateSize()).
  int stateSize() const {
    return dqn_dovs::stateSize(grid_channels, previous_action != 0, wall_rays, person_tokens, route_points);
  }

  /// The fields every normalisation has (the first 13, the paper's state).
  static constexpr int kNumFields = 13;
  /// Name of the optional 14th field, present only for a graded grid (a file without it has the +1 / -1 grid).
  static constexpr const char* kGridContactHorizonField = "grid_contact_horizon_s";
  /// (name, value) pairs in field order, as the weight file stores them: the 13 fields, then
  /// grid_contact_horizon_s when it is not 0 (so a +1 / -1 model's file is what it always was).
  std::vector<std::pair<std::string, float>> fields() const;
  /// Inverse of fields(); throws StateError naming the field when a name is missing, unknown or out of order, or
  /// the count is neither 13 nor 14.
  static StateNormalization fromFields(const std::vector<std::pair<std::string, float>>& fields);
  /// fromFields() of values in field order (13 or 14 of them, as a Dovs message's state_normalization carries
  /// them). Returns false with `why` naming the count when it is neither.
  static bool fromValues(const std::vector<float>& values, StateNormalization& out, std::string& why);
  /// Empty when usable, otherwise a message naming the field: scales finite and positive, far values finite
  /// and within [-clip, clip], clip finite and positive, grid_contact_horizon_s 0 or in [0.5, 30], grid_channels 1,
  /// 2 or 3, previous_action 0 or 1.
  std::string validate() const;
};

/// The normalisation the pipeline feeds the network with for this robot and DOVS configuration: the speed
/// scales are the robot's limits, the clearance scale the DOVS's obstacle range, the rest the defaults above.
/// The one place it is made: evaluation, training, the nodes and the planner's check of the weight file all
/// call it, so a model's stored normalisation is compared with what its states will really be.
/// One decision's velocity space, actions and network state, as every front end builds them from its observation
/// (dovs_node, the evaluation's and the training's Episode): the DOVS of `obs` built into `dovs` by `builder`, the 8
/// actions around the robot's velocity towards obs.goal, and the state (buildState with `previous_grid`,
/// `previous_choice` and `history`; with person tokens `history` first takes this observation's tracks).
class TrackHistory;
struct VelocitySpaceStep {
  ActionSet actions;
  StateVector state;
};
void buildVelocitySpaceStep(const Observation& obs, const RobotLimits& limits, const StateNormalization& norm,
                            DovsBuilder& builder, VelocitySpace& dovs, VelocitySpaceStep& out,
                            TrackHistory* history = nullptr, const std::vector<float>* previous_grid = nullptr,
                            int previous_choice = kNoPreviousChoice);

/// The metadata key of a network's state parameters (docs/weight_format.md, "Provenance").
constexpr const char* kStateParametersKey = "state parameters";
/// Everything the network state depends on beyond its normalisation and layout (which the weight file's header and
/// normalisation entries hold): every DOVS parameter (`dovs/NAME`, dovsParameterNames) and the robot's acceleration
/// limits, control period and radius (`robot/a_v`, `robot/a_w`, `robot/dt`, `robot/radius`; the dynamic window and
/// the inflation), as "NAME=VALUE" words separated by spaces, values written to round-trip. The trainer writes it
/// into every network's metadata as `state parameters: ...`.
std::string stateParametersText(const RobotLimits& limits, const DovsConfig& dovs);
/// Empty when `metadata` (a weight file's text) has no `state parameters:` line, or when every parameter it names
/// equals this configuration's within `rel_tol`; otherwise a message naming each one that differs, with both values
/// ("dovs/safety_factor is 1.2 here, the model was trained with 1.5"), or a word that cannot be read.
std::string stateParametersMismatch(const std::string& metadata, const RobotLimits& limits, const DovsConfig& dovs,
                                    double rel_tol = 1e-6);

StateNormalization stateNormalization(const RobotLimits& limits, const DovsConfig& dovs);

/// Thrown by the state functions for bad input (NaN/inf robot state or goal, wrong grid size, bad
/// normalisation); the message names the item.
class StateError : public std::runtime_error {
 public:
  explicit StateError(const std::string& what) : std::runtime_error(what) {}
};

/// The graded grid (docs/dovs.md, "The graded grid"), row-major like VelocitySpace::grid(): each cell's constant
/// velocity is rolled out over `horizon_s` (0.1 s steps) against the obstacles and walls the DOVS modelled
/// (obs, enlarged as the DOVS enlarges them, moving at their constant (v, w)); with t its earliest contact
/// (horizon_s when none), a cell the DOVS finds free holds t / T and an unsafe one t / T - 1, so the sign is the
/// +1 / -1 grid's and the size says how soon contact comes. Infeasible cells hold -1. Throws StateError for a
/// horizon outside [0.5, 30] s.
std::vector<float> gradedGrid(const VelocitySpace& dovs, const Observation& obs, double horizon_s);

/// The two extra grid channels (docs/dovs.md "Grid channels"), 800 values: the dynamic window, then the goal line,
/// each 20 x 20 row-major like VelocitySpace::grid(). A cell holds +1 when it meets the rhombus of velocities
/// reachable from the robot's current (v, w) in one control period (the window of the actions) / the goal line of
/// the actions (the circle through the goal, or turning in place to face a goal behind), and -1 otherwise.
/// Throws StateError for a NaN/inf robot twist or goal, or a grid other than 20 x 20.
std::vector<float> windowGoalChannels(const VelocitySpace& dovs, const Observation& obs);

/// The 8 normalised features of `obs` (robot twist, goal) and the DOVS's closest obstacle.
FeatureVector computeFeatures(const VelocitySpace& dovs, const Observation& obs, const StateNormalization& norm);

/// Remembers where each tracked obstacle was (fixed frame, by MovingObstacle::id) over the last kTokenHistory_s and
/// a little more, so that a person token can carry its position 1 s before. One per decision-maker: an episode, a
/// dovs_node. Obstacles without an id (-1) are not remembered.
class TrackHistory {
 public:
  /// Records the positions of `obstacles` at `stamp_s`. A stamp earlier than the last one (a time jump back, a new
  /// episode) clears the history first. Throws StateError for a NaN/inf stamp.
  void update(double stamp_s, const std::vector<MovingObstacle>& obstacles);
  /// The position of track `id` closest to kTokenHistory_s before the last update, or the oldest one kept when the
  /// track is younger; false when the track was never seen.
  bool positionBefore(int id, Vec2& out) const;
  void clear();

 private:
  struct Sample {
    double stamp_s;
    Vec2 position;
  };
  double last_stamp_s_ = -1e300;
  std::vector<std::pair<int, std::vector<Sample>>> tracks_;  // by id, samples oldest first
};

/// The person tokens of `obs` (norm.person_tokens x kPersonTokenSize floats; see kPersonTokenSize): its obstacles
/// nearest first (by centre distance minus radius), at most norm.person_tokens, then empty slots. `history` gives the
/// positions 1 s before (null, or a track it does not know: the current position). Positions are scaled by
/// norm.obstacle_clearance_scale_m, velocities by norm.obstacle_speed_scale_mps, the rest by the kToken* scales; every
/// value is clipped to +-kTokenClip. Throws StateError for a NaN/inf robot pose or obstacle.
std::vector<float> personTokens(const Observation& obs, const StateNormalization& norm,
                                const TrackHistory* history = nullptr);

/// The wall rays of `obs` (norm.wall_rays floats): along directions k * 2 pi / wall_rays (k = 0 straight ahead,
/// counter-clockwise) from the robot's centre, the distance to the nearest of obs.segments over
/// norm.obstacle_clearance_scale_m, 1 when none is nearer.
std::vector<float> wallRays(const Observation& obs, const StateNormalization& norm);

/// The route points of `obs` (norm.route_points x 2 floats): the points kRoutePointSpacing_m, 2 x kRoutePointSpacing_m,
/// ... along obs.route_ahead from its first point (along the straight line from the robot to obs.goal when it is
/// empty), the route's end for every point beyond it; x, y in the robot frame over norm.obstacle_clearance_scale_m,
/// clipped to +-kTokenClip. Throws StateError for a NaN/inf route point.
std::vector<float> routePoints(const Observation& obs, const StateNormalization& norm);

/// The network input: the DOVS grid row-major (first 400, row 0 = highest v, see VelocitySpace::grid()), with
/// norm.grid_channels = 3 followed by windowGoalChannels (800 more), with norm.grid_channels = 2 by
/// `previous_grid` (the first 400 values of the previous decision's state; the current grid when null, i.e. at an
/// episode's first decision), then the 8 features, then with norm.previous_action the one-hot of `previous_choice`
/// (an action 0..7 or kPreviousChoiceOther; kNoPreviousChoice leaves the 9 inputs at 0). With
/// norm.grid_contact_horizon_s = T > 0 the DOVS grid is graded (gradedGrid). Throws StateError unless
/// dovs.gridSize() == 20, when `previous_grid` has another size or NaN/inf values, or `previous_choice` is none of
/// those. With norm.wall_rays, norm.route_points and norm.person_tokens, wallRays, routePoints and personTokens (with
/// `history`) follow.
StateVector buildState(const VelocitySpace& dovs, const Observation& obs, const StateNormalization& norm,
                       const std::vector<float>* previous_grid = nullptr, int previous_choice = kNoPreviousChoice,
                       const TrackHistory* history = nullptr);

}  // namespace dqn_dovs
