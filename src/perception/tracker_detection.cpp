// Scan checking, clustering and circle/segment classification of the obstacle tracker.
#include <algorithm>
#include <cmath>
#include <sstream>

#include "dqn_dovs/perception/circle_fit.h"
#include "dqn_dovs/perception/static_map.h"
#include "dqn_dovs/perception/tracker.h"

namespace dqn_dovs {
namespace {

struct Beam {
  size_t index = 0;
  double range = 0.0;
  Vec2 local = Vec2::Zero();  // laser frame
};

bool validRange(const LaserScan2& scan, float r) {
  return std::isfinite(r) && r >= scan.range_min && r < scan.range_max;
}

std::vector<Vec2> slice(const std::vector<Vec2>& pts, size_t first, size_t last) {
  return std::vector<Vec2>(pts.begin() + static_cast<std::ptrdiff_t>(first),
                           pts.begin() + static_cast<std::ptrdiff_t>(last) + 1);
}

/// Index ranges [first, last] (inclusive) of pieces of `pts` that each stay within split_distance_m of
/// their chord (iterative end-point fit), with neighbouring pieces merged back when their union is straight.
/// The split distance grows to 3 sigma of the range noise at the farther end of each chord.
std::vector<std::pair<size_t, size_t>> splitAndMerge(const std::vector<Vec2>& pts, const Vec2& laser_xy,
                                                     const TrackerConfig& config) {
  auto splitDistance = [&](size_t a, size_t b) {
    const double range = std::max((pts[a] - laser_xy).norm(), (pts[b] - laser_xy).norm());
    return std::max(config.split_distance_m, 3.0 * config.rangeNoise_m(range));
  };
  std::vector<std::pair<size_t, size_t>> pieces;
  std::vector<std::pair<size_t, size_t>> stack{{0, pts.size() - 1}};
  while (!stack.empty()) {
    const auto [a, b] = stack.back();
    stack.pop_back();
    size_t worst = a;
    double worst_d = 0.0;
    if (b > a + 1) {
      const Segment chord{pts[a], pts[b]};
      for (size_t i = a + 1; i < b; ++i) {
        const double d = pointSegmentDistance(pts[i], chord);
        if (d > worst_d) {
          worst_d = d;
          worst = i;
        }
      }
    }
    if (worst_d > splitDistance(a, b)) {
      // Push the right half first so that pieces come out in scan order.
      stack.push_back({worst, b});
      stack.push_back({a, worst});
    } else {
      pieces.push_back({a, b});
    }
  }
  // Merge step: adjacent pieces whose union is one straight line. A total-least-squares line is used here,
  // not the chord: noisy end points tilt a chord and would leave short spurious pieces inside a wall.
  std::vector<std::pair<size_t, size_t>> merged;
  for (const auto& piece : pieces) {
    if (!merged.empty()) {
      const auto line = fitLine(slice(pts, merged.back().first, piece.second));
      if (line && line->max_dev_m <= splitDistance(merged.back().first, piece.second)) {
        merged.back().second = piece.second;
        continue;
      }
    }
    merged.push_back(piece);
  }
  return merged;
}

/// Largest line-fit RMS of a straight piece whose points lie at about `range_m` (line_max_rms_m, or 1.5 sigma of
/// the range noise there when that is larger).
double lineMaxRms(const TrackerConfig& config, double range_m) {
  return std::max(config.line_max_rms_m, 1.5 * config.rangeNoise_m(range_m));
}

/// Mean distance of points from the laser.
double meanRange(const std::vector<Vec2>& pts, const Vec2& laser_xy) {
  double sum = 0.0;
  for (const Vec2& p : pts) sum += (p - laser_xy).norm();
  return pts.empty() ? 0.0 : sum / static_cast<double>(pts.size());
}

/// Classifies one group of consecutive returns (fixed frame) that contains no long wall piece.
/// next_to_wall: the group continues a wall of the same cluster.
void classifyGroup(const std::vector<Vec2>& pts, const std::vector<std::pair<size_t, size_t>>& pieces,
                   bool next_to_wall, const Vec2& laser_xy, const TrackerConfig& config, ScanDetections& out,
                   int depth = 0) {
  if (static_cast<int>(pts.size()) < config.min_cluster_points) return;
  const auto line = fitLine(pts);
  if (!line) return;
  const double length = line->extent.length();
  const bool straight = line->rms_m <= lineMaxRms(config, meanRange(pts, laser_xy));
  if (straight && length >= config.segment_min_length_m) {
    out.segments.push_back(line->extent);
    return;
  }
  // A straight remnant at the end of a wall (its corner, or the stretch beside a split point) is wall too.
  const bool flat = straight && (line->max_dev_m < config.min_arc_sagitta_ratio * length ||
                                 (next_to_wall && line->max_dev_m <= config.split_distance_m));
  if (flat) {
    // A short flat piece is a wall fragment (e.g. wall seen between two obstacles), never a moving object.
    out.segments.push_back(line->extent);
    return;
  }
  // Second start for the fit: the points' centroid pushed away from the laser by the fallback radius.
  Vec2 centroid = Vec2::Zero();
  for (const Vec2& p : pts) centroid += p;
  centroid /= static_cast<double>(pts.size());
  Vec2 away = centroid - laser_xy;
  const double centroid_range = away.norm();
  away = centroid_range > 1e-9 ? Vec2(away / centroid_range) : Vec2::UnitX();
  Circle hint;
  hint.center = centroid + config.fallback_radius_m * away;
  hint.radius = config.fallback_radius_m;
  const auto fit = fitCircle(pts, hint);
  if (fit && fit->circle.radius >= config.min_circle_radius_m && fit->circle.radius <= config.max_circle_radius_m &&
      fit->rms_m <= config.circle_max_rms_m && (fit->circle.center - laser_xy).norm() > centroid_range) {
    out.circles.push_back({fit->circle, fit->rms_m, true, pts});
    return;
  }
  if (depth < 3 && static_cast<int>(pts.size()) >= 2 * config.min_cluster_points) {
    // Two objects touching in one cluster (e.g. two discs passing close): seen from the laser, the junction
    // is a notch, the farthest point behind the chord of the group's ends. Split there and classify both sides.
    const Vec2& a = pts.front();
    const Vec2& b = pts.back();
    const Vec2 chord = b - a;
    size_t notch = 0;
    double notch_depth = 0.0;
    for (size_t i = static_cast<size_t>(config.min_cluster_points) - 1;
         i + static_cast<size_t>(config.min_cluster_points) <= pts.size(); ++i) {
      // Signed distance of the point behind the chord, positive away from the laser.
      const Vec2 normal = Vec2(-chord.y(), chord.x()).normalized();
      const double side = (a - laser_xy).dot(normal) >= 0.0 ? 1.0 : -1.0;
      const double behind = side * (pts[i] - a).dot(normal);
      if (behind > notch_depth) {
        notch_depth = behind;
        notch = i;
      }
    }
    if (notch > 0 && notch_depth > config.split_distance_m) {
      const std::vector<Vec2> left(pts.begin(), pts.begin() + static_cast<std::ptrdiff_t>(notch) + 1);
      const std::vector<Vec2> right(pts.begin() + static_cast<std::ptrdiff_t>(notch), pts.end());
      classifyGroup(left, {{0, left.size() - 1}}, next_to_wall, laser_xy, config, out, depth + 1);
      classifyGroup(right, {{0, right.size() - 1}}, next_to_wall, laser_xy, config, out, depth + 1);
      return;
    }
  }
  if (length <= 2.0 * config.max_circle_radius_m) {
    // Curved but too short or noisy for a free fit: a disc of at least the fallback radius behind the arc.
    const double radius = std::max(config.fallback_radius_m, 0.5 * length);
    const auto fixed = fitCircleFixedRadius(pts, radius, centroid + radius * away);
    Circle c{centroid + radius * away, radius};
    double rms = 0.0;
    if (fixed && (fixed->circle.center - laser_xy).norm() > centroid_range) {
      c = fixed->circle;
      rms = fixed->rms_m;
    }
    out.circles.push_back({c, rms, false, pts});
    return;
  }
  // Large and curved: not a disc obstacle; report its straight pieces.
  for (const auto& [a, b] : pieces) {
    if (b > a) out.segments.push_back({pts[a], pts[b]});
  }
}

/// People at leg height (TrackerConfig::pair_legs): leg-sized detections paired into person detections, nearest
/// pairs first; lone legs become persons of person_radius_m. Other detections are left as they are.
void pairLegs(const TrackerConfig& config, std::vector<CircleDetection>& circles) {
  // Whether the returns bulge like an arc: a short flat piece is a fragment of a wall or a piece of furniture
  // between occluders, not a leg.
  auto curved = [&](const CircleDetection& d, double length) {
    const Vec2 chord = d.points.back() - d.points.front();
    const Vec2 normal(-chord.y() / length, chord.x() / length);
    double sagitta = 0.0;
    for (const Vec2& p : d.points) sagitta = std::max(sagitta, std::abs((p - d.points.front()).dot(normal)));
    return sagitta >= config.min_arc_sagitta_ratio * length;
  };
  auto span = [](const CircleDetection& d) { return (d.points.back() - d.points.front()).norm(); };
  auto isLeg = [&](const CircleDetection& d) {
    if (d.points.size() < 2) return false;
    if (static_cast<int>(d.points.size()) < config.min_cluster_points)  // a far leg's fragment: by its extent
      return span(d) <= 2.0 * config.leg_max_radius_m;
    // By the extent of its returns (a free fit on a leg's handful of returns can be far off in radius), and
    // curved.
    const double length = span(d);
    return length <= 2.0 * config.leg_max_radius_m && length >= 1e-9 && curved(d, length);
  };
  // Both legs of one person in one cluster (one partly behind the other, or touching): wider than a leg, no wider
  // than merged_legs_max_span_m, curved, and smaller than a body: a circle fitted to it, when the fit succeeded,
  // has a radius of at most merged_legs_max_radius_m (a chair or a disc seen in part fits its own, larger radius).
  auto isMergedLegs = [&](const CircleDetection& d) {
    if (static_cast<int>(d.points.size()) < config.min_cluster_points) return false;
    const double length = span(d);
    return length > 2.0 * config.leg_max_radius_m && length <= config.merged_legs_max_span_m && curved(d, length) &&
           (!d.free_fit || d.circle.radius <= config.merged_legs_max_radius_m);
  };
  // A point a leg's radius (0.6 leg_max_radius_m) behind the middle of the returns, away from the laser (toward
  // the fitted centre, which lies behind a convex arc).
  auto behindReturns = [&](const CircleDetection& d) {
    Vec2 mid = Vec2::Zero();
    for (const Vec2& p : d.points) mid += p;
    mid /= static_cast<double>(d.points.size());
    const Vec2 behind = d.circle.center - mid;
    return behind.norm() > 1e-9 ? Vec2(mid + config.leg_max_radius_m * 0.6 * behind.normalized()) : mid;
  };
  std::vector<size_t> legs;
  for (size_t i = 0; i < circles.size(); ++i) {
    if (isLeg(circles[i])) legs.push_back(i);
  }
  // A leg's centre: a free fit's when its radius is a leg's, otherwise (the fit is off, or a fallback placement
  // sits fallback_radius_m behind the arc) a leg radius behind the middle of its returns.
  auto legCentre = [&](const CircleDetection& d) {
    if (d.free_fit && d.circle.radius <= config.leg_max_radius_m) return d.circle.center;
    return behindReturns(d);
  };
  struct Pair {
    double distance;
    size_t a, b;
  };
  std::vector<Pair> pairs;
  for (size_t i = 0; i < legs.size(); ++i) {
    for (size_t j = i + 1; j < legs.size(); ++j) {
      const double d = (legCentre(circles[legs[i]]) - legCentre(circles[legs[j]])).norm();
      if (d <= config.leg_pair_max_distance_m) pairs.push_back({d, legs[i], legs[j]});
    }
  }
  std::sort(pairs.begin(), pairs.end(), [](const Pair& x, const Pair& y) {
    return x.distance < y.distance || (x.distance == y.distance && (x.a < y.a || (x.a == y.a && x.b < y.b)));
  });
  std::vector<bool> used(circles.size(), false);
  std::vector<CircleDetection> out;
  for (const Pair& p : pairs) {
    if (used[p.a] || used[p.b]) continue;
    used[p.a] = used[p.b] = true;
    const Vec2 ca = legCentre(circles[p.a]), cb = legCentre(circles[p.b]);
    CircleDetection person;
    person.circle = {0.5 * (ca + cb), std::max(config.person_radius_m, 0.5 * p.distance + config.leg_max_radius_m)};
    person.fit_rms_m = std::max(circles[p.a].fit_rms_m, circles[p.b].fit_rms_m);
    person.free_fit = true;  // its radius speaks for the person
    person.from_legs = true;
    person.paired_legs = true;
    person.leg_offset = 0.5 * (ca - cb);
    person.points = std::move(circles[p.a].points);  // both legs are used up: their returns move to the person
    person.points.insert(person.points.end(), circles[p.b].points.begin(), circles[p.b].points.end());
    out.push_back(person);
  }
  for (size_t i : legs) {
    if (used[i]) continue;
    used[i] = true;
    // A fragment of fewer than min_cluster_points returns alone is too little to start a person.
    if (static_cast<int>(circles[i].points.size()) < config.min_cluster_points) continue;
    CircleDetection person;
    person.circle = {legCentre(circles[i]), config.person_radius_m};
    // The body's centre is anywhere within half a stride of this leg: a looser measurement.
    person.fit_rms_m = std::max(circles[i].fit_rms_m, config.lone_leg_std_m);
    person.free_fit = true;
    person.from_legs = true;
    person.lone_leg = true;
    person.points = std::move(circles[i].points);
    out.push_back(person);
  }
  for (size_t i = 0; i < circles.size(); ++i) {
    // Unpaired leg fragments are dropped.
    if (used[i] || static_cast<int>(circles[i].points.size()) < config.min_cluster_points) continue;
    if (isMergedLegs(circles[i])) {
      // The body's centre lies between the two legs, about a leg's radius behind their returns; a circle fitted to
      // the two merged arcs puts it a body's radius behind them instead.
      CircleDetection person;
      person.circle = {behindReturns(circles[i]), config.person_radius_m};
      person.fit_rms_m = std::max(circles[i].fit_rms_m, config.merged_legs_std_m);
      person.free_fit = true;
      person.from_legs = true;
      person.points = std::move(circles[i].points);
      out.push_back(person);
      continue;
    }
    out.push_back(std::move(circles[i]));
  }
  circles = std::move(out);
}

/// Classifies one cluster (fixed-frame points in scan order).
void classifyCluster(const std::vector<Vec2>& pts, const Vec2& laser_xy, const TrackerConfig& config,
                     ScanDetections& out) {
  const auto pieces = splitAndMerge(pts, laser_xy, config);
  // Long straight pieces are walls; runs of the other pieces between them are classified as groups.
  std::vector<bool> is_wall(pieces.size(), false);
  for (size_t k = 0; k < pieces.size(); ++k) {
    const auto [a, b] = pieces[k];
    if (static_cast<int>(b - a + 1) < config.min_cluster_points) continue;
    const std::vector<Vec2> piece = slice(pts, a, b);
    const auto line = fitLine(piece);
    if (line && line->rms_m <= lineMaxRms(config, meanRange(piece, laser_xy)) &&
        line->extent.length() >= config.segment_min_length_m) {
      is_wall[k] = true;
      out.segments.push_back(line->extent);
    }
  }
  size_t k = 0;
  while (k < pieces.size()) {
    if (is_wall[k]) {
      ++k;
      continue;
    }
    const size_t k0 = k;
    while (k < pieces.size() && !is_wall[k]) ++k;
    // Pieces share their split points; leave out a point that belongs to a neighbouring wall.
    size_t first = pieces[k0].first, last = pieces[k - 1].second;
    if (k0 > 0 && first == pieces[k0 - 1].second) ++first;
    if (k < pieces.size() && last == pieces[k].first && last > first) --last;
    if (last < first) continue;
    std::vector<std::pair<size_t, size_t>> local;
    for (size_t j = k0; j < k; ++j) {
      const size_t a = std::max(pieces[j].first, first), b = std::min(pieces[j].second, last);
      if (b >= a) local.push_back({a - first, b - first});
    }
    const bool next_to_wall = k0 > 0 || k < pieces.size();
    classifyGroup(slice(pts, first, last), local, next_to_wall, laser_xy, config, out);
  }
}

}  // namespace

std::string checkScan(const LaserScan2& scan) {
  std::ostringstream os;
  if (!std::isfinite(scan.stamp_s)) {
    os << "scan stamp is " << scan.stamp_s;
  } else if (scan.ranges.empty()) {
    os << "scan has no beams";
  } else if (!std::isfinite(scan.angle_increment) || scan.angle_increment == 0.0) {
    os << "scan angle_increment is " << scan.angle_increment << " (must be finite and non-zero)";
  } else if (!std::isfinite(scan.angle_min)) {
    os << "scan angle_min is " << scan.angle_min;
  } else if (!std::isfinite(scan.range_min) || !std::isfinite(scan.range_max) || scan.range_min < 0.0 ||
             scan.range_max <= scan.range_min) {
    os << "scan range limits [" << scan.range_min << ", " << scan.range_max
       << "] are unusable (need finite 0 <= range_min < range_max)";
  } else if (std::abs(scan.angle_increment) * static_cast<double>(scan.ranges.size() - 1) > kTwoPi + 1e-6) {
    os << "scan of " << scan.ranges.size() << " beams at " << scan.angle_increment
       << " rad spans more than a full turn";
  }
  return os.str();
}

ScanDetections detectObstacles(const LaserScan2& scan, const Pose2& laser_pose, const TrackerConfig& config,
                               StaticMap* structure, const MapStructureView& map) {
  ScanDetections out;
  out.stamp_s = scan.stamp_s;
  const size_t n = scan.ranges.size();
  const double inc = std::abs(scan.angle_increment);
  std::vector<Beam> beams;
  beams.reserve(n);
  for (size_t i = 0; i < n; ++i) {
    const float r = scan.ranges[i];
    if (!validRange(scan, r)) continue;
    const double a = scan.angleOf(i);
    beams.push_back({i, static_cast<double>(r), Vec2(r * std::cos(a), r * std::sin(a))});
  }
  out.valid_beams = beams.size();
  out.ignored_beams = n - beams.size();
  if (beams.empty()) return out;

  auto neighbours = [&](const Beam& p, const Beam& q, size_t index_gap) {
    if (index_gap > static_cast<size_t>(config.max_skipped_beams) + 1) return false;
    const double far = std::max(p.range, q.range);
    const double threshold = config.cluster_distance_base_m +
                             config.cluster_distance_beam_factor * far * inc * static_cast<double>(index_gap);
    return (p.local - q.local).norm() <= threshold;
  };

  // Linear pass over valid beams, then close the circle for scans that cover a full turn.
  std::vector<std::vector<size_t>> clusters;  // indices into `beams`
  clusters.push_back({0});
  for (size_t k = 1; k < beams.size(); ++k) {
    if (neighbours(beams[k - 1], beams[k], beams[k].index - beams[k - 1].index)) {
      clusters.back().push_back(k);
    } else {
      clusters.push_back({k});
    }
  }
  const bool full_turn = inc * static_cast<double>(n) >= kTwoPi - 0.5 * inc;
  if (full_turn && clusters.size() > 1) {
    const Beam& last = beams[clusters.back().back()];
    const Beam& first = beams[clusters.front().front()];
    if (neighbours(last, first, first.index + n - last.index)) {
      clusters.back().insert(clusters.back().end(), clusters.front().begin(), clusters.front().end());
      clusters.erase(clusters.begin());
    }
  }

  const Vec2 laser_xy = laser_pose.position();
  std::vector<Vec2> pts;
  for (const auto& cluster : clusters) {
    if (static_cast<int>(cluster.size()) < config.min_cluster_points) {
      // A far leg may return only leg_min_points beams: kept as a leg fragment, used only if it pairs with a leg.
      if (config.pair_legs && static_cast<int>(cluster.size()) >= config.leg_min_points) {
        CircleDetection d;
        Vec2 mid = Vec2::Zero();
        for (size_t k : cluster) {
          d.points.push_back(laser_pose.toWorld(beams[k].local));
          mid += d.points.back();
        }
        mid /= static_cast<double>(d.points.size());
        const Vec2 away = (mid - laser_xy).norm() > 1e-9 ? Vec2((mid - laser_xy).normalized()) : Vec2::UnitX();
        d.circle = {mid + config.leg_max_radius_m * away, config.leg_max_radius_m};
        d.free_fit = false;
        d.fit_rms_m = 0.0;
        out.circles.push_back(std::move(d));
      }
      continue;
    }
    ++out.clusters;
    pts.clear();
    for (size_t k : cluster) pts.push_back(laser_pose.toWorld(beams[k].local));
    classifyCluster(pts, laser_xy, config, out);
  }
  // What a map gives as walls and furniture is structure whatever the memory says.
  auto onMap = [&](const CircleDetection& d) {
    return map.structure != nullptr &&
           map.structure->fraction(d.points, map.fixed_in_map) >= config.structure_max_fraction;
  };
  std::vector<Segment> walls;
  if (structure != nullptr) {
    // Only long straight pieces teach the memory: a short flat piece may be a still person's legs.
    for (const Segment& s : out.segments) {
      if (s.length() >= config.segment_min_length_m) structure->addSegment(s, scan.stamp_s);
    }
    // Pieces of known walls (seen between people, at grazing angles, broken by missing returns) are wall, and so
    // are pieces on the line of a long wall of this scan, just beyond its end (the rest of that wall, farther).
    for (const Segment& s : out.segments) {
      if (s.length() >= config.segment_min_length_m) walls.push_back(s);
    }
  }
  auto onMemory = [&](const CircleDetection& d) {
    if (structure == nullptr) return false;
    if (structure->structureFraction(d.points, config.structure_min_scans) >= config.structure_max_fraction)
      return true;
    const double extension = config.structure_line_extension_m;
    if (extension <= 0.0) return false;
    for (const Segment& w : walls) {
      const Vec2 u = (w.b - w.a) / w.length();
      // Along the wall's line, up to `extension` beyond its ends; across it, nine in ten returns within 3 sigma
      // of the range noise (a leg beside the wall has none there).
      size_t near = 0;
      bool beside = true;
      for (const Vec2& p : d.points) {
        const Vec2 rel = p - w.a;
        const double along = rel.dot(u);
        if (along < -extension || along > w.length() + extension) {
          beside = false;
          break;
        }
        const double across = std::abs(rel.x() * u.y() - rel.y() * u.x());
        if (across <= std::max(0.03, 3.0 * config.rangeNoise_m((p - laser_xy).norm()))) ++near;
      }
      if (beside && 10 * near >= 9 * d.points.size()) return true;
    }
    return false;
  };
  if (structure != nullptr || map.structure != nullptr) {
    std::vector<CircleDetection> kept;
    kept.reserve(out.circles.size());
    for (CircleDetection& d : out.circles) {
      if (d.points.size() >= 2 && (onMap(d) || onMemory(d))) {
        // Its outline as a polyline of its returns (a chord would lie behind a chair's near side by up to its
        // radius), points closer than kOutlineStep_m to the last one kept skipped.
        constexpr double kOutlineStep_m = 0.05;
        Vec2 from = d.points.front();
        for (size_t k = 1; k < d.points.size(); ++k) {
          if (k + 1 < d.points.size() && (d.points[k] - from).norm() < kOutlineStep_m) continue;
          out.segments.push_back({from, d.points[k]});
          from = d.points[k];
        }
      } else {
        kept.push_back(std::move(d));
      }
    }
    out.circles = std::move(kept);
  }
  if (config.pair_legs) pairLegs(config, out.circles);
  return out;
}

}  // namespace dqn_dovs
