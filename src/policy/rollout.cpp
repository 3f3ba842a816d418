#include "dqn_dovs/policy/rollout.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace dqn_dovs {

Rollout rollOut(const LocalScene& scene, const Twist2& u, double horizon_s, double step_s) {
  return rollOutSwitching(scene, u, horizon_s, u, horizon_s, step_s, Contact::kInflated);
}

namespace {

// The robot's poses at the roll-out times t_k = min(horizon, k step): u1 from the origin up to switch_s, then u2.
// Consecutive samples of one velocity are a fixed chord apart in the frame of the earlier one, so each sample
// composes that chord (two multiplications and additions) instead of integrating the arc from its start (four
// sines and cosines): the search of the escape rolls out about a thousand paths per decision.
class PathSampler {
 public:
  PathSampler(const Twist2& u1, double switch_s, const Twist2& u2, double step_s)
      : u1_(u1),
        u2_(u2),
        switch_s_(switch_s),
        step_s_(step_s),
        at_switch_(integrateUnicycle(Pose2{}, u1.v, u1.w, switch_s)) {}

  /// The position at the next sample time t (called for k = 1, 2, ... in order); `regular` says that t is
  /// exactly one step after the previous sample.
  Vec2 next(double t, bool regular) {
    const int phase = t <= switch_s_ ? 1 : 2;
    if (regular && phase == phase_) {
      pose_.advance(step_);
    } else {
      const Twist2& u = phase == 1 ? u1_ : u2_;
      pose_ = HeadingPose(phase == 1 ? integrateUnicycle(Pose2{}, u.v, u.w, t)
                                     : integrateUnicycle(at_switch_, u.v, u.w, t - switch_s_));
      if (phase != phase_) step_ = unicycleStep(u.v, u.w, step_s_);
      phase_ = phase;
    }
    return pose_.position;
  }

 private:
  Twist2 u1_, u2_;
  double switch_s_, step_s_;
  Pose2 at_switch_;
  int phase_ = 0;
  HeadingPose pose_;
  UnicycleStep step_;  // one step of the current phase's velocity
};

// The roll-out loop shared by LocalScene and SampledScene: clearance_at(q, k, t, inflated) is the scene's
// clearance of the robot at q at the k-th sampled time t.
// start_clearance / start_inflated: the scene's clearance of the robot where it stands (t = 0).
template <typename ClearanceAt>
Rollout rollOutLoop(double start_clearance, bool start_inflated, const Twist2& u1, double switch_s, const Twist2& u2,
                    double horizon_s, double step_s, Contact contact, double give_up_below_m, bool& abandoned,
                    ClearanceAt&& clearance_at) {
  Rollout r;
  abandoned = false;
  const bool start_inside = contact == Contact::kInflated ? start_inflated : start_clearance < 0.0;
  PathSampler path(u1, switch_s, u2, step_s);
  const int n = static_cast<int>(std::ceil(horizon_s / step_s - 1e-9));
  for (int k = 1; k <= n; ++k) {
    const bool regular = k * step_s <= horizon_s;
    const double t = regular ? k * step_s : horizon_s;
    const Vec2 q = path.next(t, regular);
    bool inflated = false;
    const double c = clearance_at(q, k, t, inflated);
    r.min_clearance_m = std::min(r.min_clearance_m, c);
    const bool touches = contact == Contact::kInflated ? inflated : c < 0.0;
    if (touches && (!start_inside || c < start_clearance - 1e-3)) {
      r.collision_time_s = t;
      break;
    }
    if (r.min_clearance_m < give_up_below_m) {
      abandoned = true;
      break;
    }
  }
  return r;
}

}  // namespace

Rollout rollOutSwitching(const LocalScene& scene, const Twist2& u1, double switch_s, const Twist2& u2, double horizon_s,
                         double step_s, Contact contact) {
  bool abandoned = false, start_inflated = false;
  const double start_clearance = scene.clearance(Vec2::Zero(), 0.0, start_inflated);
  return rollOutLoop(start_clearance, start_inflated, u1, switch_s, u2, horizon_s, step_s, contact,
                     -std::numeric_limits<double>::infinity(), abandoned,
                     [&](const Vec2& q, int, double t, bool& inflated) { return scene.clearance(q, t, inflated); });
}

SampledScene::SampledScene(const LocalScene& scene, double horizon_s, double step_s)
    : scene_(scene),
      horizon_s_(horizon_s),
      step_s_(step_s),
      steps_(static_cast<int>(std::ceil(horizon_s / step_s - 1e-9))),
      start_clearance_m_(scene.clearance(Vec2::Zero(), 0.0, start_inflated_)) {
  const std::vector<LocalObstacle>& obstacles = scene.obstacles();
  const double inflation = std::max(scene.safety_factor_, 1.0);
  const double wall_inflated = scene.robot_radius_ * scene.safety_factor_;
  row_size_ = obstacles.size() + scene.walls_.size();
  items_.reserve(static_cast<size_t>(steps_) * row_size_);
  for (int k = 1; k <= steps_; ++k) {
    const double t = std::min(horizon_s, k * step_s);
    const auto row = items_.end() - items_.begin();
    for (size_t j = 0; j < obstacles.size(); ++j) {
      Item item;
      item.centre = obstacles[j].at(t);
      item.reach = scene.reach_[j];
      item.inflated2 = scene.inflated2_[j];
      item.key = item.centre.norm() - item.reach * inflation;
      items_.push_back(item);
    }
    for (size_t w = 0; w < scene.walls_.size(); ++w) {
      Item item;
      item.wall = static_cast<int>(w);
      item.reach = scene.robot_radius_;
      item.inflated2 = wall_inflated * wall_inflated;
      item.key = std::sqrt(scene.walls_[w].distance2(Vec2::Zero())) - item.reach * inflation;
      items_.push_back(item);
    }
    std::sort(items_.begin() + row, items_.end(), [](const Item& a, const Item& b) { return a.key < b.key; });
  }
}

double SampledScene::clearanceAt(const Vec2& q, int k, bool& inflated) const {
  const Item* row = items_.data() + static_cast<size_t>(k - 1) * row_size_;
  const double from_start = q.norm();
  double best = std::numeric_limits<double>::infinity();
  inflated = false;
  for (size_t i = 0; i < row_size_; ++i) {
    const Item& item = row[i];
    // Every item from here on is at least `bound` from q beyond its inflated contact distance.
    const double bound = item.key - from_start;
    if (bound >= 0.0 && bound >= best) break;
    const double d2 = item.wall < 0 ? (q - item.centre).squaredNorm() : scene_.walls_[item.wall].distance2(q);
    if (d2 < item.inflated2) inflated = true;
    // As LocalScene::clearanceWith: a square root only where it can lower the minimum.
    const double lower = best + item.reach;
    if (lower > 0.0 && d2 < lower * lower) best = std::min(best, std::sqrt(d2) - item.reach);
  }
  return best;
}

Rollout SampledScene::rollOutSwitching(const Twist2& u1, double switch_s, const Twist2& u2, Contact contact,
                                       double give_up_below_m, bool& abandoned) const {
  return rollOutLoop(start_clearance_m_, start_inflated_, u1, switch_s, u2, horizon_s_, step_s_, contact,
                     give_up_below_m, abandoned,
                     [&](const Vec2& q, int k, double, bool& inflated) { return clearanceAt(q, k, inflated); });
}

}  // namespace dqn_dovs
