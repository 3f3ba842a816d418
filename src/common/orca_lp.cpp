// ORCA's geometry and linear program (see orca_lp.h).
#include "dqn_dovs/common/orca_lp.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

namespace dqn_dovs {
namespace {

constexpr double kEps = 1e-9;
constexpr double kInf = std::numeric_limits<double>::infinity();

inline double cross(const Vec2& a, const Vec2& b) { return a.x() * b.y() - a.y() * b.x(); }
inline Vec2 perpCcw(const Vec2& v) { return {-v.y(), v.x()}; }
inline Vec2 perpCw(const Vec2& v) { return {v.y(), -v.x()}; }
inline Vec2 rotate(const Vec2& v, double angle) {
  const double c = std::cos(angle), s = std::sin(angle);
  return {c * v.x() - s * v.y(), s * v.x() + c * v.y()};
}

/// A point of the velocity obstacle's boundary and the boundary normal pointing out of the obstacle there.
struct BoundaryCandidate {
  Vec2 point;
  Vec2 normal;
};

OrcaLine lineThrough(const Vec2& point, const Vec2& normal) { return OrcaLine{point, perpCw(normal)}; }

// The 1-D program on line `i`: the point of line i inside the speed disc and on the allowed side of every line
// before it, closest to `target` (or farthest along `target` when `along_direction`). False when empty.
bool solveOnLine(const std::vector<OrcaLine>& lines, size_t i, double radius, const Vec2& target, bool along_direction,
                 Vec2& result) {
  const OrcaLine& li = lines[i];
  const double along = li.point.dot(li.direction);
  const double disc = along * along + radius * radius - li.point.squaredNorm();
  if (disc < 0.0) return false;  // the line misses the speed disc
  double t_left = -along - std::sqrt(disc);
  double t_right = -along + std::sqrt(disc);
  for (size_t j = 0; j < i; ++j) {
    const OrcaLine& lj = lines[j];
    // A point p_i + t d_i is allowed by line j when t * cross(d_i, d_j) <= cross(d_j, p_i - p_j).
    const double denom = cross(li.direction, lj.direction);
    const double numer = cross(lj.direction, li.point - lj.point);
    if (std::abs(denom) <= kEps) {
      if (numer < 0.0) return false;  // parallel and wholly on the forbidden side of line j
      continue;
    }
    const double t = numer / denom;
    if (denom > 0.0) {
      t_right = std::min(t_right, t);
    } else {
      t_left = std::max(t_left, t);
    }
    if (t_left > t_right) return false;
  }
  double t;
  if (along_direction) {
    t = target.dot(li.direction) > 0.0 ? t_right : t_left;
  } else {
    t = std::clamp(li.direction.dot(target - li.point), t_left, t_right);
  }
  result = li.point + t * li.direction;
  return true;
}

// The incremental 2-D program. Returns lines.size() on success, otherwise the index of the line that could not
// be met (result then holds the optimum over the lines before it).
size_t solvePlanar(const std::vector<OrcaLine>& lines, double radius, const Vec2& target, bool along_direction,
                   Vec2& result) {
  if (along_direction) {
    result = target * radius;  // target is a unit direction here
  } else if (target.squaredNorm() > radius * radius) {
    result = target.normalized() * radius;
  } else {
    result = target;
  }
  for (size_t i = 0; i < lines.size(); ++i) {
    if (lines[i].margin(result) >= 0.0) continue;
    const Vec2 previous = result;
    if (!solveOnLine(lines, i, radius, target, along_direction, result)) {
      result = previous;
      return i;
    }
  }
  return lines.size();
}

// The 3-D program for the infeasible case: minimise the largest violation d of the soft lines (hard lines kept).
// Each time a line is violated by more than the current d, the optimum lies on the bisector-like lines where the
// violation of that line equals the violation of an earlier one; solving the 2-D program on those, pushing as far
// as possible into line i, gives the new optimum.
void solveLeastViolation(const std::vector<OrcaLine>& lines, size_t num_hard, size_t first_failed, double radius,
                         Vec2& result) {
  double distance = 0.0;
  std::vector<OrcaLine> projected;
  for (size_t i = first_failed; i < lines.size(); ++i) {
    const OrcaLine& li = lines[i];
    if (-li.margin(result) <= distance + kEps) continue;
    projected.assign(lines.begin(), lines.begin() + static_cast<std::ptrdiff_t>(std::min(num_hard, i)));
    for (size_t j = num_hard; j < i; ++j) {
      const OrcaLine& lj = lines[j];
      OrcaLine line;
      const double determinant = cross(li.direction, lj.direction);
      if (std::abs(determinant) <= kEps) {
        if (li.direction.dot(lj.direction) > 0.0) continue;  // same direction: line j never binds first
        line.point = 0.5 * (li.point + lj.point);            // opposite: the mid-line balances both violations
      } else {
        line.point = li.point + (cross(lj.direction, li.point - lj.point) / determinant) * li.direction;
      }
      const Vec2 dir = lj.direction - li.direction;
      if (dir.norm() <= kEps) continue;
      line.direction = dir.normalized();
      projected.push_back(line);
    }
    const Vec2 previous = result;
    if (solvePlanar(projected, radius, perpCcw(li.direction), true, result) < projected.size()) {
      // Only rounding can make this fail: the previous result satisfies every projected line.
      result = previous;
    }
    distance = -li.margin(result);
  }
}

}  // namespace

double OrcaLine::margin(const Vec2& v) const { return cross(direction, v - point); }

VelocityObstacleProjection projectOnVelocityObstacle(const Vec2& a, const Vec2& b, double combined_radius_m,
                                                     double horizon_s, const Vec2& relative_velocity,
                                                     double collision_time_step_s) {
  const double R = combined_radius_m;
  const Vec2& v = relative_velocity;
  const Segment obstacle{a, b};
  const Vec2 closest = closestPointOnSegment(Vec2::Zero(), obstacle);
  const double distance = closest.norm();
  VelocityObstacleProjection out;

  if (distance < R) {
    // Already overlapping: leave the overlap within one time step, i.e. stay out of the obstacle scaled by
    // 1 / step (the velocity obstacle's cut-off for that horizon).
    const double inv = 1.0 / collision_time_step_s;
    const Segment scaled{a * inv, b * inv};
    const Vec2 q = closestPointOnSegment(v, scaled);
    const Vec2 w = v - q;
    const double wn = w.norm();
    if (wn > kEps) {
      out.normal = w / wn;
    } else if (distance > kEps) {
      out.normal = -closest / distance;
    } else {
      out.normal = Vec2::UnitX();
    }
    out.boundary_point = q + R * inv * out.normal;
    out.inside = wn < R * inv;
    out.overlapping = true;
    return out;
  }

  const double inv = 1.0 / horizon_s;
  std::vector<BoundaryCandidate> candidates;
  candidates.reserve(6);

  // Legs: the two rays from the origin tangent to the obstacle enlarged by R, starting at the cut-off.
  const Vec2 ref = closest / distance;
  const bool is_disc = (b - a).norm() <= kEps;
  double left_angle = -kInf, right_angle = kInf;
  Vec2 left_center = a, right_center = a;
  for (const Vec2& e : {a, b}) {
    const double en = e.norm();
    const double rel = std::atan2(cross(ref, e), ref.dot(e));
    const double half = std::asin(std::min(1.0, R / en));
    if (rel + half > left_angle) {
      left_angle = rel + half;
      left_center = e;
    }
    if (rel - half < right_angle) {
      right_angle = rel - half;
      right_center = e;
    }
  }
  const Vec2 left_dir = rotate(ref, left_angle), right_dir = rotate(ref, right_angle);
  const Vec2 left_start = left_center.dot(left_dir) * left_dir * inv;
  const Vec2 right_start = right_center.dot(right_dir) * right_dir * inv;
  candidates.push_back({left_start + std::max(0.0, (v - left_start).dot(left_dir)) * left_dir, perpCcw(left_dir)});
  candidates.push_back({right_start + std::max(0.0, (v - right_start).dot(right_dir)) * right_dir, perpCw(right_dir)});

  // The cut-off: the part of the enlarged obstacle scaled by 1 / horizon that faces the origin.
  if (!is_disc) {
    const Vec2 along = (b - a).normalized();
    Vec2 side_normal = perpCcw(along);
    if (side_normal.dot(a) > 0.0) side_normal = -side_normal;  // the side facing the origin
    if (side_normal.dot(a) + R <= 0.0) {
      const Segment side{(a + R * side_normal) * inv, (b + R * side_normal) * inv};
      candidates.push_back({closestPointOnSegment(v, side), side_normal});
    }
  }
  for (int end = 0; end < (is_disc ? 1 : 2); ++end) {
    const Vec2 c = (end == 0 ? a : b) * inv;
    const Vec2 outward_end = is_disc ? Vec2::Zero() : (end == 0 ? Vec2(a - b) : Vec2(b - a));
    const Vec2 w = v - c;
    const double wn = w.norm();
    if (wn <= kEps) continue;
    const Vec2 n = w / wn;
    const Vec2 x = c + R * inv * n;
    if (n.dot(x) <= 0.0 && n.dot(outward_end) >= 0.0) candidates.push_back({x, n});
  }

  double best = kInf;
  for (const BoundaryCandidate& cand : candidates) {
    const double d = (cand.point - v).squaredNorm();
    if (d < best) {
      best = d;
      out.boundary_point = cand.point;
      out.normal = cand.normal;
    }
  }
  out.inside = segmentSegmentDistance(Segment{Vec2::Zero(), v * horizon_s}, obstacle) < R;
  return out;
}

OrcaLine orcaLineForDisc(const Vec2& robot_position, const Vec2& robot_velocity, double robot_radius_m,
                         const Vec2& obstacle_center, const Vec2& obstacle_velocity, double obstacle_radius_m,
                         double horizon_s, double collision_time_step_s, double responsibility) {
  const Vec2 rel = obstacle_center - robot_position;
  const VelocityObstacleProjection p =
      projectOnVelocityObstacle(rel, rel, robot_radius_m + obstacle_radius_m, horizon_s,
                                robot_velocity - obstacle_velocity, collision_time_step_s);
  // The obstacle does not react: the robot takes the whole correction (v + u, not ORCA's v + u / 2).
  if (responsibility == 1.0) return lineThrough(obstacle_velocity + p.boundary_point, p.normal);
  // Reciprocal: v + responsibility * u, u the smallest change of the relative velocity out of the obstacle.
  const Vec2 u = p.boundary_point - (robot_velocity - obstacle_velocity);
  return lineThrough(robot_velocity + responsibility * u, p.normal);
}

OrcaLine orcaLineForSegment(const Vec2& robot_position, const Vec2& robot_velocity, double robot_radius_m,
                            const Segment& wall, double horizon_s, double collision_time_step_s) {
  const VelocityObstacleProjection p =
      projectOnVelocityObstacle(wall.a - robot_position, wall.b - robot_position, robot_radius_m, horizon_s,
                                robot_velocity, collision_time_step_s);
  return lineThrough(p.boundary_point, p.normal);
}

OrcaLpResult solveOrcaLp(const std::vector<OrcaLine>& lines_in, size_t num_hard, double max_speed,
                         const Vec2& preferred, std::mt19937_64* rng) {
  // Unusable lines (non-finite, zero direction) are dropped and a bad speed limit stops the robot, so that odd
  // input never turns into a NaN velocity.
  std::vector<OrcaLine> lines;
  lines.reserve(lines_in.size());
  size_t kept_hard = 0;
  for (size_t i = 0; i < lines_in.size(); ++i) {
    const OrcaLine& l = lines_in[i];
    if (!(l.point.allFinite() && l.direction.allFinite() && l.direction.norm() > kEps)) continue;
    lines.push_back(OrcaLine{l.point, l.direction.normalized()});
    if (i < num_hard) ++kept_hard;
  }
  num_hard = kept_hard;
  if (!(std::isfinite(max_speed) && max_speed > 0.0)) max_speed = 0.0;
  if (rng != nullptr) {
    std::shuffle(lines.begin(), lines.begin() + static_cast<std::ptrdiff_t>(num_hard), *rng);
    std::shuffle(lines.begin() + static_cast<std::ptrdiff_t>(num_hard), lines.end(), *rng);
  }
  OrcaLpResult out;
  const Vec2 target = preferred.allFinite() ? preferred : Vec2::Zero();
  const size_t failed = solvePlanar(lines, max_speed, target, false, out.velocity);
  if (failed < lines.size()) {
    out.feasible = false;
    // When the walls alone already contradict each other, every line is treated alike (least violation of all).
    solveLeastViolation(lines, failed < num_hard ? 0 : num_hard, failed, max_speed, out.velocity);
  }
  for (const OrcaLine& l : lines) out.max_violation = std::max(out.max_violation, -l.margin(out.velocity));
  return out;
}

}  // namespace dqn_dovs
