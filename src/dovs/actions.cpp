#include "dqn_dovs/dovs/actions.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <vector>

namespace dqn_dovs {

namespace {

// n_v * v + n_w * w <= c
struct HalfPlane {
  double n_v, n_w, c;
  double eval(const Twist2& t) const { return n_v * t.v + n_w * t.w; }
};

constexpr double kTol = 1e-9;

std::array<HalfPlane, 4> feasibleSet(const RobotLimits& l) {
  return {HalfPlane{-1.0, 0.0, 0.0}, HalfPlane{1.0, 0.0, l.v_max}, HalfPlane{1.0 / l.v_max, 1.0 / l.w_max, 1.0},
          HalfPlane{1.0 / l.v_max, -1.0 / l.w_max, 1.0}};
}

std::array<HalfPlane, 4> rhombus(const DynamicWindow& dw) {
  std::array<HalfPlane, 4> out{};
  int k = 0;
  for (double sv : {-1.0, 1.0}) {
    for (double sw : {-1.0, 1.0}) {
      out[static_cast<size_t>(k++)] = {sv / dw.dv, sw / dw.dw,
                                       1.0 + sv * dw.center.v / dw.dv + sw * dw.center.w / dw.dw};
    }
  }
  return out;
}

// Farthest point of the segment from `from` (feasible) toward `to` that stays feasible.
Twist2 clipAlong(const Twist2& from, const Twist2& to, const RobotLimits& l) {
  double tau = 1.0;
  const Twist2 d{to.v - from.v, to.w - from.w};
  for (const HalfPlane& h : feasibleSet(l)) {
    const double g = h.eval(d);
    if (g > 0.0) tau = std::min(tau, (h.c - h.eval(from)) / g);
  }
  tau = std::clamp(tau, 0.0, 1.0);
  return {from.v + tau * d.v, from.w + tau * d.w};
}

}  // namespace

Twist2 GoalLine::direction() const {
  switch (kind) {
    case Kind::kArc:
      return {1.0, curvature_1pm};
    case Kind::kTurnInPlace:
      return {0.0, turn_sign};
    case Kind::kNone:
      break;
  }
  return {0.0, 0.0};
}

GoalLine goalLine(const Vec2& g) {
  if (!std::isfinite(g.x()) || !std::isfinite(g.y())) {
    std::ostringstream os;
    os << "goalLine: goal_in_robot_frame = (" << g.x() << ", " << g.y() << ") must be finite";
    throw ActionError(os.str());
  }
  GoalLine line;
  const double d2 = g.squaredNorm();
  if (d2 < kGoalAtRobotTolerance_m * kGoalAtRobotTolerance_m) return line;
  if (g.x() < 0.0) {
    // A forward circle through a goal behind the robot is a long loop; a differential drive turns to face it.
    line.kind = GoalLine::Kind::kTurnInPlace;
    line.turn_sign = g.y() < 0.0 ? -1.0 : 1.0;
    return line;
  }
  line.kind = GoalLine::Kind::kArc;
  line.curvature_1pm = 2.0 * g.y() / d2;
  return line;
}

int ActionSet::numValid() const { return static_cast<int>(std::count(valid.begin(), valid.end(), true)); }

ActionSet computeActions(const Twist2& current_in, const Vec2& goal_in_robot_frame, const RobotLimits& limits) {
  if (const std::string e = limits.validate(); !e.empty()) throw ActionError("computeActions: " + e);
  if (!std::isfinite(current_in.v) || !std::isfinite(current_in.w)) {
    std::ostringstream os;
    os << "computeActions: current velocity (v = " << current_in.v << ", w = " << current_in.w << ") must be finite";
    throw ActionError(os.str());
  }
  ActionSet set;
  set.goal_line = goalLine(goal_in_robot_frame);
  const Twist2 current = limits.clipToFeasible(current_in);
  set.window = makeDynamicWindow(current, limits);
  const std::array<Twist2, 4> corners = set.window.corners();
  for (size_t i = 0; i < 4; ++i) {
    set.velocities[i] = clipAlong(current, corners[i], limits);
    set.valid[i] = true;
  }
  set.velocities[kActionKeep] = current;
  set.valid[kActionKeep] = true;
  for (int i = kActionGoalHigh; i <= kActionGoalCurrent; ++i) {
    set.velocities[static_cast<size_t>(i)] = current;
    set.valid[static_cast<size_t>(i)] = false;
  }
  if (set.goal_line.kind == GoalLine::Kind::kNone) return set;

  // Intersect the ray lambda * d (lambda >= 0) with the feasible window, a convex polygon.
  const Twist2 d = set.goal_line.direction();
  double lo = 0.0, hi = std::numeric_limits<double>::infinity();
  bool empty = false;
  auto clip = [&](const HalfPlane& h) {
    const double g = h.eval(d);
    const double scale = std::abs(h.n_v) + std::abs(h.n_w);
    if (g > kTol * scale) {
      hi = std::min(hi, h.c / g);
    } else if (g < -kTol * scale) {
      lo = std::max(lo, h.c / g);
    } else if (h.c < -kTol * scale) {
      empty = true;  // parallel and outside
    }
  };
  for (const HalfPlane& h : feasibleSet(limits)) clip(h);
  for (const HalfPlane& h : rhombus(set.window)) clip(h);
  // A line that only touches a corner gives lo == hi up to rounding: keep it as a single point.
  const double touch = kTol * (1.0 + std::abs(hi));
  if (empty || !(lo <= hi + touch)) return set;
  if (lo > hi) lo = hi = 0.5 * (lo + hi);
  auto at = [&](double lambda) { return limits.clipToFeasible(Twist2{lambda * d.v, lambda * d.w}); };
  set.velocities[kActionGoalHigh] = at(hi);
  set.velocities[kActionGoalLow] = at(lo);
  set.valid[kActionGoalHigh] = set.valid[kActionGoalLow] = true;

  if (set.goal_line.kind == GoalLine::Kind::kArc) {
    const Twist2 on_line{current.v, set.goal_line.curvature_1pm * current.v};
    if (set.window.contains(on_line, limits, 1e-9)) {
      set.velocities[kActionGoalCurrent] = on_line;
      set.valid[kActionGoalCurrent] = true;
    }
  } else if (current.v <= 1e-9) {
    // On the v = 0 line every point has the current v: take the one closest to the current turn rate.
    const double lambda = std::clamp(current.w * set.goal_line.turn_sign, lo, hi);
    set.velocities[kActionGoalCurrent] = at(lambda);
    set.valid[kActionGoalCurrent] = true;
  }
  return set;
}

}  // namespace dqn_dovs
