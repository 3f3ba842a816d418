// The action shield: the DOVS tells which of the 8 dynamic-window actions lead into a velocity obstacle; the
// shield masks those out of the network's choice whenever a safe alternative exists. ROS-free.
//
// DQN-DOVS as published masks only the kinematically invalid goal-line actions (DESIGN §6) and leaves it to the
// network to learn, from the grid, which actions are unsafe. The shield makes the DOVS' own verdict binding:
// the network still ranks the actions, but among the safe ones. Used identically in training (the mask stored
// in replay and applied in the Double-DQN target), in evaluation and on the robot (docs/planners.md).
#pragma once

#include <array>
#include <string>
#include <vector>

#include "dqn_dovs/common/types.h"
#include "dqn_dovs/dovs/actions.h"
#include "dqn_dovs/dovs/dovs.h"
#include "dqn_dovs/policy/static_safety.h"

namespace dqn_dovs {

/// Parameters of the shield. Defaults live here only.
struct ActionShieldConfig {
  /// false: the mask is the action set's own validity mask (the paper's DQN-DOVS).
  bool enabled = true;
  /// An action counts as robustly safe when its velocity is free in the DOVS and so are the four velocities this
  /// far from it in v (m/s) ...
  double robust_dv_mps = 0.03;
  /// ... and in w (rad/s). Robustly safe actions are preferred: tracking noise then rarely turns them unsafe.
  /// Zero margins make every free action robust.
  double robust_dw_rps = 0.15;
  /// Last resort, when no valid action is free: each is held in a roll-out against the observed obstacles for up
  /// to this long (s) ...
  double last_resort_horizon_s = 3.0;
  /// ... in steps of this (s) ...
  double last_resort_step_s = 0.1;
  /// ... only those whose first inflated contact comes no more than this before the latest one remain (s) ...
  double last_resort_tolerance_s = 0.0;
  /// ... and of those, the ones whose least clearance on the way is within this of the widest (m).
  double last_resort_clearance_tolerance_m = 0.02;
  /// Escape, when no valid action is free (or none is statically safe): the planner holds, instead of an
  /// action, a velocity of the dynamic window (a lattice of escape_window_samples steps per half-diagonal, plus
  /// the strongest braking), chosen passively safe (see EscapeTier): statically safe first; then one whose best
  /// follow-up after one period keeps every true contact away over last_resort_horizon_s (widest clearance,
  /// then closest to the goal); else one whose braking trajectory comes to rest before any contact (the latest
  /// contact of its best follow-up, then the widest clearance while moving); else the lowest speed at contact.
  /// false: the last-resort action.
  bool escape_enabled = true;
  int escape_window_samples = 5;
  /// Tier kRest gives way to a dodge (a velocity that cannot rest before contact) whose best follow-up puts the
  /// first contact off by more than this beyond the best way to rest, s; negative: never (passively safe).
  double dodge_advantage_s = -1.0;
  /// When no way to rest exists: true, the lowest speed at the contact (then the latest contact); false, the
  /// latest contact of the best follow-up (the previous release's order).
  bool slowest_contact = true;
  /// The robot counts as at rest below this speed (a contact then is the other party's), m/s.
  double rest_speed_mps = 0.05;
  /// false: the escape of the previous release below tier kFree (latest true contact, any speed).
  bool passive_escape = true;
  /// Also narrow the free actions to those whose braking trajectory comes to rest before any contact with a
  /// moving obstacle, whenever any of them does (passive safety beyond the escape).
  bool passive_actions = false;
  /// Passive checks (the escape's order and passive_actions): a braking trajectory "comes to rest before
  /// contact" only when, while moving, it keeps this clearance to the moving obstacles' predicted discs ... (m)
  double passive_margin_m = 0.0;
  /// ... plus this much per second of look-ahead, for the predictions' growing uncertainty (m/s).
  double passive_margin_growth_mps = 0.0;
  /// The static braking rule (static_safety.h): no action, escape or fallback whose braking trajectory reaches
  /// static geometry is ever allowed while a statically safe one exists. Applies while `enabled`.
  StaticSafetyConfig statics;

  /// Empty when consistent, otherwise a message naming the offending field and why.
  std::string validate() const;
};

/// Sets one field of `config` by its parameter name (the names of config/dovs.yaml `action_shield/*` and
/// config/static_safety.yaml, the latter prefixed `static_safety/`), e.g. "passive_escape=false",
/// "static_safety/margin=0.1". Returns "" when set, else why not (unknown name, unreadable value). The result
/// is not validated: call validate().
std::string setShieldParameter(ActionShieldConfig& config, const std::string& name, const std::string& value);

/// Every name setShieldParameter accepts, in config-file order: what the nodes read from the parameter server
/// and the trainer from the YAML files, so that no loader lists them again.
const std::vector<std::string>& shieldParameterNames();

/// The value of the named parameter as setShieldParameter reads it back ("true"/"false", integers, numbers to 17
/// digits); throws std::invalid_argument for an unknown name.
std::string shieldParameter(const ActionShieldConfig& config, const std::string& name);

/// How the shield decided for one action set.
enum class ShieldLevel : int {
  kDisabled = 0,  ///< shield off: the validity mask
  kRobust = 1,    ///< at least one valid action is robustly safe: only those remain
  kFree = 2,      ///< no robust one, but at least one valid action is free: only the free ones remain
  kLatest = 3,    ///< every valid action is in the DOV: those that collide latest in a roll-out, widest first
  kStatic = 4,    ///< no valid action is statically safe: the escape (or the action keeping most clearance)
};

/// How passively safe the escape velocity is, best first.
enum class EscapeTier : int {
  kFree = 0,     ///< statically safe, and a follow-up keeps every contact away over the horizon
  kRest = 1,     ///< statically safe, and braking comes to rest before any contact
  kSlowest = 2,  ///< statically safe, moving at a contact: the lowest speed at contact
  kUnsafe = 3,   ///< nothing is statically safe: the most clearance to static geometry
  kDodge = 4,    ///< statically safe, moving: a dodge that puts the contact off by dodge_advantage_s more than
                 ///< any way to rest does (only with dodge_advantage_s >= 0)
};
const char* escapeTierName(EscapeTier tier);

/// The escape the shield chose, with why.
struct Escape {
  Twist2 velocity;
  EscapeTier tier = EscapeTier::kUnsafe;
  double contact_speed_mps = 0.0;  ///< kSlowest: the speed at the predicted contact
};
const char* shieldLevelName(ShieldLevel level);

struct ShieldedMask {
  std::array<bool, kNumActions> mask{};
  ShieldLevel level = ShieldLevel::kDisabled;
  /// kLatest with escape_enabled (and some valid action): the escape velocity the planner holds instead.
  bool has_escape = false;
  Twist2 escape;
  EscapeTier escape_tier = EscapeTier::kFree;
  /// Per action: its braking trajectory keeps clear of static geometry (all true when the rule is off).
  std::array<bool, kNumActions> static_safe{};
  int numAllowed() const;
};

/// The mask the network chooses under: the action set's validity mask, narrowed to the robustly safe or else the
/// free actions of `dovs` when any valid one is, or else to the valid actions whose roll-out against the obstacles
/// of `observation` (the one `dovs` was built from) collides latest (see ShieldLevel). Never empties a non-empty
/// validity mask. Throws DovsError when the configuration is invalid.
ShieldedMask shieldActions(const ActionSet& actions, const VelocitySpace& dovs, const Observation& observation,
                           const ActionShieldConfig& config);

/// The escape velocity for a boxed-in robot (see ActionShieldConfig::escape_enabled): from the robot's current
/// velocity in `observation`, against its obstacles. Throws DovsError when the configuration is invalid.
Twist2 escapeVelocity(const Observation& observation, const RobotLimits& limits, double safety_factor,
                      const ActionShieldConfig& config);
/// escapeVelocity with its tier.
Escape searchEscapeTiered(const Observation& observation, const RobotLimits& limits, double safety_factor,
                          const ActionShieldConfig& config);

}  // namespace dqn_dovs
