// Scoring a tracker against ground truth (benchmark and tests). Definitions in docs/tracker.md "Metrics".
#pragma once

#include <map>
#include <vector>

#include "dqn_dovs/common/types.h"

namespace dqn_dovs {

/// Thresholds of the scoring.
struct TrackingMetricsConfig {
  /// A track and a true obstacle can only be matched when their centres are no farther apart than this (m).
  double match_distance_m = 0.5;
  /// Speed, heading and turn-rate errors (and static speeds) are scored only for tracks at least this old (s).
  double min_track_age_s = 1.0;
  /// True obstacles at least this fast are "moving" and have their speed, heading and turn rate scored (m/s).
  double moving_speed_mps = 0.1;
  /// An id switch of a true obstacle whose centre is closer than this to another true obstacle's is also
  /// counted as "crowded" (two discs nearly touching or, in simulation, passing through each other) (m).
  double crowded_distance_m = 0.6;
};

/// Final figures (NaN where nothing was scored).
struct TrackingSummary {
  double pos_rmse_m = 0.0;
  double speed_rmse_mps = 0.0;
  double heading_err_deg_median = 0.0;
  double turn_rate_rmse_rps = 0.0;
  double id_switches_per_min = 0.0;
  double false_tracks_per_scan = 0.0;
  double missed_rate = 0.0;
  double static_speed_mps_p95 = 0.0;
  size_t scans = 0;
  size_t matched_pairs = 0;
  size_t id_switches = 0;
  /// Id switches that happened while the obstacle was crowded (see crowded_distance_m).
  size_t id_switches_crowded = 0;
  /// Id switches after the obstacle went unmatched for at least one scan (lost, then found under a new id);
  /// the rest happened between consecutive matched scans (a swap or a duplicate track taking over).
  size_t id_switches_after_gap = 0;
  /// Median |speed error| over the pairs of speed_rmse_mps (robust to the short lags after abrupt stops).
  double speed_abs_err_median_mps = 0.0;
  /// pos_rmse_m split by the state of the matched track: younger than min_track_age_s; older and updated by a
  /// measurement at this scan (its hit count grew since it was last reported, or it is reported for the first
  /// time); older and coasting (no measurement since it was last reported: occluded, or its object lost).
  double pos_rmse_young_m = 0.0;
  double pos_rmse_observed_m = 0.0;
  double pos_rmse_coasting_m = 0.0;
  /// speed_rmse_mps split the same way (its pairs are all at least min_track_age_s old).
  double speed_rmse_observed_mps = 0.0;
  double speed_rmse_coasting_mps = 0.0;
  /// Share of the matched pairs whose track was coasting.
  double coasting_pair_fraction = 0.0;
  /// A bound on what constant-velocity coasting can give: each coasting pair scored as if its track had been exact
  /// at its last measurement (the obstacle's true centre and velocity at that scan) and had gone on at that velocity
  /// since. pos_rmse_cv_bound_m and speed_rmse_cv_bound_mps are pos_rmse_m and speed_rmse_mps with the coasting pairs
  /// scored so, the other pairs as they are; the _coasting_ figures are the coasting pairs alone. What is left in
  /// them is how the hidden obstacle's motion changed, which no measurement showed; for a track carried at constant
  /// velocity (people) the rest of its coasting error is the error of its state at that last measurement.
  double pos_rmse_coasting_cv_bound_m = 0.0;
  double speed_rmse_coasting_cv_bound_mps = 0.0;
  double pos_rmse_cv_bound_m = 0.0;
  double speed_rmse_cv_bound_mps = 0.0;
  /// The speed error of the tracks younger than min_track_age_s (left out of speed_rmse_mps), matched to obstacles
  /// moving at least moving_speed_mps, and the share of the matched pairs whose track is that young: what a planner
  /// reads of a track just born (a person found again after their track was dropped starts here).
  double speed_rmse_young_mps = 0.0;
  double young_pair_fraction = 0.0;
  /// Reported radius minus the true radius over every matched pair: its RMS and its mean (a positive bias is a
  /// body reported larger than it is, which closes gaps in the velocity space that the robot could pass through).
  double radius_rmse_m = 0.0;
  double radius_bias_m = 0.0;
};

/// Accumulates per-scan matches over any number of episodes.
class TrackingEvaluator {
 public:
  explicit TrackingEvaluator(const TrackingMetricsConfig& config = {}) : config_(config) {}

  /// Starts a new episode: id histories are forgotten (ids of different episodes are unrelated).
  void beginEpisode() {
    last_id_.clear();
    last_scan_.clear();
    last_hits_.clear();
    last_hit_scan_.clear();
    history_.clear();
  }

  /// Scores one scan. truths[k] is true obstacle k (stable index within the episode; is_static marks the
  /// obstacles that never move); counts_for_missed[k] says whether obstacle k should have been reported
  /// (e.g. clearly visible for a while); empty means all. period_s is the scan period (for per-minute rates).
  /// Returns, for each truth, the index of its matched obstacle in scene.obstacles or -1.
  std::vector<int> addScan(const TrackedScene& scene, const std::vector<MovingObstacle>& truths,
                           const std::vector<bool>& counts_for_missed, double period_s);

  TrackingSummary summary() const;

 private:
  TrackingMetricsConfig config_;
  std::map<size_t, int> last_id_;        // truth index -> last matched track id in this episode
  std::map<size_t, size_t> last_scan_;   // truth index -> scan number of its last match
  std::map<int, int> last_hits_;         // track id -> its hit count when last reported in this episode
  std::map<int, size_t> last_hit_scan_;  // track id -> the scan at which its hit count last grew
  // A truth's true (centre, velocity) at every scan since it first appeared in this episode.
  struct TruthHistory {
    size_t first_scan = 0;
    std::vector<std::pair<Vec2, Vec2>> states;  // states[k]: at scan first_scan + k
    const std::pair<Vec2, Vec2>* at(size_t scan) const {
      return scan >= first_scan && scan - first_scan < states.size() ? &states[scan - first_scan] : nullptr;
    }
  };
  std::map<size_t, TruthHistory> history_;  // truth index -> its history
  std::vector<double> pos_err_, speed_err_, heading_err_deg_, turn_err_, static_speed_;
  std::vector<double> pos_err_young_, pos_err_observed_, pos_err_coasting_, speed_err_observed_, speed_err_coasting_,
      speed_err_young_, radius_err_, pos_err_coasting_cv_, speed_err_coasting_cv_;
  size_t scans_ = 0, false_tracks_ = 0, should_see_ = 0, missed_ = 0, switches_ = 0, crowded_switches_ = 0,
         gap_switches_ = 0, pairs_ = 0;
  double truth_minutes_ = 0.0;
};

}  // namespace dqn_dovs
