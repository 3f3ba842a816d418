// Forward roll-outs of a constant robot velocity against the obstacles of an observation, each on its own
// constant (v, w) motion: first inflated contact and least clearance. Shared by S-DOVS (its time-to-goal
// heuristic and escape strategy) and the action shield (its last resort). ROS-free.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "dqn_dovs/geometry.h"
#include "dqn_dovs/types.h"

namespace dqn_dovs {

/// An obstacle in the robot frame at the decision instant, on its own constant (v, w) motion.
struct LocalObstacle {
  Vec2 p = Vec2::Zero();
  double heading = 0.0;
  double speed = 0.0;
  double turn_rate = 0.0;
  double radius = 0.0;

  Vec2 at(double t) const {
    if (speed <= 0.0) return p;
    if (std::abs(turn_rate) < 1e-6) return p + speed * t * Vec2(std::cos(heading), std::sin(heading));
    const double r = speed / turn_rate, h1 = heading + turn_rate * t;
    return p + r * Vec2(std::sin(h1) - std::sin(heading), std::cos(heading) - std::cos(h1));
  }
};

/// The observation seen from the robot: what the roll-outs check the robot's path against.
class LocalScene {
 public:
  LocalScene(const Observation& obs, double robot_radius, double safety_factor)
      : robot_radius_(robot_radius), safety_factor_(safety_factor) {
    const Pose2& pose = obs.robot_pose;
    for (const MovingObstacle& m : obs.obstacles) {
      // Non-finite tracks are the DOVS's business (it refuses them); the roll-outs just leave them out.
      if (!m.center.allFinite() || !std::isfinite(m.radius) || !std::isfinite(m.heading) ||
          !std::isfinite(m.speed) || !std::isfinite(m.turn_rate)) {
        continue;
      }
      LocalObstacle o;
      o.p = pose.toLocal(m.center);
      o.heading = normalizeAngle(m.heading - pose.theta);
      o.speed = m.is_static ? 0.0 : m.speed;
      o.turn_rate = m.is_static ? 0.0 : m.turn_rate;
      if (o.speed < 0.0) {  // a backward speed is the same motion heading the other way
        o.speed = -o.speed;
        o.heading = normalizeAngle(o.heading + kPi);
      }
      o.radius = std::max(m.radius, 0.0);
      obstacles_.push_back(o);
    }
    for (const Segment& s : obs.segments) {
      if (!s.a.allFinite() || !s.b.allFinite()) continue;
      walls_.push_back(Segment{pose.toLocal(s.a), pose.toLocal(s.b)});
    }
  }

  /// Surface-to-surface clearance (true radii) of the robot at q at time t; `collides` is set when q is inside
  /// an inflated obstacle or wall band.
  double clearance(const Vec2& q, double t, bool& collides) const {
    return clearanceWith(q, [&](size_t j) { return obstacles_[j].at(t); }, collides);
  }

  /// clearance() with the obstacle centres given by at(j) (j indexes obstacles()), e.g. precomputed ones.
  template <typename At>
  double clearanceWith(const Vec2& q, At&& at, bool& collides) const {
    double best = std::numeric_limits<double>::infinity();
    collides = false;
    for (size_t j = 0; j < obstacles_.size(); ++j) {
      const LocalObstacle& o = obstacles_[j];
      const double dist = (q - at(j)).norm();
      best = std::min(best, dist - o.radius - robot_radius_);
      if (dist < (o.radius + robot_radius_) * safety_factor_) collides = true;
    }
    for (const Segment& s : walls_) {
      const double dist = pointSegmentDistance(q, s);
      best = std::min(best, dist - robot_radius_);
      if (dist < robot_radius_ * safety_factor_) collides = true;
    }
    return best;
  }

  /// True when the robot at its current position is already inside an inflation; roll-outs then only count
  /// contacts that get worse, so that moving away is never judged a collision.
  double currentClearance() const {
    bool unused = false;
    return clearance(Vec2::Zero(), 0.0, unused);
  }

  const std::vector<LocalObstacle>& obstacles() const { return obstacles_; }

 private:
  double robot_radius_;
  double safety_factor_;
  std::vector<LocalObstacle> obstacles_;
  std::vector<Segment> walls_;
};

/// Result of holding one velocity from the robot's current pose.
struct Rollout {
  double collision_time_s = std::numeric_limits<double>::infinity();
  double min_clearance_m = std::numeric_limits<double>::infinity();
};

/// Holds (v, w) for up to horizon_s; stops at the first inflated contact. When the robot starts inside an
/// inflation, a contact counts only once the clearance drops below the starting one.
Rollout rollOut(const LocalScene& scene, const Twist2& u, double horizon_s, double step_s);

/// The contact that ends a roll-out: entering an obstacle's inflation (safety factor) or touching it.
enum class Contact { kInflated, kTrue };

/// Holds u1 for switch_s, then u2 up to horizon_s, and stops at the first `contact` (starting in contact, only
/// once the clearance gets worse). rollOut is this with u2 = u1 and kInflated.
Rollout rollOutSwitching(const LocalScene& scene, const Twist2& u1, double switch_s, const Twist2& u2, double horizon_s,
                         double step_s, Contact contact);

/// A LocalScene whose obstacles are placed once at the roll-out times t_k = min(horizon, k step), k = 1..steps,
/// for many roll-outs over the same times (the escape's search). Its roll-outs equal the LocalScene ones.
class SampledScene {
 public:
  SampledScene(const LocalScene& scene, double horizon_s, double step_s);

  /// rollOutSwitching on the sampled times. A roll-out whose least clearance falls below give_up_below_m is
  /// abandoned there (`abandoned` set; its figures are then only bounds): for searches that need no more.
  Rollout rollOutSwitching(const Twist2& u1, double switch_s, const Twist2& u2, Contact contact,
                           double give_up_below_m, bool& abandoned) const;

 private:
  const LocalScene& scene_;
  double horizon_s_, step_s_;
  int steps_;
  double start_clearance_m_;   // the robot's clearance where it stands, once for every roll-out
  bool start_inflated_ = false;
  std::vector<Vec2> centres_;  // steps x obstacles, row k - 1 at t_k
};

}  // namespace dqn_dovs
