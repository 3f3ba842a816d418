#include "dqn_dovs/common/geometry.h"

#include <algorithm>

namespace dqn_dovs {

std::optional<double> rayCircle(const Vec2& o, const Vec2& d, const Circle& c) {
  const Vec2 m = o - c.center;
  const double r2 = c.radius * c.radius;
  const double cc = m.squaredNorm() - r2;
  if (cc <= 0.0) return 0.0;  // origin inside or on the circle
  const double b = m.dot(d);
  if (b > 0.0) return std::nullopt;  // pointing away and outside
  const double disc = b * b - cc;
  if (disc < 0.0) return std::nullopt;
  return -b - std::sqrt(disc);
}

std::optional<double> raySegment(const Vec2& o, const Vec2& d, const Segment& s) {
  const Vec2 e = s.b - s.a;
  const double denom = d.x() * e.y() - d.y() * e.x();
  if (std::abs(denom) < 1e-12) return std::nullopt;  // parallel (collinear treated as a miss)
  const Vec2 ao = s.a - o;
  const double t = (ao.x() * e.y() - ao.y() * e.x()) / denom;
  const double u = (ao.x() * d.y() - ao.y() * d.x()) / denom;
  if (t < 0.0 || u < 0.0 || u > 1.0) return std::nullopt;
  return t;
}

Vec2 closestPointOnSegment(const Vec2& p, const Segment& s) {
  const Vec2 e = s.b - s.a;
  const double l2 = e.squaredNorm();
  if (l2 < 1e-18) return s.a;
  const double t = std::clamp((p - s.a).dot(e) / l2, 0.0, 1.0);
  return s.a + t * e;
}

double pointSegmentDistance(const Vec2& p, const Segment& s) { return (p - closestPointOnSegment(p, s)).norm(); }

bool segmentsCross(const Vec2& p, const Vec2& q, const Segment& s) {
  auto cross = [](const Vec2& a, const Vec2& b) { return a.x() * b.y() - a.y() * b.x(); };
  const Vec2 r = q - p, w = s.b - s.a;
  const double denom = cross(r, w);
  if (std::abs(denom) < 1e-15) return false;
  const double t = cross(s.a - p, w) / denom, u = cross(s.a - p, r) / denom;
  return t >= 0.0 && t <= 1.0 && u >= 0.0 && u <= 1.0;
}

double segmentSegmentDistance(const Segment& s, const Segment& t) {
  auto cross = [](const Vec2& a, const Vec2& b) { return a.x() * b.y() - a.y() * b.x(); };
  const Vec2 r = s.b - s.a, q = t.b - t.a;
  const double denom = cross(r, q);
  if (std::abs(denom) > 1e-9) {
    const double u = cross(t.a - s.a, q) / denom;
    const double v = cross(t.a - s.a, r) / denom;
    if (u >= 0.0 && u <= 1.0 && v >= 0.0 && v <= 1.0) return 0.0;
  }
  return std::min({pointSegmentDistance(s.a, t), pointSegmentDistance(s.b, t), pointSegmentDistance(t.a, s),
                   pointSegmentDistance(t.b, s)});
}

}  // namespace dqn_dovs
