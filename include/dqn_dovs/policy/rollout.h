// Forward roll-outs of a constant robot velocity against the obstacles of an observation, each on its own
// constant (v, w) motion: first inflated contact and least clearance. Shared by S-DOVS (its time-to-goal
// heuristic and escape strategy) and the action shield (its last resort). ROS-free.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "dqn_dovs/common/geometry.h"
#include "dqn_dovs/common/types.h"

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
      if (!m.center.allFinite() || !std::isfinite(m.radius) || !std::isfinite(m.heading) || !std::isfinite(m.speed) ||
          !std::isfinite(m.turn_rate)) {
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
      reach_.push_back(o.radius + robot_radius_);
      const double inflated = (o.radius + robot_radius_) * safety_factor_;
      inflated2_.push_back(inflated * inflated);
    }
    for (const Segment& s : obs.segments) {
      if (!s.a.allFinite() || !s.b.allFinite()) continue;
      Wall w;
      w.a = pose.toLocal(s.a);
      w.e = pose.toLocal(s.b) - w.a;
      const double l2 = w.e.squaredNorm();
      w.inv_l2 = l2 < 1e-18 ? 0.0 : 1.0 / l2;  // a point: its end a
      walls_.push_back(w);
    }
  }

  /// Surface-to-surface clearance (true radii) of the robot at q at time t; `collides` is set when q is inside
  /// an inflated obstacle or wall band.
  double clearance(const Vec2& q, double t, bool& collides) const {
    return clearanceWith(
        q, [&](size_t j) { return obstacles_[j].at(t); }, collides);
  }

  /// clearance() with the obstacle centres given by at(j) (j indexes obstacles()), e.g. precomputed ones.
  /// Distances are compared squared; a square root is taken only for an item that can lower the minimum.
  template <typename At>
  double clearanceWith(const Vec2& q, At&& at, bool& collides) const {
    double best = std::numeric_limits<double>::infinity();
    collides = false;
    auto consider = [&](double d2, double reach, double inflated2) {
      if (d2 < inflated2) collides = true;
      // sqrt(d2) - reach < best needs best + reach > 0 and d2 < (best + reach)^2.
      const double bound = best + reach;
      if (bound > 0.0 && d2 < bound * bound) best = std::min(best, std::sqrt(d2) - reach);
    };
    for (size_t j = 0; j < obstacles_.size(); ++j) {
      consider((q - at(j)).squaredNorm(), reach_[j], inflated2_[j]);
    }
    const double wall_inflated = robot_radius_ * safety_factor_;
    for (const Wall& w : walls_) consider(w.distance2(q), robot_radius_, wall_inflated * wall_inflated);
    return best;
  }

  /// True when the robot at its current position is already inside an inflation; roll-outs then only count
  /// contacts that get worse, so that moving away is never judged a collision.
  double currentClearance_m() const {
    bool unused = false;
    return clearance(Vec2::Zero(), 0.0, unused);
  }

  const std::vector<LocalObstacle>& obstacles() const { return obstacles_; }

 private:
  double robot_radius_;
  double safety_factor_;
  std::vector<LocalObstacle> obstacles_;
  std::vector<double> reach_;      // per obstacle: its radius + the robot's (contact distance)
  std::vector<double> inflated2_;  // per obstacle: the squared inflated contact distance
  friend class SampledScene;
  struct Wall {
    Vec2 a = Vec2::Zero(), e = Vec2::Zero();  // from end a, e = b - a
    double inv_l2 = 0.0;                      // 1 / |e|^2 (0 for a point)
    /// Squared distance from q (closestPointOnSegment with the direction and inverse length kept).
    double distance2(const Vec2& q) const {
      const Vec2 d = q - a;
      const double t = std::clamp(d.dot(e) * inv_l2, 0.0, 1.0);
      return (d - t * e).squaredNorm();
    }
  };
  std::vector<Wall> walls_;
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
  Rollout rollOutSwitching(const Twist2& u1, double switch_s, const Twist2& u2, Contact contact, double give_up_below_m,
                           bool& abandoned) const;

 private:
  // An obstacle at one sampled time, or a wall. key = (distance from the robot's start) - (inflated contact
  // distance): from a point q the item is at least key - |q| beyond both its contact and its inflation, so a row
  // sorted by key can stop at the first item whose bound cannot lower the clearance nor inflate.
  struct Item {
    double key = 0.0;
    Vec2 centre = Vec2::Zero();  // obstacles: the centre at the row's time
    double reach = 0.0, inflated2 = 0.0;
    int wall = -1;  // >= 0: this wall of the scene instead of an obstacle
  };
  // LocalScene::clearance at the k-th sampled time (the same figures, fewer items looked at).
  double clearanceAt(const Vec2& q, int k, bool& inflated) const;

  const LocalScene& scene_;
  double horizon_s_, step_s_;
  int steps_;
  double start_clearance_m_;  // the robot's clearance where it stands, once for every roll-out
  bool start_inflated_ = false;
  size_t row_size_ = 0;      // obstacles + walls
  std::vector<Item> items_;  // steps x row_size_, row k - 1 at t_k, each row sorted by key
};

}  // namespace dqn_dovs
