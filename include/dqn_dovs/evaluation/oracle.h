// The physical limit of a benchmark episode: a planner that knows the future exactly.
//
// Where the obstacles and the people ignore the robot, their future is fixed by the scenario and the seed. At every
// control period the oracle copies the world, rolls the obstacles and people forward over its horizon with the
// robot braking where it is, and searches the robot's dynamic
// window period by period (a time-expanded kinodynamic search under the same limits, the same integration and the
// same success rule as the episode) for the command sequence that reaches the goal soonest without touching
// anything; it executes the first command and searches again at the next period. Static geometry (walls and static
// discs) is kept in a clearance field and the cost to go is the shortest path around it (not the straight line), over
// cells the search itself could pass, so rooms, corridors, doorways and furniture do not trap it.
//
// Among people who react to the robot (PeopleConfig::mix with attentive or impassive people) that future depends on
// what the robot does: the oracle then steps a copy of the true simulator along each candidate sequence (the best
// of every first command), the people reacting as they would, takes the first that reaches the goal or stays free
// over the horizon, and otherwise searches again against the people's motion around the candidate that stayed free
// longest (three searches at most).
//
// It is not deployable (it reads the simulator's future); it bounds what any planner could do on the same
// episodes. The search is a beam search: an episode it solves is solvable; one it fails may not be, so the
// evaluation runs such an episode again with wider searches (defaultOracleRetries) until one solves it (`note` says
// which, or when every searched trajectory collided).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "dqn_dovs/common/geometry.h"
#include "dqn_dovs/perception/people_predictor.h"
#include "dqn_dovs/planning/planner.h"
#include "dqn_dovs/sim/world.h"

namespace dqn_dovs {

struct OracleConfig {
  int horizon_periods = 20;          ///< control periods searched ahead (20 x 0.2 s = 4 s)
  int beam_width = 160;              ///< nodes kept per period
  int window_samples = 2;            ///< lattice steps per half-diagonal of the dynamic window (13 commands at 2)
  double grid_cell_m = 0.1;          ///< clearance field and path-length grid
  double clearance_margin_m = 0.02;  ///< clearance kept beyond touching (m): the search checks 4 instants a period
  /// A sequence's end at the horizon is safe when one of a few held commands (brake, hold, turn either way at full
  /// rate, speed up) keeps it free this many periods further; unsafe ends rank after every safe one. 0: off.
  int terminal_periods = 0;
  double scan_period_s = 0.1;      ///< the episode steps the world in chunks of this (a velocity change each)
  double goal_tolerance_m = 0.15;  ///< success as the episode counts it: this close to the goal ...
  double goal_speed_mps = 0.2;     ///< ... and slower than this
  /// Diagnostic (not the ceiling when set): how many control periods of the simulator's true future the search
  /// reads; from then on every obstacle and person goes on at the constant (speed, turn rate) it has at that moment,
  /// as a planner with perfect information could predict it. -1: the whole horizon (the oracle); 0: a constant-
  /// velocity prediction from now. Tells what the prediction costs and what the search itself finds
  /// (docs/planners.md, "What the prediction costs").
  int true_future_periods = -1;
  /// With true_future_periods >= 0: people (not the discs) go on by the social force model instead, among each
  /// other and the walls, each toward no destination at its velocity of that moment (a prediction from what a
  /// tracker and a map give; the destinations, waits and groups stay unknown).
  bool social_prediction = false;
  /// With true_future_periods >= 0: every predicted moving body's radius grows by this much per second of
  /// prediction (m/s), as the DOVS's prediction_growth does.
  double prediction_growth_mps = 0.0;
  /// With true_future_periods = 0 and no social_prediction: the people's acceleration over the last control period
  /// (their velocity now against at the previous decision, what a tracker could estimate) is carried on for this
  /// long (s), then their velocity stays; 0: constant velocity.
  double acceleration_prediction_s = 0.0;
  /// With true_future_periods = 0: a people predictor file (PeoplePredictor): the people move as it predicts from
  /// their last second and their neighbours (linearly between its steps, then on at its last step's velocity); the
  /// discs at constant velocity. Empty: none.
  std::string learned_prediction;
  std::string validate() const;
};

/// The searches the evaluation's `oracle` tries after its first one on an episode that one did not solve, each as
/// NAME=VALUE,... applied to the first search's parameters, in order, until one succeeds (dqn_dovs_eval
/// --oracle-retries): its end checked for a way on (terminal_periods), then longer horizons and wider beams. Each
/// one is a full episode of its own; the world's future does not depend on the robot, so any search that reaches the
/// goal shows the episode solvable.
std::vector<std::string> defaultOracleRetries();

/// Applies NAME=VALUE,... (setOracleParameter for each) to config; "" on success, otherwise why not.
std::string applyOracleParameters(OracleConfig& config, const std::string& spec);

/// The searches of `specs` (each NAME=VALUE,... applied to a copy of `base`) into `searches`; "" on success,
/// otherwise "oracle retry 'SPEC': why" for the first one that names no parameter or is not valid.
std::string oracleRetrySearches(const OracleConfig& base, const std::vector<std::string>& specs,
                                std::vector<OracleConfig>& searches);

/// Sets one search parameter by name (horizon_periods, terminal_periods, beam_width, window_samples, grid_cell_m,
/// clearance_margin_m, true_future_periods, social_prediction: 0 or 1, prediction_growth_mps,
/// acceleration_prediction_s, learned_prediction: a file); "" on success, otherwise why not (unknown name, not a
/// number). Call validate() after.
std::string setOracleParameter(OracleConfig& config, const std::string& name, const std::string& value);

class OraclePlanner : public Planner {
 public:
  /// `retries`: the searches runEpisode tries, each a whole episode, when this one does not reach the goal.
  explicit OraclePlanner(const OracleConfig& config = OracleConfig{}, std::vector<OracleConfig> retries = {});
  const std::vector<OracleConfig>& retries() const { return retries_; }
  std::string name() const override { return "oracle"; }
  void reset() override;
  /// The world it may read at the next decision (the episode's, true state). Must be set before decide().
  void setWorld(const sim::World* world) { world_ = world; }
  /// Throws PlannerError when no world was set.
  PlannerDecision decide(const PlannerInput& input) override;
  /// The bodies the search checks against, as decide() computes them from `world`: one list per collision check
  /// (4 per control period over the horizon and terminal_periods; index 0 is a quarter period from now), obstacles then
  /// people. With acceleration_prediction_s it also remembers the people's velocities, for the next call's
  /// acceleration.
  const std::vector<std::vector<Circle>>& futureBodies(const sim::World& world);

 private:
  struct Node {
    Pose2 pose;
    Twist2 twist;
    double cost = 0.0;  ///< time so far + cost to go
    int first = -1;     ///< index of the first command of its sequence
    int parent = -1;    ///< index of its parent in the beam of the depth before
    Twist2 command;     ///< the command that led to it from its parent
  };
  /// A command sequence the search found, with its cost (sequences that reach the goal rank first).
  struct Candidate {
    std::vector<Twist2> commands;
    double cost = 0.0;
  };
  /// What a sequence does in a copy of the true simulator.
  struct Rollout {
    bool collided = false;
    bool goal = false;
    int free_periods = 0;  ///< control periods before the first contact (all when none)
  };
  /// One beam search against future_. With `candidates`, fills them (every sequence that reaches the goal, the
  /// best sequence of every first command, the one that stays free longest when all collide; cheapest first)
  /// and searches the whole horizon; without, returns as soon as a sequence reaches the goal.
  PlannerDecision search(const sim::World& world, std::vector<Candidate>* candidates);
  /// Steps a copy of `world` along `commands` as the episode does (then braking, up to `substeps` / 4 control
  /// periods), the people reacting to the robot; with `bodies`, the obstacles' and people's bodies at every
  /// collision check of those periods.
  Rollout rollTrue(const sim::World& world, const std::vector<Twist2>& commands, int substeps,
                   std::vector<std::vector<Circle>>* bodies) const;
  /// Static geometry of the episode: clearance to the walls and path length to the goal on a grid.
  void prepareStatics(const sim::World& world);
  double wallClearance(const Vec2& p) const;
  double pathToGoal(const Vec2& p) const;
  /// The obstacles' and people's bodies at every physics sub-step of the horizon.
  void rollObstacles(const sim::World& world, double sub_dt, int substeps);
  /// Whether a robot centred at p touches a wall or a body of physics sub-step `substep` (kept `radius` away).
  bool touches(const Vec2& p, double radius, int substep) const;
  /// Whether a node at the horizon stays free for terminal_periods more under one of the held commands.
  bool terminalSafe(const Pose2& pose, const Twist2& twist, const RobotLimits& limits, int from_substep) const;

  OracleConfig config_;
  std::vector<OracleConfig> retries_;
  const sim::World* world_ = nullptr;
  bool statics_ready_ = false;
  Vec2 goal_ = Vec2::Zero();
  // Grids (row-major, origin at grid_origin_).
  Vec2 grid_origin_ = Vec2::Zero();
  int grid_w_ = 0, grid_h_ = 0;
  std::vector<float> clearance_;             ///< m to the nearest wall, per cell centre
  std::vector<float> to_goal_;               ///< m of free path to the goal, per cell centre (inf: unreachable)
  std::vector<std::vector<Circle>> future_;  ///< bodies per sub-step (index 0 = now + sub_dt)
  std::vector<std::vector<Node>> history_;   ///< the search's beam per depth (index 0: the robot now)
  // The people's velocities at the previous decision and its time (acceleration_prediction_s).
  std::vector<Vec2> previous_velocities_;
  double previous_time_s_ = 0.0;
  /// OracleConfig::learned_prediction, with the people's positions at the last decisions (by person index).
  std::unique_ptr<PredictedArcs> learned_;
  /// The people's positions at every step of the predictor's future, as it predicts them now.
  std::vector<std::vector<Vec2>> learnedFuture(const sim::World& world);
};

}  // namespace dqn_dovs
