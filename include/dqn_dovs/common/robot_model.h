// Differential-drive robot model: velocity limits, the feasible "triangle", the dynamic window.
// Defaults are a Turtlebot 2 (Kobuki); config/robot.yaml carries the same values for the nodes.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "dqn_dovs/common/geometry.h"

namespace dqn_dovs {

/// A robot velocity command / state: linear speed v (m/s, forward >= 0) and turn rate w (rad/s, CCW > 0).
struct Twist2 {
  double v = 0.0;
  double w = 0.0;
};

/// Kinodynamic limits of the robot. Every planner, the simulator and the DOVS read the same struct.
struct RobotLimits {
  double v_max = 0.7;   ///< Maximum forward speed, m/s. Reverse is not allowed (v >= 0).
  double w_max = kPi;   ///< Maximum turn rate magnitude at v = 0, rad/s.
  double a_v = 0.5;     ///< Linear acceleration limit, m/s^2 (both signs).
  double a_w = 2.0;     ///< Angular acceleration limit, rad/s^2 (both signs).
  double dt = 0.2;      ///< Control period, s.
  double radius = 0.2;  ///< Robot footprint radius, m.

  /// Empty string when consistent, otherwise a message naming the offending field and why.
  std::string validate() const;

  /// Turn-rate limit at linear speed v: w_max * (1 - v / v_max), the differential-drive triangle.
  double wLimitAt(double v) const;

  /// True when (v, w) lies in the feasible triangle (with a small tolerance).
  bool feasible(const Twist2& t, double tol = 1e-9) const;

  /// Closest feasible velocity to t (Euclidean in (v, w) scaled by the limits).
  Twist2 clipToFeasible(const Twist2& t) const;

  /// dv = a_v * dt and dw = a_w * dt: half-diagonals of the dynamic-window rhombus.
  double dv() const { return a_v * dt; }
  double dw() const { return a_w * dt; }
};

/// The dynamic window: the rhombus of velocities reachable from `current` in one control period,
/// |v' - v| / dv + |w' - w| / dw <= 1, intersected with the feasible triangle.
struct DynamicWindow {
  Twist2 center;
  double dv = 0.0;
  double dw = 0.0;

  /// Rhombus corners in action order: top (v + dv), bottom (v - dv), left (w - dw), right (w + dw).
  std::array<Twist2, 4> corners() const;
  /// True when t is inside the rhombus (ignores feasibility).
  bool containsRhombus(const Twist2& t, double tol = 1e-9) const;
  /// True when t is inside the rhombus and feasible for `limits`.
  bool contains(const Twist2& t, const RobotLimits& limits, double tol = 1e-9) const;
  /// The feasible velocities of the rhombus on a lattice of n steps per half-diagonal (|i| + |j| <= n), in a
  /// fixed order: (2n^2 + 2n + 1) samples before the feasibility cut.
  std::vector<Twist2> samples(int n, const RobotLimits& limits) const;
};

DynamicWindow makeDynamicWindow(const Twist2& current, const RobotLimits& limits);

/// Moves `current` toward `command` as far as the acceleration limits allow in time dt_s (each axis
/// limited separately), then clips to the feasible set without breaking either acceleration limit (when the
/// turn rate cannot shrink fast enough to fit the triangle, the speed is lowered instead). A non-finite
/// command keeps the current velocity; a non-finite current velocity gives (0, 0). Used by the simulator and
/// the command ramp.
Twist2 applyAccelerationLimits(const Twist2& current, const Twist2& command, const RobotLimits& limits, double dt_s);

/// The safe fallback used whenever a planner or the shield cannot decide: the dynamic-window corner that slows down
/// fastest (v - dv, w shrinking toward 0), clipped to the feasible set.
Twist2 decelerationCommand(const Twist2& current, const RobotLimits& limits);

/// Clips a command into the dynamic window around `current`, then into the feasible triangle (what an episode does
/// with every command before the simulator takes it); a non-finite command keeps the current velocity.
Twist2 clipToWindow(const Twist2& current, Twist2 command, const RobotLimits& limits);

}  // namespace dqn_dovs
