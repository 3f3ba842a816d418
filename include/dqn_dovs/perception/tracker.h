// LIDAR obstacle tracker: scan -> clusters -> circles (moving-object candidates) and segments (walls) ->
// gated optimal association -> one CTRV extended Kalman filter per track, all in a fixed frame.
// ROS-free (Eigen + std); obstacle_tracker_node wraps it. Pipeline and metrics: docs/tracker.md.
#pragma once

#include <cstddef>
#include <deque>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "dqn_dovs/common/geometry.h"
#include "dqn_dovs/common/types.h"
#include "dqn_dovs/perception/ctrv_ekf.h"
#include "dqn_dovs/perception/gait.h"
#include "dqn_dovs/perception/known_structure.h"
#include "dqn_dovs/perception/static_map.h"

namespace dqn_dovs {

/// Every parameter of the tracker. Defaults suit the 360 deg / 720-beam simulated LIDAR and a Hokuyo on a
/// Turtlebot 2 among ~0.2 m discs moving up to ~1.2 m/s.
struct TrackerConfig {
  // --- clustering -----------------------------------------------------------------------------------
  /// Fixed part of the largest gap between neighbouring returns of one cluster (m).
  double cluster_distance_base_m = 0.10;
  /// Range-growing part of that gap, in units of the spacing of neighbouring beams at the farther point's
  /// range (r * |angle_increment|): the threshold is base + factor * r * |angle_increment|, so sparse far
  /// returns of one object stay together while near objects stay apart.
  double cluster_distance_beam_factor = 3.0;
  /// Invalid beams (NaN, inf, out of range) that may sit inside one cluster without splitting it.
  int max_skipped_beams = 2;
  /// Clusters (and sub-groups) with fewer valid returns are dropped as noise.
  int min_cluster_points = 3;

  // --- sensor --------------------------------------------------------------------------------------------
  /// The LIDAR's range noise (1 sigma): max(range_noise_m, range_noise_fraction * range). The straightness
  /// thresholds below never go under 3 sigma (splits) and 1.5 sigma (line RMS) at the range of the points, so
  /// a noisy far wall stays one wall instead of breaking into small pieces that look like objects.
  double range_noise_m = 0.01;
  /// See range_noise_m.
  double range_noise_fraction = 0.0;

  // --- segments (walls) -----------------------------------------------------------------------------
  /// Split-and-merge: a run of points is split at its farthest point from its chord when that distance
  /// exceeds this (m).
  double split_distance_m = 0.04;
  /// Straight pieces (line-fit RMS <= line_max_rms_m) at least this long are walls, never circles (m).
  double segment_min_length_m = 0.6;
  /// Largest RMS distance to a fitted line for a piece to count as straight (m).
  double line_max_rms_m = 0.02;
  /// A short piece whose largest deviation from its fitted line is below this fraction of its length is
  /// flat (a wall fragment), not an arc: a visible arc of a disc bulges by at least ~7 % of its chord.
  double min_arc_sagitta_ratio = 0.06;

  // --- circles ------------------------------------------------------------------------------------------
  /// Largest fitted radius accepted as a circle (m); larger curved groups are reported as segments.
  double max_circle_radius_m = 0.6;
  /// Smallest fitted radius accepted from a free fit (m).
  double min_circle_radius_m = 0.05;
  /// Largest RMS residual of an accepted circle fit (m).
  double circle_max_rms_m = 0.03;
  /// Radius assumed for small curved clusters whose arc is too short or noisy for a free fit (m): the
  /// centre is then placed this far behind the visible points (a LIDAR sees only the front arc of a disc).
  /// Also the starting radius of the fit's second start.
  double fallback_radius_m = 0.2;
  /// Added to every reported radius (m). 0 reports the fitted (true) radius; the DOVS adds its own margins.
  double radius_margin_m = 0.0;
  /// Fitted radii kept per track (most recent first).
  int radius_window = 20;
  /// Quantile of the kept radii that is reported: above the median because partial arcs scatter low.
  double radius_quantile = 0.75;

  // --- legs ---------------------------------------------------------------------------------------------
  /// People seen at leg height: two leg-sized detections (their returns span at most 2 leg_max_radius_m) whose
  /// centres are at most leg_pair_max_distance_m apart become one person detection at their midpoint, with
  /// radius max(person_radius_m, half the legs' distance + leg radius); a leg left alone (the other one hidden)
  /// is reported as a person of person_radius_m centred on it. Off by default (the paper's discs have no legs).
  bool pair_legs = false;
  /// Clusters of at least this many (and fewer than min_cluster_points) returns are kept as leg fragments (a far
  /// leg between beams), used only when they pair with another leg.
  int leg_min_points = 2;
  /// Largest radius of a leg (m).
  double leg_max_radius_m = 0.1;
  /// Largest distance between the centres of a person's two legs (m): hip width and stride.
  double leg_pair_max_distance_m = 0.6;
  /// Body radius reported for a person (m): what the robot must keep clear of, not the legs' extent.
  double person_radius_m = 0.25;
  /// Standard deviation of a person's centre placed on a lone leg (m): the body is anywhere within about half
  /// a stride of it, so the filter leans on its prediction until both legs are seen again.
  double lone_leg_std_m = 0.12;
  /// Both legs of a person in one cluster (one partly behind the other as seen from the laser, or touching): a
  /// curved cluster wider than a leg (2 leg_max_radius_m) and at most this wide is one person, centred a leg's
  /// radius behind the middle of its returns (m; 0 disables: it is then fitted as a circle, whose centre lies a
  /// body's radius behind the legs).
  double merged_legs_max_span_m = 0.35;
  /// ... and whose fitted circle, when the fit succeeded, has at most this radius (m): a chair or a disc seen in
  /// part fits its own, larger radius; two legs fit a small one.
  double merged_legs_max_radius_m = 0.18;
  /// Standard deviation of a person's centre placed on two merged legs (m).
  double merged_legs_std_m = 0.06;
  /// Among people: a lone leg is placed back on its body by the person's gait (GaitFilter, gait.h), learned from the
  /// pairs of legs: the leg stands hip_half_width_m to one side of the body's centre line and, along the walking
  /// direction, where the gait's swing puts it; which of the two legs it is, is weighed by how well each fits the
  /// track's prediction. Applies to a track walking at gait_min_speed_mps or more whose last pair of legs is at most
  /// gait_memory_s old; other lone legs are taken as before (lone_leg_std_m).
  bool gait_model = true;
  /// Lateral offset of each leg from the body's centre line (m).
  double hip_half_width_m = 0.1;
  /// Step length at walking speed v: gait_step_base_m + gait_step_per_speed_s * v (m); two steps are one cycle.
  double gait_step_base_m = 0.3;
  double gait_step_per_speed_s = 0.3;
  /// Prior spread of the log of a person's cadence against that nominal one, learned per track (0: nominal only).
  double gait_rate_std = 0.25;
  /// Standard deviation of a leg pair's offset along the walking direction, and of a lone leg placed by the gait
  /// (m; the uncertainty of the predicted swing is added to the latter).
  double gait_offset_std_m = 0.03;
  /// A lone leg is placed by the gait at most this long after the track's last pair of legs, and a pair after a
  /// longer gap starts the gait again (s).
  double gait_memory_s = 1.0;
  /// Slowest walking speed whose gait is followed (m/s): the direction of walking must be known.
  double gait_min_speed_mps = 0.3;

  // --- static structure ---------------------------------------------------------------------------------
  /// Memory of the walls seen (StaticMap): a circle detection with at least structure_max_fraction of its
  /// returns on cells that wall pieces crossed in structure_min_scans scans of the last structure_memory_s is a
  /// piece of wall, reported as a segment and never tracked. Off with structure_memory_s = 0.
  double structure_memory_s = 30.0;
  /// Cell size of that memory (m): small enough that a leg beside a wall does not share the wall's cells.
  double structure_cell_m = 0.1;
  /// Scans in which a cell must have been crossed by a wall piece to count as structure.
  int structure_min_scans = 2;
  /// Fraction of a detection's returns on structure above which it is structure.
  double structure_max_fraction = 0.5;
  /// A detection whose returns lie on the line of a long wall of the same scan (nine in ten within 3 sigma of the
  /// range noise, at least 3 cm) and at most this far beyond its ends is the rest of that wall (m): a wall running away
  /// from the laser breaks into pieces near the end of the range, and people in front of a wall cut it into pieces of
  /// which perhaps one is long. 0 disables.
  double structure_line_extension_m = 6.0;
  /// With a map (ObstacleTracker::update's `map`): how far from its walls and furniture a return still lies on
  /// them (m; KnownStructure): the map's and the localisation's error plus the scanner's noise. A detection with at
  /// least structure_max_fraction of its returns on the map's structure is structure, never tracked.
  double map_tolerance_m = 0.1;

  // --- filter -------------------------------------------------------------------------------------------
  /// Standard deviation of a detected centre, each axis (m).
  double measurement_noise_m = 0.03;
  /// Robust update: a detection whose innovation lies d > outlier_sigma standard deviations from the track's
  /// prediction has its covariance scaled by (d / outlier_sigma)^2, so its pull on the track shrinks as the
  /// miss grows (a person placed on the legs of two people, or on one leg alone, moves the track a little, not
  /// all the way). 0 disables (plain Kalman update).
  double outlier_sigma = 2.0;
  /// Motion model of the tracks. Discs: constant turn rate and velocity (CTRV; the paper's discs move on arcs).
  /// People (with pair_legs), when true: constant velocity, white acceleration in every direction (people start,
  /// stop, turn toward where they go and side-step; their turn rate is reported as 0).
  bool people_constant_velocity = true;
  /// Under constant velocity (people): a new track's second detection is a Kalman update of its first, at rest with
  /// the velocity spread init_speed_std_mps in every direction, like every later detection, instead of giving it the
  /// velocity between the two detections (0.1 s apart, whose noise makes a speed error of about 0.4 m/s). The
  /// tracks younger than a second follow people's motion more closely (docs/tracker.md, "A new person's first
  /// velocity"). false: the velocity between the first two detections (as the CTRV filter of the discs always does).
  bool people_start_from_rest = true;
  /// With pair_legs: a track hit three times or more, at least half of them by detections that are not legs (an
  /// object: a chair, a bin, its returns fitted as a circle of its own), takes a detection made of legs (a piece of its
  /// arc cut short by a passing leg looks like one) as returns of itself, fitted with its own radius, and does not
  /// learn a body's radius from it.
  bool objects_refit_leg_detections = true;
  /// With pair_legs, the process noise of an object's track (m/s^2, as accel_noise_mps2): furniture stands still or is
  /// pushed slowly, so a detection that jumps (a chair's arc cut short, merged with a passer-by's legs) moves its
  /// velocity less. Equal to accel_noise_mps2: objects are followed like people.
  double object_accel_noise_mps2 = 0.1;
  /// With pair_legs, how long an object's track that stands still (stationary_window_s) is kept without hits (s):
  /// a chair hidden behind people, or whose returns merge with a passer-by's legs, is still there. It is dropped
  /// sooner when the scan sees through it (a beam through its centre returns from beyond), and it neither moves nor
  /// grows uncertain meanwhile. 0: such tracks are dropped after deletion_timeout_s like any other.
  double object_hold_s = 8.0;
  /// Process noise: white linear acceleration of the obstacles (m/s^2; in every direction under constant velocity).
  double accel_noise_mps2 = 1.0;
  /// Process noise: white angular acceleration of the obstacles (rad/s^2).
  double turn_accel_noise_rps2 = 1.0;
  /// Turn rates beyond this are clamped (rad/s): the CTRV model is unreliable for faster spins.
  double max_turn_rate_rps = 2.0;
  /// Prior speed spread of a one-hit track (m/s): its second detection is searched within a disc that
  /// grows with this times the elapsed time.
  double init_speed_std_mps = 0.6;
  /// Prior turn-rate spread of a new track (rad/s).
  double init_turn_rate_std_rps = 0.5;

  // --- association --------------------------------------------------------------------------------------
  /// Gate on the squared Mahalanobis distance of a detection from a track's predicted centre
  /// (chi-square, 2 degrees of freedom: 13.8 keeps 99.9 % of true pairs).
  double gate_mahalanobis2 = 13.8;
  /// Hard cap on the Euclidean distance of a pair (m), whatever the covariance says.
  double gate_max_distance_m = 1.0;
  /// Merged discs (without pair_legs): a detection paired with a track that also lies in the gate of a second
  /// confirmed track which found nothing this scan, while the two tracks' centres are closer than this factor times
  /// the sum of their radii, updates neither: two discs seen as one cluster (the paper's discs pass through each
  /// other) would pull the one track to a centre between them and leave the other to be paired with the wrong disc
  /// when they part; both coast on their predictions instead until each has its own detection again. Among people
  /// (pair_legs) it is not applied: measured there, it traded fewer id switches for chairs reported moving
  /// (docs/tracker.md, "Discs that pass through each other"). 0 disables.
  double merged_separation_factor = 1.5;
  /// Manoeuvre recovery: a track that was hit within the last maneuver_max_silence_s but finds nothing in
  /// its gate (the obstacle stopped, reversed or turned sharply) is paired, in a second assignment, with a
  /// detection left over within this distance (m); its uncertainty is then re-opened so the filter follows the
  /// new motion instead of a duplicate track being born. Without pair_legs: the position's by the whole miss, the
  /// speed's by init_speed_std_mps, the heading's by pi/2, the turn rate's by init_turn_rate_std_rps. With
  /// pair_legs (among people, where most such detections are a person placed on the wrong legs): the position's
  /// by maneuver_position_share of the miss, the speed's by maneuver_speed_std_mps, the heading's by
  /// maneuver_heading_std_rad, the turn rate's as without.
  double maneuver_gate_m = 0.45;
  /// See maneuver_gate_m (s).
  double maneuver_max_silence_s = 0.3;
  /// Speed standard deviation added on a manoeuvre recovery with pair_legs (m/s).
  double maneuver_speed_std_mps = 0.2;
  /// Heading standard deviation added on a manoeuvre recovery with pair_legs (rad).
  double maneuver_heading_std_rad = 0.5;
  /// Share of the miss (detection - predicted centre) added to the position's standard deviation on a manoeuvre
  /// recovery with pair_legs, in [0, 1].
  double maneuver_position_share = 0.0;

  // --- track life ---------------------------------------------------------------------------------------
  /// Hits needed before a track is reported (confirmed tracks stay confirmed).
  int confirm_hits = 3;
  /// A track that is not yet confirmed is dropped after this long without a hit (s).
  double tentative_timeout_s = 0.3;
  /// A confirmed track is predicted through occlusions and dropped after this long without a hit (s).
  double deletion_timeout_s = 0.8;
  /// Among people (pair_legs): a confirmed track with fewer hits than this is dropped, like a tentative one, after
  /// tentative_timeout_s without a hit. A few hits give a poor velocity, and such a track coasts off where its first
  /// detections pointed (often a piece of wall between people); once dropped it is remembered for re-identification
  /// like any other (reacquire_window_s). 0 disables.
  int established_hits = 10;
  /// A confirmed track that found no detection in a scan is dropped at once (and remembered for re-identification,
  /// reacquire_window_s) when that scan shows its disc empty: every beam through the disc at its predicted centre
  /// returns from beyond the disc, at least three of them (seenClearThrough). A beam that returns in front of it
  /// (something hides it) or inside it, or returns nothing (a dark or glancing surface drops returns too), keeps it
  /// coasting. Off by default: the tracks are closer to the truth with it, but the planners do worse among people
  /// without the tracks it drops (docs/tracker.md, "Tracks where the scan sees nothing").
  bool drop_seen_through = false;
  /// Tracks whose position standard deviation exceeds this are dropped (m).
  double max_position_std_m = 1.0;
  /// A confirmed track dropped for silence is remembered (not reported) this long (s): a new track born where
  /// the obstacle could have gone meanwhile takes over its id (it was occluded for longer than
  /// deletion_timeout_s, e.g. behind another one, or stood still out of sight). 0 disables.
  double reacquire_window_s = 8.0;
  /// Largest distance (m) between a new detection and the path a remembered track could have taken since its last
  /// hit: anywhere from standing where it was last seen to walking on at its last velocity (a person stops, or
  /// walks on, behind an occluder). The nearest remembered track by that distance lends its id.
  double reacquire_max_distance_m = 1.2;
  /// Fastest speed of a remembered obstacle (m/s): a new detection farther from its last seen position than
  /// reacquire_max_distance_m + this times the time since it was lost is never it.
  double reacquire_speed_mps = 1.5;
  /// Without pair_legs, the walking-on end of that path follows the remembered track's last turn rate (the arc its
  /// CTRV filter predicts) instead of a straight line: a disc turning at 0.4 rad/s that is hidden for 5 s is 2 m off
  /// the straight line. Among people (pair_legs) a turn rate does not last: the line is kept.
  bool reacquire_follow_turn = true;

  /// Without pair_legs, two confirmed tracks at least 1 s old on one spot (closer than half a radius) whose velocities
  /// differ by more than this (m/s) are two discs passing through each other, and both are kept; otherwise (and among
  /// people) they are one object tracked twice and the one with less evidence is dropped. 0 always drops. (A younger
  /// track's velocity is too rough: a fresh duplicate on a still disc would be kept.)
  double duplicate_max_velocity_difference_mps = 0.6;

  // --- time ---------------------------------------------------------------------------------------------
  /// A forward jump between scan stamps larger than this resets all tracks (s): their predictions would
  /// be meaningless.
  double max_time_gap_s = 1.0;

  // --- output -------------------------------------------------------------------------------------------
  /// Tracks slower than this are flagged static (m/s); their heading is frozen at the last moving value.
  double static_speed_threshold_mps = 0.1;
  /// Stationarity test (s): a track whose detections of the last stationary_window_s (at least four, spanning
  /// three quarters of it) lie within stationary_radius_m of their median, nearly all of them
  /// (stationary_inlier_fraction) and its last two without exception, stands still: it is reported at that
  /// median with speed and turn rate 0 and flagged static. The first detection off the median ends the test at
  /// once. A filter's speed never settles at 0 (range noise, a leg passing by pulls the fit); this keeps chairs
  /// and corners of furniture from being reported as creeping. 0 disables.
  double stationary_window_s = 1.0;
  /// Radius (m) around the median of the window's detections within which a stationary track's detections lie.
  double stationary_radius_m = 0.05;
  /// Share of the window's detections that must lie within stationary_radius_m of their median, in (0, 1].
  double stationary_inlier_fraction = 0.8;
  /// A stationary track's filter is also given the pseudo-measurement "speed 0, turn rate 0" at each hit, with these
  /// standard deviations (m/s, rad/s), so its speed settles instead of creeping (and a hidden still object stays
  /// put). stationary_speed_std_mps = 0 changes the report only.
  double stationary_speed_std_mps = 0.02;
  double stationary_turn_rate_std_rps = 0.1;
  /// Restart from rest (without pair_legs): a track that stood still at its last hit and whose new detection lies
  /// farther than stationary_radius_m from where it stood starts moving again as a new track does at its second
  /// hit: speed and heading from its last two detections. Its filter had been told "speed 0", and a disc that turned
  /// around still points along its old heading, so a plain update takes half a second to follow it. Among people
  /// (pair_legs) it is not applied: a chair's detection that jumps (a leg passing by) would report the chair walking
  /// off (docs/tracker.md, "Walking off from rest").
  bool restart_from_rest = true;
  /// Fastest restart (m/s) from the last two detections: a larger jump is something passing by merged into the
  /// still track's detection, and the plain update handles it.
  double restart_max_speed_mps = 1.5;

  /// Empty string when consistent, otherwise a message naming the offending field and why.
  std::string validate() const;
  /// Range noise (1 sigma, m) at `range_m` (range_noise_m, range_noise_fraction).
  double rangeNoise_m(double range_m) const;
};

/// Sets the TrackerConfig field named as in config/tracker.yaml's `tracker/` block (the field name without its
/// unit: person_radius, accel_noise, pair_legs, ...) from text. Returns an empty string, or a message naming the
/// parameter and the reason (unknown name, not a number, not an integer, not true or false). Ranges are left to
/// validate().
std::string setTrackerParameter(TrackerConfig& config, const std::string& name, const std::string& value);

/// Every name setTrackerParameter accepts, in TrackerConfig's order.
const std::vector<std::string>& trackerParameterNames();

/// Bad configuration; the message names the field.
class TrackerConfigError : public std::runtime_error {
 public:
  explicit TrackerConfigError(const std::string& what) : std::runtime_error(what) {}
};

/// A circle found in one scan (fixed frame).
struct CircleDetection {
  Circle circle;
  double fit_rms_m = 0.0;
  /// true: free least-squares fit of centre and radius; false: fallback placement with fallback_radius_m.
  bool free_fit = true;
  /// The returns it was fitted to (fixed frame), for refits with a known radius.
  std::vector<Vec2> points;
  /// A person seen by their legs (TrackerConfig::pair_legs): its centre is the body's, placed from the legs, not a
  /// circle fitted to `points` (the legs' returns).
  bool from_legs = false;
  /// A person placed on one leg alone (the other hidden or not found).
  bool lone_leg = false;
  /// A person placed between both legs; leg_offset is half the first leg's centre minus the second's (the first leg's
  /// offset from the body's centre, the second's being its negative).
  bool paired_legs = false;
  Vec2 leg_offset = Vec2::Zero();
};

/// Everything found in one scan (fixed frame); the tracker keeps the last one for display.
struct ScanDetections {
  double stamp_s = 0.0;
  std::vector<CircleDetection> circles;
  std::vector<Segment> segments;
  size_t valid_beams = 0;
  size_t ignored_beams = 0;  ///< NaN, inf, below range_min or at/above range_max
  size_t clusters = 0;
};

/// Empty when `scan` is usable, otherwise why not (empty, non-finite or zero angle_increment, bad range
/// limits, NaN stamp, a fan wider than a full turn).
std::string checkScan(const LaserScan2& scan);

class StaticMap;

/// Clustering and classification of one scan seen from `laser_pose` (fixed frame). Assumes checkScan
/// passed; invalid beams are skipped. With `structure`, the scan's wall pieces are added to it first, then
/// circle detections lying on structure (TrackerConfig::structure_*) become segments; so do those lying on a
/// map's structure when `map` holds one; legs are paired last.
ScanDetections detectObstacles(const LaserScan2& scan, const Pose2& laser_pose, const TrackerConfig& config,
                               StaticMap* structure = nullptr, const MapStructureView& map = {});

/// How one update went.
enum class TrackerStatus {
  kOk,        ///< scan used
  kRejected,  ///< scan not used, tracks untouched; message says why
  kReset,     ///< tracks were dropped (time went backwards or jumped), then the scan was used; message says why
};

const char* toString(TrackerStatus status);

struct TrackerResult {
  TrackerStatus status = TrackerStatus::kOk;
  /// Empty when status is kOk; otherwise a one-line reason (the node logs it, throttled).
  std::string message;
  /// Confirmed tracks and the scan's segments at the scan's stamp (after a rejection: the previous scene).
  TrackedScene scene;
  /// Beams of this scan that were ignored (NaN, inf, out of range).
  size_t ignored_beams = 0;
};

class ObstacleTracker {
 public:
  /// Throws TrackerConfigError when config.validate() fails.
  explicit ObstacleTracker(const TrackerConfig& config);

  /// Processes one scan. laser_pose: pose of the laser in the fixed frame at scan.stamp_s (so the robot's
  /// own motion never appears as obstacle motion). `map`, when it holds a structure: the walls and furniture a
  /// map gives, and where the fixed frame lies in it at this scan; what lies on them is never tracked
  /// (KnownStructure). Never throws on bad data: see TrackerResult (a non-finite map pose leaves the map out).
  TrackerResult update(const LaserScan2& scan, const Pose2& laser_pose, const MapStructureView& map = {});

  /// Drops every track and forgets the last stamp. Track ids keep increasing (an id is never reused).
  void reset();

  /// The last scene (confirmed tracks at the last used scan's stamp).
  const TrackedScene& scene() const { return scene_; }
  /// The confirmed tracks moved forward on their own motion to stamp_s (>= the last stamp; earlier stamps
  /// return the last scene), e.g. to the planner's decision time. A stamp more than max_time_gap_s after the
  /// last scan gives no obstacles (a scan that late resets the tracks). Does not change the tracker.
  TrackedScene predictedScene(double stamp_s) const;
  /// Circles and segments of the last used scan (fixed frame), for display.
  const ScanDetections& lastDetections() const { return detections_; }
  const TrackerConfig& config() const { return config_; }
  /// Number of live tracks, confirmed or not.
  size_t trackCount() const { return tracks_.size(); }

 private:
  struct Track {
    int id = -1;
    CtrvEkf ekf;
    double born_s = 0.0;
    double last_hit_s = 0.0;
    int hits = 0;
    bool confirmed = false;
    /// Position of the first detection; a one-hit track has no velocity yet.
    Vec2 first_position = Vec2::Zero();
    /// Filtered position and velocity at the last hit (where a lost track was last seen, and how it moved).
    Vec2 hit_position = Vec2::Zero();
    Vec2 hit_velocity = Vec2::Zero();
    double hit_turn_rate = 0.0;
    std::deque<double> radii;
    double radius = 0.0;
    double reported_heading = 0.0;
    bool updated_this_scan = false;
    /// Detections (stamp, centre) of the last stationary_window_s, oldest first, and the stationarity test's
    /// result at the last hit: stands still at stationary_position (TrackerConfig::stationary_window_s).
    std::deque<std::pair<double, Vec2>> recent_hits;
    bool stationary = false;
    Vec2 stationary_position = Vec2::Zero();
    /// Its id was taken over by a track that found its object again (see takeOverLostTrack); dropped at pruning.
    bool absorbed = false;
    /// Hits by detections of legs (CircleDetection::from_legs) and by other detections (objects).
    int leg_hits = 0;
    int object_hits = 0;
    /// The last scan saw through where it stands (seenThrough, a held object) or showed its disc empty
    /// (seenClearThrough, a coasting track; TrackerConfig::drop_seen_through): it is dropped.
    bool seen_through = false;
    /// Among people: the gait seen in the pairs of legs (TrackerConfig::gait_model).
    GaitFilter gait;
  };

  /// A lone leg's detection as a measurement of the track's body (TrackerConfig::gait_model): z and r are the
  /// detection's centre and covariance on entry and the body's on return; unchanged when the gait does not apply.
  void placeLoneLeg(const Track& track, const CircleDetection& detection, double stamp_s, Vec2& z,
                    Eigen::Matrix2d& r) const;
  /// Feeds a pair of legs to the track's gait (after its filter's update), or forgets the gait of a track too slow.
  void updateGait(Track& track, const CircleDetection& detection, double stamp_s) const;
  GaitParams gaitParams() const;
  /// Among people (pair_legs), an object rather than a person: hit three times or more, at least as often by non-leg
  /// detections as by legs.
  bool isObjectTrack(const Track& track) const {
    return config_.pair_legs && track.object_hits >= 3 && track.object_hits >= track.leg_hits;
  }
  /// A still object kept without hits (TrackerConfig::object_hold_s): not predicted, not dropped on silence.
  bool isHeldObject(const Track& track) const {
    return config_.object_hold_s > 0.0 && track.confirmed && track.stationary && !track.seen_through &&
           isObjectTrack(track);
  }
  double accelNoise(const Track& track) const {
    return isObjectTrack(track) ? config_.object_accel_noise_mps2 : config_.accel_noise_mps2;
  }
  /// Whether the scan's beams toward the middle of where a held object stands return from beyond its centre.
  static bool seenThrough(const Vec2& center, double radius, const LaserScan2& scan, const Pose2& laser_pose);
  /// Every valid beam of `scan` through the disc (center, radius) returns from beyond the disc, and at least three do:
  /// the place is seen empty. Beams with no return are left out.
  static bool seenClearThrough(const Vec2& center, double radius, const LaserScan2& scan, const Pose2& laser_pose);
  MotionModel motionModel() const {
    return config_.pair_legs && config_.people_constant_velocity ? MotionModel::kConstantVelocity : MotionModel::kCtrv;
  }
  void predictTracks(double stamp_s);
  void associateAndUpdate(const ScanDetections& detections, double stamp_s);
  /// Whether track i's detection of this scan holds a second body too (TrackerConfig::merged_separation_factor): it
  /// lies in the gate of a nearby confirmed track that found nothing (track_to_det: the first assignment, made on
  /// `cost`, the association costs of every track and detection before any update of this scan).
  bool mergedWithAnotherTrack(size_t i, const std::vector<int>& track_to_det, const Eigen::MatrixXd& cost) const;
  /// maneuver: the pair came from the second, manoeuvre assignment (re-open the motion uncertainty first).
  void updateTrack(Track& track, const CircleDetection& detection, double stamp_s, bool maneuver = false);
  void birthTrack(const CircleDetection& detection, double stamp_s);
  /// A track just confirmed takes over the id of a confirmed track that has found nothing since the new one was
  /// born, when the new one is on the path the old one could have taken (its object, lost by its filter).
  void takeOverLostTrack(Track& track, double stamp_s);
  /// Distance (m) from `z` to where `track` could be after `silent_s` without a hit (its path from standing still
  /// where it was last seen to walking on at its last velocity); infinity beyond its reachable range.
  double reacquireDistance(const Track& track, const Vec2& z, double silent_s) const;
  /// Records the detection at z and runs the stationarity test (TrackerConfig::stationary_window_s).
  void updateStationarity(Track& track, const Vec2& z, double stamp_s);
  /// Starts the track's motion afresh at detection z (at stamp_s, measurement covariance r) from an earlier one,
  /// `from` at from_s: position z, speed and heading from the two (a CTRV filter cannot learn a heading from rest).
  void startMotion(Track& track, const Vec2& from, double from_s, const Vec2& z, double stamp_s,
                   const Eigen::Matrix2d& r) const;
  void pruneTracks(double stamp_s);
  void buildScene(double stamp_s);
  /// Squared Mahalanobis distance of a detection from a track (infinity outside the hard distance cap).
  double associationCost(const Track& track, const CircleDetection& detection, double stamp_s) const;
  TrackedObstacle toTrackedObstacle(const Track& track, double stamp_s) const;
  Eigen::Matrix2d measurementCovariance(const CircleDetection& detection) const;
  /// r, inflated for a detection far outside the track's prediction (TrackerConfig::outlier_sigma).
  Eigen::Matrix2d robustCovariance(const Track& track, const Vec2& z, const Eigen::Matrix2d& r) const;

  TrackerConfig config_;
  std::vector<Track> tracks_;
  /// Confirmed tracks dropped for silence, kept for re-acquisition (as they were at their last hit).
  std::vector<Track> lost_;
  TrackedScene scene_;
  ScanDetections detections_;
  /// Walls seen recently (TrackerConfig::structure_*).
  StaticMap structure_;
  /// Scratch buffers of updateStationarity's median (kept to spare an allocation per track and hit).
  std::vector<double> median_scratch_x_, median_scratch_y_;
  bool has_stamp_ = false;
  double last_stamp_s_ = 0.0;
  int next_id_ = 0;
};

}  // namespace dqn_dovs
