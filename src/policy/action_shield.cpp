#include "dqn_dovs/policy/action_shield.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <type_traits>
#include <variant>
#include <vector>

#include "dqn_dovs/common/parse.h"
#include "dqn_dovs/policy/rollout.h"

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
  } else if (!(std::isfinite(dodge_advantage_s) && dodge_advantage_s <= 10.0)) {
    os << "action_shield.dodge_advantage_s = " << dodge_advantage_s << ": must be finite and <= 10 s (< 0: never)";
  } else if (!(std::isfinite(rest_speed_mps) && rest_speed_mps >= 0.0 && rest_speed_mps <= 0.3)) {
    os << "action_shield.rest_speed_mps = " << rest_speed_mps << ": must be in [0, 0.3] m/s";
  } else if (!(std::isfinite(passive_margin_m) && passive_margin_m >= 0.0 && passive_margin_m <= 1.0)) {
    os << "action_shield.passive_margin_m = " << passive_margin_m << ": must be in [0, 1] m";
  } else if (!(std::isfinite(passive_margin_growth_mps) && passive_margin_growth_mps >= 0.0 &&
               passive_margin_growth_mps <= 1.0)) {
    os << "action_shield.passive_margin_growth_mps = " << passive_margin_growth_mps << ": must be in [0, 1] m/s";
  } else if (const std::string e = statics.validate(); !e.empty()) {
    os << "action_shield." << e;
  }
  return os.str();
}

namespace {

// Every named parameter of the shield: its name (config/dovs.yaml action_shield/*, config/static_safety.yaml
// static_safety/*) and the field it sets. The one list behind the setter, the getter and the nodes' loader.
struct ShieldField {
  const char* name;
  std::variant<double ActionShieldConfig::*, bool ActionShieldConfig::*, int ActionShieldConfig::*,
               double StaticSafetyConfig::*, bool StaticSafetyConfig::*>
      member;
};

const std::vector<ShieldField>& shieldFields() {
  static const std::vector<ShieldField> fields = {
      {"enabled", &ActionShieldConfig::enabled},
      {"robust_dv", &ActionShieldConfig::robust_dv_mps},
      {"robust_dw", &ActionShieldConfig::robust_dw_rps},
      {"last_resort_horizon", &ActionShieldConfig::last_resort_horizon_s},
      {"last_resort_step", &ActionShieldConfig::last_resort_step_s},
      {"last_resort_tolerance", &ActionShieldConfig::last_resort_tolerance_s},
      {"last_resort_clearance_tolerance", &ActionShieldConfig::last_resort_clearance_tolerance_m},
      {"escape", &ActionShieldConfig::escape_enabled},
      {"escape_window_samples", &ActionShieldConfig::escape_window_samples},
      {"passive_escape", &ActionShieldConfig::passive_escape},
      {"slowest_contact", &ActionShieldConfig::slowest_contact},
      {"dodge_advantage", &ActionShieldConfig::dodge_advantage_s},
      {"passive_margin", &ActionShieldConfig::passive_margin_m},
      {"passive_margin_growth", &ActionShieldConfig::passive_margin_growth_mps},
      {"passive_actions", &ActionShieldConfig::passive_actions},
      {"rest_speed", &ActionShieldConfig::rest_speed_mps},
      {"static_safety/enabled", &StaticSafetyConfig::enabled},
      {"static_safety/latency", &StaticSafetyConfig::latency_s},
      {"static_safety/braking_fraction", &StaticSafetyConfig::braking_fraction},
      {"static_safety/margin", &StaticSafetyConfig::margin_m},
      {"static_safety/step", &StaticSafetyConfig::step_s},
      {"static_safety/static_speed", &StaticSafetyConfig::static_speed_mps},
  };
  return fields;
}

const ShieldField* findShieldField(const std::string& name) {
  for (const ShieldField& f : shieldFields()) {
    if (name == f.name) return &f;
  }
  return nullptr;
}

// The field of `config` a member pointer names (ActionShieldConfig's own, or its static rule's).
template <typename T>
T& fieldOf(ActionShieldConfig& config, T ActionShieldConfig::*member) {
  return config.*member;
}
template <typename T>
T& fieldOf(ActionShieldConfig& config, T StaticSafetyConfig::*member) {
  return config.statics.*member;
}

}  // namespace

const std::vector<std::string>& shieldParameterNames() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> out;
    for (const ShieldField& f : shieldFields()) out.emplace_back(f.name);
    return out;
  }();
  return names;
}

std::string setShieldParameter(ActionShieldConfig& config, const std::string& name, const std::string& value) {
  const ShieldField* field = findShieldField(name);
  if (field == nullptr) return "unknown action shield parameter '" + name + "'";
  auto number = [&]() { return parseNumber(value); };
  return std::visit(
      [&](auto member) -> std::string {
        auto& target = fieldOf(config, member);
        using T = std::decay_t<decltype(target)>;
        if constexpr (std::is_same_v<T, bool>) {
          if (value == "true" || value == "1")
            target = true;
          else if (value == "false" || value == "0")
            target = false;
          else
            return "'" + name + "': '" + value + "' is not true or false";
        } else {
          const std::optional<double> x = number();
          if (!x) return "'" + name + "': '" + value + "' is not a number";
          if constexpr (std::is_same_v<T, int>) {
            if (*x != std::floor(*x)) return "'" + name + "': '" + value + "' is not an integer";
            target = static_cast<int>(std::clamp(*x, -1e6, 1e6));
          } else {
            target = *x;
          }
        }
        return {};
      },
      field->member);
}

std::string shieldParameter(const ActionShieldConfig& config, const std::string& name) {
  const ShieldField* field = findShieldField(name);
  if (field == nullptr) throw std::invalid_argument("unknown action shield parameter '" + name + "'");
  ActionShieldConfig copy = config;
  return std::visit(
      [&](auto member) -> std::string {
        const auto& v = fieldOf(copy, member);
        using T = std::decay_t<decltype(v)>;
        if constexpr (std::is_same_v<T, bool>) {
          return v ? "true" : "false";
        } else if constexpr (std::is_same_v<T, int>) {
          return std::to_string(v);
        } else {
          std::ostringstream os;
          os.precision(17);
          os << v;
          return os.str();
        }
      },
      field->member);
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
    case ShieldLevel::kStatic:
      return "static";
  }
  return "unknown";
}

const char* escapeTierName(EscapeTier tier) {
  switch (tier) {
    case EscapeTier::kFree:
      return "free";
    case EscapeTier::kRest:
      return "rest";
    case EscapeTier::kSlowest:
      return "slowest";
    case EscapeTier::kUnsafe:
      return "unsafe";
    case EscapeTier::kDodge:
      return "dodge";
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
// searchEscapeTiered without the configuration check (shieldActions has made it).
Escape searchEscape(const Observation& observation, const RobotLimits& limits, double safety_factor,
                    const ActionShieldConfig& config);

// The braking trajectory of u (static_safety.h) against the moving obstacles of `scene`: where the robot first
// touches one (true radii) while still moving faster than rest_speed_mps, and at what speed.
struct BrakingContact {
  bool contact = false;                                          ///< a true contact while moving
  double speed_mps = 0.0;                                        ///< the robot's speed there
  double time_s = 0.0;                                           ///< when
  double clearance_m = std::numeric_limits<double>::infinity();  ///< least clearance while moving (to contact)
};

BrakingContact brakingContact(const LocalScene& scene, const Twist2& current, const Twist2& u,
                              const RobotLimits& limits, const ActionShieldConfig& config) {
  BrakingContact out;
  bool unused = false;
  const double start = scene.clearance(Vec2::Zero(), 0.0, unused);
  StaticSafetyConfig sampling = config.statics;
  sampling.step_s = std::max(sampling.step_s, 0.05);  // the contact check of the escape: 3.5 cm at v_max
  for (const BrakingSample& s : brakingSamples(current, u, limits, sampling)) {
    if (s.speed_mps <= config.rest_speed_mps) break;
    bool inflated = false;
    const double c = scene.clearance(s.position, s.t_s, inflated);
    out.clearance_m = std::min(out.clearance_m, c);
    // Starting closer than the margin (or in contact), only getting closer counts: moving away never does.
    const double floor = std::min(config.passive_margin_m + config.passive_margin_growth_mps * s.t_s, start - 1e-3);
    if (c < floor) {
      out.contact = true;
      out.speed_mps = s.speed_mps;
      out.time_s = s.t_s;
      break;
    }
  }
  return out;
}
}  // namespace

ShieldedMask shieldActions(const ActionSet& actions, const VelocitySpace& dovs, const Observation& observation,
                           const ActionShieldConfig& config) {
  if (const std::string e = config.validate(); !e.empty()) throw DovsError(e);
  ShieldedMask out;
  out.mask = actions.valid;
  out.static_safe.fill(true);
  if (!config.enabled) return out;
  const RobotLimits& limits = dovs.limits();
  const Twist2 current = observation.robot_twist;
  // The static braking rule first: it is binding whenever any valid action passes it.
  std::array<bool, kNumActions> choosable = actions.valid;
  bool any_static_safe = false;
  std::array<double, kNumActions> static_clearance{};
  if (config.statics.enabled) {
    const StaticScene statics(observation, limits, config.statics);
    for (size_t i = 0; i < choosable.size(); ++i) {
      if (!actions.valid[i]) continue;
      const BrakingPath p = brakingPath(statics, current, actions.velocities[i], limits, config.statics);
      out.static_safe[i] = p.safe;
      static_clearance[i] = p.min_clearance_m;
      any_static_safe = any_static_safe || p.safe;
    }
    for (size_t i = 0; i < choosable.size(); ++i) choosable[i] = actions.valid[i] && out.static_safe[i];
  } else {
    any_static_safe = true;
  }
  const bool any_valid = actions.numValid() > 0;
  if (!any_static_safe && any_valid) {
    // Every valid action ends in a wall: the escape searches the whole window; without it, the action keeping
    // the most static clearance.
    out.level = ShieldLevel::kStatic;
    double widest = -std::numeric_limits<double>::infinity();
    for (size_t i = 0; i < choosable.size(); ++i) {
      if (actions.valid[i]) widest = std::max(widest, static_clearance[i]);
    }
    for (size_t i = 0; i < choosable.size(); ++i) {
      out.mask[i] = actions.valid[i] && static_clearance[i] >= widest - 1e-6;
    }
    if (config.escape_enabled) {
      const Escape e = searchEscape(observation, limits, dovs.config().safety_factor, config);
      out.has_escape = true;
      out.escape = e.velocity;
      out.escape_tier = e.tier;
    }
    return out;
  }
  std::array<bool, kNumActions> free{}, robust{};
  bool any_free = false, any_robust = false;
  for (size_t i = 0; i < free.size(); ++i) {
    if (!choosable[i]) continue;
    const Twist2& u = actions.velocities[i];
    free[i] = dovs.isFree(u);
    robust[i] = free[i] && neighboursFree(dovs, u, config.robust_dv_mps, config.robust_dw_rps);
    any_free = any_free || free[i];
    any_robust = any_robust || robust[i];
  }
  if (any_free && config.passive_actions) {
    // Among the free actions, those from which braking comes to rest before any contact, when there are any.
    const LocalScene scene(observation, limits.radius, dovs.config().safety_factor);
    std::array<bool, kNumActions> passive{};
    bool any_passive = false, any_passive_robust = false;
    for (size_t i = 0; i < free.size(); ++i) {
      if (!free[i]) continue;
      passive[i] = !brakingContact(scene, current, actions.velocities[i], limits, config).contact;
      any_passive = any_passive || passive[i];
      any_passive_robust = any_passive_robust || (passive[i] && robust[i]);
    }
    if (any_passive) {
      for (size_t i = 0; i < free.size(); ++i) {
        free[i] = free[i] && passive[i];
        robust[i] = robust[i] && passive[i];
      }
      any_robust = any_passive_robust;
    }
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
    const LocalScene scene(observation, limits.radius, dovs.config().safety_factor);
    std::array<double, kNumActions> ttc{}, clearance{};
    double latest = -1.0;
    for (size_t i = 0; i < ttc.size(); ++i) {
      if (!choosable[i]) continue;
      const Rollout r = rollOut(scene, actions.velocities[i], config.last_resort_horizon_s, config.last_resort_step_s);
      ttc[i] = std::min(r.collision_time_s, config.last_resort_horizon_s);
      clearance[i] = r.min_clearance_m;
      latest = std::max(latest, ttc[i]);
    }
    // Among those colliding latest, the ones keeping the most clearance on the way.
    double widest = -std::numeric_limits<double>::infinity();
    for (size_t i = 0; i < ttc.size(); ++i) {
      out.mask[i] = choosable[i] && ttc[i] >= latest - config.last_resort_tolerance_s - 1e-9;
      if (out.mask[i]) widest = std::max(widest, clearance[i]);
    }
    for (size_t i = 0; i < ttc.size(); ++i) {
      out.mask[i] = out.mask[i] && clearance[i] >= widest - config.last_resort_clearance_tolerance_m - 1e-9;
    }
    if (config.escape_enabled && any_valid) {
      const Escape e = searchEscape(observation, limits, dovs.config().safety_factor, config);
      out.has_escape = true;
      out.escape = e.velocity;
      out.escape_tier = e.tier;
    }
  }
  return out;
}

Twist2 escapeVelocity(const Observation& observation, const RobotLimits& limits, double safety_factor,
                      const ActionShieldConfig& config) {
  return searchEscapeTiered(observation, limits, safety_factor, config).velocity;
}

Escape searchEscapeTiered(const Observation& observation, const RobotLimits& limits, double safety_factor,
                          const ActionShieldConfig& config) {
  if (const std::string e = config.validate(); !e.empty()) throw DovsError(e);
  return searchEscape(observation, limits, safety_factor, config);
}

namespace {

Escape searchEscape(const Observation& observation, const RobotLimits& limits, double safety_factor,
                    const ActionShieldConfig& config) {
  const LocalScene scene(observation, limits.radius, safety_factor);
  const Twist2 current = limits.clipToFeasible(observation.robot_twist);
  const Vec2 goal = observation.robot_pose.toLocal(observation.goal);
  const double horizon = config.last_resort_horizon_s, step = config.last_resort_step_s;
  const SampledScene sampled(scene, horizon, step);  // up to 9 x 61 roll-outs over the same times
  const StaticScene statics(observation, limits, config.statics);
  constexpr double kNone = -std::numeric_limits<double>::infinity();

  // The candidates: the window lattice and the strongest braking.
  std::vector<Twist2> candidates = makeDynamicWindow(current, limits).samples(config.escape_window_samples, limits);
  candidates.push_back(decelerationCommand(current, limits));

  // Static safety first: when any candidate passes, only those remain; otherwise the most static clearance.
  std::vector<char> keep(candidates.size(), 1);
  std::vector<double> static_clearance(candidates.size(), 0.0);
  bool any_static_safe = !config.statics.enabled;
  if (config.statics.enabled) {
    for (size_t k = 0; k < candidates.size(); ++k) {
      const BrakingPath p = brakingPath(statics, current, candidates[k], limits, config.statics);
      keep[k] = p.safe ? 1 : 0;
      static_clearance[k] = p.min_clearance_m;
      any_static_safe = any_static_safe || p.safe;
    }
  }
  if (!any_static_safe) {
    Escape e;
    e.tier = EscapeTier::kUnsafe;
    double widest = kNone, slowest = std::numeric_limits<double>::infinity();
    for (size_t k = 0; k < candidates.size(); ++k) {
      if (static_clearance[k] > widest + 1e-6 || (static_clearance[k] > widest - 1e-6 && candidates[k].v < slowest)) {
        widest = static_clearance[k];
        slowest = candidates[k].v;
        e.velocity = candidates[k];
      }
    }
    return e;
  }

  // The search of the follow-ups: among the candidates `eligible` admits, the one whose best follow-up after one
  // period puts the first true contact off longest (reaching the horizon: no contact), then the widest clearance,
  // then the closest to the goal.
  struct Best {
    bool found = false;
    double ttc = -1.0, clearance = -std::numeric_limits<double>::infinity(),
           goal = std::numeric_limits<double>::infinity();
    Twist2 u;
  };
  std::vector<double> follow_ttc(candidates.size(), -1.0);  // each searched candidate's best follow-up
  auto search = [&](auto&& eligible) {
    Best best;
    for (size_t k = 0; k < candidates.size(); ++k) {
      if (!keep[k] || !eligible(k)) continue;
      const Twist2& u1 = candidates[k];
      // The best follow-up one period on: a corner or the centre of u1's own window (its 3 x 3 box).
      double ttc = -1.0, clearance = kNone;
      for (int i = -1; i <= 1; ++i) {
        for (int j = -1; j <= 1; ++j) {
          const Twist2 u2{u1.v + i * limits.dv(), u1.w + j * limits.dw()};
          if (!limits.feasible(u2, 1e-9)) continue;
          // Once a roll-out has reached the horizon untouched, one whose clearance falls below its clearance can
          // no longer be u1's best follow-up, nor (1 mm below the best so far) tie the best velocity: abandoned,
          // which leaves the choice exactly what the full search makes.
          const double below_best = best.ttc >= horizon - 1e-9 ? best.clearance - 1e-3 - 1e-9 : kNone;
          const double below_own = ttc >= horizon - 1e-9 ? clearance : kNone;
          bool abandoned = false;
          const Rollout r =
              sampled.rollOutSwitching(u1, limits.dt, u2, Contact::kTrue, std::max(below_best, below_own), abandoned);
          if (abandoned) continue;
          const double t = std::min(r.collision_time_s, horizon);
          if (t > ttc + 1e-9 || (t > ttc - 1e-9 && r.min_clearance_m > clearance)) {
            ttc = t;
            clearance = r.min_clearance_m;
          }
        }
      }
      follow_ttc[k] = ttc;
      if (ttc < 0.0) continue;  // every follow-up abandoned: u1 cannot beat the best
      const double g = (integrateUnicycle(Pose2{}, u1.v, u1.w, limits.dt).position() - goal).norm();
      const bool better = ttc > best.ttc + 1e-9 ||
                          (ttc > best.ttc - 1e-9 &&
                           (clearance > best.clearance + 1e-3 || (clearance > best.clearance - 1e-3 && g < best.goal)));
      if (better) best = Best{true, ttc, clearance, g, u1};
    }
    return best;
  };
  auto clear = [&](const Best& b) { return b.found && b.ttc >= horizon - 1e-9; };

  Escape e;
  if (!config.passive_escape) {
    const Best b = search([](size_t) { return true; });
    e.velocity = b.found ? b.u : decelerationCommand(current, limits);
    e.tier = clear(b) ? EscapeTier::kFree : EscapeTier::kSlowest;
    return e;
  }
  // Tier kFree: no contact over the horizon with the best follow-up. A dodge that must keep moving counts: the
  // robot re-plans every period, and forcing a stop where a way out exists costs more contacts than it saves
  // (docs/planners.md, "Passive safety").
  const Best any = search([](size_t) { return true; });
  if (clear(any)) {
    e.velocity = any.u;
    e.tier = EscapeTier::kFree;
    return e;
  }
  // Passive safety of each candidate (needed only now): does its braking trajectory come to rest before any
  // contact?
  std::vector<BrakingContact> braking(candidates.size());
  for (size_t k = 0; k < candidates.size(); ++k) {
    if (keep[k]) braking[k] = brakingContact(scene, current, candidates[k], limits, config);
  }
  // Tier kRest: braking comes to rest before any contact; the latest contact of the best follow-up (the most
  // room to get away), then the widest clearance while braking, then the closest to the goal. The search above
  // abandoned nothing (no follow-up reached the horizon), so every follow-up time is exact.
  bool rest_found = false;
  double rest_ttc = kNone, rest_clearance = kNone, rest_goal = std::numeric_limits<double>::infinity();
  for (size_t k = 0; k < candidates.size(); ++k) {
    if (!keep[k] || braking[k].contact) continue;
    const Twist2& u1 = candidates[k];
    const double ttc = follow_ttc[k], c = braking[k].clearance_m;
    const double g = (integrateUnicycle(Pose2{}, u1.v, u1.w, limits.dt).position() - goal).norm();
    const bool better =
        ttc > rest_ttc + 1e-9 ||
        (ttc > rest_ttc - 1e-9 && (c > rest_clearance + 1e-3 || (c > rest_clearance - 1e-3 && g < rest_goal)));
    if (!rest_found || better) {
      rest_found = true;
      rest_ttc = ttc;
      rest_clearance = c;
      rest_goal = g;
      e.velocity = u1;
    }
  }
  if (rest_found && config.dodge_advantage_s >= 0.0 && any.ttc > rest_ttc + config.dodge_advantage_s + 1e-9) {
    e.velocity = any.u;
    e.tier = EscapeTier::kDodge;
    return e;
  }
  if (rest_found) {
    e.tier = EscapeTier::kRest;
    return e;
  }
  if (!config.slowest_contact) {
    e.velocity = any.found ? any.u : decelerationCommand(current, limits);
    e.tier = EscapeTier::kSlowest;
    return e;
  }
  // Tier kSlowest: the lowest speed at the contact, then the latest contact.
  double slow_speed = std::numeric_limits<double>::infinity(), slow_time = kNone;
  e.velocity = decelerationCommand(current, limits);
  for (size_t k = 0; k < candidates.size(); ++k) {
    if (!keep[k]) continue;
    const BrakingContact& bc = braking[k];
    if (bc.speed_mps < slow_speed - 1e-3 || (bc.speed_mps < slow_speed + 1e-3 && bc.time_s > slow_time)) {
      slow_speed = bc.speed_mps;
      slow_time = bc.time_s;
      e.velocity = candidates[k];
    }
  }
  e.tier = EscapeTier::kSlowest;
  e.contact_speed_mps = slow_speed;
  return e;
}

}  // namespace

}  // namespace dqn_dovs
