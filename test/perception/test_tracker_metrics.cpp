#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "dqn_dovs/perception/tracker_metrics.h"

using namespace dqn_dovs;

namespace {

MovingObstacle truth(double x, double y, double speed, double heading = 0.0, double radius = 0.0) {
  MovingObstacle m;
  m.center = {x, y};
  m.radius = radius;
  m.speed = speed;
  m.heading = heading;
  m.is_static = speed == 0.0;
  return m;
}

TrackedObstacle track(int id, double x, double y, double speed, double age_s, double heading = 0.0,
                      double radius = 0.0) {
  TrackedObstacle o;
  o.id = id;
  o.center = {x, y};
  o.radius = radius;
  o.speed = speed;
  o.heading = heading;
  o.age_s = age_s;
  return o;
}

/// `o` with its hit count set (a count that grows between two scans says the track was measured).
TrackedObstacle hit(TrackedObstacle o, int hits) {
  o.hits = hits;
  return o;
}

}  // namespace

TEST(TrackingMetrics, ErrorsSwitchesFalseAndMissed) {
  TrackingEvaluator ev;
  TrackedScene s;
  // Scan 1: truth 0 matched by id 7 (young: position only); truth 1 static, matched by id 8; one false track.
  s.obstacles = {track(7, 0.03, 0.04, 0.5, 0.5), track(8, 2.0, 0.0, 0.02, 2.0), track(9, 5.0, 5.0, 0.0, 3.0)};
  auto m = ev.addScan(s, {truth(0, 0, 0.6), truth(2, 0, 0.0)}, {}, 0.1);
  EXPECT_EQ(m, (std::vector<int>{0, 1}));
  // Scan 2: truth 0 now matched by id 10 (a switch), old enough for motion errors; truth 1 missed.
  s.obstacles = {track(10, 0.0, 0.0, 0.7, 1.5, 0.1)};
  m = ev.addScan(s, {truth(0, 0, 0.6), truth(2, 0, 0.0)}, {true, true}, 0.1);
  EXPECT_EQ(m, (std::vector<int>{0, -1}));
  const TrackingSummary r = ev.summary();
  EXPECT_EQ(r.scans, 2u);
  EXPECT_EQ(r.id_switches, 1u);
  EXPECT_NEAR(r.pos_rmse_m, std::sqrt((0.05 * 0.05 + 0.0 + 0.0) / 3.0), 1e-12);
  EXPECT_NEAR(r.speed_rmse_mps, 0.1, 1e-12);
  EXPECT_NEAR(r.heading_err_deg_median, 0.1 * 180.0 / kPi, 1e-9);
  EXPECT_NEAR(r.static_speed_mps_p95, 0.02, 1e-12);
  EXPECT_NEAR(r.false_tracks_per_scan, 0.5, 1e-12);
  EXPECT_NEAR(r.missed_rate, 1.0 / 4.0, 1e-12);
  // 1 switch over 2 truths x 2 scans x 0.1 s = 0.4 s = 1/150 min.
  EXPECT_NEAR(r.id_switches_per_min, 150.0, 1e-9);
}

TEST(TrackingMetrics, OneToOneMatchingAndGate) {
  TrackingEvaluator ev;
  TrackedScene s;
  // One track between two truths may be matched to one of them only; a track 0.6 m away is not a match.
  s.obstacles = {track(1, 0.2, 0.0, 0.0, 2.0), track(2, 3.6, 0.0, 0.0, 2.0)};
  const auto m = ev.addScan(s, {truth(0, 0, 0.0), truth(0.45, 0, 0.0), truth(3.0, 0.0, 0.0)}, {}, 0.1);
  EXPECT_EQ(std::count(m.begin(), m.end(), 0), 1);
  EXPECT_EQ(m[2], -1);
  EXPECT_NEAR(ev.summary().false_tracks_per_scan, 1.0, 1e-12);
}

TEST(TrackingMetrics, EpisodesDoNotShareIds) {
  TrackingEvaluator ev;
  TrackedScene s;
  s.obstacles = {track(0, 0.0, 0.0, 0.0, 2.0)};
  ev.addScan(s, {truth(0, 0, 0.0)}, {}, 0.1);
  ev.beginEpisode();
  s.obstacles = {track(5, 0.0, 0.0, 0.0, 2.0)};
  ev.addScan(s, {truth(0, 0, 0.0)}, {}, 0.1);
  EXPECT_EQ(ev.summary().id_switches, 0u);
}

TEST(TrackingMetrics, ErrorsAreSplitIntoYoungObservedAndCoastingTracks) {
  TrackingEvaluator ev;
  TrackedScene s;
  // Scan 1: id 1 young (0.1 m off); id 2 old, reported for the first time: observed (0.2 m off, speed +0.1).
  // Id 3 young on a mover (on its centre, speed +0.3: young pairs have a speed error of their own).
  s.obstacles = {hit(track(1, 0.1, 0.0, 0.0, 0.5), 3), hit(track(2, 5.2, 0.0, 0.7, 2.0), 20),
                 hit(track(3, 10.0, 0.0, 0.9, 0.3), 3)};
  ev.addScan(s, {truth(0, 0, 0.0), truth(5, 0, 0.6), truth(10, 0, 0.6)}, {}, 0.1);
  // Scan 2: id 2 has no new hit: coasting (0.4 m off, speed -0.2). Scan 3: a hit again: observed (0.1 m off).
  s.obstacles = {hit(track(2, 5.4, 0.0, 0.4, 2.1), 20)};
  ev.addScan(s, {truth(5, 0, 0.6)}, {}, 0.1);
  s.obstacles = {hit(track(2, 5.1, 0.0, 0.6, 2.2), 21)};
  ev.addScan(s, {truth(5, 0, 0.6)}, {}, 0.1);
  const TrackingSummary r = ev.summary();
  EXPECT_NEAR(r.pos_rmse_young_m, std::sqrt(0.01 / 2.0), 1e-12);
  EXPECT_NEAR(r.speed_rmse_young_mps, 0.3, 1e-12);  // id 1 is on a still obstacle: no speed pair
  EXPECT_NEAR(r.young_pair_fraction, 2.0 / 5.0, 1e-12);
  EXPECT_NEAR(r.pos_rmse_observed_m, std::sqrt((0.04 + 0.01) / 2.0), 1e-12);
  EXPECT_NEAR(r.pos_rmse_coasting_m, 0.4, 1e-12);
  EXPECT_NEAR(r.speed_rmse_observed_mps, 0.1 / std::sqrt(2.0), 1e-12);
  EXPECT_NEAR(r.speed_rmse_coasting_mps, 0.2, 1e-12);
  EXPECT_NEAR(r.coasting_pair_fraction, 1.0 / 5.0, 1e-12);
  // A new episode forgets the hit counts: the same id with the same count is observed, not coasting.
  ev.beginEpisode();
  ev.addScan(s, {truth(5, 0, 0.6)}, {}, 0.1);
  EXPECT_NEAR(ev.summary().coasting_pair_fraction, 1.0 / 6.0, 1e-12);
}

TEST(TrackingMetrics, RadiusErrorIsScoredOverEveryMatchedPairWithItsSign) {
  TrackingEvaluator ev;
  TrackedScene s;
  // A young track 0.1 m too large, an old one 0.05 m too small; the unmatched track far away does not count.
  s.obstacles = {track(1, 0.0, 0.0, 0.0, 0.3, 0.0, 0.35), track(2, 5.0, 0.0, 0.6, 2.0, 0.0, 0.2),
                 track(3, 20.0, 0.0, 0.0, 2.0, 0.0, 1.0)};
  ev.addScan(s, {truth(0, 0, 0.0, 0.0, 0.25), truth(5, 0, 0.6, 0.0, 0.25)}, {}, 0.1);
  const TrackingSummary r = ev.summary();
  EXPECT_NEAR(r.radius_rmse_m, std::sqrt((0.01 + 0.0025) / 2.0), 1e-12);
  EXPECT_NEAR(r.radius_bias_m, 0.025, 1e-12);
}

TEST(TrackingMetrics, CoastingPairsAreBoundedByTheTruthAtTheTracksLastMeasurement) {
  TrackingEvaluator ev;
  TrackedScene s;
  // Scan 1: measured, 0.1 m off; the truth walks along x at 0.6 m/s.
  s.obstacles = {hit(track(4, 0.1, 0.0, 0.6, 2.0), 10)};
  ev.addScan(s, {truth(0.0, 0.0, 0.6)}, {}, 0.1);
  // Scans 2 and 3: no hit. The truth turns to +y (scan 2) and slows to 0.3 m/s (scan 3); the track goes on along
  // x at 0.8 m/s. The bound carries the truth of scan 1 on at (0.6, 0): exact at scan 2, 0.085 m off at scan 3.
  s.obstacles = {hit(track(4, 0.2, 0.0, 0.8, 2.1), 10)};
  ev.addScan(s, {truth(0.06, 0.0, 0.6, kPi / 2.0)}, {}, 0.1);
  s.obstacles = {hit(track(4, 0.26, 0.0, 0.8, 2.2), 10)};
  ev.addScan(s, {truth(0.06, 0.06, 0.3, kPi / 2.0)}, {}, 0.1);
  const TrackingSummary r = ev.summary();
  EXPECT_NEAR(r.pos_rmse_coasting_m, std::sqrt((0.14 * 0.14 + 0.0436) / 2.0), 1e-12);
  EXPECT_NEAR(r.pos_rmse_coasting_cv_bound_m, std::sqrt(0.0072 / 2.0), 1e-12);
  EXPECT_NEAR(r.pos_rmse_cv_bound_m, std::sqrt((0.01 + 0.0072) / 3.0), 1e-12);
  EXPECT_NEAR(r.speed_rmse_coasting_mps, std::sqrt((0.04 + 0.25) / 2.0), 1e-12);
  EXPECT_NEAR(r.speed_rmse_coasting_cv_bound_mps, std::sqrt(0.09 / 2.0), 1e-12);
  EXPECT_NEAR(r.speed_rmse_cv_bound_mps, std::sqrt(0.09 / 3.0), 1e-12);
  // A new episode forgets the truths' past: the same id reported again is measured, and nothing is bounded.
  ev.beginEpisode();
  ev.addScan(s, {truth(0.06, 0.06, 0.3, kPi / 2.0)}, {}, 0.1);
  EXPECT_NEAR(ev.summary().pos_rmse_coasting_cv_bound_m, std::sqrt(0.0072 / 2.0), 1e-12);
}

TEST(TrackingMetrics, TheBoundReadsATruthThatAppearedLateAtItsOwnScans) {
  TrackingEvaluator ev;
  TrackedScene s;
  // Scan 1: one truth, still. Scan 2: a second truth appears at (5, 0) walking along +x at 1 m/s, measured. Scan 3:
  // its track coasts; the truth turned to +y. The bound carries the scan-2 state: (5.1, 0) against (5, 0.1).
  s.obstacles = {hit(track(1, 0.0, 0.0, 0.0, 2.0), 10)};
  ev.addScan(s, {truth(0, 0, 0.0)}, {}, 0.1);
  s.obstacles = {hit(track(1, 0.0, 0.0, 0.0, 2.1), 11), hit(track(2, 5.0, 0.0, 1.0, 2.0), 10)};
  ev.addScan(s, {truth(0, 0, 0.0), truth(5.0, 0.0, 1.0)}, {}, 0.1);
  s.obstacles = {hit(track(1, 0.0, 0.0, 0.0, 2.2), 12), hit(track(2, 5.1, 0.0, 1.0, 2.1), 10)};
  ev.addScan(s, {truth(0, 0, 0.0), truth(5.0, 0.1, 1.0, kPi / 2.0)}, {}, 0.1);
  EXPECT_NEAR(ev.summary().pos_rmse_coasting_cv_bound_m, std::sqrt(0.02), 1e-12);
}
