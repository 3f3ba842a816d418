// The last check between a planner and the motors: every velocity command, just before it leaves, must lie
// in the robot's feasible set (v in [0, v_max], |w| <= w_max (1 - v / v_max); when asked, also straight reverse
// v in [-reverse, 0) with w = 0, for a recovery's back-off) and within the acceleration
// limits of the previously sent command over the time actually elapsed since then:
//     |v - v_prev| <= a_v * dt,   |w - w_prev| <= a_w * dt,
// and be finite. A command that is not is replaced by the nearest admissible one (distance measured in
// velocities normalised by v_max and w_max); a non-finite command is replaced by the strongest braking the
// limits allow (the admissible command nearest to a stop). The admissible set is never empty: it holds the
// previous command itself, which this filter made admissible. ROS-free; planner_node runs it on every cmd_vel.
#pragma once

#include <cstdint>
#include <string>

#include "dqn_dovs/common/robot_model.h"

namespace dqn_dovs {

/// Ways a command can leave the envelope (bit flags of EnvelopeResult::violations).
enum EnvelopeViolation : uint32_t {
  kEnvelopeNotFinite = 1u << 0,     ///< v or w is NaN or infinite
  kEnvelopeReverse = 1u << 1,       ///< v < 0
  kEnvelopeOverSpeed = 1u << 2,     ///< v > v_max
  kEnvelopeTriangle = 1u << 3,      ///< |w| > w_max (1 - v / v_max)
  kEnvelopeLinearAccel = 1u << 4,   ///< |v - v_prev| > a_v dt
  kEnvelopeAngularAccel = 1u << 5,  ///< |w - w_prev| > a_w dt
  kEnvelopeBadPrevious = 1u << 6,   ///< the previous command itself was infeasible (it is clipped first)
};

/// Human-readable list of the flags set in `violations` ("" when none), e.g. "linear acceleration, triangle".
std::string describeEnvelopeViolations(uint32_t violations);

struct EnvelopeResult {
  Twist2 command;           ///< the command to send: the input when it was admissible, else its projection
  uint32_t violations = 0;  ///< EnvelopeViolation flags of the input (0: sent unchanged)
  bool modified() const { return violations != 0; }
};

/// Tolerance of the admissibility checks (absolute, in m/s and rad/s): rounding, not slack.
constexpr double kEnvelopeTolerance = 1e-9;

/// The EnvelopeViolation flags of `command` sent dt_s after `previous` (0: admissible). dt_s that is
/// negative or not finite counts as 0 (then only `previous` itself is admissible). With reverse_mps > 0 the
/// feasible set also holds straight reverse, v in [-reverse_mps, 0) with w = 0 (a recovery's slow back-off).
uint32_t envelopeViolations(const Twist2& previous, const Twist2& command, const RobotLimits& limits, double dt_s,
                            double tol = kEnvelopeTolerance, double reverse_mps = 0.0);

/// Checks `command` against the envelope around `previous` for a step of dt_s and projects it when needed.
/// The output is always finite, feasible and within the acceleration limits of `previous` (or of its
/// clipped version when `previous` was infeasible), and equals `command` exactly when that was admissible.
/// reverse_mps as for envelopeViolations: a reverse command is projected onto straight reverse when the turn rate
/// can reach zero this step, else onto the forward set.
EnvelopeResult enforceEnvelope(const Twist2& previous, const Twist2& command, const RobotLimits& limits, double dt_s,
                               double reverse_mps = 0.0);

/// enforceEnvelope with its memory: the previous output, the step cap and the counters.
class SafetyEnvelope {
 public:
  /// max_step_s caps dt (a long pause between two commands never licenses a jump larger than this step);
  /// reverse_mps > 0 admits straight reverse down to -reverse_mps (envelopeViolations).
  explicit SafetyEnvelope(const RobotLimits& limits, double max_step_s = 0.1, double reverse_mps = 0.0);

  /// Filters the next command, sent dt_s after the previous output, and remembers the result.
  EnvelopeResult filter(const Twist2& command, double dt_s);

  /// The base was stopped outside the ramp (a bumper contact): the next command is checked from `last`.
  void restartFrom(const Twist2& last) { last_ = last; }

  const Twist2& last() const { return last_; }
  uint64_t checked() const { return checked_; }
  uint64_t corrected() const { return corrected_; }
  /// Description of the last correction ("" when none yet): what was wrong and what was sent instead.
  const std::string& lastCorrection() const { return last_correction_; }
  double maxStep_s() const { return max_step_s_; }

 private:
  RobotLimits limits_;
  double max_step_s_, reverse_mps_;
  Twist2 last_;
  uint64_t checked_ = 0, corrected_ = 0;
  std::string last_correction_;
};

}  // namespace dqn_dovs
