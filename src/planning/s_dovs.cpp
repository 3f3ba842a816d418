#include "dqn_dovs/planning/s_dovs.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "dqn_dovs/policy/rollout.h"

namespace dqn_dovs {

std::string SDovsConfig::validate() const {
  std::ostringstream os;
  auto positive = [](double x) { return std::isfinite(x) && x > 0.0; };
  auto non_negative = [](double x) { return std::isfinite(x) && x >= 0.0; };
  if (window_samples < 1 || window_samples > 100) {
    os << "s_dovs.window_samples = " << window_samples << ": must be in [1, 100]";
  } else if (!positive(goal_tolerance_m)) {
    os << "s_dovs.goal_tolerance_m = " << goal_tolerance_m << ": must be finite and > 0";
  } else if (!non_negative(arrival_speed_mps)) {
    os << "s_dovs.arrival_speed_mps = " << arrival_speed_mps << ": must be finite and >= 0";
  } else if (!non_negative(arrival_distance_m)) {
    os << "s_dovs.arrival_distance_m = " << arrival_distance_m << ": must be finite and >= 0";
  } else if (!(braking_fraction > 0.0 && braking_fraction <= 1.0)) {
    os << "s_dovs.braking_fraction = " << braking_fraction << ": must be in (0, 1]";
  } else if (!(direct_goal_angle_rad >= 0.0 && direct_goal_angle_rad <= kPi / 2.0)) {
    os << "s_dovs.direct_goal_angle_rad = " << direct_goal_angle_rad << ": must be in [0, pi/2]";
  } else if (!positive(goal_line_step_mps)) {
    os << "s_dovs.goal_line_step_mps = " << goal_line_step_mps << ": must be finite and > 0";
  } else if (!(escape_free_fraction >= 0.0 && escape_free_fraction <= 1.0)) {
    os << "s_dovs.escape_free_fraction = " << escape_free_fraction << ": must be in [0, 1]";
  } else if (!non_negative(target_speed_margin_mps)) {
    os << "s_dovs.target_speed_margin_mps = " << target_speed_margin_mps << ": must be finite and >= 0";
  } else if (!positive(lookahead_s)) {
    os << "s_dovs.lookahead_s = " << lookahead_s << ": must be finite and > 0";
  } else if (!positive(rollout_step_s) || rollout_step_s > lookahead_s) {
    os << "s_dovs.rollout_step_s = " << rollout_step_s << ": must be > 0 and <= lookahead_s";
  } else if (!non_negative(turn_cost_factor)) {
    os << "s_dovs.turn_cost_factor = " << turn_cost_factor << ": must be finite and >= 0";
  } else if (!(std::isfinite(safety_factor) && safety_factor >= 1.0)) {
    os << "s_dovs.safety_factor = " << safety_factor << ": must be finite and >= 1";
  } else if (!non_negative(comfort_clearance_m)) {
    os << "s_dovs.comfort_clearance_m = " << comfort_clearance_m << ": must be finite and >= 0";
  } else if (!non_negative(clearance_penalty_s_per_m)) {
    os << "s_dovs.clearance_penalty_s_per_m = " << clearance_penalty_s_per_m << ": must be finite and >= 0";
  } else if (!positive(escape_horizon_s)) {
    os << "s_dovs.escape_horizon_s = " << escape_horizon_s << ": must be finite and > 0";
  } else if (!non_negative(robust_dv_mps)) {
    os << "s_dovs.robust_dv_mps = " << robust_dv_mps << ": must be finite and >= 0";
  } else if (!non_negative(robust_dw_rps)) {
    os << "s_dovs.robust_dw_rps = " << robust_dw_rps << ": must be finite and >= 0";
  }
  if (os.str().empty()) {
    if (const std::string e = statics.validate(); !e.empty()) os << "s_dovs." << e;
  }
  return os.str();
}

namespace {

const SDovsConfig& checked(const SDovsConfig& c) {
  const std::string error = c.validate();
  if (!error.empty()) throw PlannerError("S-DOVS configuration: " + error);
  return c;
}

/// What the rest of the way from pose p costs at best: straight-line time plus the heading error to turn away.
double remainingTime(const Pose2& p, const Vec2& goal, const RobotLimits& limits, double turn_cost_factor) {
  const Vec2 to_goal = goal - p.position();
  const double d = to_goal.norm();
  const double heading_error = d > 1e-6 ? std::abs(angleDiff(std::atan2(to_goal.y(), to_goal.x()), p.theta)) : 0.0;
  return d / limits.v_max + turn_cost_factor * heading_error / limits.w_max;
}

struct TargetCost {
  double cost_s = std::numeric_limits<double>::infinity();
  double min_clearance_m = std::numeric_limits<double>::infinity();
};

/// Time-to-goal heuristic of holding target u: min over switching times t in [commit, lookahead] of
/// t + remainingTime(p(t)); a target that runs into something before the commitment time is costed as stuck
/// for the whole look-ahead at its last safe pose. Reaching the goal tolerance ends the roll-out with cost t.
TargetCost targetCost(const LocalScene& scene, const Twist2& u, const Twist2& current, const Vec2& goal,
                      const RobotLimits& limits, const SDovsConfig& cfg) {
  TargetCost out;
  const double step = cfg.rollout_step_s;
  const double commit_s = std::min(cfg.lookahead_s, 1.0);
  const double reach_s = 0.5 * std::max(std::abs(u.v - current.v) / limits.a_v, std::abs(u.w - current.w) / limits.a_w);
  const double start_clearance = scene.currentClearance_m();
  bool start_inside = false;
  scene.clearance(Vec2::Zero(), 0.0, start_inside);
  Pose2 last_safe;
  const int n = static_cast<int>(std::ceil(cfg.lookahead_s / step - 1e-9));
  for (int k = 1; k <= n; ++k) {
    const double t = std::min(cfg.lookahead_s, k * step);
    const Pose2 p = integrateUnicycle(Pose2{}, u.v, u.w, t);
    bool collides = false;
    const double c = scene.clearance(p.position(), t, collides);
    if (collides && (!start_inside || c < start_clearance - 1e-3)) {
      if (t <= commit_s + 1e-9)
        out.cost_s = cfg.lookahead_s + remainingTime(last_safe, goal, limits, cfg.turn_cost_factor);
      break;
    }
    out.min_clearance_m = std::min(out.min_clearance_m, c);
    last_safe = p;
    if ((p.position() - goal).norm() < cfg.goal_tolerance_m) {
      out.cost_s = std::min(out.cost_s, t);
      break;
    }
    if (t >= commit_s - 1e-9) {
      out.cost_s = std::min(out.cost_s, t + remainingTime(p, goal, limits, cfg.turn_cost_factor));
    }
  }
  if (!std::isfinite(out.cost_s))
    out.cost_s = cfg.lookahead_s + remainingTime(last_safe, goal, limits, cfg.turn_cost_factor);
  out.cost_s += reach_s;
  if (out.min_clearance_m < cfg.comfort_clearance_m) {
    out.cost_s += cfg.clearance_penalty_s_per_m * (cfg.comfort_clearance_m - std::max(out.min_clearance_m, -1.0));
  }
  return out;
}

/// A target velocity of strategy (b) with how it relates to the DOV bands of its trajectory.
struct Target {
  Twist2 u;
  bool band_below = false;  ///< an unsafe interval lies below u's speed on its trajectory: passing in front
  bool band_above = false;  ///< an unsafe interval lies above u's speed (below the ray's top): passing behind
};

/// Free targets on every trajectory of the DOVS: one per free speed interval (its fastest speed under the cap,
/// kept target_speed_margin_mps inside the interval), plus turning in place where it is free.
std::vector<Target> freeTargets(const VelocitySpace& dovs, double v_cap, const SDovsConfig& cfg) {
  std::vector<Target> targets;
  const RobotLimits& limits = dovs.limits();
  for (int i = 0; i < dovs.numTrajectories(); ++i) {
    const Trajectory& tr = dovs.trajectory(i);
    if (tr.pure_rotation || tr.v_top_mps <= 1e-9) {
      for (double f : {0.35, 0.7}) {
        const Twist2 u{0.0, f * tr.w_top_rps};
        if (dovs.isFree(u)) targets.push_back(Target{u, false, false});
      }
      continue;
    }
    const double ratio = tr.w_top_rps / tr.v_top_mps;
    const IntervalRange unsafe = dovs.unsafeIntervals(i);
    double lo = 0.0;
    const double top = std::min(tr.v_top_mps, limits.v_max);
    auto add = [&](double a, double b, bool below, bool above) {
      const double b_capped = std::min(b, v_cap);
      if (b_capped <= a + 1e-6) return;
      double v = b_capped;
      const bool edge_above = b_capped >= b - 1e-9 && above;
      if (edge_above) v = b_capped - cfg.target_speed_margin_mps;
      if (below) v = std::max(v, a + cfg.target_speed_margin_mps);
      if (v > b_capped || v < a) v = 0.5 * (a + b_capped);
      const Twist2 u{v, ratio * v};
      if (dovs.isFree(u)) targets.push_back(Target{u, below, above});
    };
    for (const SpeedInterval& iv : unsafe) {
      if (iv.lo_mps > lo) add(lo, iv.lo_mps, lo > 0.0, true);
      lo = std::max(lo, iv.hi_mps);
    }
    if (lo < top) add(lo, top, lo > 0.0, false);
  }
  return targets;
}

}  // namespace

SDovsPlanner::SDovsPlanner(const SDovsConfig& config) : config_(checked(config)) {}

double SDovsPlanner::brakingSpeedCap(double d_goal_m, const RobotLimits& limits) const {
  if (!std::isfinite(d_goal_m)) return 0.0;
  const double beyond = std::max(0.0, d_goal_m - config_.arrival_distance_m);
  const double v_arrive = std::min(config_.arrival_speed_mps, d_goal_m > config_.arrival_distance_m
                                                                  ? config_.arrival_speed_mps
                                                                  : config_.arrival_speed_mps * d_goal_m /
                                                                        std::max(config_.arrival_distance_m, 1e-9));
  return std::min(limits.v_max, std::sqrt(v_arrive * v_arrive + 2.0 * config_.braking_fraction * limits.a_v * beyond));
}

std::vector<Twist2> SDovsPlanner::windowSamples(const Twist2& current, const RobotLimits& limits) const {
  return makeDynamicWindow(current, limits).samples(config_.window_samples, limits);
}

PlannerDecision SDovsPlanner::decide(const PlannerInput& input) {
  PlannerDecision d = plan(input);
  if (config_.statics.enabled) {
    const Observation& obs = *input.observation;
    const StaticScene statics(obs, input.limits, config_.statics);
    const Twist2 safe = staticSafeCommand(statics, input.limits.clipToFeasible(obs.robot_twist), d.command,
                                          input.limits, config_.statics);
    if (safe.v != d.command.v || safe.w != d.command.w) {
      d.command = safe;
      d.note += " (static safety)";
    }
  }
  return d;
}

PlannerDecision SDovsPlanner::plan(const PlannerInput& input) const {
  if (input.observation == nullptr) throw PlannerError("S-DOVS: the planner input has no observation");
  if (input.dovs == nullptr) throw PlannerError("S-DOVS: the planner input has no DOVS");
  const Observation& obs = *input.observation;
  const VelocitySpace& dovs = *input.dovs;
  const RobotLimits& limits = input.limits;
  if (const std::string e = limits.validate(); !e.empty()) throw PlannerError("S-DOVS: robot limits: " + e);
  if (!obs.robot_pose.isFinite()) throw PlannerError("S-DOVS: the robot pose is not finite");
  if (!std::isfinite(obs.robot_twist.v) || !std::isfinite(obs.robot_twist.w)) {
    throw PlannerError("S-DOVS: the robot twist is not finite");
  }
  if (!obs.goal.allFinite()) throw PlannerError("S-DOVS: the goal is not finite");

  const Twist2 current = limits.clipToFeasible(obs.robot_twist);
  const Vec2 goal = obs.robot_pose.toLocal(obs.goal);
  const double d_goal = goal.norm();
  const LocalScene scene(obs, limits.radius, config_.safety_factor);

  const std::vector<Twist2> samples = windowSamples(current, limits);
  std::vector<char> free(samples.size(), 0), robust(samples.size(), 0);
  size_t num_free = 0, num_robust = 0;
  auto freeOrInfeasible = [&](const Twist2& t) { return !limits.feasible(t, 1e-9) || dovs.isFree(t); };
  for (size_t k = 0; k < samples.size(); ++k) {
    const Twist2& s = samples[k];
    if (!dovs.isFree(s)) continue;
    free[k] = 1;
    ++num_free;
    const double dv = config_.robust_dv_mps, dw = config_.robust_dw_rps;
    if (freeOrInfeasible({s.v + dv, s.w}) && freeOrInfeasible({s.v - dv, s.w}) && freeOrInfeasible({s.v, s.w + dw}) &&
        freeOrInfeasible({s.v, s.w - dw})) {
      robust[k] = 1;
      ++num_robust;
    }
  }

  PlannerDecision decision;
  // Steps toward `target`: the robustly free sample closest to it (window-normalised), else the closest free one.
  auto stepToward = [&](const Twist2& target) -> Twist2 {
    const std::vector<char>& allowed = num_robust > 0 ? robust : free;
    double best = std::numeric_limits<double>::infinity();
    Twist2 chosen = decelerationCommand(current, limits);
    for (size_t k = 0; k < samples.size(); ++k) {
      if (!allowed[k]) continue;
      const double a = (samples[k].v - target.v) / limits.dv(), b = (samples[k].w - target.w) / limits.dw();
      const double c = a * a + b * b;
      if (c < best) {
        best = c;
        chosen = samples[k];
      }
    }
    return chosen;
  };

  // (d) On the goal: stop, on free velocities where there are any.
  if (d_goal < config_.goal_tolerance_m) {
    decision.command = num_free > 0 ? stepToward(Twist2{0.0, 0.0}) : decelerationCommand(current, limits);
    decision.note = "stop_on_goal";
    return decision;
  }

  // (c) Escape: (nearly) boxed in. Hold the window velocity that collides latest, then the one keeping most
  // clearance, then the one closest to the goal direction.
  const double free_fraction =
      samples.empty() ? 0.0 : static_cast<double>(num_free) / static_cast<double>(samples.size());
  if (num_free == 0 || free_fraction < config_.escape_free_fraction) {
    double best_ttc = -1.0, best_clearance = -std::numeric_limits<double>::infinity(),
           best_goal = std::numeric_limits<double>::infinity();
    Twist2 chosen = decelerationCommand(current, limits);
    for (size_t k = 0; k < samples.size(); ++k) {
      if (num_free > 0 && !free[k]) continue;
      const Rollout r = rollOut(scene, samples[k], config_.escape_horizon_s, config_.rollout_step_s);
      const double ttc = std::min(r.collision_time_s, config_.escape_horizon_s);
      const Pose2 p = integrateUnicycle(Pose2{}, samples[k].v, samples[k].w, limits.dt);
      const double g = (p.position() - goal).norm();
      const bool better = ttc > best_ttc + 1e-9 ||
                          (ttc > best_ttc - 1e-9 && (r.min_clearance_m > best_clearance + 1e-3 ||
                                                     (r.min_clearance_m > best_clearance - 1e-3 && g < best_goal)));
      if (better) {
        best_ttc = ttc;
        best_clearance = r.min_clearance_m;
        best_goal = g;
        chosen = samples[k];
      }
    }
    decision.command = chosen;
    decision.note = num_free == 0 ? "escape (no free velocity in the window)" : "escape";
    return decision;
  }

  const double v_cap = brakingSpeedCap(d_goal, limits);

  // (a) Goal-directed: the goal line from the window up to the fastest speed that still stops on the goal is free.
  const double alpha = std::atan2(goal.y(), goal.x());
  if (goal.x() > 0.0 && std::abs(alpha) <= config_.direct_goal_angle_rad) {
    const double k = 2.0 * goal.y() / (d_goal * d_goal);
    const double v_line_top = 1.0 / (1.0 / limits.v_max + std::abs(k) / limits.w_max);
    const double v_goal = std::min(v_line_top, v_cap);
    const double v_low = std::clamp(current.v - limits.dv(), 0.0, v_goal);
    bool clear = v_goal > 0.0;
    for (double v = v_low; clear && v <= v_goal + 1e-9; v += config_.goal_line_step_mps) {
      clear = dovs.isFree(Twist2{v, k * v});
    }
    clear = clear && dovs.isFree(Twist2{v_goal, k * v_goal});
    if (clear) {
      const Twist2 target{v_goal, k * v_goal};
      const Rollout r = rollOut(scene, target, std::min(config_.lookahead_s, d_goal / std::max(v_goal, 1e-3)),
                                config_.rollout_step_s);
      if (!std::isfinite(r.collision_time_s)) {
        decision.command = stepToward(target);
        decision.note = v_cap < v_line_top ? "brake_to_goal" : "goal";
        return decision;
      }
    }
  }

  // (b) The way to the goal is blocked (or the goal is far off the heading): the free target with the best
  // time-to-goal heuristic; in front of an obstacle's band, behind it, or around.
  const std::vector<Target> targets = freeTargets(dovs, v_cap, config_);
  double best_cost = std::numeric_limits<double>::infinity();
  const Target* best = nullptr;
  for (const Target& t : targets) {
    const TargetCost c = targetCost(scene, t.u, current, goal, limits, config_);
    if (c.cost_s < best_cost) {
      best_cost = c.cost_s;
      best = &t;
    }
  }
  if (best == nullptr) {
    // No free target anywhere in the DOVS (only the window has free samples): the one closest to slowing down.
    decision.command = stepToward(Twist2{0.0, 0.0});
    decision.note = "hold (no free target in the DOVS)";
    return decision;
  }
  decision.command = stepToward(best->u);
  if (best->u.v <= 1e-9) {
    decision.note = "turn";
  } else if (best->band_below) {
    decision.note = "pass_front";
  } else if (best->band_above) {
    decision.note = "pass_behind";
  } else {
    decision.note = "detour";
  }
  return decision;
}

}  // namespace dqn_dovs
