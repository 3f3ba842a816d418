// Obstacle tracker: time handling, association, track life and the reported scene.
#include "dqn_dovs/perception/tracker.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "dqn_dovs/common/named_fields.h"
#include "dqn_dovs/perception/circle_fit.h"
#include "dqn_dovs/perception/hungarian.h"

namespace dqn_dovs {
namespace {

std::string badField(const char* name, double value, const char* why) {
  std::ostringstream os;
  os << "tracker parameter '" << name << "' = " << value << ": " << why;
  return os.str();
}

bool positive(double x) { return std::isfinite(x) && x > 0.0; }
bool nonNegative(double x) { return std::isfinite(x) && x >= 0.0; }

}  // namespace

std::string TrackerConfig::validate() const {
  if (!positive(cluster_distance_base_m))
    return badField("cluster_distance_base_m", cluster_distance_base_m, "must be > 0 (m)");
  if (!nonNegative(cluster_distance_beam_factor))
    return badField("cluster_distance_beam_factor", cluster_distance_beam_factor, "must be >= 0");
  if (max_skipped_beams < 0) return badField("max_skipped_beams", max_skipped_beams, "must be >= 0");
  if (min_cluster_points < 3)
    return badField("min_cluster_points", min_cluster_points, "must be >= 3 (a circle needs 3 points)");
  if (!nonNegative(range_noise_m)) return badField("range_noise_m", range_noise_m, "must be >= 0 (m)");
  if (!(nonNegative(range_noise_fraction) && range_noise_fraction < 0.5))
    return badField("range_noise_fraction", range_noise_fraction, "must be in [0, 0.5)");
  if (!positive(split_distance_m)) return badField("split_distance_m", split_distance_m, "must be > 0 (m)");
  if (!positive(segment_min_length_m)) return badField("segment_min_length_m", segment_min_length_m, "must be > 0 (m)");
  if (!positive(line_max_rms_m)) return badField("line_max_rms_m", line_max_rms_m, "must be > 0 (m)");
  if (!(nonNegative(min_arc_sagitta_ratio) && min_arc_sagitta_ratio < 0.5))
    return badField("min_arc_sagitta_ratio", min_arc_sagitta_ratio, "must be in [0, 0.5)");
  if (!positive(max_circle_radius_m)) return badField("max_circle_radius_m", max_circle_radius_m, "must be > 0 (m)");
  if (!(positive(min_circle_radius_m) && min_circle_radius_m < max_circle_radius_m))
    return badField("min_circle_radius_m", min_circle_radius_m, "must be > 0 and below max_circle_radius_m (m)");
  if (!positive(circle_max_rms_m)) return badField("circle_max_rms_m", circle_max_rms_m, "must be > 0 (m)");
  if (!(positive(fallback_radius_m) && fallback_radius_m <= max_circle_radius_m))
    return badField("fallback_radius_m", fallback_radius_m, "must be > 0 and at most max_circle_radius_m (m)");
  if (!nonNegative(radius_margin_m)) return badField("radius_margin_m", radius_margin_m, "must be >= 0 (m)");
  if (radius_window < 1) return badField("radius_window", radius_window, "must be >= 1");
  if (!(std::isfinite(radius_quantile) && radius_quantile >= 0.0 && radius_quantile <= 1.0))
    return badField("radius_quantile", radius_quantile, "must be in [0, 1]");
  if (!positive(leg_max_radius_m)) return badField("leg_max_radius_m", leg_max_radius_m, "must be > 0 (m)");
  if (!positive(leg_pair_max_distance_m))
    return badField("leg_pair_max_distance_m", leg_pair_max_distance_m, "must be > 0 (m)");
  if (!(positive(person_radius_m) && person_radius_m <= max_circle_radius_m))
    return badField("person_radius_m", person_radius_m, "must be > 0 and at most max_circle_radius_m (m)");
  if (!nonNegative(structure_memory_s))
    return badField("structure_memory_s", structure_memory_s, "must be >= 0 (s); 0 disables");
  if (!positive(structure_cell_m)) return badField("structure_cell_m", structure_cell_m, "must be > 0 (m)");
  if (structure_min_scans < 1) return badField("structure_min_scans", structure_min_scans, "must be >= 1");
  if (!(positive(structure_max_fraction) && structure_max_fraction <= 1.0))
    return badField("structure_max_fraction", structure_max_fraction, "must be in (0, 1]");
  if (leg_min_points < 1) return badField("leg_min_points", leg_min_points, "must be >= 1");
  if (!positive(lone_leg_std_m)) return badField("lone_leg_std_m", lone_leg_std_m, "must be > 0 (m)");
  if (!nonNegative(hip_half_width_m)) return badField("hip_half_width_m", hip_half_width_m, "must be >= 0 (m)");
  if (!positive(gait_step_base_m)) return badField("gait_step_base_m", gait_step_base_m, "must be > 0 (m)");
  if (!nonNegative(gait_step_per_speed_s))
    return badField("gait_step_per_speed_s", gait_step_per_speed_s, "must be >= 0 (s)");
  if (!nonNegative(gait_rate_std)) return badField("gait_rate_std", gait_rate_std, "must be >= 0");
  if (!positive(gait_offset_std_m)) return badField("gait_offset_std_m", gait_offset_std_m, "must be > 0 (m)");
  if (!nonNegative(gait_memory_s)) return badField("gait_memory_s", gait_memory_s, "must be >= 0 (s)");
  if (!positive(gait_min_speed_mps)) return badField("gait_min_speed_mps", gait_min_speed_mps, "must be > 0 (m/s)");
  if (!nonNegative(merged_legs_max_span_m))
    return badField("merged_legs_max_span_m", merged_legs_max_span_m, "must be >= 0 (m); 0 disables");
  if (!positive(merged_legs_max_radius_m))
    return badField("merged_legs_max_radius_m", merged_legs_max_radius_m, "must be > 0 (m)");
  if (!positive(merged_legs_std_m)) return badField("merged_legs_std_m", merged_legs_std_m, "must be > 0 (m)");
  if (!nonNegative(structure_line_extension_m))
    return badField("structure_line_extension_m", structure_line_extension_m, "must be >= 0 (m); 0 disables");
  if (!nonNegative(map_tolerance_m)) return badField("map_tolerance_m", map_tolerance_m, "must be >= 0 (m)");
  if (!positive(measurement_noise_m)) return badField("measurement_noise_m", measurement_noise_m, "must be > 0 (m)");
  if (!nonNegative(outlier_sigma)) return badField("outlier_sigma", outlier_sigma, "must be >= 0; 0 disables");
  if (!positive(accel_noise_mps2)) return badField("accel_noise_mps2", accel_noise_mps2, "must be > 0 (m/s^2)");
  if (!positive(object_accel_noise_mps2))
    return badField("object_accel_noise_mps2", object_accel_noise_mps2, "must be > 0 (m/s^2)");
  if (!nonNegative(object_hold_s)) return badField("object_hold_s", object_hold_s, "must be >= 0 (s); 0 disables");
  if (!positive(turn_accel_noise_rps2))
    return badField("turn_accel_noise_rps2", turn_accel_noise_rps2, "must be > 0 (rad/s^2)");
  if (!positive(max_turn_rate_rps)) return badField("max_turn_rate_rps", max_turn_rate_rps, "must be > 0 (rad/s)");
  if (!positive(init_speed_std_mps)) return badField("init_speed_std_mps", init_speed_std_mps, "must be > 0 (m/s)");
  if (!positive(init_turn_rate_std_rps))
    return badField("init_turn_rate_std_rps", init_turn_rate_std_rps, "must be > 0 (rad/s)");
  if (!positive(gate_mahalanobis2)) return badField("gate_mahalanobis2", gate_mahalanobis2, "must be > 0");
  if (!positive(gate_max_distance_m)) return badField("gate_max_distance_m", gate_max_distance_m, "must be > 0 (m)");
  if (!nonNegative(merged_separation_factor))
    return badField("merged_separation_factor", merged_separation_factor, "must be >= 0; 0 disables");
  if (!nonNegative(maneuver_gate_m))
    return badField("maneuver_gate_m", maneuver_gate_m, "must be >= 0 (m); 0 disables");
  if (!nonNegative(maneuver_speed_std_mps))
    return badField("maneuver_speed_std_mps", maneuver_speed_std_mps, "must be >= 0 (m/s)");
  if (!(nonNegative(maneuver_position_share) && maneuver_position_share <= 1.0))
    return badField("maneuver_position_share", maneuver_position_share, "must be in [0, 1]");
  if (!nonNegative(maneuver_heading_std_rad))
    return badField("maneuver_heading_std_rad", maneuver_heading_std_rad, "must be >= 0 (rad)");
  if (!nonNegative(maneuver_max_silence_s))
    return badField("maneuver_max_silence_s", maneuver_max_silence_s, "must be >= 0 (s)");
  if (confirm_hits < 1) return badField("confirm_hits", confirm_hits, "must be >= 1");
  if (!positive(tentative_timeout_s)) return badField("tentative_timeout_s", tentative_timeout_s, "must be > 0 (s)");
  if (!positive(deletion_timeout_s)) return badField("deletion_timeout_s", deletion_timeout_s, "must be > 0 (s)");
  if (established_hits < 0) return badField("established_hits", established_hits, "must be >= 0; 0 disables");
  if (!positive(max_position_std_m)) return badField("max_position_std_m", max_position_std_m, "must be > 0 (m)");
  if (!nonNegative(reacquire_window_s)) return badField("reacquire_window_s", reacquire_window_s, "must be >= 0 (s)");
  if (!positive(reacquire_max_distance_m))
    return badField("reacquire_max_distance_m", reacquire_max_distance_m, "must be > 0 (m)");
  if (!nonNegative(reacquire_speed_mps))
    return badField("reacquire_speed_mps", reacquire_speed_mps, "must be >= 0 (m/s)");
  if (!nonNegative(duplicate_max_velocity_difference_mps)) {
    return badField("duplicate_max_velocity_difference_mps", duplicate_max_velocity_difference_mps,
                    "must be >= 0 (m/s)");
  }
  if (!positive(max_time_gap_s)) return badField("max_time_gap_s", max_time_gap_s, "must be > 0 (s)");
  if (!nonNegative(static_speed_threshold_mps))
    return badField("static_speed_threshold_mps", static_speed_threshold_mps, "must be >= 0 (m/s)");
  if (!nonNegative(stationary_window_s))
    return badField("stationary_window_s", stationary_window_s, "must be >= 0 (s); 0 disables");
  if (!positive(stationary_radius_m)) return badField("stationary_radius_m", stationary_radius_m, "must be > 0 (m)");
  if (!(positive(stationary_inlier_fraction) && stationary_inlier_fraction <= 1.0))
    return badField("stationary_inlier_fraction", stationary_inlier_fraction, "must be in (0, 1]");
  if (!nonNegative(stationary_speed_std_mps))
    return badField("stationary_speed_std_mps", stationary_speed_std_mps, "must be >= 0 (m/s); 0 disables");
  if (!positive(stationary_turn_rate_std_rps))
    return badField("stationary_turn_rate_std_rps", stationary_turn_rate_std_rps, "must be > 0 (rad/s)");
  if (!positive(restart_max_speed_mps))
    return badField("restart_max_speed_mps", restart_max_speed_mps, "must be > 0 (m/s)");
  return {};
}

namespace {

using TrackerField = NamedField<TrackerConfig>;

// Every TrackerConfig field by its config/tracker.yaml name (the field name without its unit).
const std::vector<TrackerField>& trackerFields() {
  static const std::vector<TrackerField> fields = {
      {"cluster_distance_base", &TrackerConfig::cluster_distance_base_m},
      {"cluster_distance_beam_factor", &TrackerConfig::cluster_distance_beam_factor},
      {"max_skipped_beams", nullptr, &TrackerConfig::max_skipped_beams},
      {"min_cluster_points", nullptr, &TrackerConfig::min_cluster_points},
      {"range_noise", &TrackerConfig::range_noise_m},
      {"range_noise_fraction", &TrackerConfig::range_noise_fraction},
      {"split_distance", &TrackerConfig::split_distance_m},
      {"segment_min_length", &TrackerConfig::segment_min_length_m},
      {"line_max_rms", &TrackerConfig::line_max_rms_m},
      {"min_arc_sagitta_ratio", &TrackerConfig::min_arc_sagitta_ratio},
      {"max_circle_radius", &TrackerConfig::max_circle_radius_m},
      {"min_circle_radius", &TrackerConfig::min_circle_radius_m},
      {"circle_max_rms", &TrackerConfig::circle_max_rms_m},
      {"fallback_radius", &TrackerConfig::fallback_radius_m},
      {"radius_margin", &TrackerConfig::radius_margin_m},
      {"radius_window", nullptr, &TrackerConfig::radius_window},
      {"radius_quantile", &TrackerConfig::radius_quantile},
      {"pair_legs", nullptr, nullptr, &TrackerConfig::pair_legs},
      {"leg_min_points", nullptr, &TrackerConfig::leg_min_points},
      {"leg_max_radius", &TrackerConfig::leg_max_radius_m},
      {"leg_pair_max_distance", &TrackerConfig::leg_pair_max_distance_m},
      {"person_radius", &TrackerConfig::person_radius_m},
      {"lone_leg_std", &TrackerConfig::lone_leg_std_m},
      {"merged_legs_max_span", &TrackerConfig::merged_legs_max_span_m},
      {"merged_legs_max_radius", &TrackerConfig::merged_legs_max_radius_m},
      {"merged_legs_std", &TrackerConfig::merged_legs_std_m},
      {"gait_model", nullptr, nullptr, &TrackerConfig::gait_model},
      {"hip_half_width", &TrackerConfig::hip_half_width_m},
      {"gait_step_base", &TrackerConfig::gait_step_base_m},
      {"gait_step_per_speed", &TrackerConfig::gait_step_per_speed_s},
      {"gait_rate_std", &TrackerConfig::gait_rate_std},
      {"gait_offset_std", &TrackerConfig::gait_offset_std_m},
      {"gait_memory", &TrackerConfig::gait_memory_s},
      {"gait_min_speed", &TrackerConfig::gait_min_speed_mps},
      {"structure_memory", &TrackerConfig::structure_memory_s},
      {"structure_cell", &TrackerConfig::structure_cell_m},
      {"structure_min_scans", nullptr, &TrackerConfig::structure_min_scans},
      {"structure_max_fraction", &TrackerConfig::structure_max_fraction},
      {"structure_line_extension", &TrackerConfig::structure_line_extension_m},
      {"map_tolerance", &TrackerConfig::map_tolerance_m},
      {"measurement_noise", &TrackerConfig::measurement_noise_m},
      {"outlier_sigma", &TrackerConfig::outlier_sigma},
      {"people_constant_velocity", nullptr, nullptr, &TrackerConfig::people_constant_velocity},
      {"people_start_from_rest", nullptr, nullptr, &TrackerConfig::people_start_from_rest},
      {"objects_refit_leg_detections", nullptr, nullptr, &TrackerConfig::objects_refit_leg_detections},
      {"object_accel_noise", &TrackerConfig::object_accel_noise_mps2},
      {"object_hold", &TrackerConfig::object_hold_s},
      {"accel_noise", &TrackerConfig::accel_noise_mps2},
      {"turn_accel_noise", &TrackerConfig::turn_accel_noise_rps2},
      {"max_turn_rate", &TrackerConfig::max_turn_rate_rps},
      {"init_speed_std", &TrackerConfig::init_speed_std_mps},
      {"init_turn_rate_std", &TrackerConfig::init_turn_rate_std_rps},
      {"gate_mahalanobis2", &TrackerConfig::gate_mahalanobis2},
      {"gate_max_distance", &TrackerConfig::gate_max_distance_m},
      {"merged_separation_factor", &TrackerConfig::merged_separation_factor},
      {"maneuver_gate", &TrackerConfig::maneuver_gate_m},
      {"maneuver_max_silence", &TrackerConfig::maneuver_max_silence_s},
      {"maneuver_speed_std", &TrackerConfig::maneuver_speed_std_mps},
      {"maneuver_heading_std", &TrackerConfig::maneuver_heading_std_rad},
      {"maneuver_position_share", &TrackerConfig::maneuver_position_share},
      {"confirm_hits", nullptr, &TrackerConfig::confirm_hits},
      {"tentative_timeout", &TrackerConfig::tentative_timeout_s},
      {"deletion_timeout", &TrackerConfig::deletion_timeout_s},
      {"established_hits", nullptr, &TrackerConfig::established_hits},
      {"drop_seen_through", nullptr, nullptr, &TrackerConfig::drop_seen_through},
      {"max_position_std", &TrackerConfig::max_position_std_m},
      {"reacquire_window", &TrackerConfig::reacquire_window_s},
      {"reacquire_max_distance", &TrackerConfig::reacquire_max_distance_m},
      {"reacquire_speed", &TrackerConfig::reacquire_speed_mps},
      {"reacquire_follow_turn", nullptr, nullptr, &TrackerConfig::reacquire_follow_turn},
      {"duplicate_max_velocity_difference", &TrackerConfig::duplicate_max_velocity_difference_mps},
      {"max_time_gap", &TrackerConfig::max_time_gap_s},
      {"static_speed_threshold", &TrackerConfig::static_speed_threshold_mps},
      {"stationary_window", &TrackerConfig::stationary_window_s},
      {"stationary_radius", &TrackerConfig::stationary_radius_m},
      {"stationary_inlier_fraction", &TrackerConfig::stationary_inlier_fraction},
      {"stationary_speed_std", &TrackerConfig::stationary_speed_std_mps},
      {"stationary_turn_rate_std", &TrackerConfig::stationary_turn_rate_std_rps},
      {"restart_from_rest", nullptr, nullptr, &TrackerConfig::restart_from_rest},
      {"restart_max_speed", &TrackerConfig::restart_max_speed_mps},
  };
  return fields;
}

}  // namespace

std::string setTrackerParameter(TrackerConfig& config, const std::string& name, const std::string& value) {
  return setNamedField(trackerFields(), config, "tracker parameter", name, value,
                       "(the names of config/tracker.yaml's tracker/ block)");
}

const std::vector<std::string>& trackerParameterNames() {
  static const std::vector<std::string> names = namedFieldNames(trackerFields());
  return names;
}

double TrackerConfig::rangeNoise_m(double range_m) const {
  return std::max(range_noise_m, range_noise_fraction * range_m);
}

const char* toString(TrackerStatus status) {
  switch (status) {
    case TrackerStatus::kOk:
      return "ok";
    case TrackerStatus::kRejected:
      return "rejected";
    case TrackerStatus::kReset:
      return "reset";
  }
  return "unknown";
}

namespace {
const TrackerConfig& validated(const TrackerConfig& config) {
  const std::string why = config.validate();
  if (!why.empty()) throw TrackerConfigError(why);
  return config;
}
}  // namespace

ObstacleTracker::ObstacleTracker(const TrackerConfig& config)
    : config_(validated(config)),
      structure_(config.structure_cell_m, config.structure_memory_s > 0.0 ? config.structure_memory_s : 1.0) {}

void ObstacleTracker::reset() {
  tracks_.clear();
  lost_.clear();
  structure_.clear();
  scene_ = TrackedScene{};
  detections_ = ScanDetections{};
  has_stamp_ = false;
  last_stamp_s_ = 0.0;
}

TrackerResult ObstacleTracker::update(const LaserScan2& scan, const Pose2& laser_pose, const MapStructureView& map) {
  TrackerResult result;
  auto reject = [&](const std::string& why) {
    result.status = TrackerStatus::kRejected;
    result.message = "scan rejected: " + why;
    result.scene = scene_;
    return result;
  };
  const std::string scan_problem = checkScan(scan);
  if (!scan_problem.empty()) return reject(scan_problem);
  if (!laser_pose.isFinite()) {
    std::ostringstream os;
    os << "laser pose (" << laser_pose.x << ", " << laser_pose.y << ", " << laser_pose.theta << ") is not finite";
    return reject(os.str());
  }
  if (has_stamp_) {
    const double dt = scan.stamp_s - last_stamp_s_;
    if (dt == 0.0) {
      return reject("same stamp as the previous scan (" + std::to_string(scan.stamp_s) +
                    " s); a measurement is used once");
    }
    if (dt < 0.0 || dt > config_.max_time_gap_s) {
      std::ostringstream os;
      os << "tracks reset: scan stamp " << scan.stamp_s << " s is " << std::abs(dt) << " s "
         << (dt < 0.0 ? "before the previous scan (time went backwards, e.g. a looping bag)"
                      : "after the previous scan (gap longer than max_time_gap_s)");
      reset();
      result.status = TrackerStatus::kReset;
      result.message = os.str();
    }
  }

  if (config_.structure_memory_s > 0.0) structure_.expire(scan.stamp_s);
  detections_ = detectObstacles(scan, laser_pose, config_, config_.structure_memory_s > 0.0 ? &structure_ : nullptr,
                                map.fixed_in_map.isFinite() ? map : MapStructureView{});
  result.ignored_beams = detections_.ignored_beams;
  predictTracks(scan.stamp_s);
  associateAndUpdate(detections_, scan.stamp_s);
  for (Track& t : tracks_) {
    if (t.updated_this_scan) continue;
    if (isHeldObject(t)) {
      t.seen_through =
          seenThrough(t.stationary_position, std::max(t.radius, config_.min_circle_radius_m), scan, laser_pose);
    } else if (config_.drop_seen_through && t.confirmed && t.hits >= 2) {
      // A coasting track where the scan shows nothing: whatever it followed is elsewhere (docs/tracker.md, "Tracks
      // where the scan sees nothing"). Only the whole disc seen empty counts: among people the beams through the
      // middle of a body pass between its legs.
      t.seen_through =
          seenClearThrough(t.ekf.position(), std::max(t.radius, config_.min_circle_radius_m), scan, laser_pose);
    }
  }
  pruneTracks(scan.stamp_s);
  has_stamp_ = true;
  last_stamp_s_ = scan.stamp_s;
  buildScene(scan.stamp_s);
  result.scene = scene_;
  return result;
}

namespace {

/// Visits the valid returns of the beams within half_angle of the bearing of `center` seen from the laser:
/// visit(beam angle from that bearing, range) returns false to stop. A full turn wraps around: a disc across the
/// scan's seam has beams at both ends. Beams that return nothing are skipped: a dark or glancing surface drops beams
/// too, so they say nothing.
template <typename Visit>
void forEachReturnToward(double bearing, double half_angle, const LaserScan2& scan, Visit visit) {
  const double a = (bearing - half_angle - scan.angle_min) / scan.angle_increment;
  const double b = (bearing + half_angle - scan.angle_min) / scan.angle_increment;
  const long n = static_cast<long>(scan.ranges.size());
  const bool full_turn = static_cast<double>(n) * std::abs(scan.angle_increment) >= kTwoPi - 1e-6;
  for (long k = static_cast<long>(std::ceil(std::min(a, b))); k <= static_cast<long>(std::floor(std::max(a, b))); ++k) {
    const long i = full_turn ? ((k % n) + n) % n : k;
    if (i < 0 || i >= n) continue;
    const double range = scan.ranges[static_cast<size_t>(i)];
    if (!std::isfinite(range) || range < scan.range_min || range >= scan.range_max) continue;
    if (!visit(scan.angle_min + static_cast<double>(k) * scan.angle_increment - bearing, range)) return;
  }
}

}  // namespace

bool ObstacleTracker::seenThrough(const Vec2& center, double radius, const LaserScan2& scan, const Pose2& laser_pose) {
  const Vec2 rel = center - laser_pose.position();
  const double d = rel.norm();
  if (d <= radius || d - radius >= scan.range_max) return false;
  // The beams within half the object's angular half-width of its centre: those that would hit it near its middle.
  const double bearing = angleDiff(std::atan2(rel.y(), rel.x()), laser_pose.theta);
  int valid = 0, beyond = 0;
  forEachReturnToward(bearing, 0.5 * std::asin(radius / d), scan, [&](double, double range) {
    ++valid;
    if (range > d) ++beyond;
    return true;
  });
  return valid >= 2 && 2 * beyond > valid;
}

bool ObstacleTracker::seenClearThrough(const Vec2& center, double radius, const LaserScan2& scan,
                                       const Pose2& laser_pose) {
  const Vec2 rel = center - laser_pose.position();
  const double d = rel.norm();
  if (d <= radius || d + radius >= scan.range_max) return false;
  const double bearing = angleDiff(std::atan2(rel.y(), rel.x()), laser_pose.theta);
  int valid = 0;
  bool clear = true;
  forEachReturnToward(bearing, std::asin(radius / d), scan, [&](double phi, double range) {
    // Where this beam leaves the disc: a return before that is something in front of it or in it.
    const double off = d * std::sin(phi);
    const double exit = d * std::cos(phi) + std::sqrt(std::max(0.0, radius * radius - off * off));
    clear = range > exit;
    ++valid;
    return clear;
  });
  return clear && valid >= 3;
}

void ObstacleTracker::predictTracks(double stamp_s) {
  if (!has_stamp_) return;
  const double dt = stamp_s - last_stamp_s_;
  for (Track& t : tracks_) {
    t.updated_this_scan = false;
    // One-hit tracks have no velocity: they stay at their first detection (the gate grows instead). A still object
    // stays where it stands, as sure of it as when last seen.
    if (t.hits < 2 || isHeldObject(t)) continue;
    t.ekf.predict(dt, accelNoise(t), config_.turn_accel_noise_rps2);
    t.ekf.clampTurnRate(config_.max_turn_rate_rps);
  }
  lost_.erase(std::remove_if(lost_.begin(), lost_.end(),
                             [&](const Track& t) { return stamp_s - t.last_hit_s > config_.reacquire_window_s; }),
              lost_.end());
}

Eigen::Matrix2d ObstacleTracker::measurementCovariance(const CircleDetection& detection) const {
  // Fallback placements guess the depth of the centre: trust them less.
  const double sigma = detection.free_fit ? config_.measurement_noise_m : 2.0 * config_.measurement_noise_m;
  const double var = sigma * sigma + detection.fit_rms_m * detection.fit_rms_m;
  return var * Eigen::Matrix2d::Identity();
}

Eigen::Matrix2d ObstacleTracker::robustCovariance(const Track& track, const Vec2& z, const Eigen::Matrix2d& r) const {
  if (config_.outlier_sigma <= 0.0) return r;
  const double d2 = track.ekf.mahalanobis2(z, r);
  const double k2 = config_.outlier_sigma * config_.outlier_sigma;
  return std::isfinite(d2) && d2 > k2 ? Eigen::Matrix2d(r * (d2 / k2)) : r;
}

double ObstacleTracker::associationCost(const Track& track, const CircleDetection& detection, double stamp_s) const {
  const double inf = std::numeric_limits<double>::infinity();
  const Vec2& z = detection.circle.center;
  // The detection's own uncertainty (a lone leg places a person loosely), as in the update.
  const Eigen::Matrix2d r = measurementCovariance(detection);
  if (track.hits < 2) {
    const Vec2 nu = z - track.first_position;
    if (nu.norm() > config_.gate_max_distance_m) return inf;
    const double dt = stamp_s - track.born_s;
    const double var = 2.0 * r(0, 0) + std::pow(config_.init_speed_std_mps * dt, 2);
    return nu.squaredNorm() / var;
  }
  if ((z - track.ekf.position()).norm() > config_.gate_max_distance_m) return inf;
  return track.ekf.mahalanobis2(z, r);
}

void ObstacleTracker::associateAndUpdate(const ScanDetections& detections, double stamp_s) {
  const size_t nt = tracks_.size(), nd = detections.circles.size();
  std::vector<int> track_to_det(nt, -1);
  Eigen::MatrixXd cost(nt, nd);
  if (nt > 0 && nd > 0) {
    for (size_t i = 0; i < nt; ++i) {
      for (size_t j = 0; j < nd; ++j) {
        cost(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) =
            associationCost(tracks_[i], detections.circles[j], stamp_s);
      }
    }
    track_to_det = solveGatedAssignment(cost, config_.gate_mahalanobis2);
  }
  std::vector<bool> used(nd, false);
  for (size_t i = 0; i < nt; ++i) {
    if (track_to_det[i] < 0) continue;
    used[track_to_det[i]] = true;
    // Two bodies in one detection: neither track takes it (both coast until they part).
    if (!mergedWithAnotherTrack(i, track_to_det, cost))
      updateTrack(tracks_[i], detections.circles[track_to_det[i]], stamp_s);
  }
  // Second chance for recently seen tracks that found nothing in their gate: the obstacle manoeuvred.
  std::vector<size_t> lost_tracks, free_dets;
  for (size_t i = 0; i < nt; ++i) {
    const Track& t = tracks_[i];
    if (track_to_det[i] < 0 && t.hits >= 2 && stamp_s - t.last_hit_s <= config_.maneuver_max_silence_s) {
      lost_tracks.push_back(i);
    }
  }
  for (size_t j = 0; j < nd; ++j) {
    if (!used[j]) free_dets.push_back(j);
  }
  if (config_.maneuver_gate_m > 0.0 && !lost_tracks.empty() && !free_dets.empty()) {
    Eigen::MatrixXd cost(lost_tracks.size(), free_dets.size());
    for (size_t a = 0; a < lost_tracks.size(); ++a) {
      for (size_t b = 0; b < free_dets.size(); ++b) {
        const double d =
            (tracks_[lost_tracks[a]].ekf.position() - detections.circles[free_dets[b]].circle.center).norm();
        cost(static_cast<Eigen::Index>(a), static_cast<Eigen::Index>(b)) =
            d <= config_.maneuver_gate_m ? d : std::numeric_limits<double>::infinity();
      }
    }
    const std::vector<int> second = solveGatedAssignment(cost, 2.0 * config_.maneuver_gate_m);
    for (size_t a = 0; a < lost_tracks.size(); ++a) {
      if (second[a] < 0) continue;
      const size_t j = free_dets[second[a]];
      used[j] = true;
      updateTrack(tracks_[lost_tracks[a]], detections.circles[j], stamp_s, true);
    }
  }
  for (size_t j = 0; j < nd; ++j) {
    if (used[j]) continue;
    // A leftover piece of an obstacle that already has a track (a split cluster) must not start a second one.
    const Vec2& c = detections.circles[j].circle.center;
    const bool inside_existing = std::any_of(tracks_.begin(), tracks_.end(), [&](const Track& t) {
      return t.hits >= 2 && (t.ekf.position() - c).norm() < std::max(t.radius, config_.fallback_radius_m);
    });
    if (!inside_existing) birthTrack(detections.circles[j], stamp_s);
  }
}

bool ObstacleTracker::mergedWithAnotherTrack(size_t i, const std::vector<int>& track_to_det,
                                             const Eigen::MatrixXd& cost) const {
  const Track& t = tracks_[i];
  const auto j = static_cast<Eigen::Index>(track_to_det[i]);
  if (config_.merged_separation_factor <= 0.0 || config_.pair_legs || t.hits < 2) return false;
  for (size_t k = 0; k < tracks_.size(); ++k) {
    const Track& other = tracks_[k];
    if (k == i || track_to_det[k] >= 0 || !other.confirmed || other.hits < 2) continue;
    const double separation = (other.ekf.position() - t.ekf.position()).norm();
    if (separation < config_.merged_separation_factor * (other.radius + t.radius) &&
        cost(static_cast<Eigen::Index>(k), j) < config_.gate_mahalanobis2) {
      return true;
    }
  }
  return false;
}

GaitParams ObstacleTracker::gaitParams() const {
  GaitParams g;
  g.step_base_m = config_.gait_step_base_m;
  g.step_per_speed_s = config_.gait_step_per_speed_s;
  g.rate_std = config_.gait_rate_std;
  g.offset_std_m = config_.gait_offset_std_m;
  return g;
}

void ObstacleTracker::updateGait(Track& track, const CircleDetection& detection, double stamp_s) const {
  if (!config_.pair_legs || !config_.gait_model || !detection.paired_legs || track.hits < 2) return;
  const Vec2 v = track.ekf.velocity();
  const double speed = v.norm();
  if (speed < config_.gait_min_speed_mps) {
    track.gait.reset();  // standing, or too slow to know which way is forward
    return;
  }
  const Vec2 forward = v / speed, left(-forward.y(), forward.x());
  // The left leg is the one on the left of the walking direction: the pair's first leg or the second.
  const Vec2 left_leg = detection.leg_offset.dot(left) >= 0.0 ? detection.leg_offset : Vec2(-detection.leg_offset);
  track.gait.update(left_leg.dot(forward), speed, stamp_s, config_.gait_memory_s, gaitParams());
}

void ObstacleTracker::placeLoneLeg(const Track& track, const CircleDetection& detection, double stamp_s, Vec2& z,
                                   Eigen::Matrix2d& r) const {
  if (!config_.pair_legs || !config_.gait_model || !detection.lone_leg || track.hits < 2 || !track.gait.active() ||
      stamp_s - track.gait.stamp() > config_.gait_memory_s) {
    return;
  }
  const Vec2 v = track.ekf.velocity();
  const double speed = v.norm();
  if (speed < config_.gait_min_speed_mps) return;
  const Vec2 forward = v / speed, left(-forward.y(), forward.x());
  double swing = 0.0, swing_var = 0.0;
  track.gait.predict(speed, stamp_s, gaitParams(), swing, swing_var);
  // The left leg's predicted offset from the body's centre; the right leg's is its negative.
  const Vec2 d = config_.hip_half_width_m * left + swing * forward;
  const double base_var = config_.gait_offset_std_m * config_.gait_offset_std_m;
  const Eigen::Matrix2d along = forward * forward.transpose();
  // Which leg it is: each hypothesis weighed by how well the body it implies fits the track's prediction.
  const Eigen::Matrix2d spread =
      track.ekf.covariance().topLeftCorner<2, 2>() + swing_var * along + base_var * Eigen::Matrix2d::Identity();
  const Eigen::Matrix2d information = spread.inverse();
  const Vec2 c = track.ekf.position();
  const Vec2 if_left = z - d - c, if_right = z + d - c;
  const double w_left =
      1.0 / (1.0 + std::exp(0.5 * if_left.dot(information * if_left) - 0.5 * if_right.dot(information * if_right)));
  if (!std::isfinite(w_left)) return;
  // The two-body mixture by its mean and covariance.
  const double k = 2.0 * w_left - 1.0;
  z -= k * d;
  r = base_var * Eigen::Matrix2d::Identity() + swing_var * along + (1.0 - k * k) * d * d.transpose();
}

void ObstacleTracker::updateTrack(Track& track, const CircleDetection& detection, double stamp_s, bool maneuver) {
  // An object's arc cut short by a passing leg, or a leg beside it, can look like legs: among its own returns.
  const bool as_object = detection.from_legs && config_.objects_refit_leg_detections && isObjectTrack(track);
  // Radius: only free fits speak about it; keep a window and report a high quantile (short arcs scatter low).
  if (detection.free_fit && !as_object) {
    track.radii.push_front(detection.circle.radius);
    while (static_cast<int>(track.radii.size()) > config_.radius_window) track.radii.pop_back();
  }
  if (!track.radii.empty()) {
    std::vector<double> sorted(track.radii.begin(), track.radii.end());
    std::sort(sorted.begin(), sorted.end());
    const size_t k = static_cast<size_t>(std::lround(config_.radius_quantile * static_cast<double>(sorted.size() - 1)));
    track.radius = sorted[k];
  }
  // With a known radius, one short arc pins the centre better than a free fit of centre and radius.
  CircleDetection measured = detection;
  if (track.radii.size() >= 3 && detection.points.size() >= 3 && (!detection.from_legs || as_object)) {
    if (const auto refit = fitCircleFixedRadius(detection.points, track.radius, detection.circle.center)) {
      if ((refit->circle.center - detection.circle.center).norm() < track.radius) {
        measured.circle.center = refit->circle.center;
        measured.fit_rms_m = refit->rms_m;
        measured.free_fit = true;
      }
    }
  }
  Vec2 z = measured.circle.center;
  Eigen::Matrix2d r = measurementCovariance(measured);
  if (!as_object) placeLoneLeg(track, detection, stamp_s, z, r);
  const bool stood_still = track.stationary;
  const Vec2 rest_position = track.stationary_position;
  const Vec2 previous_z = track.recent_hits.empty() ? z : track.recent_hits.back().second;
  updateStationarity(track, z, stamp_s);
  if (track.hits == 1) {
    // Among people (constant velocity) the first detection's filter (at rest, the velocity spread
    // init_speed_std_mps every way; one-hit tracks are not predicted between scans) is updated by the second: the
    // velocity is the two detections' difference shrunk by how little two noisy positions 0.1 s apart say.
    bool from_rest = false;
    if (config_.people_start_from_rest && motionModel() == MotionModel::kConstantVelocity) {
      CtrvEkf filter = track.ekf;
      filter.predict(stamp_s - track.born_s, accelNoise(track), config_.turn_accel_noise_rps2);
      from_rest = filter.update(z, r);
      if (from_rest) track.ekf = filter;
    }
    if (!from_rest) startMotion(track, track.first_position, track.born_s, z, stamp_s, r);
  } else if (config_.restart_from_rest && !config_.pair_legs && stood_still && !track.stationary &&
             (z - rest_position).norm() > config_.stationary_radius_m && stamp_s > track.last_hit_s &&
             (z - previous_z).norm() <= config_.restart_max_speed_mps * (stamp_s - track.last_hit_s)) {
    // It walks off from rest: its filter, told "speed 0" and pointing where it last went, would lag. (A faster
    // jump is a passer-by merged into its detection, not it.)
    startMotion(track, previous_z, track.last_hit_s, z, stamp_s, r);
  } else {
    if (maneuver) {
      // Among people seen by their legs most detections outside the gate only look like a manoeuvre (a person
      // placed on the wrong legs, or on two legs merged into one circle): the motion is re-opened, the position
      // by a share of the miss only (none by default), so such a detection moves the track part of the way and a
      // true manoeuvre is followed over a few scans. Discs that turn or stop are followed at once, as they are.
      const bool soft = config_.pair_legs;
      const Vec2 miss = (soft ? config_.maneuver_position_share : 1.0) * (z - track.ekf.position());
      track.ekf.reopen(miss.cwiseProduct(miss), soft ? std::pow(config_.maneuver_heading_std_rad, 2) : 0.25 * kPi * kPi,
                       std::pow(soft ? config_.maneuver_speed_std_mps : config_.init_speed_std_mps, 2),
                       std::pow(config_.init_turn_rate_std_rps, 2));
    }
    if (!track.ekf.update(z, maneuver ? r : robustCovariance(track, z, r))) return;  // unusable: a miss
  }
  if (track.stationary && config_.stationary_speed_std_mps > 0.0) {
    // Tell the filter as well, so its speed settles at 0 instead of creeping: a hidden chair stays where it was
    // (and, once lost, is remembered standing, not walking off at its creep).
    track.ekf.updateStandingStill(config_.stationary_speed_std_mps, config_.stationary_turn_rate_std_rps);
  }
  track.ekf.clampTurnRate(config_.max_turn_rate_rps);
  if (!as_object) updateGait(track, detection, stamp_s);
  track.hits += 1;
  (detection.from_legs ? track.leg_hits : track.object_hits) += 1;
  track.last_hit_s = stamp_s;
  track.hit_position = track.ekf.position();
  track.hit_velocity = track.ekf.velocity();
  track.hit_turn_rate = track.ekf.state()(kCtrvTurnRate);
  track.updated_this_scan = true;
  if (!track.confirmed && track.hits >= config_.confirm_hits) {
    track.confirmed = true;
    takeOverLostTrack(track, stamp_s);
  }
  if (track.ekf.state()(kCtrvSpeed) >= config_.static_speed_threshold_mps) {
    track.reported_heading = track.ekf.state()(kCtrvHeading);
  }
}

void ObstacleTracker::startMotion(Track& track, const Vec2& from, double from_s, const Vec2& z, double stamp_s,
                                  const Eigen::Matrix2d& r) const {
  const double dt = stamp_s - from_s;
  const Vec2 vel = (z - from) / dt;
  const double speed = vel.norm();
  const double speed_var = 2.0 * r(0, 0) / (dt * dt) + std::pow(config_.accel_noise_mps2 * dt, 2);
  track.ekf = CtrvEkf::start(motionModel(), z, r, vel, speed_var, speed_var / std::max(speed * speed, 1e-12),
                             std::pow(config_.init_turn_rate_std_rps, 2));
}

void ObstacleTracker::updateStationarity(Track& track, const Vec2& z, double stamp_s) {
  track.stationary = false;
  const double window = config_.stationary_window_s;
  if (window <= 0.0) return;
  auto& hits = track.recent_hits;
  hits.emplace_back(stamp_s, z);
  while (!hits.empty() && hits.front().first < stamp_s - window - 1e-9) hits.pop_front();
  if (hits.size() < 4 || stamp_s - hits.front().first < 0.75 * window) return;
  // Component-wise median: a leg passing by, or one bad fit, does not move it. (Scratch buffers of the tracker:
  // this runs for every track at every hit.)
  std::vector<double>& xs = median_scratch_x_;
  std::vector<double>& ys = median_scratch_y_;
  xs.clear();
  ys.clear();
  for (const auto& h : hits) {
    xs.push_back(h.second.x());
    ys.push_back(h.second.y());
  }
  auto median = [](std::vector<double>& v) {
    const size_t mid = v.size() / 2;
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(mid), v.end());
    return v[mid];
  };
  const Vec2 m(median(xs), median(ys));
  const double r = config_.stationary_radius_m;
  size_t inside = 0;
  for (const auto& h : hits) inside += (h.second - m).norm() <= r ? 1 : 0;
  const bool last_two_inside = (hits.back().second - m).norm() <= r && (hits[hits.size() - 2].second - m).norm() <= r;
  if (last_two_inside &&
      static_cast<double>(inside) >= config_.stationary_inlier_fraction * static_cast<double>(hits.size())) {
    track.stationary = true;
    track.stationary_position = m;
  }
}

double ObstacleTracker::reacquireDistance(const Track& track, const Vec2& z, double silent_s) const {
  if ((z - track.hit_position).norm() > config_.reacquire_max_distance_m + config_.reacquire_speed_mps * silent_s) {
    return std::numeric_limits<double>::infinity();
  }
  const double w = track.hit_turn_rate;
  const double speed = track.hit_velocity.norm();
  if (!config_.reacquire_follow_turn || config_.pair_legs || std::abs(w) < 1e-3 || speed < 1e-6) {
    return pointSegmentDistance(z, Segment{track.hit_position, track.hit_position + silent_s * track.hit_velocity});
  }
  // The arc its filter would have predicted, as chords of at most 0.25 s.
  const int pieces = std::clamp(static_cast<int>(std::ceil(silent_s / 0.25)), 1, 64);
  const Pose2 lost{track.hit_position.x(), track.hit_position.y(),
                   std::atan2(track.hit_velocity.y(), track.hit_velocity.x())};
  double best = std::numeric_limits<double>::infinity();
  Vec2 previous = track.hit_position;
  for (int k = 1; k <= pieces; ++k) {
    const Vec2 next = integrateUnicycle(lost, speed, w, silent_s * static_cast<double>(k) / pieces).position();
    best = std::min(best, pointSegmentDistance(z, Segment{previous, next}));
    previous = next;
  }
  return best;
}

void ObstacleTracker::takeOverLostTrack(Track& track, double stamp_s) {
  // Candidates: confirmed tracks dropped for silence, and live ones that have found nothing since this one was born.
  const Vec2 z = track.ekf.position();
  double best_d = config_.reacquire_max_distance_m;
  Track* best_live = nullptr;
  auto best_lost = lost_.end();
  auto closer = [&](const Track& old) {
    const double d = reacquireDistance(old, z, stamp_s - old.last_hit_s);
    if (d > best_d) return false;
    best_d = d;
    return true;
  };
  for (Track& old : tracks_) {
    if (&old == &track || !old.confirmed || old.absorbed || old.hits < 2 || old.last_hit_s >= track.born_s) continue;
    // A still object kept while unseen is found again by its own gate, where it stands; a new track nearby is
    // someone else.
    if (isHeldObject(old)) continue;
    if (closer(old)) best_live = &old;
  }
  for (auto it = lost_.begin(); it != lost_.end(); ++it) {
    if (it->last_hit_s < track.born_s && closer(*it)) {
      best_lost = it;
      best_live = nullptr;
    }
  }
  if (best_live != nullptr) {
    track.id = best_live->id;
    best_live->absorbed = true;
  } else if (best_lost != lost_.end()) {
    track.id = best_lost->id;
    lost_.erase(best_lost);
  }
}

void ObstacleTracker::birthTrack(const CircleDetection& detection, double stamp_s) {
  Track t;
  // A fresh id; on confirmation it may take over a lost track's (takeOverLostTrack).
  t.id = next_id_++;
  t.born_s = stamp_s;
  t.last_hit_s = stamp_s;
  t.hits = 1;
  t.first_position = detection.circle.center;
  t.hit_position = detection.circle.center;
  t.ekf =
      CtrvEkf::start(motionModel(), detection.circle.center, measurementCovariance(detection), Vec2::Zero(),
                     std::pow(config_.init_speed_std_mps, 2), kPi * kPi, std::pow(config_.init_turn_rate_std_rps, 2));
  (detection.from_legs ? t.leg_hits : t.object_hits) = 1;
  if (detection.free_fit) t.radii.push_front(detection.circle.radius);
  t.radius = detection.free_fit ? detection.circle.radius : config_.fallback_radius_m;
  t.confirmed = config_.confirm_hits <= 1;
  t.updated_this_scan = true;
  tracks_.push_back(std::move(t));
  if (tracks_.back().confirmed) takeOverLostTrack(tracks_.back(), stamp_s);
}

void ObstacleTracker::pruneTracks(double stamp_s) {
  auto dead = [&](const Track& t) {
    if (t.absorbed) return true;
    const double silent = stamp_s - t.last_hit_s;
    if (t.seen_through) return true;
    if (isHeldObject(t)) return silent > config_.object_hold_s;
    const bool established = !config_.pair_legs || t.hits >= config_.established_hits;
    if (silent > (t.confirmed && established ? config_.deletion_timeout_s : config_.tentative_timeout_s)) return true;
    const CtrvCovariance& p = t.ekf.covariance();
    if (!t.ekf.state().allFinite() || !p.allFinite()) return true;
    return std::sqrt(std::max(p(kCtrvX, kCtrvX), p(kCtrvY, kCtrvY))) > config_.max_position_std_m;
  };
  for (const Track& t : tracks_) {
    if (t.confirmed && !t.absorbed && t.hits >= 2 && dead(t) && t.ekf.state().allFinite() &&
        config_.reacquire_window_s > 0.0) {
      lost_.push_back(t);
    }
  }
  tracks_.erase(std::remove_if(tracks_.begin(), tracks_.end(), dead), tracks_.end());
  // Two tracks on one object (e.g. a coasting track and a fresh one after a missed association): keep the one
  // with more evidence.
  std::vector<bool> drop(tracks_.size(), false);
  for (size_t i = 0; i < tracks_.size(); ++i) {
    for (size_t j = i + 1; j < tracks_.size(); ++j) {
      if (drop[i] || drop[j]) continue;
      const Track& a = tracks_[i];
      const Track& b = tracks_[j];
      const Vec2 pa = a.hits < 2 ? a.first_position : a.ekf.position();
      const Vec2 pb = b.hits < 2 ? b.first_position : b.ekf.position();
      // Among people (pair_legs) two bodies are never closer than one body radius.
      const double overlap = std::max(0.5 * std::max({a.radius, b.radius, config_.fallback_radius_m}),
                                      config_.pair_legs ? config_.person_radius_m : 0.0);
      if ((pa - pb).norm() >= overlap) continue;
      // Two discs passing through each other (without pair_legs) are two tracks on one spot that move apart.
      if (!config_.pair_legs && config_.duplicate_max_velocity_difference_mps > 0.0 && a.confirmed && b.confirmed &&
          stamp_s - a.born_s >= 1.0 && stamp_s - b.born_s >= 1.0 &&
          (a.ekf.velocity() - b.ekf.velocity()).norm() > config_.duplicate_max_velocity_difference_mps) {
        continue;
      }
      const bool keep_a = a.confirmed != b.confirmed ? a.confirmed : a.hits >= b.hits;
      drop[keep_a ? j : i] = true;
    }
  }
  size_t k = 0;
  tracks_.erase(std::remove_if(tracks_.begin(), tracks_.end(), [&](const Track&) { return drop[k++]; }), tracks_.end());
}

TrackedObstacle ObstacleTracker::toTrackedObstacle(const Track& track, double stamp_s) const {
  TrackedObstacle o;
  const CtrvState& x = track.ekf.state();
  o.id = track.id;
  o.center = x.head<2>();
  o.radius = track.radius + config_.radius_margin_m;
  o.speed = x(kCtrvSpeed);
  o.turn_rate = x(kCtrvTurnRate);
  if (track.stationary) {
    // It stands still (updateStationarity): where its detections were, not where a creeping filter puts it.
    o.center = track.stationary_position;
    o.speed = 0.0;
    o.turn_rate = 0.0;
  }
  o.is_static = o.speed < config_.static_speed_threshold_mps;
  // Heading of a (nearly) still target is noise: report the last heading it had while moving.
  o.heading = o.is_static ? track.reported_heading : x(kCtrvHeading);
  o.covariance = track.ekf.covariance();
  o.age_s = stamp_s - track.born_s;
  o.hits = track.hits;
  return o;
}

void ObstacleTracker::buildScene(double stamp_s) {
  scene_.stamp_s = stamp_s;
  scene_.obstacles.clear();
  for (const Track& t : tracks_) {
    if (t.confirmed && t.hits >= 2) scene_.obstacles.push_back(toTrackedObstacle(t, stamp_s));
  }
  scene_.segments = detections_.segments;
}

TrackedScene ObstacleTracker::predictedScene(double stamp_s) const {
  if (!has_stamp_ || !std::isfinite(stamp_s) || stamp_s <= last_stamp_s_) return scene_;
  TrackedScene out = scene_;
  out.stamp_s = stamp_s;
  const double dt = stamp_s - last_stamp_s_;
  if (dt > config_.max_time_gap_s) {
    // A scan that late resets the tracks (update()); predicting them that far gives meaningless (and, for
    // absurd gaps, non-finite) states and covariances.
    out.obstacles.clear();
    return out;
  }
  size_t k = 0;
  for (const Track& t : tracks_) {
    if (!(t.confirmed && t.hits >= 2)) continue;
    Track moved = t;
    if (!isHeldObject(moved)) moved.ekf.predict(dt, accelNoise(moved), config_.turn_accel_noise_rps2);
    out.obstacles[k++] = toTrackedObstacle(moved, stamp_s);
  }
  return out;
}

}  // namespace dqn_dovs
