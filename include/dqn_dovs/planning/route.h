// Global route planning on an occupancy grid, for a local planner that only drives straight at a point goal: A*
// over the grid inflated by the robot radius (costs rising near obstacles, as costmap_2d's inflation), a route as
// a short polyline, and the subgoal on it to hand the local planner as the robot advances. The DQN-DOVS network
// was trained on goals 4-12 m away (its goal-distance input saturates at 10 m), so a goal across rooms reaches it
// as a sequence of subgoals a lookahead ahead on the route, then as the goal itself. ROS-free.
//
// The grid has its own small type (the encoding of nav_msgs/OccupancyGrid) so that planning links nothing of the
// simulator; planning/route_map.h converts a sim::OccupancyMap.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "dqn_dovs/common/geometry.h"

namespace dqn_dovs {

/// A route planner that cannot be built: the message names the grid or configuration field and the reason.
class RouteError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// An occupancy grid as nav_msgs/OccupancyGrid carries it. Cell (i, j) is column i and row j from the lower-left
/// corner, covering [i, i + 1) x [j, j + 1) cells from the origin, in the origin's frame (the map frame).
struct RouteGrid {
  double resolution_m = 0.05;  ///< cell side, m
  Pose2 origin;                ///< pose of the grid's lower-left corner in the map frame (m, m, rad)
  int width = 0;               ///< cells per row
  int height = 0;              ///< rows
  /// Row-major, bottom row first: a negative value is unknown, otherwise the occupancy probability in percent
  /// (sim::MapCell's -1 / 0 / 100 fit as they are).
  std::vector<int8_t> cells;
};

/// Parameters of the route planner. Defaults live here only.
struct RouteConfig {
  /// Radius of the robot's footprint, m. A cell is lethal (the robot's centre never enters it) when its centre is
  /// closer than this to the near edge of an occupied cell (centre distance minus half a cell).
  double robot_radius_m = 0.2;
  /// Beyond the radius, cells closer than this further distance to an obstacle cost more to cross, m
  /// (costmap_2d's inflation_radius minus the inscribed radius).
  double inflation_m = 0.4;
  /// The inflation cost of a cell at clearance c (radius <= c < radius + inflation_m) is exp(-k (c - radius)) with
  /// k this value, 1/m (costmap_2d's cost_scaling_factor): 1 against the lethal zone, decaying away from it.
  double cost_scaling_1pm = 8.0;
  /// Crossing a cell costs its length times 1 + inflation_weight x its inflation cost.
  double inflation_weight = 3.0;
  /// Whether unknown cells may be crossed (move_base's allow_unknown). Unknown cells never make others lethal.
  bool allow_unknown = true;
  /// An unknown cell's crossing costs its length times this much more (with allow_unknown).
  double unknown_penalty = 1.0;
  /// A cell whose occupancy is at least this (percent) is occupied; below it, free (map_server's 0.65).
  int occupied_threshold = 65;
  /// A lethal start (the robot pressed against a wall, localisation noise) is moved to the nearest non-lethal
  /// cell within this distance, m; farther than that the start is refused.
  double start_search_radius_m = 0.5;
  /// Whether the cell path is shortened by line of sight (any-angle, not a staircase); the shortcuts never cross
  /// a cell more expensive than the costliest cell of the path they replace.
  bool shortcut = true;
  /// Largest grid side accepted, cells (a larger grid is refused rather than allocated).
  int max_cells_per_side = 4096;

  /// Empty when consistent, otherwise a message naming the offending field and why.
  std::string validate() const;
};

/// A planned route, or the reason there is none.
struct Route {
  bool found = false;  ///< false: `why` says why, `points` is empty
  /// Why there is no route, naming the point and the reason, e.g. "goal (3.20, 1.10) is inside an obstacle
  /// inflated by the robot radius 0.18 m"; empty when found.
  std::string why;
  /// The route in the map frame, from the start to the goal, simplified (no collinear points). The first point
  /// is the start as given, even when it was moved out of a lethal cell (the second point is then that cell).
  std::vector<Vec2> points;
  /// Arc length from the first point to each point, m (the same size as `points`).
  std::vector<double> arc_m;
  double length_m = 0.0;       ///< total length, m
  double start_moved_m = 0.0;  ///< how far a lethal start was moved to a free cell, m (0 when it was not)
};

/// Where a robot is along a route: RoutePlanner::subgoal advances it and never moves it back, so that a route
/// that passes near itself (a U-turn) is not projected onto its earlier part. Reset it (= {}) for a new route.
struct RouteFollower {
  size_t segment = 0;  ///< route segment (points[segment] -> points[segment + 1]) of the last projection
  double arc_m = 0.0;  ///< arc length of the last projection from the route's start, m
};

/// What the local planner is given at one instant, and the progress along the route.
struct RouteProgress {
  Vec2 subgoal = Vec2::Zero();    ///< the point to drive at, on the route, in line of sight of the robot
  bool final_goal = false;        ///< the subgoal is the route's last point (the goal itself)
  double remaining_m = 0.0;       ///< route length from the robot's projection to the goal, m (progress checks)
  double off_route_m = 0.0;       ///< distance of the robot from its projection on the route, m (replan when large)
  double projection_arc_m = 0.0;  ///< arc length of the projection from the route's start, m
};

/// A* routes on one occupancy grid. The distance transform and the cell costs are computed once at construction;
/// plan, subgoal and lineOfSight then only read them (a planner may be shared by threads).
class RoutePlanner {
 public:
  /// Throws RouteError naming the field and the reason when config.validate() fails, the grid's resolution is not
  /// positive, its size is not positive or beyond config.max_cells_per_side on a side, or its cell count is not
  /// width x height.
  RoutePlanner(const RouteGrid& grid, const RouteConfig& config = RouteConfig());

  /// The route from start to goal (map frame): 8-connected A* with the octile heuristic, each step costing its
  /// length x (1 + inflation_weight x inflation cost) (+ unknown_penalty in unknown cells). A lethal start is
  /// moved to the nearest non-lethal cell within start_search_radius_m. Not found, with the reason in `why`: a
  /// start or goal that is not finite or outside the grid, a goal in a lethal cell (or an unknown one without
  /// allow_unknown), a start with no free cell near it, start and goal not connected.
  Route plan(const Vec2& start, const Vec2& goal) const;

  /// The same with extra obstacle points (map frame; e.g. laser points not in the map) marked occupied and
  /// inflated like the map's own obstacles, for this plan only.
  Route plan(const Vec2& start, const Vec2& goal, const std::vector<Vec2>& extra_obstacles) const;

  /// The subgoal for a robot at `robot` (map frame) following `route`: the robot is projected onto the route,
  /// searching forward from the follower's last projection (never back) over 2 x lookahead_m (at least 1 m) of
  /// route; the subgoal is lookahead_m of route ahead of the projection (the goal once less remains), pulled back
  /// along the route until the straight line from the robot has line of sight on the lethal grid (lethal cells
  /// around the robot itself are ignored). Advances `follower`. A route that was not found gives the robot's own
  /// position with final_goal set. lookahead_m <= 0 or not finite is taken as 0.
  RouteProgress subgoal(const Route& route, const Vec2& robot, double lookahead_m, RouteFollower& follower) const;

  /// Whether the straight segment a -> b (map frame) crosses only cells the route may use (not lethal; not unknown
  /// without allow_unknown), inside the grid. With skip_start_lethal, lethal cells at the start of the segment
  /// (the robot already inside the inflated zone) are skipped until the first non-lethal one.
  bool lineOfSight(const Vec2& a, const Vec2& b, bool skip_start_lethal = false) const;

  /// Clearance of the cell containing `p` (map frame): the distance from its centre to the near edge of the
  /// closest occupied cell (centre distance minus half a cell), m; +inf without occupied cells, -1 outside.
  double clearance(const Vec2& p) const;

  /// Whether `p` (map frame) lies in a lethal cell (closer than the robot radius to an occupied cell). Outside
  /// the grid counts as lethal.
  bool lethal(const Vec2& p) const;

  const RouteConfig& config() const { return config_; }
  int width() const { return width_; }
  int height() const { return height_; }
  double resolution() const { return resolution_m_; }

 private:
  /// Cell classes of the base grid.
  enum class CellClass : uint8_t { kFree, kUnknown, kLethal, kBlockedUnknown };

  /// A* on the given cell arrays (the base grid's, or a copy with extra obstacles when with_extra).
  Route search(const Vec2& start, const Vec2& goal, const std::vector<uint8_t>& passable,
               const std::vector<float>& cost, bool with_extra) const;
  /// Step factor of a passable cell at clearance_m: 1 + weighted inflation cost (+ the unknown penalty).
  float stepCost(double clearance_m, bool unknown) const;
  bool toCell(const Vec2& p, int& i, int& j) const;
  Vec2 cellCentre(int i, int j) const;
  Vec2 toGrid(const Vec2& p) const;
  bool segmentClear(const Vec2& a, const Vec2& b, const std::vector<uint8_t>& passable, const std::vector<float>& cost,
                    float max_cost, bool skip_start_lethal) const;

  RouteConfig config_;
  double resolution_m_;
  Pose2 origin_;
  int width_;
  int height_;
  std::vector<CellClass> cls_;
  std::vector<float> clearance_m_;  ///< per cell, see clearance()
  std::vector<float> cost_;         ///< per cell step factor (1 + weighted inflation + unknown penalty)
  std::vector<uint8_t> passable_;   ///< per cell: the route may use it
};

/// A route through `points` as given (a nav_msgs/Path from another global planner): arc lengths and length filled;
/// not found, with `why`, when there are no points or one is NaN/inf.
Route routeFromPoints(std::vector<Vec2> points);

/// RoutePlanner::subgoal without a grid of its own: `visible` (unset: everything is visible) says whether the
/// robot sees a point on the route; the lookahead point is pulled back by pull_step_m until it does.
RouteProgress followRoute(const Route& route, const Vec2& robot, double lookahead_m, RouteFollower& follower,
                          const std::function<bool(const Vec2&, const Vec2&)>& visible = {}, double pull_step_m = 0.05);

/// Remaining length of `route` from arc length arc_m to its end, m (0 beyond the end).
double routeRemaining(const Route& route, double arc_m);

/// The point of `route` at arc length arc_m from its start (clamped to the route).
Vec2 routePointAt(const Route& route, double arc_m);

/// Whether any of `obstacle_points` (map frame; e.g. newly seen laser points) lies within clearance_m (normally
/// the robot radius) of the part of `route` from the follower's projection to ahead_m of route further: the
/// caller then replans (RoutePlanner::plan with the points as extra obstacles). Points behind the projection,
/// beyond ahead_m or farther to the side are ignored.
bool routeBlocked(const Route& route, const RouteFollower& from, const std::vector<Vec2>& obstacle_points,
                  double clearance_m, double ahead_m);

}  // namespace dqn_dovs
