#include "dqn_dovs/perception/circle_fit.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>

namespace dqn_dovs {
namespace {

bool allFinite(const std::vector<Vec2>& points) {
  return std::all_of(points.begin(), points.end(), [](const Vec2& p) { return p.allFinite(); });
}

Vec2 centroidOf(const std::vector<Vec2>& points) {
  Vec2 c = Vec2::Zero();
  for (const Vec2& p : points) c += p;
  return c / static_cast<double>(points.size());
}

double sumSquaredResiduals(const std::vector<Vec2>& points, const Vec2& c, double r) {
  double s = 0.0;
  for (const Vec2& p : points) {
    const double e = (p - c).norm() - r;
    s += e * e;
  }
  return s;
}

}  // namespace

std::optional<Circle> fitCircleAlgebraic(const std::vector<Vec2>& points) {
  if (points.size() < 3 || !allFinite(points)) return std::nullopt;
  // Centre and scale the data so the normal equations stay well conditioned far from the origin.
  const Vec2 mean = centroidOf(points);
  double scale = 0.0;
  for (const Vec2& p : points) scale = std::max(scale, (p - mean).norm());
  if (!(scale > 1e-12)) return std::nullopt;
  const Eigen::Index n = static_cast<Eigen::Index>(points.size());
  Eigen::MatrixXd a(n, 3);
  Eigen::VectorXd b(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const Vec2 q = (points[static_cast<size_t>(i)] - mean) / scale;
    a(i, 0) = q.x();
    a(i, 1) = q.y();
    a(i, 2) = 1.0;
    b(i) = -q.squaredNorm();
  }
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(a);
  if (qr.rank() < 3) return std::nullopt;
  const Eigen::Vector3d def = qr.solve(b);
  const Vec2 c(-0.5 * def(0), -0.5 * def(1));
  const double r2 = c.squaredNorm() - def(2);
  if (!(r2 > 0.0) || !std::isfinite(r2)) return std::nullopt;
  Circle out;
  out.center = mean + scale * c;
  out.radius = scale * std::sqrt(r2);
  if (!out.center.allFinite() || !std::isfinite(out.radius)) return std::nullopt;
  return out;
}

std::optional<CircleFit> refineCircleGeometric(const std::vector<Vec2>& points, const Circle& initial,
                                               int max_iterations) {
  if (points.size() < 3 || !allFinite(points) || !initial.center.allFinite() || !std::isfinite(initial.radius)) {
    return std::nullopt;
  }
  Vec2 c = initial.center;
  double r = initial.radius;
  double cost = sumSquaredResiduals(points, c, r);
  double lambda = 1e-3;
  CircleFit fit;
  for (int it = 0; it < max_iterations; ++it) {
    fit.iterations = it + 1;
    // Residual e_i = |p_i - c| - r; de/dc = -(p_i - c)/|p_i - c|, de/dr = -1.
    Eigen::Matrix3d jtj = Eigen::Matrix3d::Zero();
    Eigen::Vector3d jte = Eigen::Vector3d::Zero();
    for (const Vec2& p : points) {
      const Vec2 d = p - c;
      const double dist = d.norm();
      if (dist < 1e-12) continue;  // a point at the centre has no defined gradient
      const Eigen::Vector3d j(-d.x() / dist, -d.y() / dist, -1.0);
      jtj += j * j.transpose();
      jte += j * (dist - r);
    }
    bool improved = false;
    for (int tries = 0; tries < 10 && !improved; ++tries) {
      Eigen::Matrix3d damped = jtj;
      damped.diagonal() *= (1.0 + lambda);
      damped.diagonal().array() += 1e-12;
      const Eigen::Vector3d step = damped.ldlt().solve(-jte);
      if (!step.allFinite()) break;
      const Vec2 c_new = c + step.head<2>();
      const double r_new = r + step(2);
      const double cost_new = sumSquaredResiduals(points, c_new, r_new);
      if (std::isfinite(cost_new) && cost_new <= cost) {
        const double rel = (cost - cost_new) / std::max(cost, 1e-300);
        c = c_new;
        r = r_new;
        cost = cost_new;
        lambda = std::max(lambda * 0.3, 1e-9);
        improved = true;
        if (step.norm() < 1e-9 || rel < 1e-12) fit.converged = true;
      } else {
        lambda *= 10.0;
      }
    }
    if (!improved) {
      fit.converged = true;  // no descent direction left: a (local) minimum
      break;
    }
    if (fit.converged) break;
  }
  if (r < 0.0) r = -r;  // (c, -r) has the same residual magnitudes only at r = 0; keep the radius positive
  if (!c.allFinite() || !std::isfinite(r)) return std::nullopt;
  fit.circle.center = c;
  fit.circle.radius = r;
  fit.rms_m = std::sqrt(sumSquaredResiduals(points, c, r) / static_cast<double>(points.size()));
  return fit;
}

std::optional<CircleFit> fitCircle(const std::vector<Vec2>& points, const std::optional<Circle>& hint) {
  std::optional<CircleFit> best;
  if (const auto algebraic = fitCircleAlgebraic(points)) best = refineCircleGeometric(points, *algebraic);
  if (hint) {
    const auto from_hint = refineCircleGeometric(points, *hint);
    if (from_hint && (!best || from_hint->rms_m < best->rms_m - 1e-12)) best = from_hint;
  }
  return best;
}

std::optional<CircleFit> fitCircleFixedRadius(const std::vector<Vec2>& points, double radius,
                                              const Vec2& initial_center, int max_iterations) {
  if (points.empty() || !allFinite(points) || !initial_center.allFinite() || !(std::isfinite(radius) && radius > 0.0)) {
    return std::nullopt;
  }
  Vec2 c = initial_center;
  double cost = sumSquaredResiduals(points, c, radius);
  CircleFit fit;
  for (int it = 0; it < max_iterations; ++it) {
    fit.iterations = it + 1;
    Eigen::Matrix2d jtj = Eigen::Matrix2d::Zero();
    Eigen::Vector2d jte = Eigen::Vector2d::Zero();
    for (const Vec2& p : points) {
      const Vec2 d = p - c;
      const double dist = d.norm();
      if (dist < 1e-12) continue;
      const Eigen::Vector2d j = -d / dist;
      jtj += j * j.transpose();
      jte += j * (dist - radius);
    }
    jtj.diagonal().array() += 1e-9;
    Eigen::Vector2d step = jtj.ldlt().solve(-jte);
    if (!step.allFinite()) break;
    // Halve the step until the cost does not grow (plain Gauss-Newton can overshoot on one-sided arcs).
    bool accepted = false;
    for (int k = 0; k < 8; ++k) {
      const double cost_new = sumSquaredResiduals(points, c + step, radius);
      if (cost_new <= cost) {
        c += step;
        cost = cost_new;
        accepted = true;
        break;
      }
      step *= 0.5;
    }
    if (!accepted || step.norm() < 1e-9) {
      fit.converged = true;
      break;
    }
  }
  if (!c.allFinite()) return std::nullopt;
  fit.circle.center = c;
  fit.circle.radius = radius;
  fit.rms_m = std::sqrt(cost / static_cast<double>(points.size()));
  return fit;
}

std::optional<LineFit> fitLine(const std::vector<Vec2>& points) {
  if (points.size() < 2 || !allFinite(points)) return std::nullopt;
  LineFit fit;
  fit.point = centroidOf(points);
  Eigen::Matrix2d scatter = Eigen::Matrix2d::Zero();
  for (const Vec2& p : points) {
    const Vec2 d = p - fit.point;
    scatter += d * d.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(scatter);
  fit.direction = eig.eigenvectors().col(1).normalized();  // largest eigenvalue: along the line
  if (!fit.direction.allFinite()) fit.direction = Vec2::UnitX();
  const Vec2 normal(-fit.direction.y(), fit.direction.x());
  double lo = std::numeric_limits<double>::infinity(), hi = -lo, sq = 0.0;
  for (const Vec2& p : points) {
    const Vec2 d = p - fit.point;
    const double along = d.dot(fit.direction);
    const double across = d.dot(normal);
    lo = std::min(lo, along);
    hi = std::max(hi, along);
    sq += across * across;
    fit.max_dev_m = std::max(fit.max_dev_m, std::abs(across));
  }
  fit.rms_m = std::sqrt(sq / static_cast<double>(points.size()));
  fit.extent.a = fit.point + lo * fit.direction;
  fit.extent.b = fit.point + hi * fit.direction;
  return fit;
}

}  // namespace dqn_dovs
