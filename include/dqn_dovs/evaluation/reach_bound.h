// An upper bound of the physical limit of a benchmark episode: what no robot within the Turtlebot's limits can do.
//
// The oracle (oracle.h) searches for a way through and so bounds the limit from below: an episode it solves is
// solvable, one it fails may still be. The bound here works the other way round. The obstacles and the people
// ignore the robot, so their future is fixed by the seed; the bound rolls it forward period by period and keeps the
// set of every position the robot's centre could hold at the end of each control period, on a grid, under a
// relaxation of the robot that can only do more than the robot: it moves in any direction (not along its heading),
// at up to v_max, stops and turns at once (only its first start from rest is held to the acceleration limit), and
// touches nothing only at the end of each period (the episode checks every physics step). A cell is kept when some
// point in it could be clear of the walls and the bodies (the cell's centre is within half a cell diagonal of it),
// and a cell is reached from one kept at the previous period within v_max * period plus a cell diagonal.
//
// So every trajectory the real robot can drive without contact stays inside the sets: when the goal region is out of
// them until the episode's step limit, no planner can succeed there; when the set becomes empty, a collision is
// certain (truly unavoidable); when the goal region is reached at period k, no planner arrives before k periods.
// The relaxation makes the bound optimistic, never wrong, up to one assumption: the world stepped with the robot
// standing aside gives the bodies' future within `body_margin_m` of the one the episode steps (the physics sub-step
// depends on the robot's speed), and the bodies are shrunk by that margin.
#pragma once

#include <string>

#include "dqn_dovs/planning/planner.h"
#include "dqn_dovs/sim/world.h"

namespace dqn_dovs {

struct ReachBoundConfig {
  double cell_m = 0.01;         ///< grid cell (m); each period adds one cell diagonal of slack to v_max * period
  double body_margin_m = 0.02;  ///< bodies shrunk by this much (m): the future stepped aside against the episode's
  double grid_margin_m = 1.0;   ///< the grid covers the walls, the start and the goal with this much around (m)
  double goal_tolerance_m =
      0.15;                    ///< success as the episode counts it: the centre this close to the goal at a period end
  int max_periods = 500;       ///< the episode's step limit (decisions)
  double scan_period_s = 0.1;  ///< the world is stepped in chunks of this, as the episode steps it
  std::string validate() const;
};

/// Sets one grid parameter by name (cell_m, body_margin_m, grid_margin_m); "" on success, otherwise why not (unknown
/// name, not a number). Call validate() after.
std::string setReachBoundParameter(ReachBoundConfig& config, const std::string& name, const std::string& value);

struct ReachBoundResult {
  enum class Verdict {
    kReachable,  ///< the goal region is reachable at the end of period `periods` (no robot gets there sooner)
    kBoxedIn,    ///< no position within the limits is clear at the end of period `periods`: a collision is certain
    kOutOfTime,  ///< clear positions remain, but the goal region is out of reach within max_periods
  };
  Verdict verdict = Verdict::kOutOfTime;
  int periods = 0;         ///< see Verdict
  double time_s = 0.0;     ///< periods * control period
  bool left_grid = false;  ///< the set touched the grid's edge at `periods`: counted reachable (it cannot tell)
};

/// The bound from `world` as it stands (a copy is stepped; `world` is left untouched). Needs people who ignore the
/// robot (throws PlannerError otherwise, and for a bad configuration).
ReachBoundResult reachBound(const sim::World& world, const ReachBoundConfig& config);

/// The bound as a method of the evaluation (`dqn_dovs_eval --methods bound,...`): runEpisode asks it for the
/// episode's verdict instead of running decisions (reachable -> success at its earliest time, boxed in ->
/// collision, out of time -> timeout). decide() is not for driving a robot and throws PlannerError.
class ReachBoundPlanner : public Planner {
 public:
  explicit ReachBoundPlanner(const ReachBoundConfig& config = ReachBoundConfig{});
  std::string name() const override { return "bound"; }
  PlannerDecision decide(const PlannerInput& input) override;
  const ReachBoundConfig& config() const { return config_; }

 private:
  ReachBoundConfig config_;
};

}  // namespace dqn_dovs
