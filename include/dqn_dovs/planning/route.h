// Global route planning on an occupancy grid, for a local planner that only drives straight at a point goal: A*
// over the grid inflated by the robot radius (costs rising near obstacles, as costmap_2d's inflation), a route as
// a short polyline, and the subgoal on it to hand the local planner as the robot advances. The DQN-DOVS network
// was trained on goals 4-12 m away (its goal-distance input saturates at 10 m), so a goal across rooms reaches it
// as a sequence of subgoals a lookahead ahead on the route, then as the goal itself. ROS-free.
//
// The grid has its own small type (the encoding of nav_msgs/OccupancyGrid) so that planning links nothing of the
// simulator; planning/route_map.h converts a OccupancyMap, routeGridFromGeometry rasterises known walls and
// furniture. RouteGuide is the route-following state every user shares (planner_node, the evaluation's Episode and
// with it the training environment): the subgoal of each control period, when the goal itself replaces it, and
// when to plan again.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
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
  /// (MapCell's -1 / 0 / 100 fit as they are).
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

/// An occupancy grid of known static geometry (a simulated world's walls and furniture): cells of
/// `resolution_m` covering [lo, hi] (grown to whole cells), occupied (100) where a segment or a disc comes within
/// half a cell diagonal of the cell's centre (so a wall never slips between two cells), free (0) elsewhere.
/// Throws RouteError when resolution_m is not positive, lo or hi is not finite, hi is not above lo, or a
/// segment or disc is not finite.
RouteGrid routeGridFromGeometry(const std::vector<Segment>& segments, const std::vector<Circle>& discs, const Vec2& lo,
                                const Vec2& hi, double resolution_m);

/// The map a robot would be given of a known world: routeGridFromGeometry over the box of the walls and of
/// `also_cover` (the robot's start, its goal), grown by two cells. What the evaluation plans routes on and what
/// simulator_node publishes as its map. Throws RouteError as routeGridFromGeometry (and for nothing to cover).
RouteGrid knownWorldGrid(const std::vector<Segment>& walls, const std::vector<Circle>& furniture,
                         const std::vector<Vec2>& also_cover, double resolution_m);

/// Settings of RouteGuide: planner_node's route/* parameters. Defaults live here only.
struct RouteGuideConfig {
  /// The subgoal is this much route ahead of the robot's projection, m (route/lookahead).
  double lookahead_m = 3.0;
  /// The robot plans again once it is farther than this from its route, m (route/replan_off_route).
  double replan_off_route_m = 1.0;
  /// Obstacle points that made the robot plan again (a blocked route, a recovery round) stay obstacles of the
  /// later plans to the same goal this long, s (route/obstacle_memory).
  double obstacle_memory_s = 60.0;
  /// The next lookahead_m of route is checked against the obstacle points seen this often, s; the route is
  /// blocked when two checks in a row find a point on it (a person walking across is gone by then; a door that
  /// closed, a cart left in the corridor is not).
  double blocked_check_period_s = 1.0;
  /// A point blocks the route within this fraction of the robot radius of it (walls beside the route, kept a
  /// radius away by the plan, never do).
  double blocked_clearance_fraction = 0.75;

  /// Empty when consistent, otherwise a message naming the offending field and why.
  std::string validate() const;
};

/// Why RouteGuide::update planned the route again.
enum class RouteReplan {
  kNone,        ///< it did not
  kOffRoute,    ///< the robot was farther than replan_off_route_m from its route
  kAfterRound,  ///< a recovery round of the navigation monitor ended
  kBlocked,     ///< the route ahead was blocked twice in a row
};
/// "", "off route", "after a recovery round", "blocked".
const char* routeReplanName(RouteReplan why);

/// What RouteGuide::update gives the local planner for one control period.
struct RouteGuidance {
  /// The point to drive at: the route's subgoal, or the goal itself once the subgoal is the route's end (or
  /// without a route).
  Vec2 local_goal = Vec2::Zero();
  bool final_goal = true;  ///< local_goal is the goal
  bool on_route = false;   ///< a route was followed (false: there is none, local_goal is the goal)
  /// Route length from the robot's projection to the goal, m; without a route the straight distance.
  double remaining_m = 0.0;
  double off_route_m = 0.0;  ///< the robot's distance from its projection on the route, m (0 without a route)
  RouteReplan replan = RouteReplan::kNone;  ///< why the route was planned again in this update
  bool replanned = false;                   ///< that plan succeeded: route() is the new route
  std::string replan_error;                 ///< that plan failed (the route is kept): why
};

/// The route-following state of one goal, shared by planner_node and the evaluation's Episode (and through it the
/// training environment), so that the robot, the evaluation and the training give the local planner the same
/// point: the route (planned on a RoutePlanner, or given as is), the robot's place along it, the obstacle points
/// remembered for later plans and the blocked-route bookkeeping. One frame throughout (the route's: the map's);
/// the caller converts. ROS-free; one instance per robot (not thread-safe).
class RouteGuide {
 public:
  /// Throws RouteError naming the field when config.validate() fails.
  explicit RouteGuide(const RouteGuideConfig& config = RouteGuideConfig());
  /// New settings from the next update on (planner_node's dynamic reconfiguration). Throws RouteError naming the
  /// field when config.validate() fails (the settings in force stay).
  void setConfig(const RouteGuideConfig& config);
  const RouteGuideConfig& config() const { return config_; }

  /// Forgets the route, the robot's place on it, the remembered obstacle points and the recovery-round and
  /// blocked-route bookkeeping (a new goal, or none).
  void clear();

  /// Plans the route from `start` to `goal` on `planner`, around the obstacle points remembered from the last
  /// obstacle_memory_s before now_s and `seen` (remembered from now on). "" when planned: the route replaces the
  /// current one and is followed from its start; otherwise the current route (if any) is kept and the reason is
  /// returned ("no route: ...").
  std::string plan(const RoutePlanner& planner, const Vec2& start, const Vec2& goal, double now_s,
                   const std::vector<Vec2>& seen = {});

  /// Follows `route` as given (another global planner's, found): it is never planned again.
  void follow(Route route);

  bool hasRoute() const { return route_.has_value(); }
  /// The route followed; only with hasRoute().
  const Route& route() const { return *route_; }
  /// Whether the route was planned here (plan) rather than given (follow).
  bool planned() const { return planned_; }

  /// One control period of a robot at `robot` heading for `goal`. With a route: the subgoal lookahead_m ahead
  /// (RoutePlanner::subgoal on `planner` for a planned route, in line of sight on its grid; followRoute for a
  /// given one or without `planner`); the goal itself replaces it once the subgoal is the route's end. Then a
  /// planned route is planned again from the robot (on `planner`, when given) when the robot is farther than
  /// replan_off_route_m from it, when `recovery_rounds` (the navigation monitor's count for this goal) rose since
  /// the last update, or when it is blocked: every blocked_check_period_s `scan_points` (obstacle points seen now)
  /// is read and checked against the next lookahead_m of route (routeBlocked within blocked_clearance_fraction of
  /// the robot radius); after a round or a blockage the new plan also avoids the points seen now. Without a route:
  /// the goal itself and the straight distance.
  RouteGuidance update(const RoutePlanner* planner, const Vec2& robot, const Vec2& goal, double now_s,
                       int recovery_rounds = 0, const std::function<std::vector<Vec2>()>& scan_points = {});

  /// How far `p` is from `goal` along the route: its distance from its projection on the route (searched ahead
  /// of the robot's place, which does not move) plus the route length from there to the end; the straight
  /// distance without a route. The training reward's distance term (docs/simulator.md, "Routes in episodes").
  double distanceToGo(const Vec2& p, const Vec2& goal) const;

  /// The route's next `length_m` metres from the robot's place on it (the last update's projection), as a polyline in
  /// the route's frame: the projection, the route's points after it, and the point `length_m` along (or the route's
  /// end when nearer). Empty without a route. The network state's route points (docs/dovs.md "The route ahead").
  std::vector<Vec2> ahead(double length_m) const;

 private:
  RouteGuideConfig config_;
  std::optional<Route> route_;
  bool planned_ = false;
  RouteFollower follower_;
  std::deque<std::pair<double, Vec2>> memory_;  ///< (time seen, point) of the obstacle points of earlier plans
  int rounds_seen_ = 0;
  double blocked_check_s_ = 0.0;
  bool blocked_checked_ = false;  ///< a blocked check ran since clear() (blocked_check_s_ holds its time)
  bool blocked_before_ = false;
};

}  // namespace dqn_dovs
