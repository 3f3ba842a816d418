// Synthetic LIDAR scans of discs and wall segments for the tracker tests (ray casting with geometry.h).
#pragma once

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "dqn_dovs/common/geometry.h"
#include "dqn_dovs/common/types.h"

namespace dqn_dovs::test {

struct SyntheticLidar {
  int beams = 720;
  double fov_rad = kTwoPi;
  double range_min = 0.05;
  double range_max = 10.0;
  double noise_std_m = 0.01;
  /// Range-proportional noise: the standard deviation is max(noise_std_m, noise_std_fraction * range).
  double noise_std_fraction = 0.0;
};

/// One scan from `laser_pose` (fixed frame) of `discs` and `walls`, nearest hit per beam, Gaussian range noise;
/// no return is +inf.
inline LaserScan2 syntheticScan(const SyntheticLidar& lidar, const Pose2& laser_pose, const std::vector<Circle>& discs,
                                const std::vector<Segment>& walls, double stamp_s, std::mt19937& rng) {
  LaserScan2 scan;
  scan.stamp_s = stamp_s;
  const bool full = lidar.fov_rad >= kTwoPi - 1e-9;
  scan.angle_increment = full ? kTwoPi / lidar.beams : lidar.fov_rad / (lidar.beams - 1);
  scan.angle_min = full ? -kPi : -0.5 * lidar.fov_rad;
  scan.range_min = lidar.range_min;
  scan.range_max = lidar.range_max;
  scan.ranges.resize(static_cast<size_t>(lidar.beams));
  std::normal_distribution<double> noise(0.0, lidar.noise_std_m);
  const Vec2 o = laser_pose.position();
  for (int i = 0; i < lidar.beams; ++i) {
    const double a = laser_pose.theta + scan.angleOf(static_cast<size_t>(i));
    const Vec2 d(std::cos(a), std::sin(a));
    double best = std::numeric_limits<double>::infinity();
    for (const Circle& c : discs) {
      if (auto t = rayCircle(o, d, c)) best = std::min(best, *t);
    }
    for (const Segment& s : walls) {
      if (auto t = raySegment(o, d, s)) best = std::min(best, *t);
    }
    if (std::isfinite(best) && lidar.noise_std_m > 0.0) {
      best += noise(rng) * std::max(1.0, lidar.noise_std_fraction * best / lidar.noise_std_m);
    }
    scan.ranges[static_cast<size_t>(i)] =
        best < lidar.range_max ? static_cast<float>(best) : std::numeric_limits<float>::infinity();
  }
  return scan;
}

/// The four walls of a square room of half side h centred on the origin.
inline std::vector<Segment> roomWalls(double h) {
  return {{{-h, -h}, {h, -h}}, {{h, -h}, {h, h}}, {{h, h}, {-h, h}}, {{-h, h}, {-h, -h}}};
}

}  // namespace dqn_dovs::test
