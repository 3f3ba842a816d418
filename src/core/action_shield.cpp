#include "dqn_dovs/action_shield.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "dqn_dovs/rollout.h"

namespace dqn_dovs {

std::string ActionShieldConfig::validate() const {
  std::ostringstream os;
  if (!(std::isfinite(robust_dv_mps) && robust_dv_mps >= 0.0)) {
    os << "action_shield.robust_dv_mps = " << robust_dv_mps << ": must be finite and >= 0";
  } else if (!(std::isfinite(robust_dw_rps) && robust_dw_rps >= 0.0)) {
    os << "action_shield.robust_dw_rps = " << robust_dw_rps << ": must be finite and >= 0";
  } else if (!(std::isfinite(last_resort_horizon_s) && last_resort_horizon_s > 0.0)) {
    os << "action_shield.last_resort_horizon_s = " << last_resort_horizon_s << ": must be finite and > 0";
  } else if (!(std::isfinite(last_resort_step_s) && last_resort_step_s > 0.0 &&
               last_resort_step_s <= last_resort_horizon_s)) {
    os << "action_shield.last_resort_step_s = " << last_resort_step_s << ": must be > 0 and <= last_resort_horizon_s";
  } else if (!(std::isfinite(last_resort_tolerance_s) && last_resort_tolerance_s >= 0.0)) {
    os << "action_shield.last_resort_tolerance_s = " << last_resort_tolerance_s << ": must be finite and >= 0";
  } else if (escape_window_samples < 1 || escape_window_samples > 30) {
    os << "action_shield.escape_window_samples = " << escape_window_samples << ": must be in [1, 30]";
  } else if (!(std::isfinite(last_resort_clearance_tolerance_m) && last_resort_clearance_tolerance_m >= 0.0)) {
    os << "action_shield.last_resort_clearance_tolerance_m = " << last_resort_clearance_tolerance_m
       << ": must be finite and >= 0";
  }
  return os.str();
}

const char* shieldLevelName(ShieldLevel level) {
  switch (level) {
    case ShieldLevel::kDisabled:
      return "disabled";
    case ShieldLevel::kRobust:
      return "robust";
    case ShieldLevel::kFree:
      return "free";
    case ShieldLevel::kLatest:
      return "latest";
  }
  return "unknown";
}

int ShieldedMask::numAllowed() const {
  int n = 0;
  for (bool b : mask) n += b ? 1 : 0;
  return n;
}

namespace {

// The neighbours dv / dw away from a free velocity that are feasible are free too (the triangle's edge is not a
// velocity obstacle: a neighbour outside it does not count against the action).
bool neighboursFree(const VelocitySpace& dovs, const Twist2& u, double dv, double dw) {
  const Twist2 neighbours[4] = {{u.v + dv, u.w}, {u.v - dv, u.w}, {u.v, u.w + dw}, {u.v, u.w - dw}};
  for (const Twist2& n : neighbours) {
    if (dovs.isFeasible(n) && !dovs.isFree(n)) return false;
  }
  return true;
}

}  // namespace

namespace {
// escapeVelocity without the configuration check (shieldActions has made it).
Twist2 searchEscape(const Observation& observation, const RobotLimits& limits, double safety_factor,
                    const ActionShieldConfig& config);
}  // namespace

ShieldedMask shieldActions(const ActionSet& actions, const VelocitySpace& dovs, const Observation& observation,
                           const ActionShieldConfig& config) {
  if (const std::string e = config.validate(); !e.empty()) throw DovsError(e);
  ShieldedMask out;
  out.mask = actions.valid;
  if (!config.enabled) return out;
  std::array<bool, kNumActions> free{}, robust{};
  bool any_free = false, any_robust = false;
  for (size_t i = 0; i < free.size(); ++i) {
    if (!actions.valid[i]) continue;
    const Twist2& u = actions.velocities[i];
    free[i] = dovs.isFree(u);
    robust[i] = free[i] && neighboursFree(dovs, u, config.robust_dv_mps, config.robust_dw_rps);
    any_free = any_free || free[i];
    any_robust = any_robust || robust[i];
  }
  if (any_robust) {
    out.mask = robust;
    out.level = ShieldLevel::kRobust;
  } else if (any_free) {
    out.mask = free;
    out.level = ShieldLevel::kFree;
  } else {
    // Boxed in: put off the contact as long as possible (what S-DOVS's escape does over the whole window).
    out.level = ShieldLevel::kLatest;
    const LocalScene scene(observation, dovs.limits().radius, dovs.config().safety_factor);
    std::array<double, kNumActions> ttc{}, clearance{};
    double latest = -1.0;
    for (size_t i = 0; i < ttc.size(); ++i) {
      if (!actions.valid[i]) continue;
      const Rollout r = rollOut(scene, actions.velocities[i], config.last_resort_horizon_s, config.last_resort_step_s);
      ttc[i] = std::min(r.collision_time_s, config.last_resort_horizon_s);
      clearance[i] = r.min_clearance_m;
      latest = std::max(latest, ttc[i]);
    }
    // Among those colliding latest, the ones keeping the most clearance on the way.
    double widest = -std::numeric_limits<double>::infinity();
    for (size_t i = 0; i < ttc.size(); ++i) {
      out.mask[i] = actions.valid[i] && ttc[i] >= latest - config.last_resort_tolerance_s - 1e-9;
      if (out.mask[i]) widest = std::max(widest, clearance[i]);
    }
    for (size_t i = 0; i < ttc.size(); ++i) {
      out.mask[i] = out.mask[i] && clearance[i] >= widest - config.last_resort_clearance_tolerance_m - 1e-9;
    }
    if (config.escape_enabled && actions.numValid() > 0) {
      out.has_escape = true;
      out.escape = searchEscape(observation, dovs.limits(), dovs.config().safety_factor, config);
    }
  }
  return out;
}

Twist2 escapeVelocity(const Observation& observation, const RobotLimits& limits, double safety_factor,
                      const ActionShieldConfig& config) {
  if (const std::string e = config.validate(); !e.empty()) throw DovsError(e);
  return searchEscape(observation, limits, safety_factor, config);
}

namespace {

Twist2 searchEscape(const Observation& observation, const RobotLimits& limits, double safety_factor,
                    const ActionShieldConfig& config) {
  const LocalScene scene(observation, limits.radius, safety_factor);
  const Twist2 current = limits.clipToFeasible(observation.robot_twist);
  const Vec2 goal = observation.robot_pose.toLocal(observation.goal);
  const double horizon = config.last_resort_horizon_s, step = config.last_resort_step_s;
  double best_ttc = -1.0, best_clearance = -std::numeric_limits<double>::infinity(),
         best_goal = std::numeric_limits<double>::infinity();
  Twist2 chosen = current;
  const SampledScene sampled(scene, horizon, step);  // up to 9 x 61 roll-outs over the same times
  constexpr double kNone = -std::numeric_limits<double>::infinity();
  for (const Twist2& u1 : makeDynamicWindow(current, limits).samples(config.escape_window_samples, limits)) {
    // The best follow-up one period on: a corner or the centre of u1's own window (its 3 x 3 box).
    double ttc = -1.0, clearance = kNone;
    for (int i = -1; i <= 1; ++i) {
      for (int j = -1; j <= 1; ++j) {
        const Twist2 u2{u1.v + i * limits.dv(), u1.w + j * limits.dw()};
        if (!limits.feasible(u2, 1e-9)) continue;
        // Once a roll-out has reached the horizon untouched, one whose clearance falls below its clearance can
        // no longer be u1's best follow-up, nor (1 mm below the best so far) tie the best velocity: abandoned,
        // which leaves the choice exactly what the full search makes.
        const double below_best = best_ttc >= horizon - 1e-9 ? best_clearance - 1e-3 - 1e-9 : kNone;
        const double below_own = ttc >= horizon - 1e-9 ? clearance : kNone;
        bool abandoned = false;
        const Rollout r = sampled.rollOutSwitching(u1, limits.dt, u2, Contact::kTrue, std::max(below_best, below_own),
                                                   abandoned);
        if (abandoned) continue;
        const double t = std::min(r.collision_time_s, horizon);
        if (t > ttc + 1e-9 || (t > ttc - 1e-9 && r.min_clearance_m > clearance)) {
          ttc = t;
          clearance = r.min_clearance_m;
        }
      }
    }
    if (ttc < 0.0) continue;  // every follow-up abandoned: u1 cannot beat the best
    const double g = (integrateUnicycle(Pose2{}, u1.v, u1.w, limits.dt).position() - goal).norm();
    const bool better = ttc > best_ttc + 1e-9 ||
                        (ttc > best_ttc - 1e-9 && (clearance > best_clearance + 1e-3 ||
                                                   (clearance > best_clearance - 1e-3 && g < best_goal)));
    if (better) {
      best_ttc = ttc;
      best_clearance = clearance;
      best_goal = g;
      chosen = u1;
    }
  }
  return chosen;
}

}  // namespace

}  // namespace dqn_dovs
