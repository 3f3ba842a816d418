#include "dqn_dovs/policy/static_safety.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace dqn_dovs {

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kMaxBrakingS = 20.0;  // a cap on the trajectory; any feasible robot stops long before
}  // namespace

std::string StaticSafetyConfig::validate() const {
  std::ostringstream os;
  if (!(std::isfinite(latency_s) && latency_s >= 0.0 && latency_s <= 2.0)) {
    os << "static_safety.latency_s = " << latency_s << ": must be in [0, 2] s";
  } else if (!(std::isfinite(braking_fraction) && braking_fraction > 0.0 && braking_fraction <= 1.0)) {
    os << "static_safety.braking_fraction = " << braking_fraction << ": must be in (0, 1]";
  } else if (!(std::isfinite(margin_m) && margin_m >= 0.0 && margin_m <= 1.0)) {
    os << "static_safety.margin_m = " << margin_m << ": must be in [0, 1] m";
  } else if (!(std::isfinite(step_s) && step_s >= 0.001 && step_s <= 0.1)) {
    os << "static_safety.step_s = " << step_s << ": must be in [0.001, 0.1] s";
  } else if (!(std::isfinite(static_speed_mps) && static_speed_mps >= 0.0 && static_speed_mps <= 0.5)) {
    os << "static_safety.static_speed_mps = " << static_speed_mps << ": must be in [0, 0.5] m/s";
  }
  return os.str();
}

StaticScene::StaticScene(const Observation& obs, const RobotLimits& limits, const StaticSafetyConfig& config)
    : robot_radius_(limits.radius) {
  // Farthest a braking trajectory can take the robot centre, and then its surface plus the margin.
  const double reach = limits.v_max * (config.latency_s + limits.dt) +
                       limits.v_max * limits.v_max / (2.0 * limits.a_v * config.braking_fraction) + limits.radius +
                       config.margin_m + 0.05;
  const Pose2& pose = obs.robot_pose;
  if (!pose.position().allFinite() || !std::isfinite(pose.theta)) return;
  for (const Segment& s : obs.segments) {
    if (!s.a.allFinite() || !s.b.allFinite()) continue;
    const Segment local{pose.toLocal(s.a), pose.toLocal(s.b)};
    if (pointSegmentDistance(Vec2::Zero(), local) <= reach) walls_.push_back(local);
  }
  for (const MovingObstacle& m : obs.obstacles) {
    if (!m.center.allFinite() || !std::isfinite(m.radius) || !(m.radius > 0.0)) continue;
    const bool still = m.is_static || (std::isfinite(m.speed) && std::abs(m.speed) <= config.static_speed_mps);
    if (!still) continue;
    const Vec2 c = pose.toLocal(m.center);
    if (c.norm() - m.radius <= reach) discs_.push_back(Circle{c, m.radius});
  }
}

std::vector<float> StaticScene::flatSegments(const Pose2& robot_pose) const {
  std::vector<float> out;
  out.reserve(4 * walls_.size());
  for (const Segment& s : walls_) {
    const Vec2 a = robot_pose.toWorld(s.a), b = robot_pose.toWorld(s.b);
    for (double x : {a.x(), a.y(), b.x(), b.y()}) out.push_back(static_cast<float>(x));
  }
  return out;
}

std::vector<float> StaticScene::flatDiscs(const Pose2& robot_pose) const {
  std::vector<float> out;
  out.reserve(3 * discs_.size());
  for (const Circle& c : discs_) {
    const Vec2 p = robot_pose.toWorld(c.center);
    for (double x : {p.x(), p.y(), c.radius}) out.push_back(static_cast<float>(x));
  }
  return out;
}

double StaticScene::clearance(const Vec2& q) const {
  double best = kInf;
  for (const Segment& s : walls_) best = std::min(best, pointSegmentDistance(q, s) - robot_radius_);
  for (const Circle& c : discs_) best = std::min(best, (q - c.center).norm() - c.radius - robot_radius_);
  return best;
}

namespace {

// Walks the braking trajectory (file comment of static_safety.h) in steps of config.step_s, calling
// visit(t, position, speed) at each sample after the start; stops early when visit returns false.
template <typename Visit>
void walkBraking(const Twist2& current, const Twist2& u, const RobotLimits& limits, const StaticSafetyConfig& config,
                 Visit&& visit) {
  Twist2 vel = (std::isfinite(current.v) && std::isfinite(current.w)) ? limits.clipToFeasible(current) : Twist2{};
  // The pose carries its heading as a cosine and sine: one sine and cosine per step instead of four (the escape
  // walks ~100 of these paths).
  HeadingPose pose;
  double t = 0.0;
  const double h = config.step_s;
  auto advance = [&](const Twist2& next, double dt) {
    pose.advance(unicycleStep(0.5 * (vel.v + next.v), 0.5 * (vel.w + next.w), dt));
    vel = next;
    t += dt;
    return visit(t, pose.position, vel.v);
  };
  // 1. reaction: the current velocity is held.
  for (double left = config.latency_s; left > 1e-9;) {
    const double dt = std::min(h, left);
    left -= dt;
    if (!advance(vel, dt)) return;
  }
  // 2. the command, for one control period, within the acceleration limits.
  for (double left = limits.dt; left > 1e-9;) {
    const double dt = std::min(h, left);
    left -= dt;
    if (!advance(applyAccelerationLimits(vel, u, limits, dt), dt)) return;
  }
  // 3. braking at the deceleration the base achieves, commanded one period at a time as the fallback does.
  RobotLimits braking = limits;
  braking.a_v *= config.braking_fraction;
  braking.a_w *= config.braking_fraction;
  while (vel.v > 1e-9 && t < kMaxBrakingS) {
    const Twist2 target = decelerationCommand(vel, braking);
    for (double left = limits.dt; left > 1e-9 && vel.v > 1e-9;) {
      const double dt = std::min(h, left);
      left -= dt;
      if (!advance(applyAccelerationLimits(vel, target, braking, dt), dt)) return;
    }
  }
}

}  // namespace

std::vector<BrakingSample> brakingSamples(const Twist2& current, const Twist2& u, const RobotLimits& limits,
                                          const StaticSafetyConfig& config) {
  std::vector<BrakingSample> out;
  if (!std::isfinite(u.v) || !std::isfinite(u.w)) return out;
  walkBraking(current, u, limits, config, [&](double t, const Vec2& q, double speed) {
    out.push_back({t, q, speed});
    return true;
  });
  return out;
}

BrakingPath brakingPath(const StaticScene& scene, const Twist2& current, const Twist2& u, const RobotLimits& limits,
                        const StaticSafetyConfig& config) {
  BrakingPath out;
  if (!std::isfinite(u.v) || !std::isfinite(u.w)) {
    out.safe = false;
    out.min_clearance_m = -kInf;
    return out;
  }
  out.min_clearance_m = scene.clearance(Vec2::Zero());
  if (!config.enabled || scene.empty()) return out;  // nothing static within reach: nothing to walk
  // Already within the margin: safe only when the robot never gets closer than it is.
  const double floor = std::min(config.margin_m, out.min_clearance_m - 1e-4);
  walkBraking(current, u, limits, config, [&](double, const Vec2& q, double) {
    out.min_clearance_m = std::min(out.min_clearance_m, scene.clearance(q));
    return true;
  });
  out.safe = out.min_clearance_m >= floor;
  return out;
}

Twist2 staticSafeCommand(const StaticScene& scene, const Twist2& current, const Twist2& u, const RobotLimits& limits,
                         const StaticSafetyConfig& config, int samples) {
  if (!config.enabled) return u;
  if (std::isfinite(u.v) && std::isfinite(u.w) && brakingPath(scene, current, u, limits, config).safe) return u;
  const Twist2 c = (std::isfinite(current.v) && std::isfinite(current.w)) ? limits.clipToFeasible(current) : Twist2{};
  std::vector<Twist2> candidates = makeDynamicWindow(c, limits).samples(std::max(1, samples), limits);
  candidates.push_back(decelerationCommand(c, limits));
  const Twist2 ref = (std::isfinite(u.v) && std::isfinite(u.w)) ? u : decelerationCommand(c, limits);
  Twist2 best_safe = decelerationCommand(c, limits), best_any = best_safe;
  double best_safe_dist = kInf, best_any_clearance = -kInf, best_any_speed = kInf;
  for (const Twist2& cand : candidates) {
    const BrakingPath p = brakingPath(scene, c, cand, limits, config);
    if (p.safe) {
      const double dv = (cand.v - ref.v) / limits.v_max, dw = (cand.w - ref.w) / limits.w_max;
      const double d = dv * dv + dw * dw;
      if (d < best_safe_dist - 1e-12) {
        best_safe_dist = d;
        best_safe = cand;
      }
    } else if (p.min_clearance_m > best_any_clearance + 1e-6 ||
               (p.min_clearance_m > best_any_clearance - 1e-6 && cand.v < best_any_speed)) {
      best_any_clearance = p.min_clearance_m;
      best_any_speed = cand.v;
      best_any = cand;
    }
  }
  return std::isfinite(best_safe_dist) ? best_safe : best_any;
}

}  // namespace dqn_dovs
