#include "dqn_dovs/planning/route.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <queue>
#include <sstream>
#include <utility>

namespace dqn_dovs {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr float kInfF = std::numeric_limits<float>::infinity();
constexpr double kSqrt2 = 1.41421356237309504880;

std::string bad(const char* field, double value, const std::string& why) {
  std::ostringstream os;
  os << "route parameter '" << field << "' = " << value << ": " << why;
  return os.str();
}

std::string point(const Vec2& p) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "(%.2f, %.2f)", p.x(), p.y());
  return buf;
}

std::string metres(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.2f m", v);
  return buf;
}

/// Squared Euclidean distance transform of one line (Felzenszwalb and Huttenlocher's lower envelope of
/// parabolas): d[q] = min over p of (q - p)^2 + f[p], over the finite f only (+inf when none is).
void distanceTransform1d(const std::vector<double>& f, std::vector<double>& d, std::vector<int>& v,
                         std::vector<double>& z) {
  const int n = static_cast<int>(f.size());
  int k = -1;
  for (int q = 0; q < n; ++q) {
    if (!std::isfinite(f[q])) continue;
    double s = -kInf;
    while (k >= 0) {
      const int p = v[k];
      s = ((f[q] + double(q) * q) - (f[p] + double(p) * p)) / (2.0 * (q - p));
      if (s > z[k]) break;
      --k;
    }
    ++k;
    v[k] = q;
    z[k] = k == 0 ? -kInf : s;
  }
  if (k < 0) {
    std::fill(d.begin(), d.end(), kInf);
    return;
  }
  z[k + 1] = kInf;
  int j = 0;
  for (int q = 0; q < n; ++q) {
    while (z[j + 1] < q) ++j;
    const double dq = q - v[j];
    d[q] = dq * dq + f[v[j]];
  }
}

/// Squared distance, in cells, from every cell centre to the closest occupied cell centre (+inf without any).
std::vector<double> squaredDistanceToOccupied(const std::vector<uint8_t>& occupied, int width, int height) {
  std::vector<double> out(occupied.size());
  const int n = std::max(width, height);
  std::vector<double> f(n), d(n), z(n + 1);
  std::vector<int> v(n);
  // Columns first, then rows over the columns' result: the exact 2-D transform is separable.
  f.resize(height);
  d.resize(height);
  for (int i = 0; i < width; ++i) {
    for (int j = 0; j < height; ++j) f[j] = occupied[size_t(j) * width + i] ? 0.0 : kInf;
    distanceTransform1d(f, d, v, z);
    for (int j = 0; j < height; ++j) out[size_t(j) * width + i] = d[j];
  }
  f.resize(width);
  d.resize(width);
  for (int j = 0; j < height; ++j) {
    std::copy(out.begin() + size_t(j) * width, out.begin() + size_t(j + 1) * width, f.begin());
    distanceTransform1d(f, d, v, z);
    std::copy(d.begin(), d.end(), out.begin() + size_t(j) * width);
  }
  return out;
}

/// An open A* node. Among equal f the one closer to the goal (larger g) goes first: in open space many cells
/// share the optimal f, and without the tie-break A* expands all of them.
struct Open {
  float f;
  float h;
  int cell;
  bool operator>(const Open& o) const { return f > o.f || (f == o.f && h > o.h); }
};

/// Distance from p to the segment a -> b and the segment parameter of the closest point, in [0, 1].
std::pair<double, double> projectOnSegment(const Vec2& p, const Vec2& a, const Vec2& b) {
  const Vec2 ab = b - a;
  const double len2 = ab.squaredNorm();
  const double t = len2 > 0.0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  return {(a + t * ab - p).norm(), t};
}

}  // namespace

std::string RouteConfig::validate() const {
  if (!(std::isfinite(robot_radius_m) && robot_radius_m >= 0.0))
    return bad("robot_radius_m", robot_radius_m, "must be >= 0 m");
  if (!(std::isfinite(inflation_m) && inflation_m >= 0.0)) return bad("inflation_m", inflation_m, "must be >= 0 m");
  if (!(std::isfinite(cost_scaling_1pm) && cost_scaling_1pm >= 0.0))
    return bad("cost_scaling_1pm", cost_scaling_1pm, "must be >= 0 1/m");
  if (!(std::isfinite(inflation_weight) && inflation_weight >= 0.0))
    return bad("inflation_weight", inflation_weight, "must be >= 0");
  if (!(std::isfinite(unknown_penalty) && unknown_penalty >= 0.0))
    return bad("unknown_penalty", unknown_penalty, "must be >= 0");
  if (occupied_threshold < 1 || occupied_threshold > 100)
    return bad("occupied_threshold", occupied_threshold, "must be in [1, 100] percent");
  if (!(std::isfinite(start_search_radius_m) && start_search_radius_m >= 0.0))
    return bad("start_search_radius_m", start_search_radius_m, "must be >= 0 m");
  if (max_cells_per_side < 1) return bad("max_cells_per_side", max_cells_per_side, "must be >= 1");
  return "";
}

RoutePlanner::RoutePlanner(const RouteGrid& grid, const RouteConfig& config)
    : config_(config),
      resolution_m_(grid.resolution_m),
      origin_(grid.origin),
      width_(grid.width),
      height_(grid.height) {
  const std::string invalid = config_.validate();
  if (!invalid.empty()) throw RouteError(invalid);
  if (!(std::isfinite(grid.resolution_m) && grid.resolution_m > 0.0)) {
    throw RouteError("route grid: resolution " + std::to_string(grid.resolution_m) + " m must be > 0");
  }
  if (!grid.origin.isFinite()) throw RouteError("route grid: the origin is not finite");
  if (grid.width < 1 || grid.height < 1) {
    throw RouteError("route grid: size " + std::to_string(grid.width) + " x " + std::to_string(grid.height) +
                     " cells must be positive");
  }
  if (grid.width > config_.max_cells_per_side || grid.height > config_.max_cells_per_side) {
    const std::string cap = std::to_string(config_.max_cells_per_side);
    throw RouteError("route grid: size " + std::to_string(grid.width) + " x " + std::to_string(grid.height) +
                     " cells exceeds the cap of " + cap + " x " + cap + " (max_cells_per_side)");
  }
  const size_t n = size_t(width_) * size_t(height_);
  if (grid.cells.size() != n) {
    throw RouteError("route grid: " + std::to_string(grid.cells.size()) + " cells for a " + std::to_string(width_) +
                     " x " + std::to_string(height_) + " grid (" + std::to_string(n) + " expected)");
  }

  std::vector<uint8_t> occupied(n);
  for (size_t c = 0; c < n; ++c) occupied[c] = grid.cells[c] >= config_.occupied_threshold;
  const std::vector<double> d2 = squaredDistanceToOccupied(occupied, width_, height_);

  cls_.resize(n);
  clearance_m_.resize(n);
  cost_.resize(n);
  passable_.resize(n);
  const double r = config_.robot_radius_m;
  for (size_t c = 0; c < n; ++c) {
    const double clear = std::isfinite(d2[c]) ? std::sqrt(d2[c]) * resolution_m_ - 0.5 * resolution_m_ : kInf;
    clearance_m_[c] = static_cast<float>(clear);
    const bool unknown = grid.cells[c] < 0;
    if (occupied[c] || clear < r) {
      cls_[c] = CellClass::kLethal;
    } else if (unknown) {
      cls_[c] = config_.allow_unknown ? CellClass::kUnknown : CellClass::kBlockedUnknown;
    } else {
      cls_[c] = CellClass::kFree;
    }
    passable_[c] = cls_[c] == CellClass::kFree || cls_[c] == CellClass::kUnknown;
    cost_[c] = passable_[c] ? stepCost(clear, unknown) : kInfF;
  }
}

float RoutePlanner::stepCost(double clearance_m, bool unknown) const {
  const double beyond = clearance_m - config_.robot_radius_m;
  const double inflation = beyond < config_.inflation_m ? std::exp(-config_.cost_scaling_1pm * beyond) : 0.0;
  return static_cast<float>(1.0 + config_.inflation_weight * inflation + (unknown ? config_.unknown_penalty : 0.0));
}

Vec2 RoutePlanner::toGrid(const Vec2& p) const { return origin_.toLocal(p) / resolution_m_; }

bool RoutePlanner::toCell(const Vec2& p, int& i, int& j) const {
  if (!std::isfinite(p.x()) || !std::isfinite(p.y())) return false;
  const Vec2 g = toGrid(p);
  if (!(g.x() >= 0.0 && g.y() >= 0.0 && g.x() < width_ && g.y() < height_)) return false;
  i = std::min(static_cast<int>(g.x()), width_ - 1);
  j = std::min(static_cast<int>(g.y()), height_ - 1);
  return true;
}

Vec2 RoutePlanner::cellCentre(int i, int j) const {
  return origin_.toWorld(Vec2((i + 0.5) * resolution_m_, (j + 0.5) * resolution_m_));
}

double RoutePlanner::clearance(const Vec2& p) const {
  int i = 0, j = 0;
  if (!toCell(p, i, j)) return -1.0;
  return clearance_m_[size_t(j) * width_ + i];
}

bool RoutePlanner::lethal(const Vec2& p) const {
  int i = 0, j = 0;
  if (!toCell(p, i, j)) return true;
  return cls_[size_t(j) * width_ + i] == CellClass::kLethal;
}

bool RoutePlanner::lineOfSight(const Vec2& a, const Vec2& b, bool skip_start_lethal) const {
  return segmentClear(a, b, passable_, cost_, kInfF, skip_start_lethal);
}

bool RoutePlanner::segmentClear(const Vec2& a, const Vec2& b, const std::vector<uint8_t>& passable,
                                const std::vector<float>& cost, float max_cost, bool skip_start_lethal) const {
  int i = 0, j = 0, ie = 0, je = 0;
  if (!toCell(a, i, j) || !toCell(b, ie, je)) return false;
  bool leading = skip_start_lethal;
  auto ok = [&](int ci, int cj) {
    if (ci < 0 || cj < 0 || ci >= width_ || cj >= height_) return false;
    const size_t c = size_t(cj) * width_ + ci;
    if (!passable[c]) return leading;
    leading = false;
    return cost[c] <= max_cost;
  };
  // Cell walk along the segment (Amanatides and Woo); through a cell corner both side cells are checked.
  const Vec2 ga = toGrid(a), gb = toGrid(b);
  const double dx = gb.x() - ga.x(), dy = gb.y() - ga.y();
  const int si = dx > 0.0 ? 1 : (dx < 0.0 ? -1 : 0);
  const int sj = dy > 0.0 ? 1 : (dy < 0.0 ? -1 : 0);
  double t_max_x = si > 0 ? (i + 1 - ga.x()) / dx : (si < 0 ? (ga.x() - i) / -dx : kInf);
  double t_max_y = sj > 0 ? (j + 1 - ga.y()) / dy : (sj < 0 ? (ga.y() - j) / -dy : kInf);
  const double t_delta_x = si != 0 ? 1.0 / std::abs(dx) : kInf;
  const double t_delta_y = sj != 0 ? 1.0 / std::abs(dy) : kInf;
  const int max_steps = std::abs(ie - i) + std::abs(je - j) + 1;
  if (!ok(i, j)) return false;
  for (int step = 0; step < max_steps && (i != ie || j != je); ++step) {
    if (std::abs(t_max_x - t_max_y) < 1e-9) {
      if (!ok(i + si, j) || !ok(i, j + sj)) return false;
      i += si;
      j += sj;
      t_max_x += t_delta_x;
      t_max_y += t_delta_y;
    } else if (t_max_x < t_max_y) {
      i += si;
      t_max_x += t_delta_x;
    } else {
      j += sj;
      t_max_y += t_delta_y;
    }
    if (!ok(i, j)) return false;
  }
  return true;
}

Route RoutePlanner::plan(const Vec2& start, const Vec2& goal) const {
  return search(start, goal, passable_, cost_, false);
}

Route RoutePlanner::plan(const Vec2& start, const Vec2& goal, const std::vector<Vec2>& extra_obstacles) const {
  if (extra_obstacles.empty()) return plan(start, goal);
  std::vector<uint8_t> passable = passable_;
  std::vector<float> cost = cost_;
  const double r = config_.robot_radius_m;
  const int reach = static_cast<int>(std::ceil((r + config_.inflation_m) / resolution_m_)) + 1;
  // Points in one cell mark the same cells: each occupied cell once (a scan has hundreds of points, many on the
  // same few cells), with the clearances and costs of its neighbourhood computed once for all.
  std::vector<size_t> occupied;
  occupied.reserve(extra_obstacles.size());
  for (const Vec2& p : extra_obstacles) {
    int pi = 0, pj = 0;
    if (toCell(p, pi, pj)) occupied.push_back(size_t(pj) * width_ + pi);
  }
  std::sort(occupied.begin(), occupied.end());
  occupied.erase(std::unique(occupied.begin(), occupied.end()), occupied.end());
  const int side = 2 * reach + 1;
  std::vector<uint8_t> stencil_lethal(size_t(side) * side);
  std::vector<float> stencil_known(stencil_lethal.size()), stencil_unknown(stencil_lethal.size());
  for (int dj = -reach; dj <= reach; ++dj) {
    for (int di = -reach; di <= reach; ++di) {
      const size_t k = size_t(dj + reach) * side + size_t(di + reach);
      const double clear = std::hypot(double(di), double(dj)) * resolution_m_ - 0.5 * resolution_m_;
      stencil_lethal[k] = clear < r;
      if (clear >= r) {
        stencil_known[k] = stepCost(clear, false);
        stencil_unknown[k] = stepCost(clear, true);
      }
    }
  }
  for (const size_t cell : occupied) {
    const int pi = int(cell % width_), pj = int(cell / width_);
    // The point's cell becomes occupied: the cells around it get the clearance an occupied cell of the map gives.
    for (int j = std::max(0, pj - reach); j <= std::min(height_ - 1, pj + reach); ++j) {
      for (int i = std::max(0, pi - reach); i <= std::min(width_ - 1, pi + reach); ++i) {
        const size_t c = size_t(j) * width_ + i;
        if (!passable[c]) continue;
        const size_t k = size_t(j - pj + reach) * side + size_t(i - pi + reach);
        if (stencil_lethal[k]) {
          passable[c] = 0;
          cost[c] = kInfF;
        } else {
          cost[c] = std::max(cost[c], cls_[c] == CellClass::kUnknown ? stencil_unknown[k] : stencil_known[k]);
        }
      }
    }
  }
  return search(start, goal, passable, cost, true);
}

Route RoutePlanner::search(const Vec2& start, const Vec2& goal, const std::vector<uint8_t>& passable,
                           const std::vector<float>& cost, bool with_extra) const {
  Route route;
  auto fail = [&route](const std::string& why) {
    route.why = why;
    return route;
  };
  const std::string radius = metres(config_.robot_radius_m);
  if (!std::isfinite(start.x()) || !std::isfinite(start.y())) return fail("start " + point(start) + " is not finite");
  if (!std::isfinite(goal.x()) || !std::isfinite(goal.y())) return fail("goal " + point(goal) + " is not finite");
  int si = 0, sj = 0, gi = 0, gj = 0;
  const std::string extent = "the map (" + std::to_string(width_) + " x " + std::to_string(height_) + " cells of " +
                             metres(resolution_m_) + " from " + point(origin_.position()) + ")";
  if (!toCell(start, si, sj)) return fail("start " + point(start) + " is outside " + extent);
  if (!toCell(goal, gi, gj)) return fail("goal " + point(goal) + " is outside " + extent);
  const size_t goal_cell = size_t(gj) * width_ + gi;
  if (!passable[goal_cell]) {
    if (cls_[goal_cell] == CellClass::kBlockedUnknown) {
      return fail("goal " + point(goal) +
                  " is in an unknown cell and unknown cells may not be crossed (allow_unknown)");
    }
    if (with_extra && passable_[goal_cell]) {
      return fail("goal " + point(goal) + " is inside an extra obstacle point inflated by the robot radius " + radius);
    }
    return fail("goal " + point(goal) + " is inside an obstacle inflated by the robot radius " + radius);
  }

  // A lethal start (not an unknown one: the robot stands there, so the cell is free in fact) moves to the
  // nearest non-lethal cell.
  size_t start_cell = size_t(sj) * width_ + si;
  Vec2 first = start;
  if (!passable[start_cell] && cls_[start_cell] != CellClass::kBlockedUnknown) {
    const int reach = static_cast<int>(std::ceil(config_.start_search_radius_m / resolution_m_));
    double best = kInf;
    for (int j = std::max(0, sj - reach); j <= std::min(height_ - 1, sj + reach); ++j) {
      for (int i = std::max(0, si - reach); i <= std::min(width_ - 1, si + reach); ++i) {
        const size_t c = size_t(j) * width_ + i;
        if (!passable[c]) continue;
        const double d = (cellCentre(i, j) - start).norm();
        if (d <= config_.start_search_radius_m && d < best) {
          best = d;
          start_cell = c;
        }
      }
    }
    if (!std::isfinite(best)) {
      return fail("start " + point(start) + " is inside an obstacle inflated by the robot radius " + radius +
                  " and no free cell lies within start_search_radius_m " + metres(config_.start_search_radius_m));
    }
    route.start_moved_m = best;
    first = cellCentre(int(start_cell % width_), int(start_cell / width_));
  }

  // A* over cells, 8-connected; a diagonal step needs both cells beside it passable (no corner cutting).
  const size_t n = size_t(width_) * height_;
  std::vector<float> g(n, kInfF);
  std::vector<int32_t> parent(n, -1);
  std::vector<uint8_t> closed(n, 0);
  auto heuristic = [gi, gj](int i, int j) {
    const int dx = std::abs(i - gi), dy = std::abs(j - gj);
    return static_cast<float>(std::max(dx, dy) + (kSqrt2 - 1.0) * std::min(dx, dy));
  };
  std::vector<Open> heap;
  heap.reserve(std::min<size_t>(n, size_t(1) << 16));
  std::priority_queue<Open, std::vector<Open>, std::greater<Open>> open(std::greater<Open>(), std::move(heap));
  g[start_cell] = 0.0f;
  const float h0 = heuristic(int(start_cell % width_), int(start_cell / width_));
  open.push({h0, h0, static_cast<int>(start_cell)});
  static const int kDi[8] = {1, -1, 0, 0, 1, 1, -1, -1};
  static const int kDj[8] = {0, 0, 1, -1, 1, -1, 1, -1};
  bool reached = false;
  while (!open.empty()) {
    const size_t c = static_cast<size_t>(open.top().cell);
    open.pop();
    if (closed[c]) continue;
    closed[c] = 1;
    if (c == goal_cell) {
      reached = true;
      break;
    }
    const int ci = int(c % width_), cj = int(c / width_);
    const float gc = g[c];
    for (int k = 0; k < 8; ++k) {
      const int ni = ci + kDi[k], nj = cj + kDj[k];
      if (ni < 0 || nj < 0 || ni >= width_ || nj >= height_) continue;
      const size_t nc = size_t(nj) * width_ + ni;
      if (!passable[nc] || closed[nc]) continue;
      const bool diagonal = k >= 4;
      if (diagonal && (!passable[size_t(cj) * width_ + ni] || !passable[size_t(nj) * width_ + ci])) continue;
      const float ng = gc + static_cast<float>(diagonal ? kSqrt2 : 1.0) * cost[nc];
      if (ng < g[nc]) {
        g[nc] = ng;
        parent[nc] = static_cast<int32_t>(c);
        const float h = heuristic(ni, nj);
        open.push({ng + h, h, static_cast<int>(nc)});
      }
    }
  }
  if (!reached) {
    std::string why = "no route: start " + point(start) + " and goal " + point(goal) +
                      " are not connected (obstacles inflated by the robot radius " + radius;
    if (with_extra) why += ", extra obstacle points included";
    if (!config_.allow_unknown) why += ", unknown cells not crossed";
    return fail(why + ")");
  }

  // Cell path, start to goal, with the exact goal (and the start, unless it was moved) at its ends.
  std::vector<size_t> cells;
  for (int32_t c = static_cast<int32_t>(goal_cell); c >= 0; c = parent[size_t(c)]) cells.push_back(size_t(c));
  std::reverse(cells.begin(), cells.end());
  std::vector<Vec2> pts(cells.size());
  std::vector<float> pts_cost(cells.size());
  for (size_t k = 0; k < cells.size(); ++k) {
    pts[k] = cellCentre(int(cells[k] % width_), int(cells[k] / width_));
    pts_cost[k] = passable[cells[k]] ? cost[cells[k]] : 1.0f;
  }
  pts.front() = first;
  if (pts.size() == 1) pts.push_back(goal);
  pts.back() = goal;
  if (pts_cost.size() < pts.size()) pts_cost.push_back(pts_cost.back());

  std::vector<Vec2> kept{pts.front()};
  if (config_.shortcut) {
    // Greedy string pulling: from each kept point, the farthest later path point in line of sight, the line
    // crossing no cell costlier than the costliest path cell it replaces.
    size_t a = 0;
    while (a + 1 < pts.size()) {
      size_t b = a + 1;
      float highest = std::max(pts_cost[a], pts_cost[b]);
      while (b + 1 < pts.size()) {
        const float h = std::max(highest, pts_cost[b + 1]);
        if (!segmentClear(pts[a], pts[b + 1], passable, cost, h + 1e-6f, false)) break;
        highest = h;
        ++b;
      }
      kept.push_back(pts[b]);
      a = b;
    }
  } else {
    kept.insert(kept.end(), pts.begin() + 1, pts.end());
  }
  // Collinear points say nothing.
  std::vector<Vec2> simple{kept.front()};
  for (size_t k = 1; k + 1 < kept.size(); ++k) {
    const Vec2 u = kept[k] - simple.back(), w = kept[k + 1] - kept[k];
    const double cross = u.x() * w.y() - u.y() * w.x();
    if (u.norm() < 1e-9 || (std::abs(cross) <= 1e-9 * u.norm() * w.norm() && u.dot(w) > 0.0)) continue;
    simple.push_back(kept[k]);
  }
  simple.push_back(kept.back());

  if (route.start_moved_m > 0.0) simple.insert(simple.begin(), start);
  const double moved = route.start_moved_m;
  route = routeFromPoints(std::move(simple));
  route.start_moved_m = moved;
  return route;
}

Route routeFromPoints(std::vector<Vec2> points) {
  Route route;
  for (const Vec2& p : points) {
    if (!p.allFinite()) {
      route.why = "a route point is NaN/inf";
      return route;
    }
  }
  if (points.empty()) {
    route.why = "the route has no points";
    return route;
  }
  route.points = std::move(points);
  route.arc_m.assign(route.points.size(), 0.0);
  for (size_t k = 1; k < route.points.size(); ++k) {
    route.arc_m[k] = route.arc_m[k - 1] + (route.points[k] - route.points[k - 1]).norm();
  }
  route.length_m = route.arc_m.back();
  route.found = true;
  return route;
}

double routeRemaining(const Route& route, double arc_m) {
  if (route.arc_m.empty()) return 0.0;
  return std::max(0.0, route.length_m - std::max(0.0, arc_m));
}

Vec2 routePointAt(const Route& route, double arc_m) {
  if (route.points.empty()) return Vec2::Zero();
  if (route.points.size() == 1 || !(arc_m > 0.0)) return route.points.front();
  if (arc_m >= route.length_m) return route.points.back();
  const size_t k = static_cast<size_t>(std::upper_bound(route.arc_m.begin(), route.arc_m.end(), arc_m) -
                                       route.arc_m.begin());  // arc_m[k - 1] <= arc < arc_m[k]
  const double len = route.arc_m[k] - route.arc_m[k - 1];
  const double t = len > 0.0 ? (arc_m - route.arc_m[k - 1]) / len : 0.0;
  return route.points[k - 1] + t * (route.points[k] - route.points[k - 1]);
}

RouteProgress RoutePlanner::subgoal(const Route& route, const Vec2& robot, double lookahead_m,
                                    RouteFollower& follower) const {
  return followRoute(
      route, robot, lookahead_m, follower, [this](const Vec2& a, const Vec2& b) { return lineOfSight(a, b, true); },
      0.5 * resolution_m_);
}

RouteProgress followRoute(const Route& route, const Vec2& robot, double lookahead_m, RouteFollower& follower,
                          const std::function<bool(const Vec2&, const Vec2&)>& visible, double pull_step_m) {
  RouteProgress out;
  if (!route.found || route.points.empty()) {
    out.subgoal = robot;
    out.final_goal = true;
    return out;
  }
  if (route.points.size() == 1) {
    out.subgoal = route.points.front();
    out.final_goal = true;
    out.off_route_m = (robot - route.points.front()).norm();
    return out;
  }
  if (!(std::isfinite(lookahead_m) && lookahead_m > 0.0)) lookahead_m = 0.0;
  const size_t segments = route.points.size() - 1;
  follower.segment = std::min(follower.segment, segments - 1);
  follower.arc_m = std::clamp(follower.arc_m, route.arc_m[follower.segment], route.arc_m[follower.segment + 1]);

  // Projection: the closest point of the route between the last projection and a window ahead of it.
  const double window_end = follower.arc_m + std::max(2.0 * lookahead_m, 1.0);
  double best_distance = kInf, best_arc = follower.arc_m;
  size_t best_segment = follower.segment;
  for (size_t s = follower.segment; s < segments && route.arc_m[s] <= window_end; ++s) {
    const double a0 = std::max(route.arc_m[s], follower.arc_m);
    const double a1 = std::min(route.arc_m[s + 1], window_end);
    if (a1 < a0) continue;
    const Vec2 p0 = routePointAt(route, a0), p1 = routePointAt(route, a1);
    const auto [distance, t] = projectOnSegment(robot, p0, p1);
    if (distance < best_distance) {
      best_distance = distance;
      best_arc = a0 + t * (a1 - a0);
      best_segment = s;
    }
  }
  follower.segment = best_segment;
  follower.arc_m = best_arc;
  out.projection_arc_m = best_arc;
  out.off_route_m = best_distance;
  out.remaining_m = routeRemaining(route, best_arc);

  // Lookahead point, pulled back toward the projection until the robot sees it.
  const double step = pull_step_m > 0.0 ? pull_step_m : 0.05;
  double arc = std::min(best_arc + lookahead_m, route.length_m);
  Vec2 target = routePointAt(route, arc);
  while (visible && arc > best_arc && !visible(robot, target)) {
    arc = std::max(best_arc, arc - step);
    target = routePointAt(route, arc);
  }
  out.subgoal = target;
  out.final_goal = arc >= route.length_m;
  return out;
}

bool routeBlocked(const Route& route, const RouteFollower& from, const std::vector<Vec2>& obstacle_points,
                  double clearance_m, double ahead_m) {
  if (!route.found || route.points.size() < 2 || obstacle_points.empty()) return false;
  const size_t segments = route.points.size() - 1;
  const size_t first = std::min(from.segment, segments - 1);
  const double begin = std::max(from.arc_m, 0.0), end = begin + std::max(ahead_m, 0.0);
  for (size_t s = first; s < segments && route.arc_m[s] <= end; ++s) {
    const double a0 = std::max(route.arc_m[s], begin), a1 = std::min(route.arc_m[s + 1], end);
    if (a1 < a0) continue;
    const Vec2 p0 = routePointAt(route, a0), p1 = routePointAt(route, a1);
    const Vec2 dir = p1 - p0;
    for (const Vec2& q : obstacle_points) {
      // Behind the robot's projection does not count.
      if (a0 == begin && dir.squaredNorm() > 0.0 && (q - p0).dot(dir) < 0.0) continue;
      if (projectOnSegment(q, p0, p1).first < clearance_m) return true;
    }
  }
  return false;
}

RouteGrid routeGridFromGeometry(const std::vector<Segment>& segments, const std::vector<Circle>& discs, const Vec2& lo,
                                const Vec2& hi, double resolution_m) {
  const std::string what = "route grid from geometry: ";
  if (!(std::isfinite(resolution_m) && resolution_m > 0.0)) {
    throw RouteError(what + "resolution " + std::to_string(resolution_m) + " m must be > 0");
  }
  if (!lo.allFinite() || !hi.allFinite() || !(hi.x() > lo.x() && hi.y() > lo.y())) {
    throw RouteError(what + "the extent " + point(lo) + " to " + point(hi) + " is not finite or empty");
  }
  const int cap = RouteConfig().max_cells_per_side;
  const double cols = std::ceil((hi.x() - lo.x()) / resolution_m), rows = std::ceil((hi.y() - lo.y()) / resolution_m);
  if (cols > cap || rows > cap) {
    throw RouteError(what + "the extent " + point(lo) + " to " + point(hi) + " needs more than " + std::to_string(cap) +
                     " cells of " + metres(resolution_m) + " on a side");
  }
  RouteGrid grid;
  grid.resolution_m = resolution_m;
  grid.origin = Pose2{lo.x(), lo.y(), 0.0};
  grid.width = std::max(1, static_cast<int>(cols));
  grid.height = std::max(1, static_cast<int>(rows));
  grid.cells.assign(size_t(grid.width) * grid.height, 0);
  const double reach = 0.5 * kSqrt2 * resolution_m;
  // Marks the cells of the box [a, b] (grown by `reach`) whose centre `near` accepts.
  auto mark = [&](const Vec2& a, const Vec2& b, const auto& near) {
    const int i0 = std::max(0, static_cast<int>(std::floor((a.x() - reach - lo.x()) / resolution_m)));
    const int j0 = std::max(0, static_cast<int>(std::floor((a.y() - reach - lo.y()) / resolution_m)));
    const int i1 = std::min(grid.width - 1, static_cast<int>(std::floor((b.x() + reach - lo.x()) / resolution_m)));
    const int j1 = std::min(grid.height - 1, static_cast<int>(std::floor((b.y() + reach - lo.y()) / resolution_m)));
    for (int j = j0; j <= j1; ++j) {
      for (int i = i0; i <= i1; ++i) {
        const Vec2 c = lo + Vec2((i + 0.5) * resolution_m, (j + 0.5) * resolution_m);
        if (near(c)) grid.cells[size_t(j) * grid.width + i] = 100;
      }
    }
  };
  for (const Segment& s : segments) {
    if (!s.a.allFinite() || !s.b.allFinite()) throw RouteError(what + "a segment is not finite");
    mark(s.a.cwiseMin(s.b), s.a.cwiseMax(s.b), [&](const Vec2& c) { return pointSegmentDistance(c, s) <= reach; });
  }
  for (const Circle& d : discs) {
    if (!d.center.allFinite() || !std::isfinite(d.radius)) throw RouteError(what + "a disc is not finite");
    const Vec2 r = Vec2::Constant(std::max(0.0, d.radius));
    mark(d.center - r, d.center + r, [&](const Vec2& c) { return (c - d.center).norm() <= d.radius + reach; });
  }
  return grid;
}

RouteGrid knownWorldGrid(const std::vector<Segment>& walls, const std::vector<Circle>& furniture,
                         const std::vector<Vec2>& also_cover, double resolution_m) {
  if (walls.empty() && also_cover.empty()) throw RouteError("known world grid: no walls and no point to cover");
  Vec2 lo = Vec2::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  for (const Vec2& p : also_cover) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  for (const Segment& w : walls) {
    lo = lo.cwiseMin(w.a).cwiseMin(w.b);
    hi = hi.cwiseMax(w.a).cwiseMax(w.b);
  }
  const Vec2 margin = Vec2::Constant(2.0 * resolution_m);
  return routeGridFromGeometry(walls, furniture, lo - margin, hi + margin, resolution_m);
}

std::string RouteGuideConfig::validate() const {
  if (!(std::isfinite(lookahead_m) && lookahead_m > 0.0)) return bad("lookahead_m", lookahead_m, "must be > 0 m");
  if (!(std::isfinite(replan_off_route_m) && replan_off_route_m > 0.0))
    return bad("replan_off_route_m", replan_off_route_m, "must be > 0 m");
  if (!(std::isfinite(obstacle_memory_s) && obstacle_memory_s >= 0.0))
    return bad("obstacle_memory_s", obstacle_memory_s, "must be >= 0 s");
  if (!(std::isfinite(blocked_check_period_s) && blocked_check_period_s > 0.0))
    return bad("blocked_check_period_s", blocked_check_period_s, "must be > 0 s");
  if (!(blocked_clearance_fraction > 0.0 && blocked_clearance_fraction <= 1.0))
    return bad("blocked_clearance_fraction", blocked_clearance_fraction, "must be in (0, 1]");
  return "";
}

const char* routeReplanName(RouteReplan why) {
  switch (why) {
    case RouteReplan::kNone:
      return "";
    case RouteReplan::kOffRoute:
      return "off route";
    case RouteReplan::kAfterRound:
      return "after a recovery round";
    case RouteReplan::kBlocked:
      return "blocked";
  }
  return "";
}

RouteGuide::RouteGuide(const RouteGuideConfig& config) { setConfig(config); }

void RouteGuide::setConfig(const RouteGuideConfig& config) {
  if (const std::string e = config.validate(); !e.empty()) throw RouteError(e);
  config_ = config;
}

void RouteGuide::clear() {
  route_.reset();
  planned_ = false;
  follower_ = RouteFollower();
  memory_.clear();
  rounds_seen_ = 0;  // the navigation monitor counts the rounds of each goal afresh
  blocked_checked_ = false;
  blocked_check_s_ = 0.0;
  blocked_before_ = false;
}

std::string RouteGuide::plan(const RoutePlanner& planner, const Vec2& start, const Vec2& goal, double now_s,
                             const std::vector<Vec2>& seen) {
  // What was seen on earlier routes to this goal stays an obstacle for obstacle_memory_s: a route planned again
  // (off the route, say) must not lead back through it.
  while (!memory_.empty() && now_s - memory_.front().first > config_.obstacle_memory_s) memory_.pop_front();
  for (const Vec2& p : seen) memory_.emplace_back(now_s, p);
  std::vector<Vec2> extra;
  extra.reserve(memory_.size());
  for (const auto& [t, p] : memory_) extra.push_back(p);
  Route route = planner.plan(start, goal, extra);
  if (!route.found) return "no route: " + route.why;
  route_ = std::move(route);
  planned_ = true;
  follower_ = RouteFollower();
  return {};
}

void RouteGuide::follow(Route route) {
  route_ = std::move(route);
  planned_ = false;
  follower_ = RouteFollower();
}

RouteGuidance RouteGuide::update(const RoutePlanner* planner, const Vec2& robot, const Vec2& goal, double now_s,
                                 int recovery_rounds, const std::function<std::vector<Vec2>()>& scan_points) {
  RouteGuidance out;
  out.local_goal = goal;
  out.remaining_m = (goal - robot).norm();
  if (!route_) return out;
  const bool after_round = recovery_rounds > rounds_seen_;
  rounds_seen_ = recovery_rounds;
  const bool on_grid = planned_ && planner != nullptr;
  const RouteProgress p = on_grid ? planner->subgoal(*route_, robot, config_.lookahead_m, follower_)
                                  : followRoute(*route_, robot, config_.lookahead_m, follower_);
  out.on_route = true;
  out.final_goal = p.final_goal;
  out.local_goal = p.final_goal ? goal : p.subgoal;
  out.remaining_m = p.remaining_m;
  out.off_route_m = p.off_route_m;
  if (!on_grid) return out;
  // Blocked: something on the next lookahead_m of route at two checks in a row.
  bool blocked = false, have_seen = false;
  std::vector<Vec2> seen;
  if (scan_points && (!blocked_checked_ || now_s - blocked_check_s_ >= config_.blocked_check_period_s)) {
    blocked_checked_ = true;
    blocked_check_s_ = now_s;
    seen = scan_points();
    have_seen = true;
    const double clearance = config_.blocked_clearance_fraction * planner->config().robot_radius_m;
    const bool on_route = routeBlocked(*route_, follower_, seen, clearance, config_.lookahead_m);
    blocked = on_route && blocked_before_;
    blocked_before_ = on_route && !blocked;
  }
  // Off the route (pushed aside, a detour around people), after a recovery round or blocked: plan again from
  // here, after a round or a blockage around the obstacle points seen now.
  if (p.off_route_m > config_.replan_off_route_m || after_round || blocked) {
    out.replan = blocked ? RouteReplan::kBlocked : (after_round ? RouteReplan::kAfterRound : RouteReplan::kOffRoute);
    if ((after_round || blocked) && !have_seen && scan_points) seen = scan_points();
    out.replan_error = plan(*planner, robot, goal, now_s, after_round || blocked ? seen : std::vector<Vec2>());
    out.replanned = out.replan_error.empty();
  }
  return out;
}

std::vector<Vec2> RouteGuide::ahead(double length_m) const {
  if (!route_ || route_->points.empty()) return {};
  const std::vector<Vec2>& pts = route_->points;
  const std::vector<double>& arc = route_->arc_m;
  const size_t seg = std::min(follower_.segment, pts.size() - 1);
  const double from = std::clamp(follower_.arc_m, arc[seg], arc.back());
  auto at = [&](size_t i, double s) {  // the point at arc length s on segment i (i + 1 < pts.size())
    const double len = arc[i + 1] - arc[i];
    return len > 0.0 ? Vec2(pts[i] + (pts[i + 1] - pts[i]) * ((s - arc[i]) / len)) : pts[i];
  };
  std::vector<Vec2> out;
  out.push_back(seg + 1 < pts.size() ? at(seg, from) : pts[seg]);
  const double until = from + std::max(length_m, 0.0);
  for (size_t i = seg + 1; i < pts.size(); ++i) {
    if (arc[i] >= until) {
      out.push_back(at(i - 1, until));
      return out;
    }
    out.push_back(pts[i]);
  }
  return out;
}

double RouteGuide::distanceToGo(const Vec2& p, const Vec2& goal) const {
  if (!route_) return (p - goal).norm();
  RouteFollower from = follower_;
  const RouteProgress q = followRoute(*route_, p, 0.0, from);
  return q.off_route_m + q.remaining_m;
}

}  // namespace dqn_dovs
