// The drawing maths of the rviz DOVS display: from a Dovs message, the 2-D shapes of the picture in the style of
// the paper's Figure 2 (w across, v up), in plot coordinates. No rviz, Ogre or Qt here, so all of it is tested
// without a render window; dovs_visual turns these shapes into Ogre objects.
//
// Plot coordinates are the normalised velocity plane: x = w / w_max in [-1, 1], y = v / v_max in [0, 1]. The
// kinematic triangle v / v_max + |w| / w_max <= 1 is then the fixed triangle (-1, 0), (1, 0), (0, 1), whatever
// the robot's limits.
#pragma once

#include <Eigen/Core>
#include <array>
#include <stdexcept>
#include <string>
#include <vector>

#include "dqn_dovs/Dovs.h"

namespace dqn_dovs_rviz {

/// A point of the plot (x = w / w_max, y = v / v_max).
using PlotPoint = Eigen::Vector2d;
/// An open chain of plot points.
using Polyline = std::vector<PlotPoint>;
/// A convex polygon, counter-clockwise, without the closing repeat of the first corner. Empty: nothing to draw.
using Polygon = std::vector<PlotPoint>;

/// A Dovs message that cannot be drawn; the message names the field and the reason.
class DovsGeometryError : public std::runtime_error {
 public:
  explicit DovsGeometryError(const std::string& what) : std::runtime_error(what) {}
};

/// Number of actions in a Dovs message (DESIGN §6 order).
constexpr size_t kNumActionPoints = 8;

/// One of the 8 actions in the plot.
struct ActionPoint {
  PlotPoint position = PlotPoint::Zero();
  /// False when the action is masked (the display draws it hollow/grey).
  bool valid = false;
};

/// Everything the display draws for one message.
struct DovsGeometry {
  /// The kinematic triangle (the feasible velocities).
  Polygon triangle;
  /// The DOV from the per-trajectory unsafe intervals: one polygon per (interval, neighbouring ray) pair.
  std::vector<Polygon> dov;
  /// The -1 cells of the network's grid as full squares: what the network sees, including the cells whose
  /// centre is outside the triangle (infeasible counts as unsafe there).
  std::vector<Polygon> grid_unsafe_cells;
  /// The dynamic-window rhombus clipped to the triangle (empty when it lies entirely outside).
  Polygon window;
  /// The goal line from the origin to the triangle edge: two points, or none (no goal, goal at the robot).
  Polyline goal_line;
  std::array<ActionPoint, kNumActionPoints> actions{};
  /// The robot's current velocity (the window's centre).
  PlotPoint current = PlotPoint::Zero();
};

/// Why `msg` cannot be drawn, or "" when it can: limits not finite and positive, dynamic-window sizes or the
/// current velocity not finite, goal fields not finite (when there is a goal), trajectory arrays of different
/// lengths, interval_begin not of size trajectories + 1 / not increasing / not ending at the interval count,
/// interval bounds not finite or reversed, grid larger than the state. NaN/inf in an action of a masked slot is
/// allowed (it is not drawn).
std::string validateDovsMessage(const dqn_dovs::Dovs& msg);

/// The whole picture of `msg`. Throws DovsGeometryError with validateDovsMessage's reason.
DovsGeometry computeDovsGeometry(const dqn_dovs::Dovs& msg);

/// Plot point of the velocity (v, w) for the given limits (both > 0).
PlotPoint toPlot(double v_mps, double w_rps, double v_max_mps, double w_max_rps);

/// The kinematic triangle: (-1, 0), (1, 0), (0, 1), counter-clockwise.
Polygon feasibleTriangle();

/// Intersection of a convex polygon (counter-clockwise) with the triangle; empty when they do not overlap.
Polygon clipToTriangle(const Polygon& convex);

/// The dynamic window of `msg` (corners (v +- dv, w), (v, w +- dw)) clipped to the triangle.
Polygon dynamicWindowPolygon(const dqn_dovs::Dovs& msg);

/// The goal line of `msg` from the origin to the triangle edge: for GOAL_ARC along w = goal_curvature * v, for
/// GOAL_TURN_IN_PLACE along v = 0 toward goal_turn_sign; empty without a goal or for GOAL_NONE.
Polyline goalLineSegment(const dqn_dovs::Dovs& msg);

/// The DOV as polygons. An unsafe interval [lo, hi] of ray i covers, at every normalised radius it spans, the
/// sectors between ray i and each of its neighbours, clipped to the triangle; an interval that reaches the ray's
/// end covers the sector out to the triangle edge. This is the velocity space's own rule between rays (a velocity
/// is free only when free on both neighbours at the same distance from the origin), with the sector's arcs drawn
/// as straight chords (at most 1 - cos(pi / (2 (n - 1))) of the radius off: 0.03 % for 65 rays).
std::vector<Polygon> dovPolygons(const dqn_dovs::Dovs& msg);

/// The grid cells of the network state that are -1 (unsafe or infeasible), as squares of the plot. Row 0 is the
/// top row (highest v), column 0 the most negative w, as in the core's grid.
std::vector<Polygon> gridUnsafeCells(const dqn_dovs::Dovs& msg);

/// The 8 action velocities with their validity.
std::array<ActionPoint, kNumActionPoints> actionPoints(const dqn_dovs::Dovs& msg);

/// True when p lies inside or within tol of the convex polygon (counter-clockwise).
bool convexPolygonContains(const Polygon& polygon, const PlotPoint& p, double tol = 1e-12);

/// Signed area (positive when counter-clockwise).
double polygonArea(const Polygon& polygon);

/// Where the overlay sits in the robot's frame (x forward, y left, z up).
struct OverlayPlacement {
  /// Metres per unit of normalised velocity: the triangle is 2 * scale_m wide and scale_m tall.
  double scale_m = 1.0;
  /// Position of the plot's origin (v = 0, w = 0) in the robot frame, m. The default puts the picture on the
  /// robot's right, clear of a robot of up to 0.5 m radius.
  Eigen::Vector3d offset_m{0.0, -1.6, 0.05};
};

/// Robot-frame position of plot point p, lifted by layer (in units of normalised velocity) so that stacked shapes
/// do not z-fight. The plot's v axis points along the robot's heading (+x) and its w axis to the robot's right
/// (-y), so that seen from above with the robot heading up the picture reads like the paper's figure.
Eigen::Vector3d plotToRobot(const PlotPoint& p, const OverlayPlacement& placement, double layer = 0.0);

}  // namespace dqn_dovs_rviz
