#include "dqn_dovs/rollout.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace dqn_dovs {

Rollout rollOut(const LocalScene& scene, const Twist2& u, double horizon_s, double step_s) {
  return rollOutSwitching(scene, u, horizon_s, u, horizon_s, step_s, Contact::kInflated);
}

namespace {

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
  const Pose2 at_switch = integrateUnicycle(Pose2{}, u1.v, u1.w, switch_s);
  const int n = static_cast<int>(std::ceil(horizon_s / step_s - 1e-9));
  for (int k = 1; k <= n; ++k) {
    const double t = std::min(horizon_s, k * step_s);
    const Pose2 p = t <= switch_s ? integrateUnicycle(Pose2{}, u1.v, u1.w, t)
                                  : integrateUnicycle(at_switch, u2.v, u2.w, t - switch_s);
    bool inflated = false;
    const double c = clearance_at(p.position(), k, t, inflated);
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
                     [&](const Vec2& q, int, double t, bool& inflated) {
                       return scene.clearance(q, t, inflated);
                     });
}

SampledScene::SampledScene(const LocalScene& scene, double horizon_s, double step_s)
    : scene_(scene), horizon_s_(horizon_s), step_s_(step_s),
      steps_(static_cast<int>(std::ceil(horizon_s / step_s - 1e-9))),
      start_clearance_m_(scene.clearance(Vec2::Zero(), 0.0, start_inflated_)) {
  const std::vector<LocalObstacle>& obstacles = scene.obstacles();
  centres_.reserve(static_cast<size_t>(steps_) * obstacles.size());
  for (int k = 1; k <= steps_; ++k) {
    const double t = std::min(horizon_s, k * step_s);
    for (const LocalObstacle& o : obstacles) centres_.push_back(o.at(t));
  }
}

Rollout SampledScene::rollOutSwitching(const Twist2& u1, double switch_s, const Twist2& u2, Contact contact,
                                       double give_up_below_m, bool& abandoned) const {
  const size_t m = scene_.obstacles().size();
  return rollOutLoop(start_clearance_m_, start_inflated_, u1, switch_s, u2, horizon_s_, step_s_, contact,
                     give_up_below_m, abandoned,
                     [&](const Vec2& q, int k, double, bool& inflated) {
                       const Vec2* row = centres_.data() + static_cast<size_t>(k - 1) * m;
                       return scene_.clearanceWith(q, [row](size_t j) { return row[j]; }, inflated);
                     });
}

}  // namespace dqn_dovs
