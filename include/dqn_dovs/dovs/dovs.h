// The Dynamic Object Velocity Space (DOVS): which robot velocities (v, w), held constant, collide with a moving
// obstacle within a time horizon or reach a static one too fast to brake. The model, its formulas and the
// grid layout are documented in docs/dovs.md. ROS-free: Eigen + std only.
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

#include "dqn_dovs/common/geometry.h"
#include "dqn_dovs/common/robot_model.h"
#include "dqn_dovs/common/types.h"

namespace dqn_dovs {

/// Bad DOVS input or configuration: the message names the offending item (obstacle index, segment index,
/// configuration field) and the reason. Uncertain input is never turned into "free" velocities silently.
class DovsError : public std::runtime_error {
 public:
  explicit DovsError(const std::string& what) : std::runtime_error(what) {}
};

/// Parameters of the DOVS model (config/dovs.yaml for the nodes). Defaults live here only.
struct DovsConfig {
  /// Obstacles whose centre is farther than this from the robot, and wall segments whose closest point is
  /// farther, are left out of the model and of the closest-obstacle features, m.
  double obstacle_range_m = 4.0;
  /// Inflation of obstacles around the point robot: a disc of radius r becomes a disc of radius
  /// (r + robot radius) * safety_factor; a wall segment becomes a band of half-width robot radius * safety_factor.
  /// Scaling the sum (not only the robot radius) is the more conservative of the two usual choices.
  double safety_factor = 1.1;
  /// Trajectories, i.e. rays from the origin of the (w, v) plane, spread evenly in angle over the normalised
  /// plane (w / w_max, v / v_max). Includes the two pure-rotation rays at v = 0; must be odd so that straight
  /// ahead (w = 0) is one of them.
  int num_trajectories = 65;
  /// Collisions with moving obstacles later than this are not part of the DOV, s.
  double time_horizon_s = 3.0;
  /// Arc-length resolution of the trajectory subdivision: each trajectory is cut into pieces no longer than this
  /// before the obstacle's passing times are bounded on each piece. Smaller is tighter and slower, m.
  double max_leaf_length_m = 0.08;
  /// Obstacles flagged static, or slower than this, follow the static braking rule instead of the moving-obstacle
  /// model, m/s.
  double static_speed_threshold_mps = 0.02;
  /// Static braking rule: how long the command is held before braking at a_v starts (one control period), s.
  double static_reaction_time_s = 0.2;
  /// Static braking rule: distance kept in reserve in front of a static obstacle after braking, m.
  double static_margin_m = 0.05;
  /// Cells per side of the free/unsafe velocity grid (the network state uses 20).
  int grid_size = 20;
  /// Growth of a moving obstacle's enlarged radius with the prediction time, m/s: t seconds ahead it counts as a
  /// disc of radius (enlarged radius + prediction_growth_mps * t) around its constant-(v, w) position. People
  /// change speed and direction, so the prediction is less sure the farther it looks; 0 is the paper's model.
  /// Static obstacles and walls are not affected.
  double prediction_growth_mps = 0.0;
  /// The network state's grid encoding (StateNormalization::grid_contact_horizon_s, docs/dovs.md "The graded
  /// grid"): 0 is the paper's +1 free / -1 unsafe grid; T > 0 grades each feasible cell by the earliest contact
  /// of its constant velocity within T seconds (free cells in (0, 1], unsafe ones in [-1, 0]). The DOVS itself,
  /// its intervals, grid() and the actions' safety do not change. 0 or [0.5, 30] s.
  double grid_contact_horizon_s = 0.0;
  /// Channels of the network state's grid (StateNormalization::grid_channels, docs/dovs.md "Grid channels"): 1 is
  /// the grid above alone (the paper's state); 2 adds the previous decision's grid (one step of history; training
  /// and evaluation only, the nodes refuse it); 3 adds the dynamic window and the goal line as two more 20 x 20
  /// images. The DOVS itself does not change. 1, 2 or 3.
  int grid_channels = 1;
  /// The previous action in the network state (StateNormalization::previous_action, docs/dovs.md "The previous
  /// action"): 1 appends 9 inputs after the features, a one-hot of the previous decision's choice (one of the 8
  /// actions, or anything else: the shield's escape, another planner's command); all 0 at an episode's first
  /// decision. Training and evaluation only: the nodes refuse it. The DOVS itself does not change. 0 or 1.
  int previous_action = 0;
  /// Wall rays and person tokens in the network state (StateNormalization::wall_rays / person_tokens, docs/dovs.md
  /// "Person tokens"): the distance to the nearest wall along that many directions, and one token per obstacle for
  /// the nearest ones (position, velocity, radius, 1 s of history, the predicted 2 s path, track age and
  /// uncertainty). The DOVS itself does not change. 0..32 and 0..16.
  int wall_rays = 0;
  int person_tokens = 0;
  /// The route's next metres in the network state (StateNormalization::route_points, docs/dovs.md "The route
  /// ahead"): that many points every 0.5 m along the route from the robot's place on it (the straight line to the
  /// goal without a route), in the robot frame. The DOVS itself does not change. 0..16.
  int route_points = 0;

  /// Empty when consistent, otherwise a message naming the offending field and why.
  std::string validate() const;
};

/// Sets the DovsConfig field named as in config/dovs.yaml's `dovs/` block (obstacle_range, safety_factor,
/// num_trajectories, time_horizon, static_reaction_time, static_margin, prediction_growth, grid_contact_horizon,
/// grid_channels, previous_action, wall_rays, person_tokens, route_points)
/// from text. Returns
/// an empty string, or a message naming the parameter and the reason (unknown name, not a number, not an
/// integer). The value is not range-checked here: validate() does that for the whole configuration.
std::string setDovsParameter(DovsConfig& config, const std::string& name, const std::string& value);

/// Every name setDovsParameter accepts, in config-file order.
const std::vector<std::string>& dovsParameterNames();

/// The value of the DOVS parameter `name` as setDovsParameter reads it back (a number written to round-trip, an
/// integer); throws DovsError for an unknown name.
std::string dovsParameter(const DovsConfig& config, const std::string& name);

/// The most grid channels a network state has (DovsConfig::grid_channels, docs/dovs.md "Grid channels"), and the
/// rule every check of a channel count states: the DOVS configuration, the state normalisation and the weight file.
constexpr int kMaxStateGridChannels = 3;
constexpr const char* kGridChannelsRule =
    "must be 1 (the DOVS grid), 2 (with the previous decision's grid) or 3 (with the dynamic window and the goal "
    "line)";

/// A closed interval of linear speeds [lo_mps, hi_mps] along one trajectory.
struct SpeedInterval {
  double lo_mps = 0.0;
  double hi_mps = 0.0;
};

/// One trajectory: the ray of velocities (v, w) = s * (v_top, w_top), s in [0, 1], all sharing the circle of
/// curvature w / v through the robot's position, tangent to its heading.
struct Trajectory {
  /// Angle of the ray in the normalised plane (w / w_max, v / v_max), measured from the -w axis: 0 is turning
  /// clockwise in place, pi/2 straight ahead, pi turning counter-clockwise in place.
  double angle_rad = 0.0;
  /// Path curvature w / v (1/m; CCW positive). Meaningless on the two pure-rotation rays.
  double curvature_1pm = 0.0;
  /// Largest feasible linear speed on the ray (where it meets the kinematic triangle), m/s.
  double v_top_mps = 0.0;
  /// Turn rate at v_top (rad/s); on the pure-rotation rays, -w_max or +w_max.
  double w_top_rps = 0.0;
  /// True for the two rays at v = 0 (the robot does not move: only obstacles reaching it matter).
  bool pure_rotation = false;
};

/// The obstacle closest to the robot (disc obstacles within range; wall segments are not counted).
struct ClosestObstacle {
  bool found = false;
  int index = -1;                     ///< index into Observation::obstacles
  Vec2 center_robot = Vec2::Zero();   ///< centre in the robot frame, m
  double clearance_m = 0.0;           ///< centre distance minus obstacle radius minus robot radius (true radii), m
  double bearing_rad = 0.0;           ///< direction of the centre seen from the robot, (-pi, pi]
  double speed_mps = 0.0;             ///< 0 for obstacles treated as static
  double relative_heading_rad = 0.0;  ///< obstacle heading minus robot heading, (-pi, pi]; 0 when static
};

/// A read-only range of intervals (no allocation).
class IntervalRange {
 public:
  IntervalRange(const SpeedInterval* b, const SpeedInterval* e) : begin_(b), end_(e) {}
  const SpeedInterval* begin() const { return begin_; }
  const SpeedInterval* end() const { return end_; }
  size_t size() const { return static_cast<size_t>(end_ - begin_); }
  bool empty() const { return begin_ == end_; }
  const SpeedInterval& operator[](size_t i) const { return begin_[i]; }

 private:
  const SpeedInterval* begin_;
  const SpeedInterval* end_;
};

/// The DOVS of one observation. Built by DovsBuilder; cheap to query.
class VelocitySpace {
 public:
  /// True when t is feasible (kinematic triangle) and not in the DOV. Exact on the trajectories; between two
  /// neighbouring trajectories a velocity is free only when it is free on both (compared at the same distance
  /// from the origin of the normalised plane). v = 0 is free unless a moving obstacle reaches the robot's
  /// current position within the horizon. NaN/inf -> false.
  bool isFree(const Twist2& t) const;
  /// True when t lies in the kinematic triangle.
  bool isFeasible(const Twist2& t) const { return limits_.feasible(t, 1e-9); }

  int numTrajectories() const { return static_cast<int>(trajectories_.size()); }
  const Trajectory& trajectory(int i) const { return trajectories_.at(static_cast<size_t>(i)); }
  /// Merged, sorted, disjoint unsafe speed intervals of trajectory i (within [0, v_top]).
  IntervalRange unsafeIntervals(int i) const;
  /// True when a moving obstacle reaches the robot's current position within the horizon (v = 0 unsafe).
  bool stationaryUnsafe() const { return stationary_unsafe_; }

  /// The free (+1) / unsafe-or-infeasible (-1) grid, row-major, gridSize() x gridSize(). Row 0 is the TOP row
  /// (highest v), as in an image of the (w, v) plane; column 0 is the most negative w. Cell (r, c) is sampled at
  /// its centre, gridCellVelocity(r, c).
  const std::vector<float>& grid() const { return grid_; }
  int gridSize() const { return grid_size_; }
  float gridCell(int row, int col) const;
  /// Centre velocity of grid cell (row, col): v = v_max (n - row - 0.5) / n, w = w_max (2 (col + 0.5) / n - 1).
  Twist2 gridCellVelocity(int row, int col) const;

  const ClosestObstacle& closestObstacle() const { return closest_; }
  const RobotLimits& limits() const { return limits_; }
  const DovsConfig& config() const { return config_; }
  /// Number of obstacles (discs) and wall segments that were within range and entered the model.
  int numObstaclesInModel() const { return num_in_model_; }

 private:
  friend class DovsBuilder;
  bool freeBetween(size_t ray, double radius_normalised, int which) const;
  bool rayUnsafeAt(size_t ray, double radius_normalised) const;

  RobotLimits limits_;
  DovsConfig config_;
  std::vector<Trajectory> trajectories_;
  std::vector<size_t> interval_begin_;  // per ray, index into intervals_; size = rays + 1
  std::vector<SpeedInterval> intervals_;
  bool stationary_unsafe_ = false;
  int grid_size_ = 0;
  std::vector<float> grid_;
  ClosestObstacle closest_;
  int num_in_model_ = 0;
};

/// Builds DOVS for one robot and configuration; keeps the trajectory geometry (precomputed once) and scratch
/// buffers, so repeated builds do not allocate once the buffers have grown.
class DovsBuilder {
 public:
  /// Throws DovsError when `limits` or `config` is invalid (message names the field).
  DovsBuilder(const RobotLimits& limits, const DovsConfig& config);

  /// Builds the DOVS of `obs` into `out` (its storage is reused). Throws DovsError naming the obstacle or segment
  /// index and the field when an input value is NaN/inf, a radius is not positive, or the robot pose is not
  /// finite; `out` is then left unspecified.
  void build(const Observation& obs, VelocitySpace& out);
  VelocitySpace build(const Observation& obs);

  const RobotLimits& limits() const { return limits_; }
  const DovsConfig& config() const { return config_; }

  /// Enlarged radius of a disc obstacle of true radius r (before the in-contact adjustment of docs/dovs.md).
  double enlargedRadius(double obstacle_radius_m) const;
  /// Half-width of the band around a wall segment.
  double wallHalfWidth_m() const;
  /// Largest speed v with v^2 / (2 a_v) + v * reaction + margin <= contact_distance_m (0 when none).
  double brakingSpeedLimit(double contact_distance_m) const;

 private:
  // Motion of one obstacle in the robot frame over the horizon.
  struct Motion {
    enum class Kind { kStatic, kLine, kArc };
    Kind kind = Kind::kStatic;
    Vec2 p0 = Vec2::Zero();   ///< centre at t = 0 (robot frame)
    Vec2 vel = Vec2::Zero();  ///< velocity (line), m/s
    double vel_sq = 0.0;
    Vec2 arc_center = Vec2::Zero();
    double arc_radius = 0.0;  ///< radius of the centre's circle (arc), m
    double beta0 = 0.0;       ///< angle of p0 seen from arc_center, rad
    double turn_rate = 0.0;   ///< rad/s (arc)
    double radius = 0.0;      ///< effective enlarged radius, m
    double slack = 0.0;       ///< extra radius covering the straight-line approximation of a barely turning obstacle
    Vec2 bound_center = Vec2::Zero();  ///< a disc containing the centre's whole path over the horizon (arc)
    double bound_radius = 0.0;
  };

  struct Node {
    double s_a, s_b;  // arc-length range of the piece
    double mx, my;    // midpoint of the piece (robot frame)
    double h;         // every point of the piece is within h of the midpoint
  };
  struct RayGeometry {
    size_t node_begin = 0;
    int depth = 0;     // leaves are at this depth (root at depth 0)
    double s_max = 0;  // max(v_top * horizon, braking distance at v_top)
  };
  struct Window {
    double t1, t2;
  };
  struct GridLookup {   // where a grid cell centre falls between two trajectories (fixed for given limits)
    size_t ray;         // lower neighbour
    double radius;      // distance from the origin in the normalised plane
    signed char which;  // 0: both neighbours, 1: lower only, 2: upper only, -1: infeasible, -2: v = 0
  };
  struct Wall {
    Segment segment;    // robot frame
    double half_width;  // effective half-width of the band, m
  };

  void precomputeRays();
  void validateObservation(const Observation& obs) const;
  // Windows in [0, horizon] during which the obstacle centre is within q of point m (q + prediction growth * t
  // for a moving obstacle); returns their number.
  int windows(const Motion& mo, const Vec2& m, double q, Window* out, int max_out) const;
  // The arc motion's windows within [t_from, t_to] for a fixed q; appended to out[count..max_out).
  int arcWindows(const Motion& mo, const Vec2& m, double q, double t_from, double t_to, Window* out, int count,
                 int max_out) const;
  // The line motion's window with q growing at prediction_growth_mps.
  int growingLineWindow(const Motion& mo, const Vec2& m, double q, Window* out) const;
  void addDynamicIntervals(size_t ray, const Motion& mo);
  void addStaticInterval(size_t ray, const Motion* disc, const Wall* wall);
  Vec2 pathPoint(double curvature, double s) const;

  RobotLimits limits_;
  DovsConfig config_;
  std::vector<Trajectory> trajectories_;
  std::vector<RayGeometry> ray_geometry_;
  std::vector<Node> nodes_;
  std::vector<GridLookup> grid_lookup_;
  // scratch, reused between builds
  std::vector<Motion> dynamic_;
  std::vector<Motion> static_discs_;
  std::vector<Wall> walls_;
  std::vector<SpeedInterval> ray_scratch_;
};

/// How the DOVS models a disc of true radius `obstacle_radius_m` whose centre is `distance_m` from the robot: the
/// enlarged radius (obstacle + robot radius) * safety_factor, shrunk to just inside the distance when the robot is
/// inside the inflation but not touching (so that moving away stays possible; docs/dovs.md).
double modelDiscRadius(const RobotLimits& limits, const DovsConfig& config, double obstacle_radius_m,
                       double distance_m);
/// The same for a wall segment `distance_m` from the robot: the band's half-width.
double modelWallHalfWidth(const RobotLimits& limits, const DovsConfig& config, double distance_m);
/// True when the DOVS treats `o` as standing still (flagged static, or slower than static_speed_threshold_mps).
bool modelAsStatic(const DovsConfig& config, const MovingObstacle& o);

/// One-shot convenience: DovsBuilder(limits, config).build(obs).
VelocitySpace buildDovs(const Observation& obs, const RobotLimits& limits, const DovsConfig& config);

}  // namespace dqn_dovs
