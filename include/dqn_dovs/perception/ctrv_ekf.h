// Kalman filter of a track measured by positions in a fixed frame, ROS-free, with one of two motion models:
// constant turn rate and velocity (CTRV, an extended Kalman filter on [x, y, heading, speed, turn_rate]) or
// constant velocity (a linear Kalman filter on [x, y, vx, vy], white acceleration in every direction). Either way
// the track is read as the CTRV state (heading, speed, turn rate; turn rate 0 under constant velocity).
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

/// Which motion model a CtrvEkf runs.
enum class MotionModel {
  kCtrv,              ///< Constant turn rate and velocity: discs on arcs, a turn rate estimated.
  kConstantVelocity,  ///< Cartesian velocity, white acceleration in every direction (people who start, stop,
                      ///< side-step).
};

/// The filter. Speed is kept non-negative: a negative estimate (the target reversed) is folded into
/// heading + pi and -speed, which describes the same motion.
class CtrvEkf {
 public:
  CtrvEkf() = default;
  CtrvEkf(const CtrvState& x, const CtrvCovariance& p) : x_(x), p_(p) {}

  /// A filter at position (covariance position_cov) moving at `velocity` whose speed has variance speed_var and
  /// whose heading has variance heading_var (at least pi^2: unknown, e.g. from rest), turn rate 0 with variance
  /// turn_rate_var (CTRV only).
  static CtrvEkf start(MotionModel model, const Vec2& position, const Eigen::Matrix2d& position_cov,
                       const Vec2& velocity, double speed_var, double heading_var, double turn_rate_var);

  /// Re-opens the uncertainty (a manoeuvre): adds position_var to both position variances, heading_var and speed_var
  /// along the motion, turn_rate_var to the turn rate (CTRV only).
  void reopen(const Vec2& position_var, double heading_var, double speed_var, double turn_rate_var);

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

  /// The state and covariance as CTRV (converted from the Cartesian velocity under constant velocity).
  const CtrvState& state() const { return x_; }
  const CtrvCovariance& covariance() const { return p_; }
  Vec2 position() const { return x_.head<2>(); }
  /// Velocity vector (m/s).
  Vec2 velocity() const;
  MotionModel model() const { return model_; }

 private:
  using CvState = Eigen::Vector4d;
  using CvCovariance = Eigen::Matrix4d;
  /// Constant velocity: refreshes the CTRV view (x_, p_) from the Cartesian state.
  void syncFromCv();
  bool cvUpdate(const Eigen::Matrix<double, 2, 4>& h, const Vec2& nu, const Eigen::Matrix2d& r);

  /// Joseph-form update with the linear measurement h x, innovation nu, noise r and innovation covariance s.
  bool linearUpdate(const Eigen::Matrix<double, 2, 5>& h, const Vec2& nu, const Eigen::Matrix2d& r,
                    const Eigen::Matrix2d& s);
  void foldNegativeSpeed();

  MotionModel model_ = MotionModel::kCtrv;
  CtrvState x_ = CtrvState::Zero();
  CtrvCovariance p_ = CtrvCovariance::Identity();
  CvState xc_ = CvState::Zero();  // constant velocity only: [x, y, vx, vy]
  CvCovariance pc_ = CvCovariance::Identity();
};

}  // namespace dqn_dovs
