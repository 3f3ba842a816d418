// Extended Kalman filter with the constant turn rate and velocity (CTRV) motion model on the state
// [x, y, heading, speed, turn_rate] in a fixed frame, measured by positions. ROS-free.
#pragma once

#include <Eigen/Core>

#include "dqn_dovs/common/geometry.h"

namespace dqn_dovs {

using CtrvState = Eigen::Matrix<double, 5, 1>;
using CtrvCovariance = Eigen::Matrix<double, 5, 5>;

/// Indices into the CTRV state.
enum CtrvIndex : int { kCtrvX = 0, kCtrvY = 1, kCtrvHeading = 2, kCtrvSpeed = 3, kCtrvTurnRate = 4 };

/// Exact CTRV motion of a state over dt (a straight line when |turn_rate| is tiny); heading wrapped.
CtrvState ctrvPredictState(const CtrvState& x, double dt);

/// Jacobian of ctrvPredictState with respect to the state, continuous at turn_rate = 0.
CtrvCovariance ctrvJacobian(const CtrvState& x, double dt);

/// Discrete process noise of white linear acceleration (std accel_std, m/s^2) and white angular acceleration
/// (std turn_accel_std, rad/s^2) acting on speed and turn rate over dt, mapped into the whole state.
CtrvCovariance ctrvProcessNoise(const CtrvState& x, double dt, double accel_std, double turn_accel_std);

/// The filter. Speed is kept non-negative: a negative estimate (the target reversed) is folded into
/// heading + pi and -speed, which describes the same motion.
class CtrvEkf {
 public:
  CtrvEkf() = default;
  CtrvEkf(const CtrvState& x, const CtrvCovariance& p) : x_(x), p_(p) {}

  /// Propagates mean and covariance by dt >= 0 seconds.
  void predict(double dt, double accel_std, double turn_accel_std);

  /// Innovation z - Hx and its covariance S = H P H^T + R for a position measurement z with covariance R.
  void innovation(const Vec2& z, const Eigen::Matrix2d& r, Vec2& nu, Eigen::Matrix2d& s) const;

  /// Squared Mahalanobis distance of position z from the predicted position.
  double mahalanobis2(const Vec2& z, const Eigen::Matrix2d& r) const;

  /// Kalman update with a position measurement (Joseph form, keeps P symmetric positive semi-definite).
  /// Returns false (and leaves the state untouched) when the innovation covariance is singular or NaN.
  bool update(const Vec2& z, const Eigen::Matrix2d& r);

  /// Kalman update with the pseudo-measurement "it stands still": speed 0 and turn rate 0, with standard deviations
  /// speed_std and turn_rate_std (Joseph form). Returns false (state untouched) when they are not positive.
  bool updateStandingStill(double speed_std, double turn_rate_std);

  /// Clamps |turn_rate| to max_turn_rate (the model's validity range) without touching the covariance.
  void clampTurnRate(double max_turn_rate);

  const CtrvState& state() const { return x_; }
  const CtrvCovariance& covariance() const { return p_; }
  Vec2 position() const { return x_.head<2>(); }

 private:
  /// Joseph-form update with the linear measurement h x, innovation nu, noise r and innovation covariance s.
  bool linearUpdate(const Eigen::Matrix<double, 2, 5>& h, const Vec2& nu, const Eigen::Matrix2d& r,
                    const Eigen::Matrix2d& s);
  void foldNegativeSpeed();

  CtrvState x_ = CtrvState::Zero();
  CtrvCovariance p_ = CtrvCovariance::Identity();
};

}  // namespace dqn_dovs
