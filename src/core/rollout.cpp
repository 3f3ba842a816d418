#include "dqn_dovs/rollout.h"

#include <algorithm>

namespace dqn_dovs {

Rollout rollOut(const LocalScene& scene, const Twist2& u, double horizon_s, double step_s) {
  return rollOutSwitching(scene, u, horizon_s, u, horizon_s, step_s, Contact::kInflated);
}

Rollout rollOutSwitching(const LocalScene& scene, const Twist2& u1, double switch_s, const Twist2& u2, double horizon_s,
                         double step_s, Contact contact) {
  Rollout r;
  const double start_clearance = scene.currentClearance();
  bool start_inflated = false;
  scene.clearance(Vec2::Zero(), 0.0, start_inflated);
  const bool start_inside = contact == Contact::kInflated ? start_inflated : start_clearance < 0.0;
  const Pose2 at_switch = integrateUnicycle(Pose2{}, u1.v, u1.w, switch_s);
  const int n = static_cast<int>(std::ceil(horizon_s / step_s - 1e-9));
  for (int k = 1; k <= n; ++k) {
    const double t = std::min(horizon_s, k * step_s);
    const Pose2 p = t <= switch_s ? integrateUnicycle(Pose2{}, u1.v, u1.w, t)
                                  : integrateUnicycle(at_switch, u2.v, u2.w, t - switch_s);
    bool inflated = false;
    const double c = scene.clearance(p.position(), t, inflated);
    r.min_clearance_m = std::min(r.min_clearance_m, c);
    const bool touches = contact == Contact::kInflated ? inflated : c < 0.0;
    if (touches && (!start_inside || c < start_clearance - 1e-3)) {
      r.collision_time_s = t;
      break;
    }
  }
  return r;
}


}  // namespace dqn_dovs
