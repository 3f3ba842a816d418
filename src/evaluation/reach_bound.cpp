#include "dqn_dovs/evaluation/reach_bound.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <sstream>
#include <vector>

#include "dqn_dovs/common/geometry.h"
#include "dqn_dovs/common/parse.h"

namespace dqn_dovs {

std::string ReachBoundConfig::validate() const {
  std::ostringstream os;
  if (!(cell_m >= 0.005 && cell_m <= 0.5))
    os << "bound cell_m " << cell_m << " not in [0.005, 0.5]";
  else if (!(body_margin_m >= 0.0 && body_margin_m < 0.2))
    os << "bound body_margin_m " << body_margin_m << " not in [0, 0.2)";
  else if (!(grid_margin_m >= 0.0 && grid_margin_m <= 20.0))
    os << "bound grid_margin_m " << grid_margin_m << " not in [0, 20]";
  else if (!(goal_tolerance_m > 0.0 && std::isfinite(goal_tolerance_m)))
    os << "bound goal_tolerance_m " << goal_tolerance_m << " must be > 0";
  else if (max_periods < 1)
    os << "bound max_periods " << max_periods << " must be >= 1";
  else if (!(scan_period_s > 0.0 && std::isfinite(scan_period_s)))
    os << "bound scan_period_s " << scan_period_s << " must be > 0";
  return os.str();
}

std::string setReachBoundParameter(ReachBoundConfig& config, const std::string& name, const std::string& value) {
  const std::optional<double> parsed = parseNumber(value);
  if (!parsed || !std::isfinite(*parsed)) return "bound parameter '" + name + "' = '" + value + "' is not a number";
  if (name == "cell_m")
    config.cell_m = *parsed;
  else if (name == "body_margin_m")
    config.body_margin_m = *parsed;
  else if (name == "grid_margin_m")
    config.grid_margin_m = *parsed;
  else
    return "unknown bound parameter '" + name + "' (cell_m, body_margin_m, grid_margin_m)";
  return {};
}

namespace {

/// Cells [x0, x1) x [y0, y1) of the grid.
struct Box {
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
};

/// The robot's reachable positions on a grid, one period at a time.
class ReachGrid {
 public:
  ReachGrid(const Vec2& origin, int w, int h, double cell) : origin_(origin), w_(w), h_(h), cell_(cell) {
    const size_t n = static_cast<size_t>(w) * static_cast<size_t>(h);
    static_blocked_.assign(n, 0);
    blocked_.assign(n, 0);
    set_.assign(n, 0);
    next_.assign(n, 0);
    row_gap_.assign(n, 0);
  }
  Vec2 center(int i, int j) const { return origin_ + Vec2((i + 0.5) * cell_, (j + 0.5) * cell_); }
  size_t at(int i, int j) const { return static_cast<size_t>(j) * static_cast<size_t>(w_) + static_cast<size_t>(i); }

  /// Cells whose centre is within `reach` of `p`, clipped to the grid.
  Box around(const Vec2& p, double reach) const {
    Box b;
    b.x0 = std::max(0, static_cast<int>(std::floor((p.x() - reach - origin_.x()) / cell_)));
    b.y0 = std::max(0, static_cast<int>(std::floor((p.y() - reach - origin_.y()) / cell_)));
    b.x1 = std::min(w_, static_cast<int>(std::ceil((p.x() + reach - origin_.x()) / cell_)) + 1);
    b.y1 = std::min(h_, static_cast<int>(std::ceil((p.y() + reach - origin_.y()) / cell_)) + 1);
    return b;
  }

  /// Marks cells whose centre is closer than `within` to `c` in `mask`.
  void markDisc(std::vector<uint8_t>& mask, const Vec2& c, double within) const {
    if (within <= 0.0) return;
    const Box b = around(c, within);
    const double w2 = within * within;
    for (int j = b.y0; j < b.y1; ++j) {
      for (int i = b.x0; i < b.x1; ++i) {
        if ((center(i, j) - c).squaredNorm() < w2) mask[at(i, j)] = 1;
      }
    }
  }

  std::vector<uint8_t>& staticBlocked() { return static_blocked_; }
  std::vector<uint8_t>& blocked() { return blocked_; }
  void resetBlocked() { blocked_ = static_blocked_; }

  bool seed(const Vec2& p) {
    const int i = static_cast<int>(std::floor((p.x() - origin_.x()) / cell_));
    const int j = static_cast<int>(std::floor((p.y() - origin_.y()) / cell_));
    if (i < 0 || j < 0 || i >= w_ || j >= h_ || blocked_[at(i, j)]) return false;
    set_[at(i, j)] = 1;
    box_ = Box{i, j, i + 1, j + 1};
    count_ = 1;
    return true;
  }

  /// The next period's set: cells not blocked, within `reach` (m, centre to centre) of a cell of the set, and within
  /// `from_start` of `start`. Returns the number of cells.
  size_t advance(double reach, const Vec2& start, double from_start) {
    const int r = static_cast<int>(std::floor(reach / cell_));
    const double r2 = (reach / cell_) * (reach / cell_);
    Box out{std::max(0, box_.x0 - r), std::max(0, box_.y0 - r), std::min(w_, box_.x1 + r), std::min(h_, box_.y1 + r)};
    // Per row of the set's box, the distance (cells) from every column of `out` to the row's nearest set cell.
    constexpr int kFar = 1 << 20;
    for (int j = box_.y0; j < box_.y1; ++j) {
      int last = -kFar;
      for (int i = out.x0; i < out.x1; ++i) {
        if (i >= box_.x0 && i < box_.x1 && set_[at(i, j)]) last = i;
        row_gap_[at(i, j)] = i - last;
      }
      last = kFar;
      for (int i = out.x1 - 1; i >= out.x0; --i) {
        if (i >= box_.x0 && i < box_.x1 && set_[at(i, j)]) last = i;
        row_gap_[at(i, j)] = std::min(row_gap_[at(i, j)], last - i);
      }
    }
    const double s2 = from_start * from_start;
    Box next_box{w_, h_, 0, 0};
    size_t count = 0;
    for (int j = out.y0; j < out.y1; ++j) {
      const int k0 = std::max(box_.y0, j - r), k1 = std::min(box_.y1 - 1, j + r);
      for (int i = out.x0; i < out.x1; ++i) {
        const size_t c = at(i, j);
        next_[c] = 0;
        if (blocked_[c] || (center(i, j) - start).squaredNorm() > s2) continue;
        for (int k = k0; k <= k1; ++k) {
          const double g = row_gap_[at(i, k)];
          if (g * g + static_cast<double>((k - j) * (k - j)) <= r2) {
            next_[c] = 1;
            break;
          }
        }
        if (next_[c]) {
          ++count;
          next_box.x0 = std::min(next_box.x0, i);
          next_box.y0 = std::min(next_box.y0, j);
          next_box.x1 = std::max(next_box.x1, i + 1);
          next_box.y1 = std::max(next_box.y1, j + 1);
        }
      }
    }
    // `out` holds the old set's box: the new set replaces the old one there.
    for (int j = out.y0; j < out.y1; ++j) {
      for (int i = out.x0; i < out.x1; ++i) set_[at(i, j)] = next_[at(i, j)];
    }
    box_ = next_box;
    count_ = count;
    return count;
  }

  /// Whether a cell of the set has its centre within `within` of `p`.
  bool holdsNear(const Vec2& p, double within) const {
    if (count_ == 0) return false;
    const Box b = around(p, within);
    for (int j = std::max(b.y0, box_.y0); j < std::min(b.y1, box_.y1); ++j) {
      for (int i = std::max(b.x0, box_.x0); i < std::min(b.x1, box_.x1); ++i) {
        if (set_[at(i, j)] && (center(i, j) - p).norm() <= within) return true;
      }
    }
    return false;
  }

  /// Whether the set touches the grid's edge.
  bool touchesEdge() const { return count_ > 0 && (box_.x0 == 0 || box_.y0 == 0 || box_.x1 == w_ || box_.y1 == h_); }

 private:
  Vec2 origin_;
  int w_, h_;
  double cell_;
  std::vector<uint8_t> static_blocked_, blocked_, set_, next_;
  std::vector<int> row_gap_;
  Box box_;
  size_t count_ = 0;
};

/// The farthest the robot can be from where it starts after `t` seconds, from speed `v0` under the acceleration
/// limit `a` and the top speed `v_max`.
double farthestFromStart(double v0, double a, double v_max, double t) {
  const double to_top = std::max(0.0, (v_max - v0) / a);
  if (t <= to_top) return v0 * t + 0.5 * a * t * t;
  return v0 * to_top + 0.5 * a * to_top * to_top + v_max * (t - to_top);
}

}  // namespace

ReachBoundResult reachBound(const sim::World& world, const ReachBoundConfig& config) {
  if (const std::string e = config.validate(); !e.empty()) throw PlannerError(e);
  if (world.config().people.effectiveMix().anyReacts()) {
    throw PlannerError("bound: people react to the robot (people mix " + world.config().people.effectiveMix().str() +
                       "), so their future depends on it and cannot be rolled ahead");
  }
  const RobotLimits& limits = world.config().robot;
  const double cell = config.cell_m, half_diagonal = 0.5 * std::sqrt(2.0) * cell;
  const Vec2 start = world.robotPose().position(), goal = world.goal();
  Vec2 lo = start.cwiseMin(goal), hi = start.cwiseMax(goal);
  for (const Segment& s : world.walls()) {
    lo = lo.cwiseMin(s.a).cwiseMin(s.b);
    hi = hi.cwiseMax(s.a).cwiseMax(s.b);
  }
  const Vec2 origin = lo - Vec2::Constant(config.grid_margin_m);
  const int w = static_cast<int>(std::ceil((hi.x() - lo.x() + 2.0 * config.grid_margin_m) / cell)) + 1;
  const int h = static_cast<int>(std::ceil((hi.y() - lo.y() + 2.0 * config.grid_margin_m) / cell)) + 1;
  ReachGrid grid(origin, w, h, cell);

  // A cell is blocked by the walls when even the point of it farthest from them touches one.
  const double radius = limits.radius;
  for (const Segment& s : world.walls()) {
    const double within = radius - half_diagonal;
    if (within <= 0.0) continue;
    // Cells near the segment: its bounding box grown by `within`.
    const Vec2 a = s.a.cwiseMin(s.b), b = s.a.cwiseMax(s.b);
    const Box box = grid.around(0.5 * (a + b), 0.5 * (b - a).norm() + within);
    for (int j = box.y0; j < box.y1; ++j) {
      for (int i = box.x0; i < box.x1; ++i) {
        if (pointSegmentDistance(grid.center(i, j), s) < within) grid.staticBlocked()[grid.at(i, j)] = 1;
      }
    }
  }
  auto blockBodies = [&](const sim::World& now) {
    grid.resetBlocked();
    for (const MovingObstacle& o : now.groundTruthObstacles()) {
      grid.markDisc(grid.blocked(), o.center, radius + o.radius - half_diagonal - config.body_margin_m);
    }
  };

  ReachBoundResult result;
  sim::World future = world;  // the robot stands aside; the bodies ignore it
  blockBodies(future);
  if (world.collided() || !grid.seed(start)) {
    result.verdict = ReachBoundResult::Verdict::kBoxedIn;
    return result;
  }
  const double dt = limits.dt;
  const int chunks = std::max(1, static_cast<int>(std::lround(dt / config.scan_period_s)));
  const double reach = limits.v_max * dt + 2.0 * half_diagonal;
  const double v0 = std::max(0.0, world.robotTwist().v);
  for (int k = 1; k <= config.max_periods; ++k) {
    for (int c = 0; c < chunks; ++c) future.step(Twist2{}, dt / chunks);
    blockBodies(future);
    const double from_start = farthestFromStart(v0, limits.a_v, limits.v_max, k * dt) + half_diagonal;
    const size_t held = grid.advance(reach, start, from_start);
    result.periods = k;
    result.time_s = k * dt;
    if (held == 0) {
      result.verdict = ReachBoundResult::Verdict::kBoxedIn;
      return result;
    }
    if (grid.touchesEdge()) {
      // Beyond the grid the robot might survive or arrive sooner: the grid cannot tell, so it counts as reached.
      result.left_grid = true;
      result.verdict = ReachBoundResult::Verdict::kReachable;
      return result;
    }
    if (grid.holdsNear(goal, config.goal_tolerance_m + half_diagonal)) {
      result.verdict = ReachBoundResult::Verdict::kReachable;
      return result;
    }
  }
  result.verdict = ReachBoundResult::Verdict::kOutOfTime;
  return result;
}

ReachBoundPlanner::ReachBoundPlanner(const ReachBoundConfig& config) : config_(config) {
  if (const std::string e = config_.validate(); !e.empty()) throw PlannerError(e);
}

PlannerDecision ReachBoundPlanner::decide(const PlannerInput& /*input*/) {
  throw PlannerError("bound: an analysis of the whole episode (runEpisode asks reachBound), not a planner to drive");
}

}  // namespace dqn_dovs
