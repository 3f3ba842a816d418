// Simulated 2-D LIDAR: ray casting against the room walls, extra wall segments and disc obstacles with true
// occlusion (each beam reports its nearest hit), plus seeded sensor effects: Gaussian range noise, missing
// returns (dark surfaces at random, glancing surfaces by incidence angle) and mixed pixels at depth edges.
// Named profiles model the scanners a Turtlebot 2 carries.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "dqn_dovs/common/geometry.h"
#include "dqn_dovs/common/random.h"
#include "dqn_dovs/common/types.h"
#include "dqn_dovs/sim/errors.h"

namespace dqn_dovs::sim {

/// LIDAR geometry and noise. Beam i points at angle_min + i * angle_increment in the laser frame with
/// angle_min = -fov_rad / 2; a full circle (fov_rad = 2 pi) uses angle_increment = 2 pi / beams so that the
/// last beam does not repeat the first, a partial fan uses fov_rad / (beams - 1) so that its two outer beams
/// lie exactly on +-fov_rad / 2.
struct LidarConfig {
  /// Angular field of view (rad), in (0, 2 pi], centred on the laser's x axis.
  double fov_rad = kTwoPi;
  /// Number of beams per scan (>= 2 for a partial fan, >= 1 for a full circle).
  int beams = 720;
  /// Returns closer than this are reported as -inf ("too close", REP 117) (m).
  double range_min_m = 0.05;
  /// Beams with no hit up to this range are reported as +inf ("no return", REP 117) (m).
  double range_max_m = 10.0;
  /// Standard deviation of the additive Gaussian range noise, constant part (m). 0 disables noise.
  double noise_std_m = 0.01;
  /// Range-proportional noise: the standard deviation is max(noise_std_m, noise_std_fraction * range)
  /// (dimensionless; 0.01 = 1 % of the range).
  double noise_std_fraction = 0.0;
  /// Probability that a beam with a hit returns nothing (+inf): dark or absorbing surfaces. 0 disables.
  double dropout_probability = 0.0;
  /// A beam meeting a surface further than this from its normal returns nothing (+inf): glancing surfaces
  /// reflect away from the sensor (rad, in (0, pi/2]; pi/2 disables).
  double grazing_limit_rad = kPi / 2.0;
  /// At a depth edge (neighbouring beams differ by more than mixed_pixel_jump_m), the probability that the
  /// farther beam reports a range between the two surfaces (the beam's footprint straddles the edge). 0 disables.
  double mixed_pixel_probability = 0.0;
  /// Smallest range difference between neighbouring beams that makes a depth edge (m).
  double mixed_pixel_jump_m = 0.15;
  /// Time between scans (s): the scanner's rotation period.
  double scan_period_s = 0.1;
  /// Pose of the laser on the robot base frame (m, m, rad); x forward, theta = 0 looks forward.
  Pose2 mount;

  /// Empty string when consistent, otherwise a message naming the offending field and why.
  std::string validate() const;

  /// True when the fan closes the full circle.
  bool fullCircle() const { return fov_rad >= kTwoPi - 1e-9; }
  /// Angle of beam 0 in the laser frame (rad).
  double angleMin_rad() const { return -0.5 * fov_rad; }
  /// Angular step between consecutive beams (rad).
  double angleIncrement_rad() const;

  /// Simulation profile used for training and evaluation: 360 deg, 720 beams (0.5 deg), 0.05..10 m,
  /// 1 cm noise, mounted at the robot centre.
  static LidarConfig simProfile();
  /// A Hokuyo URG-04LX-like scanner restricted to the front half-plane as mounted on a Turtlebot 2:
  /// 180 deg at the device's native 360/1024 deg step (513 beams, both +-90 deg beams included),
  /// 0.02..5.6 m, noise sigma max(5 mm, 0.5 % of the range) (the datasheet's +-10 mm up to 1 m and +-1 %
  /// beyond taken as 2-sigma bounds), mounted at the robot centre looking forward.
  static LidarConfig hokuyoProfile();
  /// The full Hokuyo URG-04LX: 240 deg at 360/1024 deg (683 beams), 0.02..5.6 m, the same noise, 10 Hz, 1 %
  /// missing returns, none beyond 80 deg of incidence, mixed pixels at half of the depth edges.
  static LidarConfig urg04lxProfile();
  /// An RPLIDAR A1-like scanner: 360 deg, 360 beams (1 deg), 0.15..8 m, noise sigma max(5 mm, 1 % of the
  /// range), about 7 Hz, 2 % missing returns, none beyond 75 deg of incidence, mixed pixels at half of the
  /// depth edges.
  static LidarConfig rplidarA1Profile();
  /// The profile of that name: "sim", "hokuyo", "urg04lx" or "rplidar_a1". Throws SimConfigError naming the
  /// name and the known ones otherwise.
  static LidarConfig profile(const std::string& name);
  /// The names profile() accepts.
  static std::vector<std::string> profileNames();
};

/// What the LIDAR can see: a square room centred on the origin (optional), extra wall segments and discs.
struct LidarScene {
  /// Half the side of the square room whose four walls are cast analytically (m); <= 0 means no room.
  double room_half_size_m = 0.0;
  /// Extra static wall segments (world frame).
  std::vector<Segment> segments;
  /// Obstacle discs (world frame).
  std::vector<Circle> discs;
};

/// Ray-casting LIDAR. Each disc is tested only on the beams inside the angular span it subtends from the
/// laser, and the room walls are intersected in closed form, so a 720-beam scan among a few dozen discs
/// costs tens of microseconds.
class Lidar {
 public:
  /// Throws SimConfigError when config.validate() fails.
  Lidar(const LidarConfig& config, uint64_t seed);

  /// Restarts the noise stream.
  void reseed(uint64_t seed) { rng_.reseed(seed); }

  const LidarConfig& config() const { return config_; }

  /// Noisy scan from `laser_pose` (world frame, i.e. robot pose composed with the mount), stamped stamp_s.
  LaserScan2 scan(const Pose2& laser_pose, const LidarScene& scene, double stamp_s);
  /// Same as scan(), reusing `out`'s storage (no allocation once sized).
  void scanInto(const Pose2& laser_pose, const LidarScene& scene, double stamp_s, LaserScan2& out);

  /// Exact distance to the nearest hit along each beam (no noise, no range limits; +inf when nothing is hit).
  /// Does not touch the noise stream.
  std::vector<double> trueRanges(const Pose2& laser_pose, const LidarScene& scene) const;

 private:
  /// True ranges along every beam, and (when `incidence_cos` is given) the cosine of the angle between each
  /// beam and the normal of the surface it hits (1 when nothing is hit).
  void castAll(const Pose2& laser_pose, const LidarScene& scene, std::vector<Vec2>& dirs_world,
               std::vector<double>& ranges, std::vector<double>* incidence_cos = nullptr) const;

  LidarConfig config_;
  std::vector<Vec2> beam_dirs_local_;  // unit beam directions in the laser frame
  std::vector<Vec2> dirs_world_;       // per-scan scratch: beam directions in the world frame
  std::vector<double> work_;           // per-scan scratch: true ranges
  std::vector<double> incidence_;      // per-scan scratch: cosine of each beam's incidence angle
  Rng rng_;
};

}  // namespace dqn_dovs::sim
