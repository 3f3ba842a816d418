#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "dqn_dovs/common/geometry.h"
#include "dqn_dovs/perception/gait.h"

using namespace dqn_dovs;

namespace {

/// Feeds the filter a swing of amplitude 0.12 m at `cadence` times the nominal rate of walking at 1 m/s, sampled at
/// 10 Hz for `seconds` with 1 cm of noise, and returns its prediction error `ahead` seconds after the last sample.
double predictionError(GaitFilter& filter, const GaitParams& params, double cadence, double seconds, double ahead) {
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 0.01);
  const double w = cadence * gaitNominalRate(1.0, params);
  auto swing = [&](double t) { return 0.12 * std::sin(w * t + 0.4); };
  double t = 0.0;
  for (; t <= seconds + 1e-9; t += 0.1) filter.update(swing(t) + noise(rng), 1.0, t, 1.0, params);
  const double last = t - 0.1;
  double s = 0.0, variance = 0.0;
  filter.predict(1.0, last + ahead, params, s, variance);
  return std::abs(s - swing(last + ahead));
}

}  // namespace

TEST(Gait, TheNominalRateIsHalfACyclePerStep) {
  GaitParams params;  // steps of 0.3 + 0.3 v metres
  EXPECT_NEAR(gaitNominalRate(1.0, params), kPi / 0.6, 1e-12);
  EXPECT_NEAR(gaitNominalRate(0.0, params), 0.0, 1e-12);
  EXPECT_NEAR(gaitNominalRate(-1.0, params), 0.0, 1e-12);  // no negative speed
}

TEST(Gait, FollowsASwingAndPredictsItAheadBetterThanItsLastValue) {
  GaitParams params;
  GaitFilter filter;
  EXPECT_FALSE(filter.active());
  const double error = predictionError(filter, params, 1.0, 3.0, 0.3);
  EXPECT_TRUE(filter.active());
  EXPECT_LT(error, 0.01);
  // Holding the last measured offset for 0.3 s (a third of a cycle at 1 m/s) would be off by far more.
  const double w = gaitNominalRate(1.0, params);
  const double last = 0.1 * std::round(3.0 / 0.1);
  EXPECT_GT(std::abs(0.12 * std::sin(w * last + 0.4) - 0.12 * std::sin(w * (last + 0.3) + 0.4)), 0.05);
}

TEST(Gait, LearnsAPersonsOwnCadence) {
  // Someone stepping 30 % faster than the nominal cadence of their speed: learned from the pairs, the cadence factor
  // comes near 1.3 and the prediction is close; held at the nominal cadence (rate_std 0) it is not.
  GaitParams learned;
  GaitFilter a;
  const double learned_error = predictionError(a, learned, 1.3, 5.0, 0.3);
  EXPECT_NEAR(a.cadenceFactor(), 1.3, 0.1);
  EXPECT_LT(learned_error, 0.01);
  GaitParams fixed;
  fixed.rate_std = 0.0;
  GaitFilter b;
  const double fixed_error = predictionError(b, fixed, 1.3, 5.0, 0.3);
  EXPECT_NEAR(b.cadenceFactor(), 1.0, 1e-9);
  EXPECT_GT(fixed_error, 0.015);
}

TEST(Gait, APairAfterALongGapStartsAgainAndThePredictionGrowsUncertain) {
  GaitParams params;
  GaitFilter filter;
  filter.update(0.10, 1.0, 0.0, 1.0, params);
  filter.update(0.05, 1.0, 0.1, 1.0, params);
  double s = 0.0, near = 0.0, far = 0.0;
  filter.predict(1.0, 0.2, params, s, near);
  filter.predict(1.0, 0.8, params, s, far);
  EXPECT_GT(far, near);
  // Two seconds later (more than the 1 s it bridges): the filter starts at the new pair.
  filter.update(-0.08, 1.0, 2.1, 1.0, params);
  EXPECT_DOUBLE_EQ(filter.stamp(), 2.1);
  filter.predict(1.0, 2.1, params, s, near);
  EXPECT_NEAR(s, -0.08, 1e-12);
  EXPECT_NEAR(near, params.offset_std_m * params.offset_std_m, 1e-12);
  filter.reset();
  EXPECT_FALSE(filter.active());
}
