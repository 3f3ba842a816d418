// A walking person's gait as a 2-D scan at leg height shows it, ROS-free.
//
// Seen from above, a person's two legs stand a hip's half width either side of the body's centre line and swing in
// opposite phase along the walking direction. The left leg's offset from the body's centre along that direction, s,
// rises and falls once per gait cycle (two steps). GaitFilter follows s as a harmonic oscillator, [s, ds/dt, log k],
// whose angular rate is k times the nominal rate of the walking speed v: a step of step_base + step_per_speed * v
// metres is half a cycle (adults lengthen their steps as they walk faster), and k is the person's own cadence against
// that, learned from the pairs of legs (its log has the prior spread rate_std; a cadence within a factor 2 of the
// nominal). Each pair of legs measures s; a lone leg is then placed back on the body by the predicted s (the tracker,
// ObstacleTracker, docs/tracker.md "A lone leg placed by the gait").
#pragma once

#include <Eigen/Core>

namespace dqn_dovs {

/// Parameters of the gait model (TrackerConfig carries them).
struct GaitParams {
  /// Step length at walking speed v: step_base_m + step_per_speed_s * v (m).
  double step_base_m = 0.3;
  double step_per_speed_s = 0.3;
  /// Prior spread of the log of a person's cadence against the nominal one (0: the nominal cadence exactly).
  double rate_std = 0.25;
  /// Standard deviation of a leg pair's offset along the walking direction (m).
  double offset_std_m = 0.03;
};

/// Nominal angular rate of the gait oscillator at walking speed v >= 0 (rad/s): pi per step.
double gaitNominalRate(double speed_mps, const GaitParams& params);

/// The oscillator of one person. Inactive until its first measurement.
class GaitFilter {
 public:
  bool active() const { return stamp_s_ >= 0.0; }
  double stamp() const { return stamp_s_; }
  /// Forgets the gait (the person stopped, or was lost).
  void reset() { stamp_s_ = -1.0; }

  /// A pair of legs at stamp_s measured the left leg's offset s (m) while the person walked at speed_mps. Starts the
  /// filter when inactive or when its last measurement is older than restart_after_s (a new cycle it cannot bridge),
  /// keeping the learned cadence in the latter case.
  void update(double s, double speed_mps, double stamp_s, double restart_after_s, const GaitParams& params);

  /// Predicted offset and its variance at stamp_s >= stamp() at walking speed speed_mps (the filter is not changed).
  void predict(double speed_mps, double stamp_s, const GaitParams& params, double& s, double& variance) const;

  /// The learned cadence factor k (1: the nominal cadence).
  double cadenceFactor() const;

 private:
  using State = Eigen::Vector3d;  // [s, ds/dt, log k]
  using Covariance = Eigen::Matrix3d;
  void propagate(double speed_mps, double dt, const GaitParams& params, State& x, Covariance& p) const;

  double stamp_s_ = -1.0;
  State x_ = State::Zero();
  Covariance p_ = Covariance::Identity();
};

}  // namespace dqn_dovs
