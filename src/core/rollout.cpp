#include "dqn_dovs/rollout.h"

#include <algorithm>

namespace dqn_dovs {

Rollout rollOut(const LocalScene& scene, const Twist2& u, double horizon_s, double step_s) {
  Rollout r;
  const double start_clearance = scene.currentClearance();
  bool start_inside = false;
  scene.clearance(Vec2::Zero(), 0.0, start_inside);
  const int n = static_cast<int>(std::ceil(horizon_s / step_s - 1e-9));
  for (int k = 1; k <= n; ++k) {
    const double t = std::min(horizon_s, k * step_s);
    const Pose2 p = integrateUnicycle(Pose2{}, u.v, u.w, t);
    bool collides = false;
    const double c = scene.clearance(p.position(), t, collides);
    r.min_clearance_m = std::min(r.min_clearance_m, c);
    if (collides && (!start_inside || c < start_clearance - 1e-3)) {
      r.collision_time_s = t;
      break;
    }
  }
  return r;
}


}  // namespace dqn_dovs
