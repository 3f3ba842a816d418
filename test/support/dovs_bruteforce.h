// Brute-force reference for the DOVS (shared by test_dovs_bruteforce and bench_dovs): random scenes, and the
// unsafe set found by rolling the robot and the obstacles forward in small time steps. The comparison it makes
// is defined in docs/dovs.md ("Brute-force comparison").
#pragma once

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "dqn_dovs/dovs/dovs.h"

namespace dqn_dovs::bruteforce {

/// How random scenes are drawn.
struct SceneOptions {
  int min_obstacles = 1;
  int max_obstacles = 15;
  double static_probability = 0.2;       ///< chance that an obstacle is static
  double random_pose_probability = 0.5;  ///< otherwise the robot is at the origin heading +x
  int max_extra_walls = 2;               ///< random wall segments inside the room besides its 4 walls
  bool room_walls = true;                ///< the room's 4 walls at x, y = +-4 m
};

inline double uniform(std::mt19937_64& rng, double lo, double hi) {
  return std::uniform_real_distribution<double>(lo, hi)(rng);
}

/// A random scene: robot inside an 8 x 8 m room, obstacles of radius 0.2-0.4 m with random (v, w) or static,
/// random walls. Every obstacle and wall starts outside its inflation around the robot, so the builder's
/// in-contact adjustment never applies and both sides use the same radii.
inline Observation randomScene(std::mt19937_64& rng, const DovsBuilder& builder, const SceneOptions& opt) {
  Observation obs;
  std::vector<Segment> walls;
  if (opt.room_walls) {
    walls.push_back({{-4, -4}, {4, -4}});
    walls.push_back({{4, -4}, {4, 4}});
    walls.push_back({{4, 4}, {-4, 4}});
    walls.push_back({{-4, 4}, {-4, -4}});
  }
  const int extra = std::uniform_int_distribution<int>(0, opt.max_extra_walls)(rng);
  for (int i = 0; i < extra; ++i) {
    const Vec2 a(uniform(rng, -3.5, 3.5), uniform(rng, -3.5, 3.5));
    const double ang = uniform(rng, -kPi, kPi), len = uniform(rng, 0.5, 3.0);
    walls.push_back({a, a + len * Vec2(std::cos(ang), std::sin(ang))});
  }
  const double wall_hw = builder.wallHalfWidth_m();
  for (int attempt = 0;; ++attempt) {
    if (uniform(rng, 0.0, 1.0) < opt.random_pose_probability || attempt > 0) {
      obs.robot_pose = {uniform(rng, -3.5, 3.5), uniform(rng, -3.5, 3.5), uniform(rng, -kPi, kPi)};
    } else {
      obs.robot_pose = {0.0, 0.0, 0.0};
    }
    bool ok = true;
    for (const Segment& s : walls) ok = ok && pointSegmentDistance(obs.robot_pose.position(), s) > wall_hw + 0.02;
    if (ok) break;
  }
  obs.segments = walls;
  const int n = std::uniform_int_distribution<int>(opt.min_obstacles, opt.max_obstacles)(rng);
  while (static_cast<int>(obs.obstacles.size()) < n) {
    MovingObstacle o;
    o.radius = uniform(rng, 0.2, 0.4);
    // Mostly near the robot so that the obstacles matter.
    o.center = obs.robot_pose.position() + Vec2(uniform(rng, -3.5, 3.5), uniform(rng, -3.5, 3.5));
    if ((o.center - obs.robot_pose.position()).norm() <= builder.enlargedRadius(o.radius) + 0.02) continue;
    o.heading = uniform(rng, -kPi, kPi);
    if (uniform(rng, 0.0, 1.0) < opt.static_probability) {
      o.is_static = true;
    } else {
      o.speed = uniform(rng, 0.2, 1.2);
      const double kind = uniform(rng, 0.0, 1.0);
      o.turn_rate = kind < 0.1 ? 0.0 : kind < 0.2 ? uniform(rng, -2.0, 2.0) : uniform(rng, -0.52, 0.52);
    }
    obs.obstacles.push_back(o);
  }
  obs.robot_twist = {uniform(rng, 0.0, 0.7), 0.0};
  obs.goal = {uniform(rng, -3.5, 3.5), uniform(rng, -3.5, 3.5)};
  return obs;
}

/// Removes static obstacles and walls (for the moving-obstacle-only comparison).
inline Observation dynamicOnly(const Observation& obs, const DovsBuilder& builder) {
  Observation out = obs;
  out.segments.clear();
  out.obstacles.clear();
  for (const MovingObstacle& o : obs.obstacles) {
    if (!(o.is_static || std::abs(o.speed) <= builder.config().static_speed_threshold_mps)) out.obstacles.push_back(o);
  }
  return out;
}

/// Brute-force unsafe test of one scene: robot and obstacles rolled forward with time step dt_s (a moving
/// obstacle's radius growing at DovsConfig::prediction_growth_mps); static
/// obstacles and walls judged by the same braking rule as the DOVS, with the contact found by stepping ds_m
/// along the path.
class Reference {
 public:
  Reference(const DovsBuilder& builder, const Observation& obs, double dt_s = 0.01, double ds_m = 0.002)
      : b_(builder), dt_(dt_s), ds_(ds_m), growth_(builder.config().prediction_growth_mps) {
    const DovsConfig& cfg = builder.config();
    steps_ = static_cast<int>(std::ceil(cfg.time_horizon_s / dt_s - 1e-9));
    dt_ = cfg.time_horizon_s / steps_;
    const Pose2& pose = obs.robot_pose;
    for (const MovingObstacle& o : obs.obstacles) {
      const Vec2 c = pose.toLocal(o.center);
      if (c.norm() > cfg.obstacle_range_m) continue;
      const double r = builder.enlargedRadius(o.radius);
      if (o.is_static || std::abs(o.speed) <= cfg.static_speed_threshold_mps) {
        static_centers_.push_back(c);
        static_radii_.push_back(r);
        continue;
      }
      Pose2 p{c.x(), c.y(), normalizeAngle(o.heading - pose.theta)};
      std::vector<Vec2> track;
      track.reserve(static_cast<size_t>(steps_ + 1));
      for (int j = 0; j <= steps_; ++j) track.push_back(integrateUnicycle(p, o.speed, o.turn_rate, j * dt_).position());
      tracks_.push_back(std::move(track));
      radii_.push_back(r);
      // Longest relative displacement within one step: lets most steps be skipped with one squared norm.
      const double reach = r + growth_ * cfg.time_horizon_s + (std::abs(o.speed) + builder.limits().v_max) * dt_ + 1e-9;
      reach_sq_.push_back(reach * reach);
    }
    for (const Segment& s : obs.segments) {
      const Segment l{pose.toLocal(s.a), pose.toLocal(s.b)};
      if (pointSegmentDistance(Vec2::Zero(), l) <= cfg.obstacle_range_m) walls_.push_back(l);
    }
  }

  /// True when holding t collides with a moving obstacle within the horizon.
  bool dynamicUnsafe(const Twist2& t) const {
    if (tracks_.empty()) return false;
    Vec2 prev_robot = Vec2::Zero();
    for (int j = 1; j <= steps_; ++j) {
      const Vec2 robot = integrateUnicycle(Pose2{}, t.v, t.w, j * dt_).position();
      for (size_t k = 0; k < tracks_.size(); ++k) {
        // Closest approach of the relative motion, linear within the step.
        const Vec2 r1 = tracks_[k][static_cast<size_t>(j)] - robot;
        if (r1.squaredNorm() > reach_sq_[k]) continue;
        const Vec2 r0 = tracks_[k][static_cast<size_t>(j - 1)] - prev_robot;
        // A growing prediction counts with its radius at the start of the step: never more than the model's.
        const double radius = radii_[k] + growth_ * (j - 1) * dt_;
        if (pointSegmentDistance(Vec2::Zero(), Segment{r0, r1}) < radius) return true;
      }
      prev_robot = robot;
    }
    return false;
  }

  /// True when t reaches a static obstacle or wall closer than its braking distance.
  bool staticUnsafe(const Twist2& t) const {
    if (t.v <= 0.0) return false;
    const DovsConfig& cfg = b_.config();
    const double brake = t.v * t.v / (2.0 * b_.limits().a_v) + t.v * cfg.static_reaction_time_s + cfg.static_margin_m;
    const double k = t.w / t.v;
    const double hw = b_.wallHalfWidth_m();
    // Only shapes that the path can reach before the braking distance.
    std::vector<size_t> discs, walls;
    for (size_t i = 0; i < static_centers_.size(); ++i)
      if (static_centers_[i].norm() < brake + static_radii_[i]) discs.push_back(i);
    for (size_t i = 0; i < walls_.size(); ++i)
      if (pointSegmentDistance(Vec2::Zero(), walls_[i]) < brake + hw) walls.push_back(i);
    if (discs.empty() && walls.empty()) return false;
    for (double s = 0.0; s < brake; s += ds_) {
      const Vec2 p = std::abs(k) < 1e-12 ? Vec2(s, 0.0) : Vec2(std::sin(k * s) / k, (1.0 - std::cos(k * s)) / k);
      for (size_t i : discs)
        if ((p - static_centers_[i]).norm() < static_radii_[i]) return true;
      for (size_t i : walls)
        if (pointSegmentDistance(p, walls_[i]) < hw) return true;
    }
    return false;
  }

  bool unsafe(const Twist2& t) const { return staticUnsafe(t) || dynamicUnsafe(t); }

 private:
  const DovsBuilder& b_;
  double dt_, ds_;
  double growth_;  // DovsConfig::prediction_growth_mps
  int steps_ = 0;
  std::vector<std::vector<Vec2>> tracks_;
  std::vector<double> radii_;
  std::vector<double> reach_sq_;
  std::vector<Vec2> static_centers_;
  std::vector<double> static_radii_;
  std::vector<Segment> walls_;
};

/// Totals of a DOVS-versus-brute-force comparison on a lattice of velocities.
struct Tally {
  long feasible = 0;            ///< feasible lattice points
  long reference_unsafe = 0;    ///< brute-force unsafe points
  long dovs_unsafe = 0;         ///< points the DOVS marks unsafe
  long missed = 0;              ///< brute-force unsafe, DOVS free, no brute-force-free point within one grid cell
  long missed_near_border = 0;  ///< brute-force unsafe, DOVS free, within one grid cell of a brute-force-free point

  void add(const Tally& o) {
    feasible += o.feasible;
    reference_unsafe += o.reference_unsafe;
    dovs_unsafe += o.dovs_unsafe;
    missed += o.missed;
    missed_near_border += o.missed_near_border;
  }
  double missedRate() const { return reference_unsafe > 0 ? static_cast<double>(missed) / reference_unsafe : 0.0; }
  double excessRatio() const {
    return reference_unsafe > 0 ? static_cast<double>(dovs_unsafe) / reference_unsafe - 1.0 : 0.0;
  }
};

/// Compares dovs with `unsafe` on an nv x nw lattice of cell centres over [0, v_max] x [-w_max, w_max].
template <typename UnsafeFn>
Tally compareOnLattice(const VelocitySpace& dovs, UnsafeFn unsafe, int nv, int nw) {
  const RobotLimits& l = dovs.limits();
  const int grid = dovs.gridSize();
  std::vector<signed char> ref(static_cast<size_t>(nv * nw), -1);  // -1 infeasible, 0 free, 1 unsafe
  std::vector<signed char> mine(static_cast<size_t>(nv * nw), 0);
  Tally t;
  auto at = [&](int i, int j) { return Twist2{l.v_max * (i + 0.5) / nv, l.w_max * (2.0 * (j + 0.5) / nw - 1.0)}; };
  for (int i = 0; i < nv; ++i) {
    for (int j = 0; j < nw; ++j) {
      const Twist2 tw = at(i, j);
      if (!l.feasible(tw, 0.0)) continue;
      const size_t idx = static_cast<size_t>(i * nw + j);
      ref[idx] = unsafe(tw) ? 1 : 0;
      mine[idx] = dovs.isFree(tw) ? 0 : 1;
      ++t.feasible;
      t.reference_unsafe += ref[idx];
      t.dovs_unsafe += mine[idx];
    }
  }
  // One grid cell of the network grid, in lattice steps.
  const int di = static_cast<int>(std::ceil(static_cast<double>(nv) / grid - 1e-9));
  const int dj = static_cast<int>(std::ceil(static_cast<double>(nw) / grid - 1e-9));
  for (int i = 0; i < nv; ++i) {
    for (int j = 0; j < nw; ++j) {
      const size_t idx = static_cast<size_t>(i * nw + j);
      if (ref[idx] != 1 || mine[idx] != 0) continue;
      bool near_free = false;
      for (int a = std::max(0, i - di); a <= std::min(nv - 1, i + di) && !near_free; ++a)
        for (int b = std::max(0, j - dj); b <= std::min(nw - 1, j + dj) && !near_free; ++b)
          near_free = ref[static_cast<size_t>(a * nw + b)] == 0;
      if (near_free)
        ++t.missed_near_border;
      else
        ++t.missed;
    }
  }
  return t;
}

}  // namespace dqn_dovs::bruteforce
