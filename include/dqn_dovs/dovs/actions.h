// The discrete action set of DQN-DOVS (DESIGN §6): four corners of the dynamic window, keep, and three
// velocities on the goal line. ROS-free.
#pragma once

#include <array>
#include <stdexcept>
#include <string>

#include "dqn_dovs/common/geometry.h"
#include "dqn_dovs/common/robot_model.h"

namespace dqn_dovs {

/// Non-finite input to the action computation; the message names the argument.
class ActionError : public std::runtime_error {
 public:
  explicit ActionError(const std::string& what) : std::runtime_error(what) {}
};

constexpr int kNumActions = 8;

/// Action indices in their fixed order (the network's output order).
enum ActionIndex : int {
  kActionDwTop = 0,       ///< (v + dv, w)
  kActionDwBottom = 1,    ///< (v - dv, w)
  kActionDwLeft = 2,      ///< (v, w - dw)
  kActionDwRight = 3,     ///< (v, w + dw)
  kActionKeep = 4,        ///< (v, w)
  kActionGoalHigh = 5,    ///< goal line inside the dynamic window, highest v
  kActionGoalLow = 6,     ///< goal line inside the dynamic window, lowest v
  kActionGoalCurrent = 7  ///< goal line at the current v
};

/// A goal closer than this to the robot has no goal line (actions 5-7 invalid), m.
constexpr double kGoalAtRobotTolerance_m = 1e-3;

/// The velocities whose constant-(v, w) path leads to the goal.
struct GoalLine {
  enum class Kind {
    kNone,         ///< goal at the robot: no direction to go
    kArc,          ///< goal ahead or level (x >= 0): w = curvature * v, v >= 0, the circle through the goal
    kTurnInPlace,  ///< goal behind (x < 0): v = 0, w toward the goal's side (turning in place to face it)
  };
  Kind kind = Kind::kNone;
  /// Curvature k = 2 y / (x^2 + y^2) of the circle through the goal (kArc), 1/m.
  double curvature_1pm = 0.0;
  /// +1 (CCW, goal on the left or straight behind) or -1 (kTurnInPlace).
  double turn_sign = 1.0;
  /// Direction of the line in the (v, w) plane, not normalised: (1, k) for kArc, (0, turn_sign) for
  /// kTurnInPlace, (0, 0) for kNone.
  Twist2 direction() const;
};

/// Goal line for a goal given in the robot frame (x forward, y left). Throws ActionError on NaN/inf.
GoalLine goalLine(const Vec2& goal_in_robot_frame);

/// The 8 actions. velocities[i] is meaningful only when valid[i]; invalid entries hold the "keep" velocity so
/// that an accidental use is harmless.
struct ActionSet {
  std::array<Twist2, kNumActions> velocities{};
  std::array<bool, kNumActions> valid{};
  /// The goal line the actions 5-7 were taken from (for display).
  GoalLine goal_line;
  /// The dynamic window around the (feasible) current velocity.
  DynamicWindow window;

  int numValid() const;
};

/// Computes the action set. Corners 0-3 are clipped into the feasible part of the dynamic window by moving them
/// toward the current velocity (the window's centre) along the segment joining them; 0-4 are always valid.
/// 5 and 6 are the two ends of the goal line's intersection with the feasible window (5 the end farther from
/// v = w = 0, i.e. highest v; on a turn-in-place goal line the fastest turn), 7 the goal-line velocity with
/// the current v (on a turn-in-place line: valid only at v = 0, the closest turn rate); each valid only where
/// it lies in the feasible window. A current velocity outside the kinematic triangle is first clipped into it.
/// Throws ActionError when current or goal is NaN/inf or the limits are invalid.
ActionSet computeActions(const Twist2& current, const Vec2& goal_in_robot_frame, const RobotLimits& limits);

}  // namespace dqn_dovs
