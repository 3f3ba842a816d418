#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "dqn_dovs/common/random.h"
#include "dqn_dovs/common/robot_model.h"

namespace dqn_dovs {
namespace {

TEST(RobotLimits, DefaultsAreTheTurtlebotAndValid) {
  const RobotLimits l;
  EXPECT_EQ(l.validate(), "");
  EXPECT_DOUBLE_EQ(l.v_max, 0.7);
  EXPECT_DOUBLE_EQ(l.w_max, kPi);
  EXPECT_DOUBLE_EQ(l.dv(), 0.1);
  EXPECT_DOUBLE_EQ(l.dw(), 0.4);
}

TEST(RobotLimits, ValidateNamesTheBadField) {
  RobotLimits l;
  l.a_w = -1.0;
  EXPECT_NE(l.validate().find("a_w"), std::string::npos);
  l = RobotLimits();
  l.v_max = std::nan("");
  EXPECT_NE(l.validate().find("v_max"), std::string::npos);
  l = RobotLimits();
  l.dt = 0.0;
  EXPECT_NE(l.validate().find("dt"), std::string::npos);
}

TEST(RobotLimits, TriangleLimitAndFeasibility) {
  const RobotLimits l;
  EXPECT_NEAR(l.wLimitAt(0.0), kPi, 1e-12);
  EXPECT_NEAR(l.wLimitAt(0.35), kPi / 2, 1e-12);
  EXPECT_NEAR(l.wLimitAt(0.7), 0.0, 1e-12);
  EXPECT_NEAR(l.wLimitAt(2.0), 0.0, 1e-12);
  EXPECT_TRUE(l.feasible({0.0, kPi}));
  EXPECT_TRUE(l.feasible({0.0, -kPi}));
  EXPECT_TRUE(l.feasible({0.7, 0.0}));
  EXPECT_TRUE(l.feasible({0.35, -kPi / 2}));
  EXPECT_FALSE(l.feasible({0.35, kPi / 2 + 1e-3}));
  EXPECT_FALSE(l.feasible({-0.01, 0.0}));
  EXPECT_FALSE(l.feasible({0.71, 0.0}));
  EXPECT_FALSE(l.feasible({std::nan(""), 0.0}));
  EXPECT_FALSE(l.feasible({0.1, std::numeric_limits<double>::infinity()}));
}

TEST(RobotLimits, ClipToFeasibleKnownCases) {
  const RobotLimits l;
  const Twist2 keep = l.clipToFeasible({0.2, 0.5});
  EXPECT_DOUBLE_EQ(keep.v, 0.2);
  EXPECT_DOUBLE_EQ(keep.w, 0.5);
  const Twist2 fast = l.clipToFeasible({1.0, 0.0});
  EXPECT_NEAR(fast.v, 0.7, 1e-12);
  EXPECT_NEAR(fast.w, 0.0, 1e-12);
  const Twist2 back = l.clipToFeasible({-0.5, 1.0});
  EXPECT_NEAR(back.v, 0.0, 1e-12);
  EXPECT_NEAR(back.w, 1.0, 1e-12);
  // (v_max, w_max) projects onto the middle of the hypotenuse.
  const Twist2 corner = l.clipToFeasible({0.7, -kPi});
  EXPECT_NEAR(corner.v, 0.35, 1e-12);
  EXPECT_NEAR(corner.w, -kPi / 2, 1e-12);
  const Twist2 nan = l.clipToFeasible({std::nan(""), 1.0});
  EXPECT_EQ(nan.v, 0.0);
  EXPECT_EQ(nan.w, 0.0);
}

TEST(RobotLimits, ClipToFeasibleIsTheClosestPointInScaledCoordinates) {
  const RobotLimits l;
  sim::Rng rng(3);
  for (int trial = 0; trial < 300; ++trial) {
    const Twist2 t{rng.uniform(-1.0, 2.0), rng.uniform(-8.0, 8.0)};
    const Twist2 c = l.clipToFeasible(t);
    ASSERT_TRUE(l.feasible(c, 1e-9));
    auto dist2 = [&](const Twist2& q) {
      const double a = (q.v - t.v) / l.v_max, b = (q.w - t.w) / l.w_max;
      return a * a + b * b;
    };
    const double best = dist2(c);
    // No feasible sample on a fine grid is closer.
    for (double a = 0.0; a <= 1.0; a += 0.02) {
      for (double b = -(1.0 - a); b <= 1.0 - a; b += 0.02) {
        ASSERT_GE(dist2({a * l.v_max, b * l.w_max}), best - 1e-12) << "t = (" << t.v << ", " << t.w << ")";
      }
    }
  }
}

TEST(DynamicWindow, CornersInActionOrderAndContainment) {
  const RobotLimits l;
  const DynamicWindow dw = makeDynamicWindow({0.3, 0.5}, l);
  const auto c = dw.corners();
  EXPECT_NEAR(c[0].v, 0.4, 1e-12);  // top
  EXPECT_NEAR(c[0].w, 0.5, 1e-12);
  EXPECT_NEAR(c[1].v, 0.2, 1e-12);  // bottom
  EXPECT_NEAR(c[2].w, 0.1, 1e-12);  // left
  EXPECT_NEAR(c[3].w, 0.9, 1e-12);  // right
  for (const Twist2& corner : c) EXPECT_TRUE(dw.containsRhombus(corner));
  EXPECT_TRUE(dw.containsRhombus({0.35, 0.7}));   // |0.05| / 0.1 + |0.2| / 0.4 = 1
  EXPECT_FALSE(dw.containsRhombus({0.36, 0.7}));  // just outside the rhombus, inside its bounding box
  // Inside the rhombus but above the triangle: (0.4, 0.5) is fine, (0.35, 0.7)? 0.35/0.7 + 0.7/pi = 0.72 -> ok.
  EXPECT_TRUE(dw.contains({0.35, 0.7}, l));
  const DynamicWindow high = makeDynamicWindow({0.65, 0.1}, l);
  EXPECT_TRUE(high.containsRhombus({0.7, 0.1}));
  EXPECT_FALSE(high.contains({0.7, 0.1}, l));  // infeasible: at v_max only w = 0 is allowed
}

TEST(ApplyAccelerationLimits, LimitsEachAxisThenClips) {
  const RobotLimits l;
  const Twist2 a = applyAccelerationLimits({0.0, 0.0}, {0.7, 2.0}, l, 0.2);
  EXPECT_NEAR(a.v, 0.1, 1e-12);
  EXPECT_NEAR(a.w, 0.4, 1e-12);
  const Twist2 b = applyAccelerationLimits({0.3, 0.0}, {0.35, -0.1}, l, 0.2);  // reachable at once
  EXPECT_NEAR(b.v, 0.35, 1e-12);
  EXPECT_NEAR(b.w, -0.1, 1e-12);
  const Twist2 c = applyAccelerationLimits({0.05, 0.0}, {-1.0, 0.0}, l, 0.2);  // no reversing
  EXPECT_NEAR(c.v, 0.0, 1e-12);
  const Twist2 keep = applyAccelerationLimits({0.3, 0.2}, {std::nan(""), 0.0}, l, 0.2);
  EXPECT_NEAR(keep.v, 0.3, 1e-12);
  EXPECT_NEAR(keep.w, 0.2, 1e-12);
  const Twist2 bad_state = applyAccelerationLimits({std::nan(""), 0.0}, {0.3, 0.0}, l, 0.2);
  EXPECT_EQ(bad_state.v, 0.0);
  EXPECT_EQ(bad_state.w, 0.0);
}

TEST(ApplyAccelerationLimits, NeverBreaksTheAngularLimitToFitTheTriangle) {
  // Spinning at w_max and asked to drive straight on at full speed: the turn rate may only drop by a_w dt,
  // so the speed has to wait rather than the turn rate jumping down to the triangle's edge.
  const RobotLimits l;
  const Twist2 out = applyAccelerationLimits({0.0, kPi}, {0.7, kPi}, l, 0.2);
  EXPECT_LE(std::abs(out.w - kPi), l.a_w * 0.2 + 1e-12);
  EXPECT_LE(std::abs(out.v - 0.0), l.a_v * 0.2 + 1e-12);
  EXPECT_TRUE(l.feasible(out, 1e-9));
}

TEST(ApplyAccelerationLimits, RandomStatesStayFeasibleAndWithinTheAccelerationBox) {
  const RobotLimits l;
  sim::Rng rng(11);
  for (int trial = 0; trial < 20000; ++trial) {
    const double a = rng.uniform01();
    const double b = rng.uniform(-(1.0 - a), 1.0 - a);
    const Twist2 current{a * l.v_max, b * l.w_max};
    const Twist2 command{rng.uniform(-0.5, 1.5), rng.uniform(-5.0, 5.0)};
    const double dt = rng.uniform(0.001, 0.5);
    const Twist2 out = applyAccelerationLimits(current, command, l, dt);
    ASSERT_TRUE(l.feasible(out, 1e-9)) << trial;
    ASSERT_LE(std::abs(out.v - current.v), l.a_v * dt + 1e-9) << trial;
    ASSERT_LE(std::abs(out.w - current.w), l.a_w * dt + 1e-9) << trial;
    // A feasible command inside the reachable box is taken as is.
    if (l.feasible(command) && std::abs(command.v - current.v) <= l.a_v * dt &&
        std::abs(command.w - current.w) <= l.a_w * dt) {
      ASSERT_NEAR(out.v, command.v, 1e-12);
      ASSERT_NEAR(out.w, command.w, 1e-12);
    }
  }
}

}  // namespace
}  // namespace dqn_dovs
