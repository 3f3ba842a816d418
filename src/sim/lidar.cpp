#include "dqn_dovs/sim/lidar.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace dqn_dovs::sim {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

std::string bad(const char* field, double value, const std::string& why) {
  std::ostringstream os;
  os << "lidar parameter '" << field << "' = " << value << ": " << why;
  return os.str();
}

// Distance to the inside of the axis-aligned square |x|, |y| <= half from a point strictly inside it.
inline double rayRoomFromInside(const Vec2& o, const Vec2& d, double half) {
  double t = kInf;
  if (d.x() > 0.0)
    t = (half - o.x()) / d.x();
  else if (d.x() < 0.0)
    t = (-half - o.x()) / d.x();
  if (d.y() > 0.0)
    t = std::min(t, (half - o.y()) / d.y());
  else if (d.y() < 0.0)
    t = std::min(t, (-half - o.y()) / d.y());
  return t;
}

}  // namespace

std::string LidarConfig::validate() const {
  if (!(std::isfinite(fov_rad) && fov_rad > 0.0 && fov_rad <= kTwoPi + 1e-9)) {
    return bad("fov_rad", fov_rad, "must be in (0, 2 pi] rad");
  }
  if (beams < 1 || beams > 100000) return bad("beams", beams, "must be in [1, 100000]");
  if (!fullCircle() && beams < 2) return bad("beams", beams, "a partial field of view needs at least 2 beams");
  if (!(std::isfinite(range_min_m) && range_min_m >= 0.0)) {
    return bad("range_min_m", range_min_m, "must be finite and >= 0 m");
  }
  if (!(std::isfinite(range_max_m) && range_max_m > range_min_m)) {
    return bad("range_max_m", range_max_m, "must be finite and > range_min_m");
  }
  if (!(std::isfinite(noise_std_m) && noise_std_m >= 0.0)) {
    return bad("noise_std_m", noise_std_m, "must be finite and >= 0 m");
  }
  if (!(std::isfinite(noise_std_fraction) && noise_std_fraction >= 0.0 && noise_std_fraction < 1.0)) {
    return bad("noise_std_fraction", noise_std_fraction, "must be in [0, 1)");
  }
  if (!(std::isfinite(dropout_probability) && dropout_probability >= 0.0 && dropout_probability < 1.0)) {
    return bad("dropout_probability", dropout_probability, "must be in [0, 1)");
  }
  if (!(std::isfinite(grazing_limit_rad) && grazing_limit_rad > 0.0 && grazing_limit_rad <= kPi / 2.0 + 1e-12)) {
    return bad("grazing_limit_rad", grazing_limit_rad, "must be in (0, pi/2] rad");
  }
  if (!(std::isfinite(mixed_pixel_probability) && mixed_pixel_probability >= 0.0 && mixed_pixel_probability <= 1.0)) {
    return bad("mixed_pixel_probability", mixed_pixel_probability, "must be in [0, 1]");
  }
  if (!(std::isfinite(mixed_pixel_jump_m) && mixed_pixel_jump_m > 0.0)) {
    return bad("mixed_pixel_jump_m", mixed_pixel_jump_m, "must be finite and > 0 m");
  }
  if (!(std::isfinite(scan_period_s) && scan_period_s > 0.0 && scan_period_s <= 1.0)) {
    return bad("scan_period_s", scan_period_s, "must be in (0, 1] s");
  }
  if (!mount.isFinite()) return bad("mount", mount.x + mount.y + mount.theta, "mount pose must be finite");
  return {};
}

double LidarConfig::angleIncrement_rad() const {
  if (fullCircle()) return kTwoPi / static_cast<double>(beams);
  return beams > 1 ? fov_rad / static_cast<double>(beams - 1) : 0.0;
}

LidarConfig LidarConfig::simProfile() {
  LidarConfig c;
  c.fov_rad = kTwoPi;
  c.beams = 720;
  c.range_min_m = 0.05;
  c.range_max_m = 10.0;
  c.noise_std_m = 0.01;
  c.noise_std_fraction = 0.0;
  return c;
}

LidarConfig LidarConfig::hokuyoProfile() {
  LidarConfig c;
  c.fov_rad = kPi;
  c.beams = 513;  // 180 deg / (360 / 1024 deg) = 512 steps -> 513 beams
  c.range_min_m = 0.02;
  c.range_max_m = 5.6;
  c.noise_std_m = 0.005;
  c.noise_std_fraction = 0.005;
  return c;
}

LidarConfig LidarConfig::urg04lxProfile() {
  LidarConfig c = hokuyoProfile();
  c.fov_rad = 240.0 * kPi / 180.0;
  c.beams = 683;  // 240 deg / (360 / 1024 deg) = 682.7 steps
  c.dropout_probability = 0.01;
  c.grazing_limit_rad = 80.0 * kPi / 180.0;
  c.mixed_pixel_probability = 0.5;
  c.scan_period_s = 0.1;
  return c;
}

LidarConfig LidarConfig::rplidarA1Profile() {
  LidarConfig c;
  c.fov_rad = kTwoPi;
  c.beams = 360;
  c.range_min_m = 0.15;
  c.range_max_m = 8.0;
  c.noise_std_m = 0.005;
  c.noise_std_fraction = 0.01;
  c.dropout_probability = 0.02;
  c.grazing_limit_rad = 75.0 * kPi / 180.0;
  c.mixed_pixel_probability = 0.5;
  c.scan_period_s = 1.0 / 7.0;
  return c;
}

std::vector<std::string> LidarConfig::profileNames() { return {"sim", "hokuyo", "urg04lx", "rplidar_a1"}; }

LidarConfig LidarConfig::profile(const std::string& name) {
  if (name == "sim") return simProfile();
  if (name == "hokuyo") return hokuyoProfile();
  if (name == "urg04lx") return urg04lxProfile();
  if (name == "rplidar_a1") return rplidarA1Profile();
  std::string known;
  for (const std::string& n : profileNames()) known += (known.empty() ? "" : ", ") + n;
  throw SimConfigError("lidar profile '" + name + "' is not one of " + known);
}

Lidar::Lidar(const LidarConfig& config, uint64_t seed) : config_(config), rng_(seed) {
  const std::string error = config_.validate();
  if (!error.empty()) throw SimConfigError(error);
  const double amin = config_.angleMin_rad(), inc = config_.angleIncrement_rad();
  beam_dirs_local_.resize(static_cast<size_t>(config_.beams));
  for (size_t i = 0; i < beam_dirs_local_.size(); ++i) {
    const double a = amin + static_cast<double>(i) * inc;
    beam_dirs_local_[i] = Vec2(std::cos(a), std::sin(a));
  }
}

void Lidar::castAll(const Pose2& laser_pose, const LidarScene& scene, std::vector<Vec2>& dirs_world,
                    std::vector<double>& ranges, std::vector<double>* incidence_cos) const {
  const size_t n = beam_dirs_local_.size();
  ranges.assign(n, kInf);
  if (incidence_cos != nullptr) incidence_cos->assign(n, 1.0);
  // The cosine between beam i and a surface normal (unit or not: only its direction counts).
  auto incidence = [&](size_t i, const Vec2& normal) {
    if (incidence_cos == nullptr) return;
    const double norm = normal.norm();
    (*incidence_cos)[i] = norm > 0.0 ? std::abs(dirs_world[i].dot(normal)) / norm : 1.0;
  };
  if (!laser_pose.isFinite()) return;  // a broken pose sees nothing rather than garbage
  const Vec2 o = laser_pose.position();
  const double c = std::cos(laser_pose.theta), s = std::sin(laser_pose.theta);
  dirs_world.resize(n);
  for (size_t i = 0; i < n; ++i) {
    const Vec2& d = beam_dirs_local_[i];
    dirs_world[i] = Vec2(c * d.x() - s * d.y(), s * d.x() + c * d.y());
  }

  const double half = scene.room_half_size_m;
  if (half > 0.0) {
    if (std::abs(o.x()) < half && std::abs(o.y()) < half) {
      for (size_t i = 0; i < n; ++i) {
        ranges[i] = rayRoomFromInside(o, dirs_world[i], half);
        if (incidence_cos != nullptr) {
          // The wall hit is the one whose coordinate the hit point reaches.
          const Vec2 hit = o + ranges[i] * dirs_world[i];
          incidence(i, std::abs(std::abs(hit.x()) - half) < std::abs(std::abs(hit.y()) - half) ? Vec2(1.0, 0.0)
                                                                                               : Vec2(0.0, 1.0));
        }
      }
    } else {
      // Outside the room (only a misplaced robot can be there): fall back to the four wall segments.
      const Segment walls[4] = {{Vec2(-half, -half), Vec2(half, -half)},
                                {Vec2(half, -half), Vec2(half, half)},
                                {Vec2(half, half), Vec2(-half, half)},
                                {Vec2(-half, half), Vec2(-half, -half)}};
      for (size_t i = 0; i < n; ++i) {
        for (const Segment& w : walls) {
          const std::optional<double> t = raySegment(o, dirs_world[i], w);
          if (t && *t < ranges[i]) {
            ranges[i] = *t;
            incidence(i, Vec2(-(w.b - w.a).y(), (w.b - w.a).x()));
          }
        }
      }
    }
  }

  const double amin = config_.angleMin_rad(), inc = config_.angleIncrement_rad();
  const double yaw = laser_pose.theta;
  const long last = static_cast<long>(n) - 1;
  // Calls hit(i) for every beam whose angle (from beam 0) lies in [lo, hi] rad, with one guard beam on each side
  // against rounding, across the wrap of a full circle (hit decides exactly).
  auto forBeamsIn = [&](double lo, double hi, auto&& hit) {
    for (const double shift : {-kTwoPi, 0.0, kTwoPi}) {
      if (inc <= 0.0) {
        if (lo + shift <= 0.0 && hi + shift >= 0.0) hit(0);
        continue;
      }
      const long i0 = std::max(0L, static_cast<long>(std::floor((lo + shift) / inc)) - 1);
      const long i1 = std::min(last, static_cast<long>(std::ceil((hi + shift) / inc)) + 1);
      for (long i = i0; i <= i1; ++i) hit(static_cast<size_t>(i));
    }
  };
  // The angle of a world point from beam 0, in [0, 2 pi).
  auto beamAngle = [&](const Vec2& p) {
    double a = std::fmod(std::atan2(p.y() - o.y(), p.x() - o.x()) - yaw - amin, kTwoPi);
    return a < 0.0 ? a + kTwoPi : a;
  };

  for (const Segment& seg : scene.segments) {
    const Vec2 normal(-(seg.b - seg.a).y(), (seg.b - seg.a).x());
    auto hit = [&](size_t i) {
      const std::optional<double> t = raySegment(o, dirs_world[i], seg);
      if (t && *t < ranges[i]) {
        ranges[i] = *t;
        incidence(i, normal);
      }
    };
    // Only the beams between the angles of the two ends can hit the segment (the shorter arc between them; a
    // laser on the segment's line, where the arc is undefined, tries every beam).
    const Vec2 ra = seg.a - o, rb = seg.b - o;
    const double side = ra.x() * rb.y() - ra.y() * rb.x();
    if (!(seg.a.allFinite() && seg.b.allFinite())) continue;
    if (std::abs(side) < 1e-12 * std::max(1.0, ra.squaredNorm() + rb.squaredNorm())) {
      for (size_t i = 0; i < n; ++i) hit(i);
      continue;
    }
    double lo = beamAngle(seg.a), hi = beamAngle(seg.b);
    if (side < 0.0) std::swap(lo, hi);  // counter-clockwise from lo to hi
    if (hi < lo) hi += kTwoPi;
    forBeamsIn(lo, hi, hit);
  }

  for (const Circle& disc : scene.discs) {
    if (!(disc.center.allFinite() && std::isfinite(disc.radius) && disc.radius > 0.0)) continue;
    const Vec2 rel = disc.center - o;
    const double dist = rel.norm();
    if (dist <= disc.radius) {
      // The laser is inside the disc: every beam is blocked at once.
      std::fill(ranges.begin(), ranges.end(), 0.0);
      return;
    }
    // Only the beams inside the disc's angular span [bearing - half_span, bearing + half_span] can hit it.
    const double half_span = std::asin(disc.radius / dist);
    const double bearing = beamAngle(disc.center);
    forBeamsIn(bearing - half_span, bearing + half_span, [&](size_t k) {
      const std::optional<double> t = rayCircle(o, dirs_world[k], disc);
      if (t && *t < ranges[k]) {
        ranges[k] = *t;
        incidence(k, o + *t * dirs_world[k] - disc.center);
      }
    });
  }
}

std::vector<double> Lidar::trueRanges(const Pose2& laser_pose, const LidarScene& scene) const {
  std::vector<Vec2> dirs;
  std::vector<double> ranges;
  castAll(laser_pose, scene, dirs, ranges);
  return ranges;
}

LaserScan2 Lidar::scan(const Pose2& laser_pose, const LidarScene& scene, double stamp_s) {
  LaserScan2 out;
  scanInto(laser_pose, scene, stamp_s, out);
  return out;
}

void Lidar::scanInto(const Pose2& laser_pose, const LidarScene& scene, double stamp_s, LaserScan2& out) {
  const bool grazing = config_.grazing_limit_rad < kPi / 2.0;
  castAll(laser_pose, scene, dirs_world_, work_, grazing ? &incidence_ : nullptr);
  out.stamp_s = stamp_s;
  out.angle_min = config_.angleMin_rad();
  out.angle_increment = config_.angleIncrement_rad();
  out.range_min = config_.range_min_m;
  out.range_max = config_.range_max_m;
  out.ranges.resize(work_.size());
  const double rmin = config_.range_min_m, rmax = config_.range_max_m;
  const bool noisy = config_.noise_std_m > 0.0 || config_.noise_std_fraction > 0.0;
  const double grazing_cos = std::cos(config_.grazing_limit_rad);
  // Mixed pixels: at a depth edge the farther beam may report a range between the two surfaces. Decided on the
  // true ranges before noise, so a beam is mixed at most once.
  if (config_.mixed_pixel_probability > 0.0) {
    for (size_t i = 0; i + 1 < work_.size(); ++i) {
      const double a = work_[i], b = work_[i + 1];
      if (!(std::isfinite(a) && std::isfinite(b)) || std::abs(a - b) <= config_.mixed_pixel_jump_m) continue;
      if (rng_.uniform01() >= config_.mixed_pixel_probability) continue;
      double& far = a > b ? work_[i] : work_[i + 1];
      const double near = std::min(a, b);
      far = near + rng_.uniform01() * (far - near);
      ++i;  // the mixed beam is not the near side of the next edge
    }
  }
  for (size_t i = 0; i < work_.size(); ++i) {
    const double r = work_[i];
    double value = 0.0;
    const bool lost =
        r <= rmax && ((grazing && incidence_[i] < grazing_cos) ||
                      (config_.dropout_probability > 0.0 && rng_.uniform01() < config_.dropout_probability));
    if (!(r <= rmax) || lost) {
      value = kInf;
    } else if (r < rmin) {
      value = -kInf;
    } else {
      value = r;
      if (noisy) {
        const double sigma = std::max(config_.noise_std_m, config_.noise_std_fraction * r);
        value = std::clamp(r + sigma * rng_.normal(), rmin, rmax);
      }
    }
    out.ranges[i] = static_cast<float>(value);
  }
}

}  // namespace dqn_dovs::sim
