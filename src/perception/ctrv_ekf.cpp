#include "dqn_dovs/perception/ctrv_ekf.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>

namespace dqn_dovs {
namespace {
// Below this |turn_rate * dt| the arc formulas lose precision; the straight-line limit (with its
// first-order turn correction in the Jacobian) is used instead.
constexpr double kStraightThreshold = 1e-6;
}  // namespace

CtrvState ctrvPredictState(const CtrvState& x, double dt) {
  CtrvState out = x;
  const double th = x(kCtrvHeading), v = x(kCtrvSpeed), w = x(kCtrvTurnRate);
  if (std::abs(w * dt) < kStraightThreshold) {
    out(kCtrvX) += v * dt * std::cos(th);
    out(kCtrvY) += v * dt * std::sin(th);
  } else {
    const double th1 = th + w * dt;
    out(kCtrvX) += v / w * (std::sin(th1) - std::sin(th));
    out(kCtrvY) += v / w * (std::cos(th) - std::cos(th1));
  }
  out(kCtrvHeading) = normalizeAngle(th + w * dt);
  return out;
}

CtrvCovariance ctrvJacobian(const CtrvState& x, double dt) {
  CtrvCovariance f = CtrvCovariance::Identity();
  const double th = x(kCtrvHeading), v = x(kCtrvSpeed), w = x(kCtrvTurnRate);
  const double s0 = std::sin(th), c0 = std::cos(th);
  if (std::abs(w * dt) < kStraightThreshold) {
    f(kCtrvX, kCtrvHeading) = -v * dt * s0;
    f(kCtrvX, kCtrvSpeed) = dt * c0;
    f(kCtrvX, kCtrvTurnRate) = -0.5 * v * dt * dt * s0;
    f(kCtrvY, kCtrvHeading) = v * dt * c0;
    f(kCtrvY, kCtrvSpeed) = dt * s0;
    f(kCtrvY, kCtrvTurnRate) = 0.5 * v * dt * dt * c0;
  } else {
    const double th1 = th + w * dt;
    const double s1 = std::sin(th1), c1 = std::cos(th1);
    f(kCtrvX, kCtrvHeading) = v / w * (c1 - c0);
    f(kCtrvX, kCtrvSpeed) = (s1 - s0) / w;
    f(kCtrvX, kCtrvTurnRate) = v * dt * c1 / w - v * (s1 - s0) / (w * w);
    f(kCtrvY, kCtrvHeading) = v / w * (s1 - s0);
    f(kCtrvY, kCtrvSpeed) = (c0 - c1) / w;
    f(kCtrvY, kCtrvTurnRate) = v * dt * s1 / w - v * (c0 - c1) / (w * w);
  }
  f(kCtrvHeading, kCtrvTurnRate) = dt;
  return f;
}

CtrvCovariance ctrvProcessNoise(const CtrvState& x, double dt, double accel_std, double turn_accel_std) {
  // Noise input u = [linear accel, angular accel] through G (piecewise-constant over dt).
  const double th = x(kCtrvHeading) + 0.5 * x(kCtrvTurnRate) * dt;
  Eigen::Matrix<double, 5, 2> g = Eigen::Matrix<double, 5, 2>::Zero();
  g(kCtrvX, 0) = 0.5 * dt * dt * std::cos(th);
  g(kCtrvY, 0) = 0.5 * dt * dt * std::sin(th);
  g(kCtrvSpeed, 0) = dt;
  g(kCtrvHeading, 1) = 0.5 * dt * dt;
  g(kCtrvTurnRate, 1) = dt;
  const Eigen::Vector2d q(accel_std * accel_std, turn_accel_std * turn_accel_std);
  return g * q.asDiagonal() * g.transpose();
}

void CtrvEkf::predict(double dt, double accel_std, double turn_accel_std) {
  if (!(dt > 0.0)) return;
  const CtrvCovariance f = ctrvJacobian(x_, dt);
  const CtrvCovariance q = ctrvProcessNoise(x_, dt, accel_std, turn_accel_std);
  x_ = ctrvPredictState(x_, dt);
  p_ = f * p_ * f.transpose() + q;
  p_ = 0.5 * (p_ + p_.transpose());
}

void CtrvEkf::innovation(const Vec2& z, const Eigen::Matrix2d& r, Vec2& nu, Eigen::Matrix2d& s) const {
  nu = z - x_.head<2>();
  s = p_.topLeftCorner<2, 2>() + r;
}

double CtrvEkf::mahalanobis2(const Vec2& z, const Eigen::Matrix2d& r) const {
  Vec2 nu;
  Eigen::Matrix2d s;
  innovation(z, r, nu, s);
  const double det = s.determinant();
  if (!(det > 0.0) || !std::isfinite(det)) return std::numeric_limits<double>::infinity();
  const double d2 = nu.dot(s.inverse() * nu);
  return std::isfinite(d2) ? d2 : std::numeric_limits<double>::infinity();
}

bool CtrvEkf::update(const Vec2& z, const Eigen::Matrix2d& r) {
  Vec2 nu;
  Eigen::Matrix2d s;
  innovation(z, r, nu, s);
  Eigen::Matrix<double, 2, 5> h = Eigen::Matrix<double, 2, 5>::Zero();
  h(0, kCtrvX) = 1.0;
  h(1, kCtrvY) = 1.0;
  return linearUpdate(h, nu, r, s);
}

bool CtrvEkf::updateStandingStill(double speed_std, double turn_rate_std) {
  if (!(speed_std > 0.0 && turn_rate_std > 0.0)) return false;
  Eigen::Matrix<double, 2, 5> h = Eigen::Matrix<double, 2, 5>::Zero();
  h(0, kCtrvSpeed) = 1.0;
  h(1, kCtrvTurnRate) = 1.0;
  const Eigen::Matrix2d r = Vec2(speed_std * speed_std, turn_rate_std * turn_rate_std).asDiagonal();
  return linearUpdate(h, -h * x_, r, h * p_ * h.transpose() + r);
}

bool CtrvEkf::linearUpdate(const Eigen::Matrix<double, 2, 5>& h, const Vec2& nu, const Eigen::Matrix2d& r,
                           const Eigen::Matrix2d& s) {
  const double det = s.determinant();
  if (!(det > 0.0) || !std::isfinite(det) || !nu.allFinite()) return false;
  const Eigen::Matrix<double, 5, 2> k = p_ * h.transpose() * s.inverse();
  const CtrvCovariance i_kh = CtrvCovariance::Identity() - k * h;
  const CtrvState x_new = x_ + k * nu;
  const CtrvCovariance p_new = i_kh * p_ * i_kh.transpose() + k * r * k.transpose();
  if (!x_new.allFinite() || !p_new.allFinite()) return false;
  x_ = x_new;
  p_ = 0.5 * (p_new + p_new.transpose());
  x_(kCtrvHeading) = normalizeAngle(x_(kCtrvHeading));
  foldNegativeSpeed();
  return true;
}

void CtrvEkf::clampTurnRate(double max_turn_rate) {
  x_(kCtrvTurnRate) = std::clamp(x_(kCtrvTurnRate), -max_turn_rate, max_turn_rate);
}

void CtrvEkf::foldNegativeSpeed() {
  if (x_(kCtrvSpeed) >= 0.0) return;
  // (heading, -speed) -> (heading + pi, speed) is the same velocity vector; turn rate is unchanged.
  // Covariance transforms with J = diag(1, 1, 1, -1, 1).
  x_(kCtrvSpeed) = -x_(kCtrvSpeed);
  x_(kCtrvHeading) = normalizeAngle(x_(kCtrvHeading) + kPi);
  p_.row(kCtrvSpeed) *= -1.0;
  p_.col(kCtrvSpeed) *= -1.0;
}

}  // namespace dqn_dovs
