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

/// Joseph-form Kalman update of (x, p) with the linear measurement h x, innovation nu, noise r and innovation
/// covariance s; false (x, p untouched) when s is singular or anything is not finite.
template <int N>
bool josephUpdate(Eigen::Matrix<double, N, 1>& x, Eigen::Matrix<double, N, N>& p, const Eigen::Matrix<double, 2, N>& h,
                  const Vec2& nu, const Eigen::Matrix2d& r, const Eigen::Matrix2d& s) {
  const double det = s.determinant();
  if (!(det > 0.0) || !std::isfinite(det) || !nu.allFinite()) return false;
  const Eigen::Matrix<double, N, 2> k = p * h.transpose() * s.inverse();
  const Eigen::Matrix<double, N, N> i_kh = Eigen::Matrix<double, N, N>::Identity() - k * h;
  const Eigen::Matrix<double, N, 1> x_new = x + k * nu;
  const Eigen::Matrix<double, N, N> p_new = i_kh * p * i_kh.transpose() + k * r * k.transpose();
  if (!x_new.allFinite() || !p_new.allFinite()) return false;
  x = x_new;
  p = 0.5 * (p_new + p_new.transpose());
  return true;
}
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

CtrvEkf CtrvEkf::start(MotionModel model, const Vec2& position, const Eigen::Matrix2d& position_cov,
                       const Vec2& velocity, double speed_var, double heading_var, double turn_rate_var) {
  const double speed = velocity.norm();
  CtrvEkf f;
  f.model_ = model;
  if (model == MotionModel::kCtrv) {
    f.x_ << position.x(), position.y(), speed > 1e-9 ? std::atan2(velocity.y(), velocity.x()) : 0.0, speed, 0.0;
    f.p_ = CtrvCovariance::Zero();
    f.p_.topLeftCorner<2, 2>() = position_cov;
    f.p_(kCtrvHeading, kCtrvHeading) = std::min(heading_var, kPi * kPi);
    f.p_(kCtrvSpeed, kCtrvSpeed) = speed_var;
    f.p_(kCtrvTurnRate, kCtrvTurnRate) = turn_rate_var;
    return f;
  }
  f.xc_ << position, velocity;
  f.pc_ = CvCovariance::Zero();
  f.pc_.topLeftCorner<2, 2>() = position_cov;
  if (heading_var >= kPi * kPi || speed < 1e-6) {
    // No direction known: the velocity's spread is the same in every direction.
    f.pc_.bottomRightCorner<2, 2>() = speed_var * Eigen::Matrix2d::Identity();
    f.syncFromCv();
  } else {
    f.reopen(Vec2::Zero(), heading_var, speed_var, 0.0);
  }
  return f;
}

void CtrvEkf::reopen(const Vec2& position_var, double heading_var, double speed_var, double turn_rate_var) {
  if (model_ == MotionModel::kCtrv) {
    p_(kCtrvX, kCtrvX) += position_var.x();
    p_(kCtrvY, kCtrvY) += position_var.y();
    p_(kCtrvHeading, kCtrvHeading) += heading_var;
    p_(kCtrvSpeed, kCtrvSpeed) += speed_var;
    p_(kCtrvTurnRate, kCtrvTurnRate) += turn_rate_var;
    return;
  }
  pc_(0, 0) += position_var.x();
  pc_(1, 1) += position_var.y();
  const Vec2 v = xc_.tail<2>();
  const double speed = v.norm();
  if (speed < 1e-6) {
    pc_.bottomRightCorner<2, 2>() += speed_var * Eigen::Matrix2d::Identity();
  } else {
    // Along the motion the speed's spread, across it the heading's (times the speed).
    const Vec2 u = v / speed, n(-u.y(), u.x());
    pc_.bottomRightCorner<2, 2>() += speed_var * u * u.transpose() + speed * speed * heading_var * n * n.transpose();
  }
  syncFromCv();
}

Vec2 CtrvEkf::velocity() const {
  if (model_ == MotionModel::kConstantVelocity) return xc_.tail<2>();
  return x_(kCtrvSpeed) * Vec2(std::cos(x_(kCtrvHeading)), std::sin(x_(kCtrvHeading)));
}

void CtrvEkf::syncFromCv() {
  pc_ = 0.5 * (pc_ + pc_.transpose());
  const double vx = xc_(2), vy = xc_(3);
  const double speed = std::hypot(vx, vy);
  x_ << xc_(0), xc_(1), speed > 1e-9 ? std::atan2(vy, vx) : x_(kCtrvHeading), speed, 0.0;
  // Heading and speed carry the velocity's covariance through the Jacobian of its polar form; at rest the heading
  // is unknown and the speed spreads as the velocity does.
  Eigen::Matrix<double, 5, 4> j = Eigen::Matrix<double, 5, 4>::Zero();
  j(kCtrvX, 0) = 1.0;
  j(kCtrvY, 1) = 1.0;
  const bool moving = speed > 1e-6;
  if (moving) {
    j(kCtrvHeading, 2) = -vy / (speed * speed);
    j(kCtrvHeading, 3) = vx / (speed * speed);
    j(kCtrvSpeed, 2) = vx / speed;
    j(kCtrvSpeed, 3) = vy / speed;
  }
  p_ = j * pc_ * j.transpose();
  p_(kCtrvHeading, kCtrvHeading) = moving ? std::min(p_(kCtrvHeading, kCtrvHeading), kPi * kPi) : kPi * kPi;
  if (!moving) p_(kCtrvSpeed, kCtrvSpeed) = 0.5 * (pc_(2, 2) + pc_(3, 3));
}

bool CtrvEkf::cvUpdate(const Eigen::Matrix<double, 2, 4>& h, const Vec2& nu, const Eigen::Matrix2d& r) {
  if (!josephUpdate<4>(xc_, pc_, h, nu, r, h * pc_ * h.transpose() + r)) return false;
  syncFromCv();
  return true;
}

void CtrvEkf::predict(double dt, double accel_std, double turn_accel_std) {
  if (!(dt > 0.0)) return;
  if (model_ == MotionModel::kConstantVelocity) {
    CvCovariance f = CvCovariance::Identity();
    f(0, 2) = dt;
    f(1, 3) = dt;
    // White acceleration in every direction, piecewise constant over dt.
    const double a2 = accel_std * accel_std;
    CvCovariance q = CvCovariance::Zero();
    q(0, 0) = q(1, 1) = 0.25 * dt * dt * dt * dt * a2;
    q(0, 2) = q(2, 0) = q(1, 3) = q(3, 1) = 0.5 * dt * dt * dt * a2;
    q(2, 2) = q(3, 3) = dt * dt * a2;
    xc_ = f * xc_;
    pc_ = f * pc_ * f.transpose() + q;
    syncFromCv();
    return;
  }
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
  if (model_ == MotionModel::kConstantVelocity) {
    Eigen::Matrix<double, 2, 4> h = Eigen::Matrix<double, 2, 4>::Zero();
    h(0, 0) = h(1, 1) = 1.0;
    return cvUpdate(h, z - xc_.head<2>(), r);
  }
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
  if (model_ == MotionModel::kConstantVelocity) {
    Eigen::Matrix<double, 2, 4> h = Eigen::Matrix<double, 2, 4>::Zero();
    h(0, 2) = h(1, 3) = 1.0;
    return cvUpdate(h, -xc_.tail<2>(), speed_std * speed_std * Eigen::Matrix2d::Identity());
  }
  Eigen::Matrix<double, 2, 5> h = Eigen::Matrix<double, 2, 5>::Zero();
  h(0, kCtrvSpeed) = 1.0;
  h(1, kCtrvTurnRate) = 1.0;
  const Eigen::Matrix2d r = Vec2(speed_std * speed_std, turn_rate_std * turn_rate_std).asDiagonal();
  return linearUpdate(h, -h * x_, r, h * p_ * h.transpose() + r);
}

bool CtrvEkf::linearUpdate(const Eigen::Matrix<double, 2, 5>& h, const Vec2& nu, const Eigen::Matrix2d& r,
                           const Eigen::Matrix2d& s) {
  if (!josephUpdate<5>(x_, p_, h, nu, r, s)) return false;
  x_(kCtrvHeading) = normalizeAngle(x_(kCtrvHeading));
  foldNegativeSpeed();
  return true;
}

void CtrvEkf::clampTurnRate(double max_turn_rate) {
  if (model_ == MotionModel::kConstantVelocity) return;  // its turn rate is 0
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
