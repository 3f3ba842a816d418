#include "dqn_dovs/common/robot_model.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace dqn_dovs {

std::string RobotLimits::validate() const {
  auto bad = [](const char* name, double value, const char* why) {
    std::ostringstream os;
    os << "robot parameter '" << name << "' = " << value << ": " << why;
    return os.str();
  };
  if (!(std::isfinite(v_max) && v_max > 0.0)) return bad("v_max", v_max, "must be a finite positive speed (m/s)");
  if (!(std::isfinite(w_max) && w_max > 0.0)) return bad("w_max", w_max, "must be a finite positive turn rate (rad/s)");
  if (!(std::isfinite(a_v) && a_v > 0.0)) return bad("a_v", a_v, "must be a finite positive acceleration (m/s^2)");
  if (!(std::isfinite(a_w) && a_w > 0.0)) return bad("a_w", a_w, "must be a finite positive acceleration (rad/s^2)");
  if (!(std::isfinite(dt) && dt > 0.0 && dt <= 2.0)) return bad("dt", dt, "control period must be in (0, 2] s");
  if (!(std::isfinite(radius) && radius > 0.0 && radius < 5.0)) return bad("radius", radius, "must be in (0, 5) m");
  return {};
}

double RobotLimits::wLimitAt(double v) const {
  return std::max(0.0, w_max * (1.0 - std::clamp(v, 0.0, v_max) / v_max));
}

bool RobotLimits::feasible(const Twist2& t, double tol) const {
  if (!std::isfinite(t.v) || !std::isfinite(t.w)) return false;
  if (t.v < -tol || t.v > v_max + tol) return false;
  // |w| / w_max + v / v_max <= 1
  return std::abs(t.w) / w_max + t.v / v_max <= 1.0 + tol;
}

Twist2 RobotLimits::clipToFeasible(const Twist2& t) const {
  if (!std::isfinite(t.v) || !std::isfinite(t.w)) return {0.0, 0.0};
  if (feasible(t, 0.0)) return t;
  // Work in normalised coordinates (a = v / v_max, b = |w| / w_max): feasible set is a >= 0, b >= 0, a + b <= 1.
  const double sign = t.w < 0.0 ? -1.0 : 1.0;
  double a = t.v / v_max, b = std::abs(t.w) / w_max;
  if (a < 0.0) a = 0.0;
  if (a + b > 1.0) {
    // Project onto the line a + b = 1, then clamp to its ends.
    const double excess = (a + b - 1.0) / 2.0;
    a -= excess;
    b -= excess;
    if (a < 0.0) {
      a = 0.0;
      b = 1.0;
    } else if (b < 0.0) {
      b = 0.0;
      a = 1.0;
    }
  }
  return {a * v_max, sign * b * w_max};
}

std::array<Twist2, 4> DynamicWindow::corners() const {
  return {Twist2{center.v + dv, center.w}, Twist2{center.v - dv, center.w}, Twist2{center.v, center.w - dw},
          Twist2{center.v, center.w + dw}};
}

bool DynamicWindow::containsRhombus(const Twist2& t, double tol) const {
  return std::abs(t.v - center.v) / dv + std::abs(t.w - center.w) / dw <= 1.0 + tol;
}

bool DynamicWindow::contains(const Twist2& t, const RobotLimits& limits, double tol) const {
  return containsRhombus(t, tol) && limits.feasible(t, tol);
}

std::vector<Twist2> DynamicWindow::samples(int n, const RobotLimits& limits) const {
  std::vector<Twist2> out;
  if (n < 1) return out;
  out.reserve(static_cast<size_t>(2 * n * n + 2 * n + 1));
  for (int i = -n; i <= n; ++i) {
    for (int j = -n; j <= n; ++j) {
      if (std::abs(i) + std::abs(j) > n) continue;
      const Twist2 t{center.v + dv * i / n, center.w + dw * j / n};
      if (limits.feasible(t, 1e-9)) out.push_back(t);
    }
  }
  return out;
}

DynamicWindow makeDynamicWindow(const Twist2& current, const RobotLimits& limits) {
  return {current, limits.dv(), limits.dw()};
}

Twist2 applyAccelerationLimits(const Twist2& current, const Twist2& command, const RobotLimits& limits, double dt_s) {
  if (!std::isfinite(current.v) || !std::isfinite(current.w)) return {0.0, 0.0};
  if (!std::isfinite(command.v) || !std::isfinite(command.w)) return limits.clipToFeasible(current);
  const double step_s = std::isfinite(dt_s) ? std::max(0.0, dt_s) : 0.0;
  const double max_dv = limits.a_v * step_s, max_dw = limits.a_w * step_s;
  Twist2 out;
  out.v = current.v + std::clamp(command.v - current.v, -max_dv, max_dv);
  out.w = current.w + std::clamp(command.w - current.w, -max_dw, max_dw);
  out.v = std::clamp(out.v, 0.0, limits.v_max);
  const double wl = limits.wLimitAt(out.v);
  if (std::abs(out.w) > wl) {
    // Reduce |w| into the triangle, but only as far as the angular acceleration allows; when that is not
    // enough, give up speed instead: from a feasible state the turn rate nearest zero within reach always
    // fits under the limit of some v between current.v and out.v.
    const double w_lo = current.w - max_dw, w_hi = current.w + max_dw;
    const double w_smallest = std::clamp(0.0, w_lo, w_hi);
    if (std::abs(w_smallest) <= wl) {
      out.w = std::clamp(out.w, -wl, wl);
    } else {
      out.w = w_smallest;
      out.v = std::min(out.v, limits.v_max * (1.0 - std::abs(out.w) / limits.w_max));
    }
  }
  // Only reachable when `current` itself was infeasible: then feasibility wins over the acceleration limits.
  if (!limits.feasible(out)) out = limits.clipToFeasible(out);
  return out;
}

Twist2 decelerationCommand(const Twist2& current, const RobotLimits& limits) {
  Twist2 c = current;
  if (!std::isfinite(c.v) || !std::isfinite(c.w)) return Twist2{0.0, 0.0};
  c = limits.clipToFeasible(c);
  // Speed first: it is what carries the robot into things. The bottom corner of the window lowers v by dv;
  // when less than dv of speed is left, the rest of the window's budget stops the turning (toward w = 0).
  // The result stays inside the rhombus, so a caller that clips to the window keeps it as it is.
  Twist2 out;
  const double dv = limits.dv(), dw = limits.dw();
  const double dv_used = std::min(c.v, dv);
  out.v = c.v - dv_used;
  const double dw_budget = dw * (1.0 - dv_used / dv);
  out.w = std::abs(c.w) <= dw_budget ? 0.0 : c.w - std::copysign(dw_budget, c.w);
  return limits.clipToFeasible(out);
}

Twist2 clipToWindow(const Twist2& current, Twist2 command, const RobotLimits& limits) {
  if (!std::isfinite(command.v) || !std::isfinite(command.w)) return current;
  const double dv = limits.dv(), dw = limits.dw();
  const double norm = std::abs(command.v - current.v) / dv + std::abs(command.w - current.w) / dw;
  if (norm > 1.0) {
    command.v = current.v + (command.v - current.v) / norm;
    command.w = current.w + (command.w - current.w) / norm;
  }
  return limits.clipToFeasible(command);
}

}  // namespace dqn_dovs
