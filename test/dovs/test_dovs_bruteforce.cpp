// The DOVS against brute force over random scenes: no unsafe velocity marked free away from the DOV border, and
// a DOV at most 25% larger than the brute-force unsafe set (definitions in docs/dovs.md).
#include <gtest/gtest.h>

#include <cstdio>
#include <utility>

#include "dovs_bruteforce.h"

namespace dqn_dovs {
namespace {

constexpr int kLatticeV = 40;
constexpr int kLatticeW = 80;

// Runs the comparison on kScenes random scenes; returns the totals (all obstacles, moving only).
std::pair<bruteforce::Tally, bruteforce::Tally> compareRandomScenes(const DovsConfig& config, uint64_t seed) {
  DovsBuilder builder(RobotLimits{}, config);
  std::mt19937_64 rng(seed);
  bruteforce::SceneOptions opt;
  bruteforce::Tally all, dyn;
  VelocitySpace dovs;
  constexpr int kScenes = 250;
  for (int k = 0; k < kScenes; ++k) {
    const Observation obs = bruteforce::randomScene(rng, builder, opt);
    builder.build(obs, dovs);
    const bruteforce::Reference ref(builder, obs);
    const bruteforce::Tally t = bruteforce::compareOnLattice(
        dovs, [&](const Twist2& tw) { return ref.unsafe(tw); }, kLatticeV, kLatticeW);
    all.add(t);
    EXPECT_EQ(t.missed, 0) << "scene " << k << " with " << obs.obstacles.size() << " obstacles";

    const Observation moving = bruteforce::dynamicOnly(obs, builder);
    builder.build(moving, dovs);
    const bruteforce::Reference ref_moving(builder, moving);
    dyn.add(bruteforce::compareOnLattice(
        dovs, [&](const Twist2& tw) { return ref_moving.dynamicUnsafe(tw); }, kLatticeV, kLatticeW));
  }
  return {all, dyn};
}

TEST(DovsBruteForce, RandomScenesNoMissesAndBoundedExcess) {
  const auto [all, dyn] = compareRandomScenes(DovsConfig{}, 20240611);
  std::printf("all: feasible %ld ref unsafe %ld dovs unsafe %ld missed %ld near border %ld excess %.3f\n", all.feasible,
              all.reference_unsafe, all.dovs_unsafe, all.missed, all.missed_near_border, all.excessRatio());
  std::printf("moving only: ref unsafe %ld dovs unsafe %ld missed %ld near border %ld excess %.3f\n",
              dyn.reference_unsafe, dyn.dovs_unsafe, dyn.missed, dyn.missed_near_border, dyn.excessRatio());
  EXPECT_GT(all.reference_unsafe, 10000);  // the scenes are not trivially empty
  EXPECT_EQ(all.missed, 0);
  EXPECT_EQ(dyn.missed, 0);
  EXPECT_LE(all.excessRatio(), 0.25);
  EXPECT_LE(dyn.excessRatio(), 0.25);
  EXPECT_GE(all.excessRatio(), 0.0);  // never smaller than the true unsafe set in total
}

// A growing prediction (people who may change course): the same guarantees against a brute force whose moving
// obstacles grow at the same rate, and a DOV that really grows (larger than without growth on the same scenes).
TEST(DovsBruteForce, GrowingPredictionNoMissesAndBoundedExcess) {
  DovsConfig grown;
  grown.prediction_growth_mps = 0.3;
  const auto [all, dyn] = compareRandomScenes(grown, 20261203);
  const auto [all0, dyn0] = compareRandomScenes(DovsConfig{}, 20261203);
  std::printf("growth 0.3: ref unsafe %ld dovs unsafe %ld missed %ld near border %ld excess %.3f (moving %.3f)\n",
              all.reference_unsafe, all.dovs_unsafe, all.missed, all.missed_near_border, all.excessRatio(),
              dyn.excessRatio());
  EXPECT_EQ(all.missed, 0);
  EXPECT_EQ(dyn.missed, 0);
  EXPECT_LE(all.excessRatio(), 0.25);
  EXPECT_LE(dyn.excessRatio(), 0.25);
  EXPECT_GT(dyn.reference_unsafe, dyn0.reference_unsafe * 1.1);  // the growth matters in these scenes
  EXPECT_GT(dyn.dovs_unsafe, dyn0.dovs_unsafe);
}

}  // namespace
}  // namespace dqn_dovs
