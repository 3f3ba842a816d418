#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "dqn_dovs/perception/circle_fit.h"

using namespace dqn_dovs;

namespace {

std::vector<Vec2> arc(const Vec2& c, double r, double a0, double a1, int n, double noise, std::mt19937& rng) {
  std::normal_distribution<double> g(0.0, noise);
  std::vector<Vec2> pts;
  for (int i = 0; i < n; ++i) {
    const double a = a0 + (a1 - a0) * i / (n - 1);
    const double rr = r + (noise > 0.0 ? g(rng) : 0.0);
    pts.emplace_back(c.x() + rr * std::cos(a), c.y() + rr * std::sin(a));
  }
  return pts;
}

}  // namespace

TEST(CircleFit, ExactOnFullCircleFarFromOrigin) {
  std::mt19937 rng(1);
  const Vec2 c(105.3, -42.7);
  const auto pts = arc(c, 0.35, 0.0, 2.0 * kPi * 0.97, 60, 0.0, rng);
  const auto alg = fitCircleAlgebraic(pts);
  ASSERT_TRUE(alg);
  EXPECT_NEAR((alg->center - c).norm(), 0.0, 1e-6);
  EXPECT_NEAR(alg->radius, 0.35, 1e-6);
  const auto fit = fitCircle(pts);
  ASSERT_TRUE(fit);
  EXPECT_NEAR((fit->circle.center - c).norm(), 0.0, 1e-8);
  EXPECT_NEAR(fit->circle.radius, 0.35, 1e-8);
  EXPECT_LT(fit->rms_m, 1e-8);
}

TEST(CircleFit, NoisyFullAndPartialArcs) {
  // The LIDAR's view of a 0.2 m disc: a 120 deg front arc with 1 cm noise. The geometric fit must place
  // the centre behind the points (not at their centroid) within a few cm over many draws.
  std::mt19937 rng(3);
  const Vec2 c(2.0, 1.0);
  double err_full = 0.0, err_part = 0.0, rad_part = 0.0;
  const int trials = 200;
  for (int t = 0; t < trials; ++t) {
    const auto full = fitCircle(arc(c, 0.2, 0.0, 2.0 * kPi * 0.98, 80, 0.01, rng));
    ASSERT_TRUE(full);
    err_full += (full->circle.center - c).norm();
    const auto part_pts = arc(c, 0.2, kPi - 1.05, kPi + 1.05, 25, 0.01, rng);
    const auto part = fitCircle(part_pts, Circle{c + Vec2(0.05, 0.0), 0.2});
    ASSERT_TRUE(part);
    err_part += (part->circle.center - c).norm();
    rad_part += part->circle.radius;
    EXPECT_LT(part->rms_m, 0.02);
  }
  EXPECT_LT(err_full / trials, 0.005);
  EXPECT_LT(err_part / trials, 0.03);
  EXPECT_NEAR(rad_part / trials, 0.2, 0.02);
}

TEST(CircleFit, AlgebraicIsBiasedOnShortArcsGeometricIsNot) {
  std::mt19937 rng(5);
  const Vec2 c(0.0, 3.0);
  double alg_r = 0.0, geo_r = 0.0;
  const int trials = 300;
  int n_ok = 0;
  for (int t = 0; t < trials; ++t) {
    const auto pts = arc(c, 0.3, -kPi / 2 - 0.8, -kPi / 2 + 0.8, 30, 0.01, rng);
    const auto alg = fitCircleAlgebraic(pts);
    const auto geo = fitCircle(pts);
    if (!alg || !geo) continue;
    ++n_ok;
    alg_r += alg->radius;
    geo_r += geo->circle.radius;
  }
  ASSERT_GT(n_ok, trials * 9 / 10);
  EXPECT_LT(std::abs(geo_r / n_ok - 0.3), std::abs(alg_r / n_ok - 0.3));
  EXPECT_NEAR(geo_r / n_ok, 0.3, 0.02);
}

TEST(CircleFit, FixedRadiusFindsCentreBehindArc) {
  std::mt19937 rng(9);
  const Vec2 c(4.0, -2.0);
  const auto pts = arc(c, 0.2, kPi / 2 - 0.6, kPi / 2 + 0.6, 12, 0.005, rng);
  const auto fit = fitCircleFixedRadius(pts, 0.2, c + Vec2(0.0, 0.15));
  ASSERT_TRUE(fit);
  EXPECT_NEAR((fit->circle.center - c).norm(), 0.0, 0.02);
  EXPECT_DOUBLE_EQ(fit->circle.radius, 0.2);
}

TEST(CircleFit, DegenerateInput) {
  EXPECT_FALSE(fitCircleAlgebraic({{0, 0}, {1, 1}}));
  EXPECT_FALSE(fitCircleAlgebraic({{0, 0}, {1, 1}, {2, 2}, {3, 3}}));  // collinear
  EXPECT_FALSE(fitCircle({{0, 0}, {1, 0}, {std::nan(""), 1}}));
  EXPECT_FALSE(fitCircleFixedRadius({{0, 0}, {1, 0}}, -1.0, Vec2::Zero()));
  EXPECT_FALSE(fitLine({{0, 0}}));
}

TEST(LineFit, StraightNoisyWall) {
  std::mt19937 rng(11);
  std::normal_distribution<double> g(0.0, 0.01);
  std::vector<Vec2> pts;
  for (int i = 0; i <= 100; ++i) pts.emplace_back(-1.0 + 0.02 * i, 0.5 * (-1.0 + 0.02 * i) + 1.0 + g(rng));
  const auto line = fitLine(pts);
  ASSERT_TRUE(line);
  EXPECT_NEAR(std::abs(line->direction.y() / line->direction.x()), 0.5, 0.02);
  EXPECT_LT(line->rms_m, 0.012);
  EXPECT_NEAR(line->extent.length(), std::sqrt(4.0 + 1.0), 0.05);
}
