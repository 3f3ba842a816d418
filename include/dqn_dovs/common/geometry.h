// Planar geometry shared by every core module: poses, angles, rays, circles and segments.
// ROS-free: Eigen + std only.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <optional>

namespace dqn_dovs {

using Vec2 = Eigen::Vector2d;

constexpr double kPi = 3.14159265358979323846;
constexpr double kTwoPi = 2.0 * kPi;

/// Wraps an angle to (-pi, pi].
inline double normalizeAngle(double a) {
  if (!std::isfinite(a)) return a;
  a = std::fmod(a + kPi, kTwoPi);
  if (a <= 0.0) a += kTwoPi;
  return a - kPi;
}

/// Smallest signed difference a - b, wrapped to (-pi, pi].
inline double angleDiff(double a, double b) { return normalizeAngle(a - b); }

/// A planar pose: position in metres, heading theta in radians (REP 103: x forward, CCW positive).
struct Pose2 {
  double x = 0.0;
  double y = 0.0;
  double theta = 0.0;

  Vec2 position() const { return {x, y}; }
  /// Maps a point expressed in this pose's frame into the parent frame.
  Vec2 toWorld(const Vec2& p_local) const {
    const double c = std::cos(theta), s = std::sin(theta);
    return {x + c * p_local.x() - s * p_local.y(), y + s * p_local.x() + c * p_local.y()};
  }
  /// Maps a point of the parent frame into this pose's frame.
  Vec2 toLocal(const Vec2& p_world) const {
    const double c = std::cos(theta), s = std::sin(theta);
    const double dx = p_world.x() - x, dy = p_world.y() - y;
    return {c * dx + s * dy, -s * dx + c * dy};
  }
  /// Composition this * other (other expressed in this frame).
  Pose2 compose(const Pose2& other) const {
    const Vec2 p = toWorld(other.position());
    return {p.x(), p.y(), normalizeAngle(theta + other.theta)};
  }
  Pose2 inverse() const {
    const double c = std::cos(theta), s = std::sin(theta);
    return {-(c * x + s * y), -(-s * x + c * y), normalizeAngle(-theta)};
  }
  bool isFinite() const { return std::isfinite(x) && std::isfinite(y) && std::isfinite(theta); }
};

/// A disc.
struct Circle {
  Vec2 center = Vec2::Zero();
  double radius = 0.0;
};

/// A line segment from a to b.
struct Segment {
  Vec2 a = Vec2::Zero();
  Vec2 b = Vec2::Zero();
  double length() const { return (b - a).norm(); }
};

/// Advances a unicycle exactly for time dt with constant linear speed v (m/s) and turn rate w (rad/s):
/// a straight line when |w| is tiny, otherwise an arc of radius v / w.
inline Pose2 integrateUnicycle(const Pose2& p, double v, double w, double dt) {
  Pose2 out;
  if (std::abs(w) < 1e-9) {
    out.x = p.x + v * dt * std::cos(p.theta);
    out.y = p.y + v * dt * std::sin(p.theta);
    out.theta = p.theta;
  } else {
    const double th1 = p.theta + w * dt;
    out.x = p.x + v / w * (std::sin(th1) - std::sin(p.theta));
    out.y = p.y - v / w * (std::cos(th1) - std::cos(p.theta));
    out.theta = normalizeAngle(th1);
  }
  return out;
}

/// One arc of (v, w) held for dt, in the frame of the pose it starts from: the displacement and the turn as a cosine
/// and sine (integrateUnicycle's arc; 1 - cos written as 2 sin^2 so that slow turns keep their precision).
struct UnicycleStep {
  double dx = 0.0, dy = 0.0, turn_c = 1.0, turn_s = 0.0;
};
inline UnicycleStep unicycleStep(double v, double w, double dt) {
  UnicycleStep s;
  if (std::abs(w) < 1e-9) {
    s.dx = v * dt;
    return s;
  }
  const double a = w * dt, half = std::sin(0.5 * a);
  s.turn_s = std::sin(a);
  s.turn_c = 1.0 - 2.0 * half * half;
  s.dx = v / w * s.turn_s;
  s.dy = v / w * 2.0 * half * half;
  return s;
}

/// A pose that carries its heading as a cosine and sine, moved by UnicycleSteps without further trigonometry (for
/// paths sampled many times per decision: the escape's roll-outs, the braking walks).
struct HeadingPose {
  Vec2 position = Vec2::Zero();
  double c = 1.0, s = 0.0;
  HeadingPose() = default;
  explicit HeadingPose(const Pose2& p) : position(p.position()), c(std::cos(p.theta)), s(std::sin(p.theta)) {}
  void advance(const UnicycleStep& u) {
    position += Vec2(c * u.dx - s * u.dy, s * u.dx + c * u.dy);
    const double c1 = c * u.turn_c - s * u.turn_s;
    s = s * u.turn_c + c * u.turn_s;
    c = c1;
  }
};

/// Distance along a ray (origin o, unit direction d) to its first hit with a circle, if any in [0, inf).
/// A ray starting inside the circle hits at distance 0.
std::optional<double> rayCircle(const Vec2& o, const Vec2& d, const Circle& c);

/// Distance along a ray (origin o, unit direction d) to its hit with a segment, if any.
std::optional<double> raySegment(const Vec2& o, const Vec2& d, const Segment& s);

/// Distance from point p to segment s.
double pointSegmentDistance(const Vec2& p, const Segment& s);

/// Closest point of segment s to p.
Vec2 closestPointOnSegment(const Vec2& p, const Segment& s);

/// True when the segment from p to q meets segment s (ends included; parallel segments never meet).
bool segmentsCross(const Vec2& p, const Vec2& q, const Segment& s);

/// Distance between segments s and t (0 when they meet).
double segmentSegmentDistance(const Segment& s, const Segment& t);

}  // namespace dqn_dovs
