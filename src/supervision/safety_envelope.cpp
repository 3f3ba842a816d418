#include "dqn_dovs/supervision/safety_envelope.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <sstream>

namespace dqn_dovs {

namespace {

double effectiveStep(double dt_s) { return std::isfinite(dt_s) && dt_s > 0.0 ? dt_s : 0.0; }

bool finite(const Twist2& t) { return std::isfinite(t.v) && std::isfinite(t.w); }

/// Straight reverse within `reverse` (m/s; 0: none).
bool inReverse(const Twist2& t, double reverse, double tol) {
  return reverse > 0.0 && t.v < 0.0 && t.v >= -reverse - tol && std::abs(t.w) <= tol;
}

/// The previous command the acceleration limits are measured from: itself when feasible, else its clip.
Twist2 effectivePrevious(const Twist2& previous, const RobotLimits& limits, double reverse, bool& was_bad) {
  was_bad = !finite(previous) ||
            (!limits.feasible(previous, kEnvelopeTolerance) && !inReverse(previous, reverse, kEnvelopeTolerance));
  return was_bad ? limits.clipToFeasible(previous) : previous;
}

uint32_t violationsFrom(const Twist2& prev, const Twist2& c, const RobotLimits& limits, double dt, double tol,
                        double reverse) {
  if (!finite(c)) return kEnvelopeNotFinite;
  uint32_t v = 0;
  if (c.v < -tol && !inReverse(c, reverse, tol)) v |= kEnvelopeReverse;
  if (c.v > limits.v_max + tol) v |= kEnvelopeOverSpeed;
  if (std::abs(c.w) > limits.wLimitAt(c.v) + tol) v |= kEnvelopeTriangle;
  if (std::abs(c.v - prev.v) > limits.a_v * dt + tol) v |= kEnvelopeLinearAccel;
  if (std::abs(c.w - prev.w) > limits.a_w * dt + tol) v |= kEnvelopeAngularAccel;
  return v;
}

struct P {
  double x, y;  // x = v / v_max, y = w / w_max
};

/// Sutherland-Hodgman: keeps the part of `poly` with a.x * x + a.y * y <= b (points within eps of the line
/// count as inside, so that a previous command exactly on the triangle's edge survives rounding).
template <size_t N>
size_t clipHalfPlane(const std::array<P, N>& in, size_t n, double ax, double ay, double b, std::array<P, N>& out) {
  constexpr double eps = 1e-12;
  size_t m = 0;
  for (size_t i = 0; i < n; ++i) {
    const P& p = in[i];
    const P& q = in[(i + 1) % n];
    const double fp = ax * p.x + ay * p.y - b, fq = ax * q.x + ay * q.y - b;
    const bool pin = fp <= eps, qin = fq <= eps;
    if (pin && m < N) out[m++] = p;
    if (pin != qin && std::abs(fp - fq) > 0.0) {
      const double t = fp / (fp - fq);
      if (t > 0.0 && t < 1.0 && m < N) out[m++] = {p.x + t * (q.x - p.x), p.y + t * (q.y - p.y)};
    }
  }
  return m;
}

P nearestOnSegment(const P& a, const P& b, const P& q) {
  const double dx = b.x - a.x, dy = b.y - a.y;
  const double len2 = dx * dx + dy * dy;
  if (len2 <= 0.0) return a;
  const double t = std::clamp(((q.x - a.x) * dx + (q.y - a.y) * dy) / len2, 0.0, 1.0);
  return {a.x + t * dx, a.y + t * dy};
}

}  // namespace

std::string describeEnvelopeViolations(uint32_t violations) {
  static const std::array<std::pair<uint32_t, const char*>, 7> names = {{
      {kEnvelopeNotFinite, "not finite"},
      {kEnvelopeReverse, "reverse speed"},
      {kEnvelopeOverSpeed, "above v_max"},
      {kEnvelopeTriangle, "turn rate outside the triangle |w| <= w_max (1 - v / v_max)"},
      {kEnvelopeLinearAccel, "linear acceleration above a_v"},
      {kEnvelopeAngularAccel, "angular acceleration above a_w"},
      {kEnvelopeBadPrevious, "previous command infeasible"},
  }};
  std::string out;
  for (const auto& [flag, name] : names) {
    if (!(violations & flag)) continue;
    if (!out.empty()) out += ", ";
    out += name;
  }
  return out;
}

uint32_t envelopeViolations(const Twist2& previous, const Twist2& command, const RobotLimits& limits, double dt_s,
                            double tol, double reverse_mps) {
  bool bad_prev = false;
  const Twist2 prev = effectivePrevious(previous, limits, reverse_mps, bad_prev);
  return violationsFrom(prev, command, limits, effectiveStep(dt_s), tol, reverse_mps) |
         (bad_prev ? kEnvelopeBadPrevious : 0u);
}

EnvelopeResult enforceEnvelope(const Twist2& previous, const Twist2& command, const RobotLimits& limits, double dt_s,
                               double reverse_mps) {
  const double dt = effectiveStep(dt_s);
  bool bad_prev = false;
  const Twist2 prev = effectivePrevious(previous, limits, reverse_mps, bad_prev);
  EnvelopeResult r;
  r.violations = violationsFrom(prev, command, limits, dt, kEnvelopeTolerance, reverse_mps) |
                 (bad_prev ? kEnvelopeBadPrevious : 0u);
  if (!(r.violations & ~static_cast<uint32_t>(kEnvelopeBadPrevious))) {
    r.command = command;
    return r;
  }
  if (reverse_mps > 0.0 && finite(command) && std::abs(prev.w) <= limits.a_w * dt) {
    // Straight reverse: asked for (a back-off), or the only way on from a reverse the acceleration limit does not
    // let end this step. The turn rate goes to zero; the speed is clamped into the box and the reverse limit.
    const double lo = std::max(-reverse_mps, prev.v - limits.a_v * dt), hi = std::min(0.0, prev.v + limits.a_v * dt);
    const bool stays_in_reverse = prev.v + limits.a_v * dt < 0.0;
    if ((command.v < 0.0 || stays_in_reverse) && lo <= hi) {
      r.command = {std::clamp(command.v, lo, hi), 0.0};
      if (r.command.v < 0.0 || stays_in_reverse) return r;
    }
  }

  // The admissible set in normalised coordinates: the acceleration box around `prev`, clipped to v >= 0,
  // v <= v_max, and the two sides of the triangle x + y <= 1, x - y <= 1.
  const double vm = limits.v_max, wm = limits.w_max;
  const double v_lo = std::max(0.0, prev.v - limits.a_v * dt), v_hi = std::min(vm, prev.v + limits.a_v * dt);
  const double w_lo = prev.w - limits.a_w * dt, w_hi = prev.w + limits.a_w * dt;
  std::array<P, 8> a{}, b{};
  a[0] = {v_lo / vm, w_lo / wm};
  a[1] = {v_hi / vm, w_lo / wm};
  a[2] = {v_hi / vm, w_hi / wm};
  a[3] = {v_lo / vm, w_hi / wm};
  size_t n = clipHalfPlane(a, 4, 1.0, 1.0, 1.0, b);
  n = clipHalfPlane(b, n, 1.0, -1.0, 1.0, a);

  // Target: the command itself, or a stop when it is not a number (the nearest admissible braking).
  const P q = finite(command) ? P{command.v / vm, command.w / wm} : P{0.0, 0.0};
  P best{prev.v / vm, prev.w / wm};
  if (n == 1) {
    best = a[0];
  } else if (n >= 2) {
    double best_d2 = std::numeric_limits<double>::infinity();
    for (size_t i = 0; i < n; ++i) {
      const P c = nearestOnSegment(a[i], a[(i + 1) % n], q);
      const double d2 = (c.x - q.x) * (c.x - q.x) + (c.y - q.y) * (c.y - q.y);
      if (d2 < best_d2) {
        best_d2 = d2;
        best = c;
      }
    }
  }
  // Back to m/s and rad/s; the box is enforced exactly (the triangle holds to rounding).
  r.command.v = std::clamp(best.x * vm, v_lo, v_hi);
  r.command.w = std::clamp(best.y * wm, w_lo, w_hi);
  if (!finite(r.command) || !limits.feasible(r.command, kEnvelopeTolerance)) r.command = prev;  // cannot happen
  return r;
}

SafetyEnvelope::SafetyEnvelope(const RobotLimits& limits, double max_step_s, double reverse_mps)
    : limits_(limits),
      max_step_s_(std::isfinite(max_step_s) && max_step_s > 0.0 ? max_step_s : 0.1),
      reverse_mps_(std::isfinite(reverse_mps) && reverse_mps > 0.0 ? reverse_mps : 0.0) {}

EnvelopeResult SafetyEnvelope::filter(const Twist2& command, double dt_s) {
  const double dt = std::min(effectiveStep(dt_s), max_step_s_);
  const EnvelopeResult r = enforceEnvelope(last_, command, limits_, dt, reverse_mps_);
  ++checked_;
  if (r.modified()) {
    ++corrected_;
    std::ostringstream os;
    os.precision(4);
    os << describeEnvelopeViolations(r.violations) << ": (" << command.v << " m/s, " << command.w << " rad/s) after ("
       << last_.v << ", " << last_.w << ") in " << dt << " s -> sent (" << r.command.v << ", " << r.command.w << ")";
    last_correction_ = os.str();
  }
  last_ = r.command;
  return r;
}

}  // namespace dqn_dovs
