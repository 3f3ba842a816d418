// Least-squares fits of circles and lines to 2-D points (LIDAR clusters). ROS-free.
//
// A LIDAR sees only the near arc of a disc. The centroid of those points lies in front of the true centre,
// so the tracker fits circles properly: an algebraic fit (Kasa, on centred data) to start, then a
// geometric Levenberg-Marquardt refinement of sum (|p - c| - r)^2, which is unbiased on partial arcs.
#pragma once

#include <optional>
#include <vector>

#include "dqn_dovs/common/geometry.h"

namespace dqn_dovs {

/// Outcome of a circle fit.
struct CircleFit {
  Circle circle;
  double rms_m = 0.0;  ///< root mean square of the geometric residuals |p - c| - r
  int iterations = 0;  ///< refinement iterations used
  bool converged = false;
};

/// Algebraic (Kasa) circle fit: least squares of x^2 + y^2 + D x + E y + F = 0 on centred, scaled data.
/// Biased toward small radii on short arcs, so used as a starting point. Needs >= 3 non-collinear points;
/// nullopt otherwise (collinear, too few, or non-finite input).
std::optional<Circle> fitCircleAlgebraic(const std::vector<Vec2>& points);

/// Geometric refinement (Levenberg-Marquardt on centre and radius) from `initial`.
/// nullopt when the points are fewer than 3, non-finite, or the fit diverges to a non-finite circle.
std::optional<CircleFit> refineCircleGeometric(const std::vector<Vec2>& points, const Circle& initial,
                                               int max_iterations = 30);

/// Algebraic start + geometric refinement; `hint` (when given) is tried as a second start and the fit with
/// the smaller residual wins (short noisy arcs can send the algebraic start to the wrong side).
std::optional<CircleFit> fitCircle(const std::vector<Vec2>& points, const std::optional<Circle>& hint = std::nullopt);

/// Best centre for a circle of known `radius` (Gauss-Newton on the centre only), from `initial_center`.
/// Used when the radius is known better than one short arc can tell (per-track radius estimate).
std::optional<CircleFit> fitCircleFixedRadius(const std::vector<Vec2>& points, double radius,
                                              const Vec2& initial_center, int max_iterations = 20);

/// Total-least-squares line through points.
struct LineFit {
  Vec2 point = Vec2::Zero();       ///< centroid, a point on the line
  Vec2 direction = Vec2::UnitX();  ///< unit direction
  double rms_m = 0.0;              ///< RMS perpendicular distance
  double max_dev_m = 0.0;          ///< largest perpendicular distance
  /// The points' extent projected on the line, as a segment.
  Segment extent;
};

/// nullopt for fewer than 2 points or non-finite input.
std::optional<LineFit> fitLine(const std::vector<Vec2>& points);

}  // namespace dqn_dovs
