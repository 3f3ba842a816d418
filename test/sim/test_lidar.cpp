#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "dqn_dovs/sim/lidar.h"

namespace dqn_dovs::sim {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

LidarConfig noiseless(LidarConfig c = LidarConfig::simProfile()) {
  c.noise_std_m = 0.0;
  c.noise_std_fraction = 0.0;
  return c;
}

size_t beamAt(const LidarConfig& c, double angle) {
  return static_cast<size_t>(std::lround((angle - c.angleMin_rad()) / c.angleIncrement_rad()));
}

// Reference: every beam against every wall segment and every disc, no prefilter.
std::vector<double> bruteForce(const LidarConfig& c, const Pose2& pose, const LidarScene& scene) {
  std::vector<Segment> segments = scene.segments;
  const double h = scene.room_half_size_m;
  if (h > 0.0) {
    segments.push_back({Vec2(-h, -h), Vec2(h, -h)});
    segments.push_back({Vec2(h, -h), Vec2(h, h)});
    segments.push_back({Vec2(h, h), Vec2(-h, h)});
    segments.push_back({Vec2(-h, h), Vec2(-h, -h)});
  }
  std::vector<double> out(static_cast<size_t>(c.beams), kInf);
  for (size_t i = 0; i < out.size(); ++i) {
    const double a = pose.theta + c.angleMin_rad() + static_cast<double>(i) * c.angleIncrement_rad();
    const Vec2 d(std::cos(a), std::sin(a));
    for (const Segment& s : segments) {
      const auto t = raySegment(pose.position(), d, s);
      if (t) out[i] = std::min(out[i], *t);
    }
    for (const Circle& disc : scene.discs) {
      const auto t = rayCircle(pose.position(), d, disc);
      if (t) out[i] = std::min(out[i], *t);
    }
  }
  return out;
}

TEST(LidarConfig, ProfilesFollowLaserScanSemantics) {
  const LidarConfig sim = LidarConfig::simProfile();
  EXPECT_EQ(sim.validate(), "");
  EXPECT_EQ(sim.beams, 720);
  EXPECT_TRUE(sim.fullCircle());
  EXPECT_NEAR(sim.angleMin_rad(), -kPi, 1e-12);
  EXPECT_NEAR(sim.angleIncrement_rad(), kTwoPi / 720.0, 1e-15);
  // The last beam stops one increment short of the first: no duplicate at +-pi.
  EXPECT_NEAR(sim.angleMin_rad() + 719 * sim.angleIncrement_rad(), kPi - kTwoPi / 720.0, 1e-12);

  const LidarConfig hok = LidarConfig::hokuyoProfile();
  EXPECT_EQ(hok.validate(), "");
  EXPECT_FALSE(hok.fullCircle());
  EXPECT_EQ(hok.beams, 513);
  EXPECT_NEAR(hok.angleIncrement_rad(), kTwoPi / 1024.0, 1e-15);
  EXPECT_NEAR(hok.angleMin_rad(), -kPi / 2, 1e-12);
  EXPECT_NEAR(hok.angleMin_rad() + 512 * hok.angleIncrement_rad(), kPi / 2, 1e-12);
  EXPECT_DOUBLE_EQ(hok.range_max_m, 5.6);
}

TEST(LidarConfig, ValidateNamesTheBadField) {
  LidarConfig c;
  c.beams = 0;
  EXPECT_NE(c.validate().find("beams"), std::string::npos);
  c = LidarConfig();
  c.fov_rad = 7.0;
  EXPECT_NE(c.validate().find("fov_rad"), std::string::npos);
  c = LidarConfig();
  c.range_max_m = 0.01;
  EXPECT_NE(c.validate().find("range_max_m"), std::string::npos);
  c = LidarConfig();
  c.noise_std_m = std::nan("");
  EXPECT_NE(c.validate().find("noise_std_m"), std::string::npos);
  c = LidarConfig();
  c.fov_rad = kPi;
  c.beams = 1;
  EXPECT_NE(c.validate().find("beams"), std::string::npos);
  try {
    Lidar lidar(c, 0);
    FAIL() << "an invalid config must throw";
  } catch (const SimConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("beams"), std::string::npos);
  }
}

TEST(Lidar, DiscStraightAheadAtKnownRange) {
  const LidarConfig c = noiseless();
  Lidar lidar(c, 1);
  LidarScene scene;
  scene.discs.push_back({Vec2(3.0, 0.0), 0.5});
  const LaserScan2 scan = lidar.scan(Pose2{}, scene, 12.5);
  ASSERT_EQ(scan.ranges.size(), 720u);
  EXPECT_DOUBLE_EQ(scan.stamp_s, 12.5);
  EXPECT_DOUBLE_EQ(scan.angle_min, c.angleMin_rad());
  EXPECT_DOUBLE_EQ(scan.angle_increment, c.angleIncrement_rad());
  EXPECT_NEAR(scan.ranges[beamAt(c, 0.0)], 2.5, 1e-6);
  // The disc subtends asin(0.5 / 3) = 9.6 deg on each side: a beam at 9 deg hits, one at 10.5 deg does not.
  EXPECT_TRUE(std::isfinite(scan.ranges[beamAt(c, 9.0 * kPi / 180)]));
  EXPECT_FALSE(std::isfinite(scan.ranges[beamAt(c, 10.5 * kPi / 180)]));
  // With no room, everything else is a non-return.
  EXPECT_TRUE(std::isinf(scan.ranges[beamAt(c, kPi / 2)]) && scan.ranges[beamAt(c, kPi / 2)] > 0);
  // Rotating the laser by +90 deg moves the hit to the beam at -90 deg.
  const LaserScan2 turned = lidar.scan(Pose2{0.0, 0.0, kPi / 2}, scene, 0.0);
  EXPECT_NEAR(turned.ranges[beamAt(c, -kPi / 2)], 2.5, 1e-6);
}

TEST(Lidar, NearDiscOccludesFarDisc) {
  const LidarConfig c = noiseless();
  Lidar lidar(c, 1);
  LidarScene scene;
  scene.discs.push_back({Vec2(5.0, 0.0), 0.5});
  scene.discs.push_back({Vec2(2.0, 0.0), 0.3});
  const auto r = lidar.trueRanges(Pose2{}, scene);
  EXPECT_NEAR(r[beamAt(c, 0.0)], 1.7, 1e-9);
  // Order in the scene does not matter.
  std::swap(scene.discs[0], scene.discs[1]);
  EXPECT_NEAR(lidar.trueRanges(Pose2{}, scene)[beamAt(c, 0.0)], 1.7, 1e-9);
  // Beside the near disc's shadow the far disc is seen: move the near disc up so that a beam at -3 deg
  // clears it (its span is [2.9, 19.8] deg) but still hits the far disc (span +-5.7 deg).
  LidarScene offset;
  offset.discs.push_back({Vec2(5.0, 0.0), 0.5});
  offset.discs.push_back({Vec2(2.0, 0.4), 0.3});
  const size_t i = beamAt(c, -3.0 * kPi / 180);
  const double a = c.angleMin_rad() + static_cast<double>(i) * c.angleIncrement_rad();
  const auto far_hit = rayCircle(Vec2::Zero(), Vec2(std::cos(a), std::sin(a)), Circle{Vec2(5.0, 0.0), 0.5});
  ASSERT_TRUE(far_hit.has_value());
  EXPECT_NEAR(lidar.trueRanges(Pose2{}, offset)[i], *far_hit, 1e-9);
  EXPECT_GT(*far_hit, 4.4);
}

TEST(Lidar, WallDistancesFromTheCentreOfTheRoom) {
  const LidarConfig c = noiseless();
  Lidar lidar(c, 1);
  LidarScene scene;
  scene.room_half_size_m = 4.0;
  const auto r = lidar.trueRanges(Pose2{}, scene);
  EXPECT_NEAR(r[beamAt(c, 0.0)], 4.0, 1e-9);
  EXPECT_NEAR(r[beamAt(c, kPi / 2)], 4.0, 1e-9);
  EXPECT_NEAR(r[beamAt(c, -kPi)], 4.0, 1e-9);
  EXPECT_NEAR(r[beamAt(c, kPi / 4)], 4.0 * std::sqrt(2.0), 1e-9);
  EXPECT_NEAR(r[beamAt(c, -3 * kPi / 4)], 4.0 * std::sqrt(2.0), 1e-9);
  for (size_t i = 0; i < r.size(); ++i) {
    const double a = c.angleMin_rad() + static_cast<double>(i) * c.angleIncrement_rad();
    EXPECT_NEAR(r[i], 4.0 / std::max(std::abs(std::cos(a)), std::abs(std::sin(a))), 1e-9) << i;
  }
}

TEST(Lidar, WallDistancesFromAnOffCentrePose) {
  const LidarConfig c = noiseless();
  Lidar lidar(c, 1);
  LidarScene scene;
  scene.room_half_size_m = 4.0;
  const Pose2 pose{1.0, -2.5, kPi / 6};  // a whole number of beam increments, so one beam looks along -y
  const auto r = lidar.trueRanges(pose, scene);
  const auto ref = bruteForce(c, pose, scene);
  for (size_t i = 0; i < r.size(); ++i) ASSERT_NEAR(r[i], ref[i], 1e-9) << i;
  // Looking along the room's -y axis from y = -2.5 the wall is 1.5 m away.
  EXPECT_NEAR(r[beamAt(c, -kPi / 2 - kPi / 6)], 1.5, 1e-9);
}

TEST(Lidar, PrefilteredCastingMatchesBruteForce) {
  Rng rng(42);
  for (const LidarConfig& base : {LidarConfig::simProfile(), LidarConfig::hokuyoProfile()}) {
    LidarConfig c = noiseless(base);
    c.range_max_m = 100.0;
    Lidar lidar(c, 7);
    for (int trial = 0; trial < 60; ++trial) {
      LidarScene scene;
      scene.room_half_size_m = 4.0;
      for (int k = 0; k < 15; ++k) {
        scene.discs.push_back({Vec2(rng.uniform(-3.8, 3.8), rng.uniform(-3.8, 3.8)), rng.uniform(0.05, 0.6)});
      }
      // Wall segments, prefiltered by the arc between their ends: short and long ones, some passing behind the
      // laser (arcs across beam 0), one through the laser's position line (every beam tried).
      for (int k = 0; k < 6; ++k) {
        scene.segments.push_back(
            {Vec2(rng.uniform(-3, 3), rng.uniform(-3, 3)), Vec2(rng.uniform(-3, 3), rng.uniform(-3, 3))});
      }
      // Include headings at the +-pi seam so that spans wrapping around beam 0 are exercised.
      const double theta = trial % 3 == 0 ? kPi - 1e-4 : rng.uniform(-kPi, kPi);
      Pose2 pose{rng.uniform(-3.5, 3.5), rng.uniform(-3.5, 3.5), theta};
      const Vec2 along(std::cos(rng.uniform(-kPi, kPi)), 0.3);
      scene.segments.push_back({pose.position() + 0.5 * along, pose.position() + 2.0 * along});
      bool inside = false;
      for (const Circle& d : scene.discs) inside = inside || (d.center - pose.position()).norm() <= d.radius;
      if (inside) continue;
      const auto r = lidar.trueRanges(pose, scene);
      const auto ref = bruteForce(c, pose, scene);
      ASSERT_EQ(r.size(), ref.size());
      for (size_t i = 0; i < r.size(); ++i) ASSERT_NEAR(r[i], ref[i], 1e-9) << "trial " << trial << " beam " << i;
    }
  }
}

TEST(Lidar, RangeLimitsAndFieldOfView) {
  const LidarConfig c = noiseless(LidarConfig::hokuyoProfile());
  Lidar lidar(c, 1);
  LidarScene scene;
  scene.room_half_size_m = 4.0;
  scene.discs.push_back({Vec2(-2.0, 0.0), 0.3});  // behind the 180 deg fan
  const LaserScan2 s = lidar.scan(Pose2{}, scene, 0.0);
  ASSERT_EQ(s.ranges.size(), 513u);
  EXPECT_DOUBLE_EQ(s.range_max, 5.6);
  EXPECT_NEAR(s.ranges[256], 4.0, 1e-6);  // straight ahead: the +x wall
  EXPECT_NEAR(s.ranges[0], 4.0, 1e-6);    // -90 deg: the -y wall
  EXPECT_NEAR(s.ranges[512], 4.0, 1e-6);  // +90 deg: the +y wall
  // Beyond 5.6 m (the corners at 5.66 m): no return, reported as +inf.
  const size_t diag = beamAt(c, kPi / 4);
  EXPECT_TRUE(std::isinf(s.ranges[diag]) && s.ranges[diag] > 0.0);
  // The disc behind the robot is invisible: the scan equals the empty room's.
  LidarScene empty;
  empty.room_half_size_m = 4.0;
  const LaserScan2 e = lidar.scan(Pose2{}, empty, 0.0);
  for (size_t i = 0; i < s.ranges.size(); ++i) EXPECT_EQ(s.ranges[i], e.ranges[i]) << i;
}

TEST(Lidar, TooCloseAndInsideAreMinusInfinity) {
  const LidarConfig c = noiseless();
  Lidar lidar(c, 1);
  LidarScene scene;
  scene.room_half_size_m = 4.0;
  scene.discs.push_back({Vec2(0.1, 0.0), 0.2});  // the laser sits inside this disc
  const LaserScan2 s = lidar.scan(Pose2{}, scene, 0.0);
  for (float r : s.ranges) ASSERT_TRUE(std::isinf(r) && r < 0.0);
  LidarScene near;
  near.discs.push_back({Vec2(0.25, 0.0), 0.22});  // surface 3 cm ahead, below range_min = 5 cm
  const LaserScan2 n = lidar.scan(Pose2{}, near, 0.0);
  EXPECT_TRUE(std::isinf(n.ranges[beamAt(c, 0.0)]) && n.ranges[beamAt(c, 0.0)] < 0.0);
}

TEST(Lidar, NoiseHasTheConfiguredStatistics) {
  LidarConfig c = LidarConfig::simProfile();
  c.noise_std_m = 0.02;
  Lidar lidar(c, 5);
  LidarScene scene;
  scene.room_half_size_m = 4.0;
  const Pose2 pose{0.5, 0.3, 0.2};
  const auto truth = lidar.trueRanges(pose, scene);
  double sum = 0.0, sum2 = 0.0;
  size_t n = 0;
  for (int k = 0; k < 100; ++k) {
    const LaserScan2 s = lidar.scan(pose, scene, 0.0);
    for (size_t i = 0; i < s.ranges.size(); ++i) {
      const double e = static_cast<double>(s.ranges[i]) - truth[i];
      sum += e;
      sum2 += e * e;
      ++n;
    }
  }
  const double mean = sum / n, std = std::sqrt(sum2 / n - mean * mean);
  EXPECT_NEAR(mean, 0.0, 5e-4);  // 72000 samples: standard error 7.5e-5
  EXPECT_NEAR(std, 0.02, 0.02 * 0.03);

  // Range-proportional noise: sigma grows with distance.
  LidarConfig f = LidarConfig::simProfile();
  f.noise_std_m = 0.001;
  f.noise_std_fraction = 0.01;
  Lidar prop(f, 6);
  LidarScene far_scene;
  far_scene.room_half_size_m = 4.0;
  double s2 = 0.0;
  size_t m = 0;
  const size_t ahead = beamAt(f, 0.0);
  for (int k = 0; k < 2000; ++k) {
    const double e = prop.scan(Pose2{}, far_scene, 0.0).ranges[ahead] - 4.0;
    s2 += e * e;
    ++m;
  }
  EXPECT_NEAR(std::sqrt(s2 / m), 0.04, 0.04 * 0.08);
}

TEST(Lidar, SameSeedSameScanDifferentSeedDifferentNoise) {
  LidarScene scene;
  scene.room_half_size_m = 4.0;
  scene.discs.push_back({Vec2(1.0, 1.0), 0.2});
  Lidar a(LidarConfig::simProfile(), 99), b(LidarConfig::simProfile(), 99), c(LidarConfig::simProfile(), 100);
  const LaserScan2 sa = a.scan(Pose2{}, scene, 0.0), sb = b.scan(Pose2{}, scene, 0.0), sc = c.scan(Pose2{}, scene, 0.0);
  EXPECT_EQ(sa.ranges, sb.ranges);
  EXPECT_NE(sa.ranges, sc.ranges);
  a.reseed(99);
  EXPECT_EQ(a.scan(Pose2{}, scene, 0.0).ranges, sa.ranges);
}

TEST(Lidar, NonFiniteInputsDoNotCrash) {
  Lidar lidar(noiseless(), 1);
  LidarScene scene;
  scene.room_half_size_m = 4.0;
  scene.discs.push_back({Vec2(std::nan(""), 0.0), 0.2});
  scene.discs.push_back({Vec2(2.0, 0.0), std::numeric_limits<double>::infinity()});
  const LaserScan2 s = lidar.scan(Pose2{}, scene, 0.0);
  EXPECT_NEAR(s.ranges[beamAt(lidar.config(), 0.0)], 4.0, 1e-6);  // broken discs are ignored
  const LaserScan2 bad_pose = lidar.scan(Pose2{std::nan(""), 0.0, 0.0}, scene, 0.0);
  for (float r : bad_pose.ranges) ASSERT_TRUE(std::isinf(r) && r > 0.0);
}

TEST(LidarConfig, NamedProfilesOfTheTurtlebotScanners) {
  const LidarConfig urg = LidarConfig::profile("urg04lx");
  EXPECT_EQ(urg.validate(), "");
  EXPECT_EQ(urg.beams, 683);
  EXPECT_NEAR(urg.angleMin_rad(), -120.0 * kPi / 180.0, 1e-12);
  EXPECT_NEAR(urg.angleMin_rad() + 682 * urg.angleIncrement_rad(), 120.0 * kPi / 180.0, 1e-12);
  EXPECT_NEAR(urg.angleIncrement_rad(), kTwoPi / 1024.0, 2e-5);  // the device's native step, to 0.1 %
  EXPECT_DOUBLE_EQ(urg.range_min_m, 0.02);
  EXPECT_DOUBLE_EQ(urg.range_max_m, 5.6);
  EXPECT_DOUBLE_EQ(urg.scan_period_s, 0.1);
  const LidarConfig a1 = LidarConfig::profile("rplidar_a1");
  EXPECT_EQ(a1.validate(), "");
  EXPECT_TRUE(a1.fullCircle());
  EXPECT_EQ(a1.beams, 360);
  EXPECT_DOUBLE_EQ(a1.range_max_m, 8.0);
  EXPECT_NEAR(1.0 / a1.scan_period_s, 7.0, 1e-9);
  for (const std::string& name : LidarConfig::profileNames()) EXPECT_EQ(LidarConfig::profile(name).validate(), "");
  // The simulation profile has none of the hardware effects: training scans stay as they were.
  const LidarConfig sim = LidarConfig::profile("sim");
  EXPECT_EQ(sim.dropout_probability, 0.0);
  EXPECT_EQ(sim.mixed_pixel_probability, 0.0);
  EXPECT_DOUBLE_EQ(sim.grazing_limit_rad, kPi / 2.0);
  try {
    LidarConfig::profile("velodyne");
    FAIL() << "no error for an unknown profile";
  } catch (const SimConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("'velodyne' is not one of sim, hokuyo, urg04lx, rplidar_a1"),
              std::string::npos)
        << e.what();
  }
  LidarConfig c;
  c.dropout_probability = 1.0;
  EXPECT_NE(c.validate().find("dropout_probability"), std::string::npos);
  c = LidarConfig();
  c.grazing_limit_rad = 2.0;
  EXPECT_NE(c.validate().find("grazing_limit_rad"), std::string::npos);
  c = LidarConfig();
  c.mixed_pixel_probability = -0.1;
  EXPECT_NE(c.validate().find("mixed_pixel_probability"), std::string::npos);
  c = LidarConfig();
  c.scan_period_s = 0.0;
  EXPECT_NE(c.validate().find("scan_period_s"), std::string::npos);
}

TEST(Lidar, DarkSurfacesDropReturnsAtTheirRateReproducibly) {
  LidarConfig c = noiseless();
  c.dropout_probability = 0.1;
  LidarScene room;
  room.room_half_size_m = 4.0;
  Lidar a(c, 7), b(c, 7);
  size_t lost = 0, total = 0;
  for (int k = 0; k < 20; ++k) {
    const LaserScan2 sa = a.scan({0.3, -0.2, 0.1}, room, 0.0), sb = b.scan({0.3, -0.2, 0.1}, room, 0.0);
    for (size_t i = 0; i < sa.ranges.size(); ++i) {
      EXPECT_EQ(std::isinf(sa.ranges[i]), std::isinf(sb.ranges[i]));  // same seed, same losses
      lost += sa.ranges[i] == static_cast<float>(kInf);
      ++total;
    }
  }
  const double rate = static_cast<double>(lost) / static_cast<double>(total);
  EXPECT_NEAR(rate, 0.1, 0.01) << lost << " of " << total;  // 14,400 beams: 4.5 standard deviations
}

TEST(Lidar, GlancingSurfacesReturnNothingBeyondTheLimit) {
  LidarConfig c = noiseless();
  c.grazing_limit_rad = 60.0 * kPi / 180.0;
  // A long wall along y = 1: the beam at bearing b meets it 90 deg - b from its normal.
  LidarScene wall;
  wall.segments.push_back({Vec2(-50.0, 1.0), Vec2(50.0, 1.0)});
  Lidar lidar(c, 1);
  const LaserScan2 scan = lidar.scan({}, wall, 0.0);
  for (double bearing_deg : {90.0, 60.0, 45.0, 31.0}) {
    const size_t i = beamAt(c, bearing_deg * kPi / 180.0);
    EXPECT_NEAR(scan.ranges[i], 1.0 / std::sin(bearing_deg * kPi / 180.0), 1e-4) << bearing_deg;
  }
  for (double bearing_deg : {29.0, 20.0, 10.0}) {
    const size_t i = beamAt(c, bearing_deg * kPi / 180.0);
    EXPECT_TRUE(std::isinf(scan.ranges[i]) && scan.ranges[i] > 0) << bearing_deg << " deg: " << scan.ranges[i];
  }
  // A disc is seen face-on at its centre and glancingly at its rim.
  LidarScene disc;
  disc.discs.push_back({Vec2(3.0, 0.0), 1.0});
  const LaserScan2 d = lidar.scan({}, disc, 0.0);
  EXPECT_NEAR(d.ranges[beamAt(c, 0.0)], 2.0, 1e-6);
  // The beam at bearing a meets the disc 3 sin(a) off its centre line: asin(3 sin a) from the surface normal.
  int kept = 0, dropped = 0;
  for (size_t i = 0; i < d.ranges.size(); ++i) {
    const double a = c.angleMin_rad() + static_cast<double>(i) * c.angleIncrement_rad();
    const double offset = 3.0 * std::sin(std::abs(a));
    if (std::cos(a) <= 0.0 || offset >= 1.0) continue;  // misses the disc
    if (offset < std::sin(59.0 * kPi / 180.0)) {
      EXPECT_TRUE(std::isfinite(d.ranges[i])) << "bearing " << a;
      ++kept;
    } else if (offset > std::sin(61.0 * kPi / 180.0)) {
      EXPECT_TRUE(std::isinf(d.ranges[i])) << "bearing " << a;
      ++dropped;
    }
  }
  EXPECT_GT(kept, 10);
  EXPECT_GT(dropped, 2);
}

TEST(Lidar, MixedPixelsLieBetweenTheSurfacesAtDepthEdgesOnly) {
  LidarConfig c = noiseless();
  c.mixed_pixel_probability = 1.0;
  LidarScene scene;
  scene.room_half_size_m = 6.0;
  scene.discs.push_back({Vec2(2.0, 0.0), 0.5});
  const Pose2 pose{};
  Lidar lidar(c, 3);
  const std::vector<double> truth = lidar.trueRanges(pose, scene);
  const LaserScan2 scan = lidar.scan(pose, scene, 0.0);
  int mixed = 0;
  for (size_t i = 0; i < truth.size(); ++i) {
    const double r = scan.ranges[i];
    if (std::abs(r - truth[i]) < 1e-6) continue;
    ++mixed;
    // Only a beam beside a depth edge changes, to a range between its neighbour's surface and its own.
    const double left = truth[(i + truth.size() - 1) % truth.size()], right = truth[(i + 1) % truth.size()];
    const double near = std::min(left, right);
    EXPECT_LT(near + c.mixed_pixel_jump_m, truth[i]) << "beam " << i << " is not the far side of an edge";
    EXPECT_GE(r, near - 1e-6);
    EXPECT_LE(r, truth[i] + 1e-6);
  }
  EXPECT_EQ(mixed, 2) << "one mixed beam at each side of the disc";
}

}  // namespace
}  // namespace dqn_dovs::sim
