// The action shield: which of the 8 actions the network may choose among, given the DOVS.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>

#include "dqn_dovs/dovs/actions.h"
#include "dqn_dovs/dovs/dovs.h"
#include "dqn_dovs/planning/planner.h"
#include "dqn_dovs/policy/action_shield.h"
#include "dqn_dovs/policy/rollout.h"
#include "obstacle_test_helpers.h"

namespace dqn_dovs {
namespace {

using test::movingDisc;

struct Scene {
  Observation obs;
  VelocitySpace dovs;
  ActionSet actions;
};

Scene scene(const Twist2& twist, const Vec2& goal, std::vector<MovingObstacle> obstacles) {
  Scene s;
  s.obs.robot_twist = twist;
  s.obs.goal = goal;
  s.obs.obstacles = std::move(obstacles);
  const RobotLimits limits;
  s.dovs = buildDovs(s.obs, limits, DovsConfig{});
  s.actions = computeActions(twist, goal, limits);
  return s;
}

TEST(ActionShield, EmptySpaceKeepsEveryValidAction) {
  const Scene s = scene({0.3, 0.0}, {4.0, 0.0}, {});
  const ShieldedMask m = shieldActions(s.actions, s.dovs, s.obs, ActionShieldConfig{});
  EXPECT_EQ(m.level, ShieldLevel::kRobust);
  EXPECT_EQ(m.mask, s.actions.valid);
}

TEST(ActionShield, DisabledIsTheValidityMask) {
  const Scene s = scene({0.6, 0.0}, {4.0, 0.0}, {movingDisc(0.9, 0.0)});
  ActionShieldConfig off;
  off.enabled = false;
  const ShieldedMask m = shieldActions(s.actions, s.dovs, s.obs, off);
  EXPECT_EQ(m.level, ShieldLevel::kDisabled);
  EXPECT_EQ(m.mask, s.actions.valid);
}

TEST(ActionShield, SpeedingTowardAStaticObstacleIsMasked) {
  // 0.5 m/s with a static disc 0.9 m ahead: faster is unsafe (cannot brake in time), slowing down is safe.
  const Scene s = scene({0.5, 0.0}, {4.0, 0.0}, {movingDisc(0.9, 0.0)});
  ASSERT_FALSE(s.dovs.isFree(s.actions.velocities[kActionDwTop]));
  ASSERT_TRUE(s.dovs.isFree(s.actions.velocities[kActionDwBottom]));
  const ShieldedMask m = shieldActions(s.actions, s.dovs, s.obs, ActionShieldConfig{});
  EXPECT_NE(m.level, ShieldLevel::kLatest);
  EXPECT_FALSE(m.mask[kActionDwTop]);
  EXPECT_TRUE(m.mask[kActionDwBottom]);
}

TEST(ActionShield, NothingSafeKeepsTheActionsThatCollideLatest) {
  // A disc coming head-on at 1 m/s, touching distance: every velocity of the window is in its DOV.
  const Scene s = scene({0.3, 0.0}, {4.0, 0.0}, {movingDisc(0.9, 0.0, kPi, 1.0)});
  bool any_free = false;
  for (size_t i = 0; i < s.actions.valid.size(); ++i) {
    any_free = any_free || (s.actions.valid[i] && s.dovs.isFree(s.actions.velocities[i]));
  }
  ASSERT_FALSE(any_free) << "the scene was meant to leave no free action";
  const ActionShieldConfig config;
  const ShieldedMask m = shieldActions(s.actions, s.dovs, s.obs, config);
  EXPECT_EQ(m.level, ShieldLevel::kLatest);
  ASSERT_GT(m.numAllowed(), 0);
  // Roll-outs of our own: every kept action collides no earlier than every dropped one (within the tolerance).
  const LocalScene local(s.obs, RobotLimits{}.radius, DovsConfig{}.safety_factor);
  double worst_kept = 1e9, best_dropped = -1.0;
  for (size_t i = 0; i < m.mask.size(); ++i) {
    if (!s.actions.valid[i]) continue;
    const double t = std::min(rollOut(local, s.actions.velocities[i], 3.0, 0.1).collision_time_s, 3.0);
    if (m.mask[i])
      worst_kept = std::min(worst_kept, t);
    else
      best_dropped = std::max(best_dropped, t);
  }
  EXPECT_GE(worst_kept, best_dropped - config.last_resort_tolerance_s - 1e-9);
}

TEST(ActionShield, RandomScenesKeepOnlySafeActionsAndNeverEmptyTheMask) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  const RobotLimits limits;
  int narrowed = 0, robust = 0, latest = 0;
  for (int k = 0; k < 400; ++k) {
    std::vector<MovingObstacle> obstacles;
    const int n = static_cast<int>(u01(rng) * 8);
    for (int i = 0; i < n; ++i) {
      const double r = 0.6 + 3.0 * u01(rng), a = (u01(rng) * 2 - 1) * kPi;
      obstacles.push_back(
          movingDisc(r * std::cos(a), r * std::sin(a), (u01(rng) * 2 - 1) * kPi, u01(rng) < 0.3 ? 0.0 : u01(rng)));
    }
    const double v = u01(rng) * limits.v_max;
    const double w = (u01(rng) * 2 - 1) * limits.w_max * (1 - v / limits.v_max);
    const Scene s = scene({v, w}, {(u01(rng) * 2 - 1) * 5, (u01(rng) * 2 - 1) * 5}, obstacles);
    const ShieldedMask m = shieldActions(s.actions, s.dovs, s.obs, ActionShieldConfig{});
    ASSERT_GT(m.numAllowed(), 0) << "scene " << k;
    for (size_t i = 0; i < m.mask.size(); ++i) {
      if (m.mask[i]) {
        ASSERT_TRUE(s.actions.valid[i]) << "scene " << k << ": shield allowed the invalid action " << i;
        if (m.level != ShieldLevel::kLatest && m.level != ShieldLevel::kStatic) {
          ASSERT_TRUE(s.dovs.isFree(s.actions.velocities[i])) << "scene " << k;
        }
        // The static braking rule binds whenever any valid action passes it.
        if (m.level != ShieldLevel::kStatic) {
          ASSERT_TRUE(m.static_safe[i]) << "scene " << k << ", action " << i;
        }
      } else if (s.actions.valid[i] && m.level == ShieldLevel::kFree) {
        EXPECT_FALSE(s.dovs.isFree(s.actions.velocities[i]) && m.static_safe[i])
            << "scene " << k << ": a free, statically safe action was masked";
      }
    }
    narrowed += m.mask != s.actions.valid ? 1 : 0;
    robust += m.level == ShieldLevel::kRobust ? 1 : 0;
    latest += m.level == ShieldLevel::kLatest ? 1 : 0;
  }
  // The scenes exercise every branch.
  EXPECT_GT(narrowed, 20);
  EXPECT_GT(robust, 100);
  EXPECT_GT(latest, 0);
}

TEST(ActionShield, BoxedInEscapePutsTheTrueContactOffAtLeastAsLongAsAnyAction) {
  const Scene s = scene({0.3, 0.0}, {4.0, 0.0}, {movingDisc(0.9, 0.0, kPi, 1.0), movingDisc(0.7, 0.6, -kPi / 2, 0.6)});
  ActionShieldConfig config;
  config.passive_escape = false;  // the latest-contact order (the passive order: test_static_safety.cpp)
  const ShieldedMask m = shieldActions(s.actions, s.dovs, s.obs, config);
  ASSERT_EQ(m.level, ShieldLevel::kLatest);
  ASSERT_TRUE(m.has_escape);
  const RobotLimits limits;
  EXPECT_TRUE(makeDynamicWindow(limits.clipToFeasible(s.obs.robot_twist), limits).contains(m.escape, limits, 1e-9));
  // The escape's time to touching, with its best follow-up, beats every corner of the window and "keep" with
  // theirs (the corners and the centre are lattice points of the escape's search).
  const LocalScene local(s.obs, limits.radius, DovsConfig{}.safety_factor);
  auto bestFollowUp = [&](const Twist2& u1) {
    double best = -1.0;
    for (int i = -1; i <= 1; ++i) {
      for (int j = -1; j <= 1; ++j) {
        const Twist2 u2{u1.v + i * limits.dv(), u1.w + j * limits.dw()};
        if (!limits.feasible(u2, 1e-9)) continue;
        best = std::max(
            best, std::min(3.0, rollOutSwitching(local, u1, limits.dt, u2, 3.0, 0.1, Contact::kTrue).collision_time_s));
      }
    }
    return best;
  };
  const double escape_ttc = bestFollowUp(m.escape);
  for (int a : {kActionDwTop, kActionDwBottom, kActionDwLeft, kActionDwRight, kActionKeep}) {
    EXPECT_GE(escape_ttc, bestFollowUp(s.actions.velocities[static_cast<size_t>(a)]) - 1e-9) << "action " << a;
  }
  ActionShieldConfig off = config;
  off.escape_enabled = false;
  EXPECT_FALSE(shieldActions(s.actions, s.dovs, s.obs, off).has_escape);
}

TEST(Rollout, SwitchingRollOutGeneralisesTheConstantOne) {
  Observation obs;
  obs.obstacles = {movingDisc(1.5, 0.1, kPi, 0.5), movingDisc(0.5, -1.0, kPi / 2, 0.3)};
  const LocalScene local(obs, 0.2, 1.2);
  for (const Twist2 u : {Twist2{0.5, 0.0}, Twist2{0.3, 0.8}, Twist2{0.0, -1.0}}) {
    const Rollout a = rollOut(local, u, 3.0, 0.1);
    const Rollout b = rollOutSwitching(local, u, 3.0, u, 3.0, 0.1, Contact::kInflated);
    EXPECT_EQ(a.collision_time_s, b.collision_time_s);
    EXPECT_EQ(a.min_clearance_m, b.min_clearance_m);
    // Touching comes no earlier than entering the inflation.
    EXPECT_GE(rollOutSwitching(local, u, 3.0, u, 3.0, 0.1, Contact::kTrue).collision_time_s, a.collision_time_s);
  }
  // Driving at the disc ahead, then stopping after 0.2 s: contact only when the disc itself arrives.
  const Rollout stop = rollOutSwitching(local, {0.5, 0.0}, 0.2, {0.0, 0.0}, 3.0, 0.1, Contact::kTrue);
  const Rollout go = rollOutSwitching(local, {0.5, 0.0}, 0.2, {0.5, 0.0}, 3.0, 0.1, Contact::kTrue);
  EXPECT_GT(stop.collision_time_s, go.collision_time_s);
}

// The escape as its documentation states it: every lattice velocity with every follow-up, nothing abandoned.
Twist2 escapeByFullSearch(const Observation& obs, const ActionShieldConfig& config) {
  const RobotLimits limits;
  const LocalScene scene(obs, limits.radius, DovsConfig{}.safety_factor);
  const Twist2 current = limits.clipToFeasible(obs.robot_twist);
  const Vec2 goal = obs.robot_pose.toLocal(obs.goal);
  const double h = config.last_resort_horizon_s;
  double best_ttc = -1.0, best_clearance = -1e300, best_goal = 1e300;
  Twist2 chosen = current;
  std::vector<Twist2> candidates = makeDynamicWindow(current, limits).samples(config.escape_window_samples, limits);
  candidates.push_back(decelerationCommand(current, limits));
  for (const Twist2& u1 : candidates) {
    double ttc = -1.0, clearance = -1e300;
    for (int i = -1; i <= 1; ++i) {
      for (int j = -1; j <= 1; ++j) {
        const Twist2 u2{u1.v + i * limits.dv(), u1.w + j * limits.dw()};
        if (!limits.feasible(u2, 1e-9)) continue;
        const Rollout r = rollOutSwitching(scene, u1, limits.dt, u2, h, config.last_resort_step_s, Contact::kTrue);
        const double t = std::min(r.collision_time_s, h);
        if (t > ttc + 1e-9 || (t > ttc - 1e-9 && r.min_clearance_m > clearance)) {
          ttc = t;
          clearance = r.min_clearance_m;
        }
      }
    }
    const double g = (integrateUnicycle(Pose2{}, u1.v, u1.w, limits.dt).position() - goal).norm();
    if (ttc > best_ttc + 1e-9 || (ttc > best_ttc - 1e-9 && (clearance > best_clearance + 1e-3 ||
                                                            (clearance > best_clearance - 1e-3 && g < best_goal)))) {
      best_ttc = ttc;
      best_clearance = clearance;
      best_goal = g;
      chosen = u1;
    }
  }
  return chosen;
}

// Random crowded scenes around a robot at the origin (some moving, some turning), with walls.
Observation crowd(std::mt19937& rng) {
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  const RobotLimits limits;
  Observation obs;
  const double v = u01(rng) * limits.v_max;
  obs.robot_twist = {v, (u01(rng) * 2 - 1) * limits.w_max * (1 - v / limits.v_max)};
  obs.goal = {4.0 * (u01(rng) * 2 - 1), 4.0 * (u01(rng) * 2 - 1)};
  const int n = 4 + static_cast<int>(u01(rng) * 12);
  for (int i = 0; i < n; ++i) {
    const double r = 0.5 + 2.0 * u01(rng), a = (u01(rng) * 2 - 1) * kPi;
    MovingObstacle o =
        movingDisc(r * std::cos(a), r * std::sin(a), (u01(rng) * 2 - 1) * kPi, u01(rng) < 0.2 ? 0.0 : 1.2 * u01(rng));
    if (u01(rng) < 0.3) o.turn_rate = u01(rng) * 2 - 1;
    obs.obstacles.push_back(o);
  }
  obs.segments = {Segment{{-3.0, -3.0}, {3.0, -3.0}}, Segment{{3.0, -3.0}, {3.0, 3.0}}};
  return obs;
}

TEST(Rollout, SampledSceneRollsOutExactlyLikeTheLocalScene) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  const RobotLimits limits;
  int abandoned_seen = 0;
  for (int k = 0; k < 200; ++k) {
    const Observation obs = crowd(rng);
    const LocalScene scene(obs, limits.radius, 1.1);
    const SampledScene sampled(scene, 3.0, 0.1);
    for (int m = 0; m < 5; ++m) {
      const Twist2 u1{u01(rng) * 0.7, (u01(rng) * 2 - 1)}, u2{u01(rng) * 0.7, (u01(rng) * 2 - 1)};
      for (Contact c : {Contact::kInflated, Contact::kTrue}) {
        const Rollout a = rollOutSwitching(scene, u1, 0.2, u2, 3.0, 0.1, c);
        bool abandoned = true;
        const Rollout b = sampled.rollOutSwitching(u1, 0.2, u2, c, -std::numeric_limits<double>::infinity(), abandoned);
        ASSERT_FALSE(abandoned);
        ASSERT_EQ(a.collision_time_s, b.collision_time_s) << "scene " << k;
        ASSERT_EQ(a.min_clearance_m, b.min_clearance_m) << "scene " << k;
        // Giving up below a level: abandoned exactly when the full roll-out's clearance went below it before
        // its contact.
        const double level = a.min_clearance_m + 0.05;
        const Rollout g = sampled.rollOutSwitching(u1, 0.2, u2, c, level, abandoned);
        if (abandoned) {
          ++abandoned_seen;
          EXPECT_LT(g.min_clearance_m, level);
          EXPECT_GE(g.collision_time_s, a.collision_time_s);
        } else {
          EXPECT_EQ(g.collision_time_s, a.collision_time_s);
        }
      }
    }
  }
  EXPECT_GT(abandoned_seen, 100);
}

TEST(ActionShield, EscapeSearchAbandonsNothingThatCouldWin) {
  std::mt19937 rng(9);
  int compared = 0;
  for (int k = 0; k < 150; ++k) {
    const Observation obs = crowd(rng);
    for (int n : {2, 5}) {
      ActionShieldConfig config;
      config.escape_window_samples = n;
      config.passive_escape = false;   // the full search below is the latest-contact order ...
      config.statics.enabled = false;  // ... over the whole window
      const Twist2 fast = escapeVelocity(obs, RobotLimits{}, DovsConfig{}.safety_factor, config);
      const Twist2 full = escapeByFullSearch(obs, config);
      ASSERT_EQ(fast.v, full.v) << "scene " << k << ", lattice " << n;
      ASSERT_EQ(fast.w, full.w) << "scene " << k << ", lattice " << n;
      ++compared;
    }
  }
  EXPECT_EQ(compared, 300);
}

TEST(DynamicWindow, LatticeSamplesAreInsideAndCountedRight) {
  const RobotLimits limits;
  const DynamicWindow w = makeDynamicWindow({0.3, 0.0}, limits);  // whole rhombus feasible
  for (int n : {1, 3, 10}) {
    const std::vector<Twist2> samples = w.samples(n, limits);
    EXPECT_EQ(samples.size(), static_cast<size_t>(2 * n * n + 2 * n + 1)) << n;
    for (const Twist2& t : samples) EXPECT_TRUE(w.contains(t, limits, 1e-9));
  }
  const DynamicWindow at_rest = makeDynamicWindow({0.0, 0.0}, limits);  // half of it is backwards
  for (const Twist2& t : at_rest.samples(10, limits)) EXPECT_TRUE(limits.feasible(t, 1e-9));
  EXPECT_LT(at_rest.samples(10, limits).size(), w.samples(10, limits).size());
  EXPECT_TRUE(w.samples(0, limits).empty());
}

TEST(ActionShield, BadMarginsAreNamed) {
  const Scene s = scene({0.3, 0.0}, {4.0, 0.0}, {});
  ActionShieldConfig c;
  c.robust_dw_rps = -1.0;
  EXPECT_NE(c.validate().find("robust_dw_rps"), std::string::npos);
  EXPECT_THROW(shieldActions(s.actions, s.dovs, s.obs, c), DovsError);
  c = ActionShieldConfig{};
  c.robust_dv_mps = std::nan("");
  EXPECT_NE(c.validate().find("robust_dv_mps"), std::string::npos);
  c = ActionShieldConfig{};
  c.escape_window_samples = 0;
  EXPECT_NE(c.validate().find("escape_window_samples"), std::string::npos);
}

TEST(ActionShield, ParametersAreSetByTheirConfigNames) {
  ActionShieldConfig c;
  EXPECT_EQ(setShieldParameter(c, "passive_escape", "false"), "");
  EXPECT_FALSE(c.passive_escape);
  EXPECT_EQ(setShieldParameter(c, "static_safety/margin", "0.12"), "");
  EXPECT_DOUBLE_EQ(c.statics.margin_m, 0.12);
  EXPECT_EQ(setShieldParameter(c, "escape_window_samples", "7"), "");
  EXPECT_EQ(c.escape_window_samples, 7);
  EXPECT_EQ(setShieldParameter(c, "passive_margin_growth", "0.1"), "");
  EXPECT_DOUBLE_EQ(c.passive_margin_growth_mps, 0.1);
  EXPECT_NE(setShieldParameter(c, "static_safety/nonsense", "1").find("unknown action shield parameter"),
            std::string::npos);
  EXPECT_NE(setShieldParameter(c, "rest_speed", "fast").find("not a number"), std::string::npos);
  EXPECT_NE(setShieldParameter(c, "escape", "maybe").find("not true or false"), std::string::npos);
  EXPECT_NE(setShieldParameter(c, "escape_window_samples", "2.5").find("not an integer"), std::string::npos);
  // Set but invalid: validate() names it.
  EXPECT_EQ(setShieldParameter(c, "static_safety/braking_fraction", "1.5"), "");
  EXPECT_NE(c.validate().find("braking_fraction"), std::string::npos);
}

}  // namespace
}  // namespace dqn_dovs
