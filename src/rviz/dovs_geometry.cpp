#include "dovs_geometry.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace dqn_dovs_rviz {

namespace {

// Points closer than this (normalised velocity) are merged when polygons are cleaned up.
constexpr double kSamePoint = 1e-12;
// An interval whose upper end is within this fraction of the ray's end reaches the triangle edge.
constexpr double kReachesEnd = 1e-6;
// A radius past every point of the triangle (its farthest points are at radius 1).
constexpr double kBeyondTriangle = 2.0;

std::string fieldError(const std::string& field, double value, const std::string& why) {
  std::ostringstream os;
  os << "Dovs message: field '" << field << "' = " << value << ": " << why;
  return os.str();
}

std::string indexed(const char* field, size_t i) { return std::string(field) + "[" + std::to_string(i) + "]"; }

double cross(const PlotPoint& a, const PlotPoint& b) { return a.x() * b.y() - a.y() * b.x(); }

// Keeps the part of a convex polygon where n . p <= c (Sutherland-Hodgman, one edge).
Polygon clipHalfPlane(const Polygon& in, const PlotPoint& n, double c) {
  Polygon out;
  if (in.empty()) return out;
  out.reserve(in.size() + 1);
  for (size_t k = 0; k < in.size(); ++k) {
    const PlotPoint& a = in[k];
    const PlotPoint& b = in[(k + 1) % in.size()];
    const double da = n.dot(a) - c, db = n.dot(b) - c;
    if (da <= 0.0) out.push_back(a);
    if ((da < 0.0 && db > 0.0) || (da > 0.0 && db < 0.0)) out.push_back(a + (b - a) * (da / (da - db)));
  }
  return out;
}

// Drops repeated corners (including a last one equal to the first); fewer than 3 corners or no area -> empty.
Polygon cleaned(Polygon p) {
  Polygon out;
  out.reserve(p.size());
  for (const PlotPoint& q : p) {
    if (out.empty() || (q - out.back()).norm() > kSamePoint) out.push_back(q);
  }
  while (out.size() > 1 && (out.front() - out.back()).norm() <= kSamePoint) out.pop_back();
  if (out.size() < 3 || polygonArea(out) <= kSamePoint) out.clear();
  return out;
}

// Direction (unit) and end point of ray i in the plot; false for a ray that cannot be drawn (no length).
bool rayInPlot(const dqn_dovs::Dovs& msg, size_t i, PlotPoint& dir, PlotPoint& top) {
  top = toPlot(msg.trajectory_v_top[i], msg.trajectory_w_top[i], msg.v_max, msg.w_max);
  const double reach = top.norm();
  if (!(reach > kSamePoint)) return false;
  dir = top / reach;
  return true;
}

}  // namespace

PlotPoint toPlot(double v_mps, double w_rps, double v_max_mps, double w_max_rps) {
  return {w_rps / w_max_rps, v_mps / v_max_mps};
}

Polygon feasibleTriangle() { return {PlotPoint(-1.0, 0.0), PlotPoint(1.0, 0.0), PlotPoint(0.0, 1.0)}; }

Polygon clipToTriangle(const Polygon& convex) {
  Polygon p = clipHalfPlane(convex, PlotPoint(0.0, -1.0), 0.0);  // v >= 0
  p = clipHalfPlane(p, PlotPoint(1.0, 1.0), 1.0);                // v / v_max + w / w_max <= 1
  p = clipHalfPlane(p, PlotPoint(-1.0, 1.0), 1.0);               // v / v_max - w / w_max <= 1
  return cleaned(std::move(p));
}

std::string validateDovsMessage(const dqn_dovs::Dovs& msg) {
  if (!std::isfinite(msg.v_max) || msg.v_max <= 0.0)
    return fieldError("v_max", msg.v_max, "must be finite and positive");
  if (!std::isfinite(msg.w_max) || msg.w_max <= 0.0)
    return fieldError("w_max", msg.w_max, "must be finite and positive");
  if (!std::isfinite(msg.dv) || msg.dv < 0.0) return fieldError("dv", msg.dv, "must be finite and not negative");
  if (!std::isfinite(msg.dw) || msg.dw < 0.0) return fieldError("dw", msg.dw, "must be finite and not negative");
  if (!std::isfinite(msg.v)) return fieldError("v", msg.v, "must be finite");
  if (!std::isfinite(msg.w)) return fieldError("w", msg.w, "must be finite");
  if (msg.goal_line_kind > dqn_dovs::Dovs::GOAL_TURN_IN_PLACE) {
    return fieldError("goal_line_kind", msg.goal_line_kind,
                      "must be GOAL_NONE (0), GOAL_ARC (1) or GOAL_TURN_IN_PLACE (2)");
  }
  if (msg.has_goal && msg.goal_line_kind == dqn_dovs::Dovs::GOAL_ARC && !std::isfinite(msg.goal_curvature)) {
    return fieldError("goal_curvature", msg.goal_curvature, "must be finite on a GOAL_ARC goal line");
  }
  if (msg.has_goal && msg.goal_line_kind == dqn_dovs::Dovs::GOAL_TURN_IN_PLACE &&
      (!std::isfinite(msg.goal_turn_sign) || msg.goal_turn_sign == 0.0)) {
    return fieldError("goal_turn_sign", msg.goal_turn_sign,
                      "must be finite and non-zero on a GOAL_TURN_IN_PLACE goal line");
  }
  for (size_t i = 0; i < kNumActionPoints; ++i) {
    if (!msg.action_valid[i]) continue;
    if (!std::isfinite(msg.action_v[i]))
      return fieldError(indexed("action_v", i), msg.action_v[i], "must be finite for a valid action");
    if (!std::isfinite(msg.action_w[i]))
      return fieldError(indexed("action_w", i), msg.action_w[i], "must be finite for a valid action");
  }

  const size_t n = msg.trajectory_curvature.size();
  if (msg.trajectory_pure_rotation.size() != n || msg.trajectory_v_top.size() != n ||
      msg.trajectory_w_top.size() != n) {
    std::ostringstream os;
    os << "Dovs message: trajectory arrays differ in length (trajectory_curvature " << n
       << ", trajectory_pure_rotation " << msg.trajectory_pure_rotation.size() << ", trajectory_v_top "
       << msg.trajectory_v_top.size() << ", trajectory_w_top " << msg.trajectory_w_top.size() << ")";
    return os.str();
  }
  for (size_t i = 0; i < n; ++i) {
    const double v_top = msg.trajectory_v_top[i], w_top = msg.trajectory_w_top[i];
    if (!std::isfinite(v_top) || v_top < 0.0)
      return fieldError(indexed("trajectory_v_top", i), v_top, "must be finite and not negative");
    if (!std::isfinite(w_top)) return fieldError(indexed("trajectory_w_top", i), w_top, "must be finite");
  }
  if (msg.interval_lo.size() != msg.interval_hi.size()) {
    return "Dovs message: interval_lo has " + std::to_string(msg.interval_lo.size()) + " entries but interval_hi has " +
           std::to_string(msg.interval_hi.size());
  }
  const size_t num_intervals = msg.interval_lo.size();
  if (n == 0) {
    if (num_intervals != 0) return "Dovs message: " + std::to_string(num_intervals) + " intervals but no trajectories";
  } else {
    if (msg.interval_begin.size() != n + 1) {
      return "Dovs message: interval_begin has " + std::to_string(msg.interval_begin.size()) +
             " entries, expected trajectories + 1 = " + std::to_string(n + 1);
    }
    if (msg.interval_begin.front() != 0)
      return fieldError("interval_begin[0]", msg.interval_begin.front(), "must be 0");
    for (size_t i = 0; i < n; ++i) {
      if (msg.interval_begin[i + 1] < msg.interval_begin[i]) {
        return fieldError(indexed("interval_begin", i + 1), msg.interval_begin[i + 1],
                          "must not be below the entry before it");
      }
    }
    if (msg.interval_begin.back() != num_intervals) {
      return fieldError(indexed("interval_begin", n), msg.interval_begin.back(),
                        "must equal the number of intervals (" + std::to_string(num_intervals) + ")");
    }
  }
  for (size_t k = 0; k < num_intervals; ++k) {
    const double lo = msg.interval_lo[k], hi = msg.interval_hi[k];
    if (!std::isfinite(lo)) return fieldError(indexed("interval_lo", k), lo, "must be finite");
    if (!std::isfinite(hi)) return fieldError(indexed("interval_hi", k), hi, "must be finite");
    if (hi < lo)
      return fieldError(indexed("interval_hi", k), hi, "must not be below interval_lo (" + std::to_string(lo) + ")");
  }
  const size_t cells = static_cast<size_t>(msg.grid_rows) * msg.grid_cols;
  if (cells > msg.state.size()) {
    return "Dovs message: grid of " + std::to_string(msg.grid_rows) + " x " + std::to_string(msg.grid_cols) +
           " cells does not fit in a state of " + std::to_string(msg.state.size()) + " values";
  }
  for (size_t k = 0; k < cells; ++k) {
    if (!std::isfinite(msg.state[k])) return fieldError(indexed("state", k), msg.state[k], "grid cells must be finite");
  }
  return {};
}

Polygon dynamicWindowPolygon(const dqn_dovs::Dovs& msg) {
  const PlotPoint c = toPlot(msg.v, msg.w, msg.v_max, msg.w_max);
  const double hv = msg.dv / msg.v_max, hw = msg.dw / msg.w_max;
  return clipToTriangle(
      {c + PlotPoint(0.0, -hv), c + PlotPoint(hw, 0.0), c + PlotPoint(0.0, hv), c + PlotPoint(-hw, 0.0)});
}

Polyline goalLineSegment(const dqn_dovs::Dovs& msg) {
  if (!msg.has_goal) return {};
  if (msg.goal_line_kind == dqn_dovs::Dovs::GOAL_ARC) {
    const double k = msg.goal_curvature;
    // Speed at which w = k v meets the triangle edge v / v_max + |w| / w_max = 1.
    const double v_edge = 1.0 / (1.0 / msg.v_max + std::abs(k) / msg.w_max);
    return {PlotPoint::Zero(), toPlot(v_edge, k * v_edge, msg.v_max, msg.w_max)};
  }
  if (msg.goal_line_kind == dqn_dovs::Dovs::GOAL_TURN_IN_PLACE) {
    return {PlotPoint::Zero(), PlotPoint(msg.goal_turn_sign > 0.0 ? 1.0 : -1.0, 0.0)};
  }
  return {};
}

std::vector<Polygon> dovPolygons(const dqn_dovs::Dovs& msg) {
  std::vector<Polygon> out;
  const size_t n = msg.trajectory_v_top.size();
  if (n < 2 || msg.interval_begin.size() != n + 1) return out;
  for (size_t i = 0; i < n; ++i) {
    PlotPoint dir_i, top_i;
    if (!rayInPlot(msg, i, dir_i, top_i) || msg.trajectory_pure_rotation[i]) continue;
    const double v_top = msg.trajectory_v_top[i];
    const double reach = top_i.norm();
    for (uint32_t k = msg.interval_begin[i]; k < msg.interval_begin[i + 1]; ++k) {
      const double lo = std::max(0.0, static_cast<double>(msg.interval_lo[k]));
      const double hi = msg.interval_hi[k];
      if (lo >= v_top) continue;
      const double r0 = lo / v_top * reach;
      const double r1 = hi >= v_top * (1.0 - kReachesEnd) ? kBeyondTriangle : hi / v_top * reach;
      for (const size_t j : {i - 1, i + 1}) {
        if (j >= n) continue;  // i - 1 wraps around for i = 0
        PlotPoint dir_j, top_j;
        if (!rayInPlot(msg, j, dir_j, top_j)) continue;
        // Counter-clockwise: from the ray with the smaller polar angle to the other one.
        const bool i_first = cross(dir_i, dir_j) > 0.0;
        const PlotPoint& a = i_first ? dir_i : dir_j;
        const PlotPoint& b = i_first ? dir_j : dir_i;
        Polygon quad = clipToTriangle({r0 * a, r1 * a, r1 * b, r0 * b});
        if (!quad.empty()) out.push_back(std::move(quad));
      }
    }
  }
  return out;
}

std::vector<Polygon> gridUnsafeCells(const dqn_dovs::Dovs& msg) {
  std::vector<Polygon> out;
  const size_t rows = msg.grid_rows, cols = msg.grid_cols;
  if (rows == 0 || cols == 0 || rows * cols > msg.state.size()) return out;
  for (size_t r = 0; r < rows; ++r) {
    const double y0 = static_cast<double>(rows - r - 1) / static_cast<double>(rows);
    const double y1 = static_cast<double>(rows - r) / static_cast<double>(rows);
    for (size_t c = 0; c < cols; ++c) {
      if (!(msg.state[r * cols + c] < 0.0f)) continue;
      const double x0 = 2.0 * static_cast<double>(c) / static_cast<double>(cols) - 1.0;
      const double x1 = 2.0 * static_cast<double>(c + 1) / static_cast<double>(cols) - 1.0;
      out.push_back({PlotPoint(x0, y0), PlotPoint(x1, y0), PlotPoint(x1, y1), PlotPoint(x0, y1)});
    }
  }
  return out;
}

std::array<ActionPoint, kNumActionPoints> actionPoints(const dqn_dovs::Dovs& msg) {
  std::array<ActionPoint, kNumActionPoints> out{};
  for (size_t i = 0; i < kNumActionPoints; ++i) {
    out[i].position = toPlot(msg.action_v[i], msg.action_w[i], msg.v_max, msg.w_max);
    out[i].valid = msg.action_valid[i] && out[i].position.allFinite();
  }
  return out;
}

DovsGeometry computeDovsGeometry(const dqn_dovs::Dovs& msg) {
  const std::string error = validateDovsMessage(msg);
  if (!error.empty()) throw DovsGeometryError(error);
  DovsGeometry g;
  g.triangle = feasibleTriangle();
  g.dov = dovPolygons(msg);
  g.grid_unsafe_cells = gridUnsafeCells(msg);
  g.window = dynamicWindowPolygon(msg);
  g.goal_line = goalLineSegment(msg);
  g.actions = actionPoints(msg);
  g.current = toPlot(msg.v, msg.w, msg.v_max, msg.w_max);
  return g;
}

bool convexPolygonContains(const Polygon& polygon, const PlotPoint& p, double tol) {
  if (polygon.size() < 3 || !p.allFinite()) return false;
  for (size_t k = 0; k < polygon.size(); ++k) {
    const PlotPoint& a = polygon[k];
    const PlotPoint& b = polygon[(k + 1) % polygon.size()];
    const PlotPoint edge = b - a;
    const double len = edge.norm();
    if (len <= kSamePoint) continue;
    // Signed distance of p to the edge's line, positive on the inner (left) side.
    if (cross(edge, p - a) / len < -tol) return false;
  }
  return true;
}

double polygonArea(const Polygon& polygon) {
  double twice = 0.0;
  for (size_t k = 0; k < polygon.size(); ++k) twice += cross(polygon[k], polygon[(k + 1) % polygon.size()]);
  return 0.5 * twice;
}

Eigen::Vector3d plotToRobot(const PlotPoint& p, const OverlayPlacement& placement, double layer) {
  const double s = placement.scale_m;
  return {placement.offset_m.x() + s * p.y(), placement.offset_m.y() - s * p.x(), placement.offset_m.z() + s * layer};
}

}  // namespace dqn_dovs_rviz
