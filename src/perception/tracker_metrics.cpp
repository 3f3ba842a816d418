#include "dqn_dovs/perception/tracker_metrics.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "dqn_dovs/perception/hungarian.h"

namespace dqn_dovs {
namespace {

double rootMeanSquare(const std::vector<double>& e) {
  if (e.empty()) return std::numeric_limits<double>::quiet_NaN();
  double s = 0.0;
  for (double x : e) s += x * x;
  return std::sqrt(s / static_cast<double>(e.size()));
}

double quantile(std::vector<double> e, double q) {
  if (e.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::sort(e.begin(), e.end());
  const double pos = q * static_cast<double>(e.size() - 1);
  const size_t lo = static_cast<size_t>(std::floor(pos));
  const size_t hi = std::min(lo + 1, e.size() - 1);
  return e[lo] + (pos - static_cast<double>(lo)) * (e[hi] - e[lo]);
}

}  // namespace

std::vector<int> TrackingEvaluator::addScan(const TrackedScene& scene, const std::vector<MovingObstacle>& truths,
                                            const std::vector<bool>& counts_for_missed, double period_s) {
  ++scans_;
  truth_minutes_ += static_cast<double>(truths.size()) * period_s / 60.0;
  const size_t nt = truths.size(), no = scene.obstacles.size();
  std::vector<Vec2> truth_centres, track_centres;
  for (const MovingObstacle& t : truths) truth_centres.push_back(t.center);
  for (const TrackedObstacle& o : scene.obstacles) track_centres.push_back(o.center);
  const std::vector<int> truth_to_obs = matchWithin(truth_centres, track_centres, config_.match_distance_m);
  std::vector<bool> obs_matched(no, false);
  for (size_t i = 0; i < nt; ++i) {
    const bool should_see = counts_for_missed.empty() || (i < counts_for_missed.size() && counts_for_missed[i]);
    if (should_see) ++should_see_;
    const int j = truth_to_obs[i];
    if (j < 0) {
      if (should_see) ++missed_;
      continue;
    }
    obs_matched[j] = true;
    ++pairs_;
    const TrackedObstacle& o = scene.obstacles[j];
    const MovingObstacle& t = truths[i];
    const auto last = last_id_.find(i);
    if (last != last_id_.end() && last->second != o.id) {
      ++switches_;
      if (last_scan_[i] + 1 < scans_) ++gap_switches_;
      for (size_t q = 0; q < nt; ++q) {
        if (q != i && (truths[q].center - t.center).norm() < config_.crowded_distance_m) {
          ++crowded_switches_;
          break;
        }
      }
    }
    last_id_[i] = o.id;
    last_scan_[i] = scans_;
    pos_err_.push_back((o.center - t.center).norm());
    radius_err_.push_back(o.radius - t.radius);
    if (o.age_s < config_.min_track_age_s) {
      pos_err_young_.push_back(pos_err_.back());
      if (!t.is_static && t.speed >= config_.moving_speed_mps) speed_err_young_.push_back(o.speed - t.speed);
      continue;
    }
    const auto hits_before = last_hits_.find(o.id);
    const bool observed = hits_before == last_hits_.end() || o.hits > hits_before->second;
    (observed ? pos_err_observed_ : pos_err_coasting_).push_back(pos_err_.back());
    // The constant-velocity bound: a coasting pair scored from the truth's state at the track's last measurement
    // (as the tracker scored it when that state is unknown: the truth appeared after that measurement).
    const std::pair<Vec2, Vec2>* then = nullptr;
    if (!observed) {
      const auto hit = last_hit_scan_.find(o.id);
      const auto past = history_.find(i);
      if (hit != last_hit_scan_.end() && past != history_.end()) then = past->second.at(hit->second);
      const double dt = then != nullptr ? static_cast<double>(scans_ - hit->second) * period_s : 0.0;
      pos_err_coasting_cv_.push_back(then != nullptr ? (then->first + dt * then->second - t.center).norm()
                                                     : pos_err_.back());
    }
    if (t.is_static) {
      static_speed_.push_back(o.speed);
    } else if (t.speed >= config_.moving_speed_mps) {
      speed_err_.push_back(o.speed - t.speed);
      (observed ? speed_err_observed_ : speed_err_coasting_).push_back(speed_err_.back());
      if (!observed)
        speed_err_coasting_cv_.push_back(then != nullptr ? then->second.norm() - t.speed : speed_err_.back());
      heading_err_deg_.push_back(std::abs(angleDiff(o.heading, t.heading)) * 180.0 / kPi);
      turn_err_.push_back(o.turn_rate - t.turn_rate);
    }
  }
  false_tracks_ += static_cast<size_t>(std::count(obs_matched.begin(), obs_matched.end(), false));
  for (const TrackedObstacle& o : scene.obstacles) {
    const auto before = last_hits_.find(o.id);
    if (before == last_hits_.end() || o.hits > before->second) last_hit_scan_[o.id] = scans_;
    last_hits_[o.id] = o.hits;
  }
  for (size_t i = 0; i < nt; ++i) {
    const MovingObstacle& t = truths[i];
    TruthHistory& past = history_[i];
    if (past.states.empty()) past.first_scan = scans_;
    past.states.emplace_back(t.center, t.speed * Vec2(std::cos(t.heading), std::sin(t.heading)));
  }
  return truth_to_obs;
}

TrackingSummary TrackingEvaluator::summary() const {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  TrackingSummary s;
  s.pos_rmse_m = rootMeanSquare(pos_err_);
  s.speed_rmse_mps = rootMeanSquare(speed_err_);
  s.heading_err_deg_median = quantile(heading_err_deg_, 0.5);
  s.turn_rate_rmse_rps = rootMeanSquare(turn_err_);
  s.id_switches_per_min = truth_minutes_ > 0.0 ? static_cast<double>(switches_) / truth_minutes_ : nan;
  s.false_tracks_per_scan = scans_ > 0 ? static_cast<double>(false_tracks_) / static_cast<double>(scans_) : nan;
  s.missed_rate = should_see_ > 0 ? static_cast<double>(missed_) / static_cast<double>(should_see_) : nan;
  s.static_speed_mps_p95 = quantile(static_speed_, 0.95);
  s.scans = scans_;
  s.matched_pairs = pairs_;
  s.id_switches = switches_;
  s.id_switches_crowded = crowded_switches_;
  s.id_switches_after_gap = gap_switches_;
  std::vector<double> abs_speed(speed_err_.size());
  std::transform(speed_err_.begin(), speed_err_.end(), abs_speed.begin(), [](double e) { return std::abs(e); });
  s.speed_abs_err_median_mps = quantile(abs_speed, 0.5);
  s.pos_rmse_young_m = rootMeanSquare(pos_err_young_);
  s.pos_rmse_observed_m = rootMeanSquare(pos_err_observed_);
  s.pos_rmse_coasting_m = rootMeanSquare(pos_err_coasting_);
  s.speed_rmse_observed_mps = rootMeanSquare(speed_err_observed_);
  s.speed_rmse_coasting_mps = rootMeanSquare(speed_err_coasting_);
  s.coasting_pair_fraction =
      pos_err_.empty() ? nan : static_cast<double>(pos_err_coasting_.size()) / static_cast<double>(pos_err_.size());
  s.pos_rmse_coasting_cv_bound_m = rootMeanSquare(pos_err_coasting_cv_);
  s.speed_rmse_coasting_cv_bound_mps = rootMeanSquare(speed_err_coasting_cv_);
  // Every pair as scored, the coasting ones replaced by their bound (the same count: one bound per coasting pair).
  const auto replaced = [](const std::vector<double>& all, const std::vector<double>& coasting,
                           const std::vector<double>& bound) {
    if (all.empty()) return std::numeric_limits<double>::quiet_NaN();
    double sum = 0.0;
    for (double x : all) sum += x * x;
    for (double x : coasting) sum -= x * x;
    for (double x : bound) sum += x * x;
    return std::sqrt(std::max(sum, 0.0) / static_cast<double>(all.size()));
  };
  s.pos_rmse_cv_bound_m = replaced(pos_err_, pos_err_coasting_, pos_err_coasting_cv_);
  s.speed_rmse_cv_bound_mps = replaced(speed_err_, speed_err_coasting_, speed_err_coasting_cv_);
  s.speed_rmse_young_mps = rootMeanSquare(speed_err_young_);
  s.young_pair_fraction =
      pos_err_.empty() ? nan : static_cast<double>(pos_err_young_.size()) / static_cast<double>(pos_err_.size());
  s.radius_rmse_m = rootMeanSquare(radius_err_);
  s.radius_bias_m = radius_err_.empty() ? nan
                                        : std::accumulate(radius_err_.begin(), radius_err_.end(), 0.0) /
                                              static_cast<double>(radius_err_.size());
  return s;
}

}  // namespace dqn_dovs
