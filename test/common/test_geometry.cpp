#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "dqn_dovs/common/geometry.h"

namespace dqn_dovs {
namespace {

TEST(NormalizeAngle, WrapsIntoHalfOpenInterval) {
  EXPECT_NEAR(normalizeAngle(0.0), 0.0, 1e-15);
  EXPECT_NEAR(normalizeAngle(kPi), kPi, 1e-12);
  EXPECT_NEAR(normalizeAngle(-kPi), kPi, 1e-12);  // (-pi, pi]: -pi maps to +pi
  EXPECT_NEAR(normalizeAngle(3.0 * kPi), kPi, 1e-12);
  EXPECT_NEAR(normalizeAngle(kTwoPi + 0.1), 0.1, 1e-12);
  EXPECT_NEAR(normalizeAngle(-kTwoPi - 0.1), -0.1, 1e-12);
  EXPECT_NEAR(normalizeAngle(100.0), std::remainder(100.0, kTwoPi), 1e-9);
  for (double a = -50.0; a < 50.0; a += 0.37) {
    const double n = normalizeAngle(a);
    EXPECT_GT(n, -kPi);
    EXPECT_LE(n, kPi);
    EXPECT_NEAR(std::cos(n), std::cos(a), 1e-9);
    EXPECT_NEAR(std::sin(n), std::sin(a), 1e-9);
  }
}

TEST(NormalizeAngle, PassesNonFiniteThrough) {
  EXPECT_TRUE(std::isnan(normalizeAngle(std::nan(""))));
  EXPECT_TRUE(std::isinf(normalizeAngle(std::numeric_limits<double>::infinity())));
}

TEST(AngleDiff, TakesTheShortWayRound) {
  EXPECT_NEAR(angleDiff(0.1, kTwoPi - 0.1), 0.2, 1e-12);
  EXPECT_NEAR(angleDiff(kTwoPi - 0.1, 0.1), -0.2, 1e-12);
  EXPECT_NEAR(angleDiff(kPi - 0.1, -kPi + 0.1), -0.2, 1e-12);
}

TEST(Pose2, ToWorldAndToLocalAreInverse) {
  const Pose2 p{1.0, -2.0, 0.7};
  const Vec2 q(0.3, 1.9);
  const Vec2 back = p.toLocal(p.toWorld(q));
  EXPECT_NEAR(back.x(), q.x(), 1e-12);
  EXPECT_NEAR(back.y(), q.y(), 1e-12);
  // A point one metre ahead of a pose facing +y lies one metre up.
  const Vec2 ahead = Pose2{2.0, 3.0, kPi / 2}.toWorld(Vec2(1.0, 0.0));
  EXPECT_NEAR(ahead.x(), 2.0, 1e-12);
  EXPECT_NEAR(ahead.y(), 4.0, 1e-12);
}

TEST(Pose2, ComposeAndInverse) {
  const Pose2 a{1.0, 2.0, kPi / 2};
  const Pose2 b{1.0, 0.0, kPi / 2};
  const Pose2 ab = a.compose(b);  // one metre ahead of a (i.e. +y), then another quarter turn
  EXPECT_NEAR(ab.x, 1.0, 1e-12);
  EXPECT_NEAR(ab.y, 3.0, 1e-12);
  EXPECT_NEAR(ab.theta, kPi, 1e-12);

  const Pose2 p{-0.4, 2.5, -2.9};
  const Pose2 identity = p.compose(p.inverse());
  EXPECT_NEAR(identity.x, 0.0, 1e-12);
  EXPECT_NEAR(identity.y, 0.0, 1e-12);
  EXPECT_NEAR(identity.theta, 0.0, 1e-12);
  const Pose2 identity2 = p.inverse().compose(p);
  EXPECT_NEAR(identity2.x, 0.0, 1e-12);
  EXPECT_NEAR(identity2.y, 0.0, 1e-12);
  EXPECT_NEAR(identity2.theta, 0.0, 1e-12);
  // Associativity with a third pose.
  const Pose2 c{0.2, -0.3, 1.1};
  const Pose2 l = a.compose(b).compose(c), r = a.compose(b.compose(c));
  EXPECT_NEAR(l.x, r.x, 1e-12);
  EXPECT_NEAR(l.y, r.y, 1e-12);
  EXPECT_NEAR(angleDiff(l.theta, r.theta), 0.0, 1e-12);
  EXPECT_FALSE((Pose2{std::nan(""), 0.0, 0.0}.isFinite()));
}

TEST(IntegrateUnicycle, StraightLineAndArcs) {
  const Pose2 s = integrateUnicycle({1.0, 1.0, kPi / 4}, 2.0, 0.0, 0.5);
  EXPECT_NEAR(s.x, 1.0 + std::sqrt(0.5), 1e-12);
  EXPECT_NEAR(s.y, 1.0 + std::sqrt(0.5), 1e-12);
  EXPECT_NEAR(s.theta, kPi / 4, 1e-12);

  // Quarter circle of radius 1 to the left.
  const Pose2 q = integrateUnicycle({0.0, 0.0, 0.0}, 1.0, 1.0, kPi / 2);
  EXPECT_NEAR(q.x, 1.0, 1e-12);
  EXPECT_NEAR(q.y, 1.0, 1e-12);
  EXPECT_NEAR(q.theta, kPi / 2, 1e-12);
  // A full circle returns to the start.
  const Pose2 f = integrateUnicycle({0.5, -0.5, 0.3}, 0.8, -0.4, kTwoPi / 0.4);
  EXPECT_NEAR(f.x, 0.5, 1e-12);
  EXPECT_NEAR(f.y, -0.5, 1e-12);
  EXPECT_NEAR(angleDiff(f.theta, 0.3), 0.0, 1e-12);
  // Turning in place.
  const Pose2 t = integrateUnicycle({0.5, -0.5, 0.0}, 0.0, 1.0, 1.0);
  EXPECT_NEAR(t.x, 0.5, 1e-15);
  EXPECT_NEAR(t.theta, 1.0, 1e-12);
  // Continuity between the straight-line branch and a tiny turn rate.
  const Pose2 a = integrateUnicycle({0.0, 0.0, 0.2}, 0.7, 0.0, 0.2);
  const Pose2 b = integrateUnicycle({0.0, 0.0, 0.2}, 0.7, 1e-7, 0.2);
  EXPECT_NEAR(a.x, b.x, 1e-8);
  EXPECT_NEAR(a.y, b.y, 1e-8);
  // Splitting a step in two gives the same pose (exact integration).
  const Pose2 one = integrateUnicycle({0.1, 0.2, 0.3}, 0.6, 0.9, 0.4);
  const Pose2 two = integrateUnicycle(integrateUnicycle({0.1, 0.2, 0.3}, 0.6, 0.9, 0.25), 0.6, 0.9, 0.15);
  EXPECT_NEAR(one.x, two.x, 1e-12);
  EXPECT_NEAR(one.y, two.y, 1e-12);
  EXPECT_NEAR(angleDiff(one.theta, two.theta), 0.0, 1e-12);
}

TEST(RayCircle, HitsAtTheNearSurface) {
  const Circle c{Vec2(3.0, 0.0), 0.5};
  const auto t = rayCircle(Vec2::Zero(), Vec2(1.0, 0.0), c);
  ASSERT_TRUE(t.has_value());
  EXPECT_NEAR(*t, 2.5, 1e-12);
  // Off-axis ray: the chord is at distance 0.3 from the centre.
  const Vec2 d = Vec2(3.0, 0.3).normalized();
  const auto t2 = rayCircle(Vec2::Zero(), d, Circle{Vec2(3.0, 0.3) + Vec2(0.0, 0.0), 0.5});
  ASSERT_TRUE(t2.has_value());
  EXPECT_NEAR(*t2, Vec2(3.0, 0.3).norm() - 0.5, 1e-12);
}

TEST(RayCircle, MissesBehindBesideAndReportsZeroInside) {
  const Circle c{Vec2(3.0, 0.0), 0.5};
  EXPECT_FALSE(rayCircle(Vec2::Zero(), Vec2(-1.0, 0.0), c).has_value());    // behind
  EXPECT_FALSE(rayCircle(Vec2::Zero(), Vec2(0.0, 1.0), c).has_value());     // beside
  EXPECT_FALSE(rayCircle(Vec2(0.0, 0.51), Vec2(1.0, 0.0), c).has_value());  // passes just above
  const auto inside = rayCircle(Vec2(3.1, 0.0), Vec2(1.0, 0.0), c);
  ASSERT_TRUE(inside.has_value());
  EXPECT_EQ(*inside, 0.0);
  // Tangent ray grazes at the tangent point.
  const auto tangent = rayCircle(Vec2(0.0, 0.5), Vec2(1.0, 0.0), c);
  ASSERT_TRUE(tangent.has_value());
  EXPECT_NEAR(*tangent, 3.0, 1e-9);
}

TEST(RaySegment, HitsInsideAndMissesOutside) {
  const Segment wall{Vec2(2.0, -1.0), Vec2(2.0, 1.0)};
  const auto t = raySegment(Vec2::Zero(), Vec2(1.0, 0.0), wall);
  ASSERT_TRUE(t.has_value());
  EXPECT_NEAR(*t, 2.0, 1e-12);
  const Vec2 d45 = Vec2(1.0, 1.0).normalized();
  const auto t45 = raySegment(Vec2::Zero(), d45, Segment{Vec2(2.0, -1.0), Vec2(2.0, 2.5)});
  ASSERT_TRUE(t45.has_value());
  EXPECT_NEAR(*t45, 2.0 * std::sqrt(2.0), 1e-12);
  EXPECT_FALSE(raySegment(Vec2::Zero(), d45, Segment{Vec2(2.0, -1.0), Vec2(2.0, 1.9)}).has_value());  // beyond the end
  EXPECT_FALSE(raySegment(Vec2::Zero(), Vec2(-1.0, 0.0), wall).has_value());                          // behind
  EXPECT_FALSE(raySegment(Vec2::Zero(), Vec2(0.0, 1.0), wall).has_value());                           // parallel
  EXPECT_FALSE(raySegment(Vec2(2.0, -5.0), Vec2(0.0, 1.0), wall).has_value());  // collinear counts as a miss
}

TEST(PointSegment, DistanceAndClosestPoint) {
  const Segment s{Vec2(0.0, 0.0), Vec2(4.0, 0.0)};
  EXPECT_NEAR(pointSegmentDistance(Vec2(2.0, 3.0), s), 3.0, 1e-12);   // perpendicular foot inside
  EXPECT_NEAR(pointSegmentDistance(Vec2(-3.0, 4.0), s), 5.0, 1e-12);  // nearest is end a
  EXPECT_NEAR(pointSegmentDistance(Vec2(7.0, -4.0), s), 5.0, 1e-12);  // nearest is end b
  const Vec2 c = closestPointOnSegment(Vec2(1.5, -2.0), s);
  EXPECT_NEAR(c.x(), 1.5, 1e-12);
  EXPECT_NEAR(c.y(), 0.0, 1e-12);
  const Segment point{Vec2(1.0, 1.0), Vec2(1.0, 1.0)};  // degenerate
  EXPECT_NEAR(pointSegmentDistance(Vec2(4.0, 5.0), point), 5.0, 1e-12);
  EXPECT_NEAR(s.length(), 4.0, 1e-12);
}

TEST(Geometry, SegmentsCrossIncludingTheirEnds) {
  const Segment wall{Vec2(0.0, -1.0), Vec2(0.0, 1.0)};
  EXPECT_TRUE(segmentsCross(Vec2(-1.0, 0.0), Vec2(1.0, 0.5), wall));
  EXPECT_TRUE(segmentsCross(Vec2(-1.0, 0.0), Vec2(0.0, 0.0), wall));    // ends on the wall
  EXPECT_TRUE(segmentsCross(Vec2(-1.0, 1.0), Vec2(1.0, 1.0), wall));    // through the wall's end
  EXPECT_FALSE(segmentsCross(Vec2(-1.0, 0.0), Vec2(-0.1, 0.0), wall));  // stops short
  EXPECT_FALSE(segmentsCross(Vec2(-1.0, 1.5), Vec2(1.0, 1.5), wall));   // passes beyond its end
  EXPECT_FALSE(segmentsCross(Vec2(0.5, -1.0), Vec2(0.5, 1.0), wall));   // parallel
}

TEST(Geometry, SegmentSegmentDistance) {
  const Segment wall{Vec2(0.0, -1.0), Vec2(0.0, 1.0)};
  EXPECT_DOUBLE_EQ(segmentSegmentDistance({Vec2(-1.0, 0.0), Vec2(1.0, 0.5)}, wall), 0.0);     // crossing
  EXPECT_DOUBLE_EQ(segmentSegmentDistance({Vec2(0.5, -1.0), Vec2(0.5, 1.0)}, wall), 0.5);     // parallel
  EXPECT_NEAR(segmentSegmentDistance({Vec2(-1.0, 1.3), Vec2(1.0, 1.3)}, wall), 0.3, 1e-12);   // past its end
  EXPECT_NEAR(segmentSegmentDistance({Vec2(-1.0, 0.0), Vec2(-0.2, 0.0)}, wall), 0.2, 1e-12);  // stops short
  EXPECT_DOUBLE_EQ(segmentSegmentDistance(wall, {Vec2(-1.0, 0.0), Vec2(-0.2, 0.0)}),
                   segmentSegmentDistance({Vec2(-1.0, 0.0), Vec2(-0.2, 0.0)}, wall));  // symmetric
}

}  // namespace
}  // namespace dqn_dovs
