// Passive safety against what stands still: a velocity command is admissible only when the robot, after
// holding it through the worst-case reaction time and then braking at the deceleration the base really
// achieves, stops short of every wall, map segment and static obstacle by a margin. Hitting a static thing is
// never necessary, so this is a hard constraint on every command the stack sends: the network's actions, the
// escape, S-DOVS and the planner node's ramp (docs/planners.md, "Static safety"). ROS-free.
//
// The braking trajectory of a command u, seen from the robot's pose at the observation instant, with the
// robot moving at c:
//   1. reaction: c is held for latency_s (scan -> tracker -> DOVS -> decision -> command);
//   2. command: the velocity ramps from c toward u within the acceleration limits for one control period;
//   3. braking: every later period the base is commanded decelerationCommand() (speed first, the turn rate
//      held while any speed is left), which it follows at braking_fraction of its acceleration limits,
//      until v = 0. Turning in place afterwards does not move the disc robot.
// The same braking is what the escape and the planner's fallback command, so the model is the robot's own.
#pragma once

#include <string>
#include <vector>

#include "dqn_dovs/common/geometry.h"
#include "dqn_dovs/common/robot_model.h"
#include "dqn_dovs/common/types.h"

namespace dqn_dovs {

/// Parameters of the static braking rule. Defaults live here only (config/dovs.yaml `static_safety/*`).
struct StaticSafetyConfig {
  /// false: no static check (the paper's DQN-DOVS); every command passes.
  bool enabled = true;
  /// Worst-case time from the scan behind an observation to the command it produces reaching the base (one
  /// scan period covers tracker + DOVS + decision, measured at p99 < 5 ms, plus the scan's own age), s.
  double latency_s = 0.1;
  /// Deceleration the base really achieves while braking, as a fraction of a_v and a_w (measured on the
  /// ramp: about 0.4 of the 0.5 m/s^2 limit), in (0, 1].
  double braking_fraction = 0.8;
  /// Clearance kept to static geometry along the whole braking trajectory, m.
  double margin_m = 0.05;
  /// Time step of the braking trajectory's samples, s.
  double step_s = 0.02;
  /// Discs flagged static, or slower than this, are static geometry, m/s.
  double static_speed_mps = 0.02;

  /// Empty when consistent, otherwise a message naming the offending field and why.
  std::string validate() const;
};

/// The static geometry near the robot, in its frame at the observation instant: wall / map segments and the
/// discs that stand still. Only what a braking trajectory of the robot can reach is kept.
class StaticScene {
 public:
  StaticScene(const Observation& obs, const RobotLimits& limits, const StaticSafetyConfig& config);

  /// Surface clearance (true radii) of the robot centred at q (robot frame); +inf when nothing is near.
  double clearance(const Vec2& q) const;
  bool empty() const { return walls_.empty() && discs_.empty(); }
  size_t size() const { return walls_.size() + discs_.size(); }
  /// The kept geometry, in the robot frame.
  const std::vector<Segment>& walls() const { return walls_; }
  const std::vector<Circle>& discs() const { return discs_; }
  /// The kept geometry in the frame the robot's pose `robot_pose` is given in, flat as the Dovs message carries
  /// it: x1 y1 x2 y2 per segment, x y radius per disc.
  std::vector<float> flatSegments(const Pose2& robot_pose) const;
  std::vector<float> flatDiscs(const Pose2& robot_pose) const;

 private:
  double robot_radius_;
  std::vector<Segment> walls_;
  std::vector<Circle> discs_;
};

/// The braking trajectory of one command (see the file comment).
struct BrakingPath {
  bool safe = true;              ///< never closer than the margin to static geometry (see clearance_m)
  double min_clearance_m = 0.0;  ///< least static clearance over the trajectory (+inf: nothing near), m
};

/// The braking trajectory of command u from velocity `current` (robot frame at the observation instant).
/// When the robot already stands within the margin, a trajectory counts as safe when it never gets closer than
/// where it starts. Non-finite u: unsafe.
BrakingPath brakingPath(const StaticScene& scene, const Twist2& current, const Twist2& u, const RobotLimits& limits,
                        const StaticSafetyConfig& config);

/// Samples of the braking trajectory: robot positions (robot frame) and the speed at each, every config.step_s
/// up to the stop. For tests, plots and the contact roll-outs of the escape.
struct BrakingSample {
  double t_s = 0.0;
  Vec2 position = Vec2::Zero();
  double speed_mps = 0.0;
};
std::vector<BrakingSample> brakingSamples(const Twist2& current, const Twist2& u, const RobotLimits& limits,
                                          const StaticSafetyConfig& config);

/// The command to send instead of an inadmissible `u` (the planner node's last line): u itself when its
/// braking trajectory is safe; otherwise the velocity of the dynamic window around `current` (a lattice of
/// `samples` steps per half-diagonal, plus the strongest braking) whose braking trajectory is safe and nearest
/// to u, or when none is, the one keeping the most static clearance.
Twist2 staticSafeCommand(const StaticScene& scene, const Twist2& current, const Twist2& u, const RobotLimits& limits,
                         const StaticSafetyConfig& config, int samples = 5);

}  // namespace dqn_dovs
