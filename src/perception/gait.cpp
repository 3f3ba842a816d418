#include "dqn_dovs/perception/gait.h"

#include <algorithm>
#include <cmath>

#include "dqn_dovs/common/geometry.h"

namespace dqn_dovs {
namespace {

/// White acceleration of the swing (m/s^2): how far a real gait strays from a sine over one scan.
constexpr double kSwingAccelNoise = 1.0;
/// Random walk of the log cadence (1/sqrt(s)): a person changes cadence slowly.
constexpr double kCadenceDrift = 0.05;
/// The learned cadence stays within a factor 2 of the nominal one.
constexpr double kMaxLogCadence = 0.7;

/// Exact transition of [s, ds/dt] of a harmonic oscillator at angular rate w over dt.
Eigen::Matrix2d oscillator(double w, double dt) {
  Eigen::Matrix2d f;
  if (w < 1e-6) {
    f << 1.0, dt, 0.0, 1.0;
  } else {
    const double c = std::cos(w * dt), s = std::sin(w * dt);
    f << c, s / w, -w * s, c;
  }
  return f;
}

/// w times the derivative of oscillator(w, dt) by w: how the transition changes with the log of the rate.
Eigen::Matrix2d oscillatorByLogRate(double w, double dt) {
  if (w < 1e-6) return Eigen::Matrix2d::Zero();
  const double c = std::cos(w * dt), s = std::sin(w * dt);
  Eigen::Matrix2d d;
  d << -dt * s, (dt * c * w - s) / (w * w), -s - w * dt * c, -dt * s;
  return w * d;
}

}  // namespace

double gaitNominalRate(double speed_mps, const GaitParams& params) {
  const double v = std::max(speed_mps, 0.0);
  return kPi * v / (params.step_base_m + params.step_per_speed_s * v);
}

void GaitFilter::propagate(double speed_mps, double dt, const GaitParams& params, State& x, Covariance& p) const {
  if (!(dt > 0.0)) return;
  const double w = gaitNominalRate(speed_mps, params) * std::exp(x(2));
  const Eigen::Matrix2d transition = oscillator(w, dt);
  // Jacobian: the oscillator's block, and the cadence's column.
  Covariance f = Covariance::Identity();
  f.topLeftCorner<2, 2>() = transition;
  f.block<2, 1>(0, 2) = oscillatorByLogRate(w, dt) * x.head<2>();
  x.head<2>() = transition * x.head<2>();
  Covariance q = Covariance::Zero();
  const double a2 = kSwingAccelNoise * kSwingAccelNoise;
  q(0, 0) = 0.25 * dt * dt * dt * dt * a2;
  q(0, 1) = q(1, 0) = 0.5 * dt * dt * dt * a2;
  q(1, 1) = dt * dt * a2;
  q(2, 2) = params.rate_std > 0.0 ? dt * kCadenceDrift * kCadenceDrift : 0.0;
  p = f * p * f.transpose() + q;
}

void GaitFilter::update(double s, double speed_mps, double stamp_s, double restart_after_s, const GaitParams& params) {
  const double r = params.offset_std_m * params.offset_std_m;
  if (!active() || stamp_s - stamp_s_ > restart_after_s || stamp_s < stamp_s_) {
    const double log_k = active() ? x_(2) : 0.0;
    const double w = gaitNominalRate(speed_mps, params) * std::exp(log_k);
    x_ << s, 0.0, log_k;
    // The swing's rate is unknown at a first pair: anything up to the amplitude of a fast walker's swing.
    p_ = Eigen::Vector3d(r, std::pow(0.15 * w, 2), params.rate_std * params.rate_std).asDiagonal();
    stamp_s_ = stamp_s;
    return;
  }
  propagate(speed_mps, stamp_s - stamp_s_, params, x_, p_);
  const double innovation_var = p_(0, 0) + r;
  const State gain = p_.col(0) / innovation_var;
  x_ += gain * (s - x_(0));
  p_ -= gain * p_.row(0);
  p_ = 0.5 * (p_ + p_.transpose());
  x_(2) = std::clamp(x_(2), -kMaxLogCadence, kMaxLogCadence);
  stamp_s_ = stamp_s;
}

void GaitFilter::predict(double speed_mps, double stamp_s, const GaitParams& params, double& s,
                         double& variance) const {
  State x = x_;
  Covariance p = p_;
  propagate(speed_mps, stamp_s - stamp_s_, params, x, p);
  s = x(0);
  variance = p(0, 0);
}

double GaitFilter::cadenceFactor() const { return std::exp(x_(2)); }

}  // namespace dqn_dovs
