// One navigation episode run without ROS: simulator -> LIDAR -> tracker -> DOVS -> state, with the
// paper's reward and termination. The trainer (through the Python module) and the evaluation CLI both
// drive this class, so training and evaluation run exactly the code the robot runs. In worlds with walls the
// robot follows a route as planner_node does (RouteGuide): the DOVS, the state and the planners see its subgoal.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "dqn_dovs/common/types.h"
#include "dqn_dovs/dovs/actions.h"
#include "dqn_dovs/dovs/dovs.h"
#include "dqn_dovs/dovs/state.h"
#include "dqn_dovs/perception/people_predictor.h"
#include "dqn_dovs/perception/tracker.h"
#include "dqn_dovs/planning/planner.h"
#include "dqn_dovs/planning/route.h"
#include "dqn_dovs/sim/scenario.h"
#include "dqn_dovs/sim/world.h"

namespace dqn_dovs {

/// Reward and termination constants (DESIGN §7, the paper's values).
/// The defaults are the paper's; the terms after max_steps price the yardstick (evaluation/yardstick.h) and are off
/// by default. The trainer sets them by name (setRewardParameter, its config's `reward:` section).
struct RewardConfig {
  double goal_reward = 15.0;        ///< terminal reward for reaching and stopping at the goal
  double collision_reward = -15.0;  ///< terminal reward for a collision the robot is at fault for (robotAtFault)
  double distance_weight = 2.5;     ///< r = distance_weight * (d(t-1) - shaping_gamma d(t)), d along the route if any
  double safe_distance_m = 0.2;     ///< clearance below which r_safe applies
  double safe_weight = 0.1;         ///< r_safe = -safe_weight * |safe_distance_m - clearance|
  double goal_tolerance_m = 0.15;   ///< success: distance to goal below this ...
  double goal_speed_mps = 0.2;      ///< ... and linear speed below this
  int max_steps = 500;              ///< decisions before the episode is truncated (timeout)
  /// Terminal reward for a collision the robot is not at fault for (walked into while at rest long enough); NaN:
  /// collision_reward, as the paper does not tell the two apart. Must lie in [collision_reward, 0).
  double hit_at_rest_reward = std::numeric_limits<double>::quiet_NaN();
  /// The progress term as potential-based shaping with potential -distance_weight d: gamma-consistent when it is
  /// the trainer's discount (Ng et al., 1999); 1 is the paper's difference of distances. In (0, 1].
  double shaping_gamma = 1.0;
  /// Per second of a control period ending with a person's body within kIntimateDistance_m of the moving robot's.
  double intimate_weight = 0.0;
  /// Per second of a control period ending with the robot blocking a passage (inPassageMiddle, someone held up).
  double blocking_weight = 0.0;
  /// The collision reward of a contact: collision_reward when the robot was at fault, hit_at_rest_reward otherwise.
  double collisionReward(bool at_fault) const {
    return at_fault || std::isnan(hit_at_rest_reward) ? collision_reward : hit_at_rest_reward;
  }
  std::string validate() const;
};
/// Sets a reward parameter by its field name ("goal_reward", ..., "blocking_weight"); "" on success, otherwise the
/// name and the reason (unknown name, not a number). Call validate() after.
std::string setRewardParameter(RewardConfig& config, const std::string& name, const std::string& value);
/// Every name setRewardParameter accepts, in declaration order.
std::vector<std::string> rewardParameterNames();

/// The route of an episode (docs/simulator.md, "Routes in episodes"): in a scenario with static segments
/// (walls, furniture; not the paper's room, whose only walls are its own four) the robot plans a route on the grid
/// of the known static geometry (the walls, the furniture and the static discs, not the people) and follows it with
/// RouteGuide as planner_node does: the DOVS, the state and the planners see the route's subgoal until the goal
/// itself replaces it. Success, collisions and timeouts stay those of the final goal.
struct EpisodeRouteConfig {
  /// Whether scenarios with static segments get a route (dqn_dovs_eval --route, the training world option
  /// `route`; EvalConfig::route sets it).
  bool enabled = true;
  double resolution_m = 0.05;  ///< cell side of the grid of the known static geometry, m
  RouteConfig planner;         ///< the route planner (its robot_radius_m is replaced by world.robot.radius)
  RouteGuideConfig guide;      ///< following it: planner_node's route/* defaults
  std::string validate() const;
};

/// A diagnostic of what the tracker costs the planners (docs/tracker.md, "Which part of the tracks costs the
/// planners"): each confirmed track within kTrackTruthMatch_m of a true body (one to one, nearest first by total
/// distance) is given part of that body's true state before the planners see it. Tracks that match no body (false
/// tracks) stay as they are; bodies no track follows (hidden, not yet confirmed, out of the field of view) stay unseen.
/// Not deployable: it reads the simulator.
enum class TrackTruth {
  kNone = 0,    ///< the tracks as the tracker gives them
  kMotion = 1,  ///< the true speed, heading, turn rate and static flag; the track's centre and radius
  kState = 2,   ///< the true centre, radius and motion: the truth of exactly the bodies that are tracked
};
constexpr double kTrackTruthMatch_m = 0.5;
const char* trackTruthName(TrackTruth t);
/// Parses none / motion / state; throws std::invalid_argument naming the value otherwise.
TrackTruth parseTrackTruth(const std::string& name);

struct EpisodeConfig {
  sim::WorldConfig world;  ///< simulator (robot limits live in world.robot)
  TrackerConfig tracker;   ///< obstacle tracker used when perfect_info is false
  DovsConfig dovs;         ///< velocity-space model
  RewardConfig reward;
  EpisodeRouteConfig route;      ///< the route in worlds with walls
  double scan_period_s = 0.1;    ///< LIDAR period; must divide the control period world.robot.dt
  bool perfect_info = false;     ///< true: the planner sees the simulator's ground truth (comparison only)
  double sensor_warmup_s = 0.3;  ///< the robot senses this long, standing still, before the episode starts
  /// A people predictor file (evaluation/people_predictor.h): the people the planners see (with the tracker, its
  /// tracks when it pairs legs into people; with perfect_info, the world's people, not the room's discs) move on the
  /// arc that fits their learned prediction instead of at their present (speed, turn rate), among the world's walls.
  /// Empty: none (docs/planners.md, "A learned prediction of the people").
  std::string people_predictor;
  /// The tracker is given the map a robot would have (the world's walls and furniture, static discs included, not
  /// the people), placed by a perfect localisation: what lies on it is never tracked (KnownStructure). With the
  /// tracker only.
  bool tracker_map = false;
  /// The velocity space also takes the map's walls and the outlines of its furniture within map_range_m of the
  /// robot, placed by a perfect localisation, beside what the scan shows (dovs_node's use_map): a table edge seen
  /// at a glancing angle, or not yet seen, is known all the same. With the tracker only.
  bool dovs_map = false;
  double map_range_m = 4.0;  ///< dovs_node's map_range
  /// With the tracker only: how much of the truth its tracks are given (TrackTruth; a diagnostic).
  TrackTruth track_truth = TrackTruth::kNone;
  std::string validate() const;
};

enum class Outcome { kRunning = 0, kSuccess = 1, kCollision = 2, kTimeout = 3 };
const char* outcomeName(Outcome o);

struct StepResult {
  double reward = 0.0;
  bool terminated = false;  ///< success or collision (no bootstrapping past it)
  bool truncated = false;   ///< step limit reached (bootstrap from the final state)
  Outcome outcome = Outcome::kRunning;
};

class Episode {
 public:
  explicit Episode(const EpisodeConfig& config);

  /// Starts a new episode on `scenario`; `seed` drives sensor noise.
  void reset(const sim::Scenario& scenario, uint64_t seed);

  /// Applies `command` (clipped to the dynamic window and the feasible set) for one control period:
  /// the world advances, the LIDAR scans every scan_period_s and feeds the tracker, then the next
  /// decision context (observation, DOVS, actions, state) is built. Throws std::logic_error when the
  /// episode has already ended.
  StepResult step(const Twist2& command);
  /// step() with the velocity of action `a` of the current action set (an invalid action throws).
  StepResult stepAction(int a);
  /// Holonomic robot mode (the `orca_holonomic` baseline only): the robot moves for one control period at the
  /// fixed-frame velocity `velocity` (m/s, norm clipped to v_max, no acceleration limit; World::stepHolonomic).
  /// Sensing, reward and termination are those of step().
  StepResult stepHolonomic(const Vec2& velocity);
  /// Executes a planner's decision: stepHolonomic(*d.holonomic_velocity) when the planner drives a holonomic
  /// robot, step(d.command) otherwise. The next state's previous choice (DovsConfig::previous_action) is d.action
  /// when it is one of the 8 actions, kPreviousChoiceOther otherwise (as after step() and stepHolonomic()).
  StepResult stepDecision(const PlannerDecision& d);

  // Decision context for the current step.
  const Observation& observation() const { return observation_; }
  /// The tracker's last scene (empty with perfect_info).
  const TrackedScene& trackedScene() const { return tracker_.scene(); }
  const VelocitySpace& dovs() const { return dovs_; }
  const ActionSet& actions() const { return actions_; }
  const Eigen::VectorXf& state() const { return state_; }
  const StateNormalization& normalization() const { return normalization_; }

  // Episode status and statistics.
  Outcome outcome() const { return outcome_; }
  bool done() const { return outcome_ != Outcome::kRunning; }
  int steps() const { return steps_; }
  double time_s() const { return world_.time_s() - start_time_s_; }  ///< since the start (after warm-up)
  double pathLength_m() const { return path_length_m_; }
  double minClearance_m() const { return min_clearance_m_; }
  int dangerSteps() const { return danger_steps_; }  ///< steps with clearance < reward.safe_distance_m
  const sim::World& world() const { return world_; }
  const sim::Scenario& scenario() const { return world_.scenario(); }
  const std::vector<Pose2>& trajectory() const { return trajectory_; }
  const EpisodeConfig& config() const { return config_; }
  /// The current decision context as the planners read it (pointers into this episode).
  PlannerInput plannerInput() const;

  // The route (docs/simulator.md, "Routes in episodes"), in the odom frame (the room's at the start).
  /// Whether this episode follows a route (route.enabled, static segments, and a route was found).
  bool hasRoute() const { return route_guide_.hasRoute(); }
  const RouteGuide& routeGuide() const { return route_guide_; }
  /// The last control period's guidance: the subgoal the context was built for, the route remaining.
  const RouteGuidance& routeGuidance() const { return guidance_; }
  /// Why a scenario with static segments has no route (the planner's reason); empty otherwise.
  const std::string& routeError() const { return route_error_; }

 private:
  void sense();         // scan + tracker update at the current world time
  void buildContext();  // observation -> DOVS, actions, state
  void planRoute();     // the grid of the known static geometry and the route from the robot to the goal
  // EpisodeConfig::track_truth: the observation's tracks take `what` of the true body each follows.
  void giveTracksTruth(const std::vector<MovingObstacle>& truth, TrackTruth what);
  /// The obstacle points the robot sees now (odom frame), for the route's blocked check: the last scan's returns,
  /// or with perfect information points around the true bodies.
  std::vector<Vec2> routeScanPoints() const;
  /// The yardstick's price of the control period just run (RewardConfig::intimate_weight, blocking_weight).
  double yardstickCost() const;
  // Runs one control period, moving the robot with `move_robot(dt_s)` at each scan, then scores it.
  StepResult advance(const std::function<void(double)>& move_robot);
  // step() recording `choice` (an action, or kPreviousChoiceOther) as the next state's previous choice.
  StepResult stepChoice(const Twist2& command, int choice);

  EpisodeConfig config_;
  sim::World world_;
  ObstacleTracker tracker_;
  std::unique_ptr<PredictedArcs> predicted_arcs_;    ///< EpisodeConfig::people_predictor
  std::unique_ptr<KnownStructure> known_structure_;  ///< EpisodeConfig::tracker_map, in the world's frame
  std::vector<Segment> map_segments_;                ///< EpisodeConfig::dovs_map: walls and furniture outlines (world)
  DovsBuilder dovs_builder_;
  StateNormalization normalization_;
  LaserScan2 scan_;
  Pose2 scan_laser_;                             // where the robot believed its laser was at scan_
  std::unique_ptr<RoutePlanner> route_planner_;  // null: no route this episode
  RouteGuide route_guide_;
  RouteGuidance guidance_;
  std::string route_error_;
  Observation observation_;
  VelocitySpace dovs_;
  ActionSet actions_;
  Eigen::VectorXf state_;
  std::vector<float> previous_grid_;  // the last decision's first grid channel (grid_channels = 2), empty at reset
  int previous_choice_ = kNoPreviousChoice;  // what the last step ran (previous_action = 1), none at reset
  TrackHistory track_history_;  // where the tracks were, for the person tokens' history (person_tokens > 0)
  Outcome outcome_ = Outcome::kRunning;
  int steps_ = 0;
  double path_length_m_ = 0.0;
  double min_clearance_m_ = 0.0;
  int danger_steps_ = 0;
  double start_time_s_ = 0.0;
  std::vector<Pose2> trajectory_;
};

}  // namespace dqn_dovs
