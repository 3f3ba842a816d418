#include "conversions.h"

#include <tf2/utils.h>

#include <cmath>
#include <sstream>

namespace dqn_dovs {

std::string laserScanFromMsg(const sensor_msgs::LaserScan& msg, LaserScan2& out, size_t* invalid_beams) {
  std::ostringstream why;
  if (msg.header.frame_id.empty()) return "scan has an empty header.frame_id";
  if (msg.ranges.empty()) return "scan has no ranges";
  if (!std::isfinite(msg.angle_min) || !std::isfinite(msg.angle_max) || !std::isfinite(msg.angle_increment)) {
    return "scan angle_min / angle_max / angle_increment is not finite";
  }
  if (std::abs(msg.angle_increment) < 1e-9) return "scan angle_increment is zero";
  if (!std::isfinite(msg.range_max) || msg.range_max <= 0.0f || !std::isfinite(msg.range_min) || msg.range_min < 0.0f ||
      msg.range_min >= msg.range_max) {
    why << "scan range limits are invalid (range_min " << msg.range_min << ", range_max " << msg.range_max << ")";
    return why.str();
  }
  const double span = static_cast<double>(msg.angle_increment) * static_cast<double>(msg.ranges.size() - 1);
  if (std::abs(span) > 2.0 * kPi + 1e-3) {
    why << "scan has " << msg.ranges.size() << " beams of " << msg.angle_increment << " rad: more than one turn";
    return why.str();
  }
  // The angles must describe the ranges: angle_max = angle_min + (n - 1) angle_increment, give or take a beam
  // (drivers differ on whether angle_max is the last beam's angle or one increment past it).
  const double described = (static_cast<double>(msg.angle_max) - msg.angle_min) / msg.angle_increment + 1.0;
  if (!(std::abs(described - static_cast<double>(msg.ranges.size())) <= 1.01)) {
    why << "scan has " << msg.ranges.size() << " ranges but its angles (angle_min " << msg.angle_min << ", angle_max "
        << msg.angle_max << ", angle_increment " << msg.angle_increment << ") describe " << described << " beams";
    return why.str();
  }
  out.stamp_s = msg.header.stamp.toSec();
  out.angle_min = msg.angle_min;
  out.angle_increment = msg.angle_increment;
  out.range_min = msg.range_min;
  out.range_max = msg.range_max;
  out.ranges.assign(msg.ranges.begin(), msg.ranges.end());
  if (invalid_beams) {
    size_t bad = 0;
    for (float r : msg.ranges) {
      if (!std::isfinite(r) || r < msg.range_min || r > msg.range_max) ++bad;
    }
    *invalid_beams = bad;
  }
  return {};
}

void laserScanToMsg(const LaserScan2& scan, sensor_msgs::LaserScan& msg) {
  msg.angle_min = static_cast<float>(scan.angle_min);
  msg.angle_increment = static_cast<float>(scan.angle_increment);
  msg.angle_max = static_cast<float>(scan.angleOf(scan.ranges.empty() ? 0 : scan.ranges.size() - 1));
  msg.range_min = static_cast<float>(scan.range_min);
  msg.range_max = static_cast<float>(scan.range_max);
  msg.time_increment = 0.0f;
  msg.scan_time = 0.0f;
  msg.ranges = scan.ranges;
  msg.intensities.clear();
}

std::string occupancyMapFromMsg(const nav_msgs::OccupancyGrid& msg, OccupancyMap& out) {
  std::ostringstream os;
  const auto& info = msg.info;
  geometry_msgs::Transform origin;
  origin.translation.x = info.origin.position.x;
  origin.translation.y = info.origin.position.y;
  origin.rotation = info.origin.orientation;
  Pose2 origin_pose;
  if (msg.header.frame_id.empty()) {
    os << "map has an empty frame_id";
  } else if (!std::isfinite(info.resolution) || info.resolution <= 0.0f) {
    os << "map resolution " << info.resolution << " m is not a positive number";
  } else if (info.width == 0 || info.height == 0) {
    os << "map has no cells (" << info.width << " x " << info.height << ")";
  } else if (msg.data.size() != static_cast<size_t>(info.width) * info.height) {
    os << "map data has " << msg.data.size() << " cells, width x height is " << info.width << " x " << info.height;
  } else if (!poseFromTransform(origin, origin_pose)) {
    os << "map origin is not finite";
  }
  if (!os.str().empty()) return os.str();
  out = OccupancyMap{};
  out.name = "map in frame '" + msg.header.frame_id + "'";
  out.resolution_m = info.resolution;
  out.origin = origin_pose;
  out.width = static_cast<int>(info.width);
  out.height = static_cast<int>(info.height);
  out.cells.resize(msg.data.size());
  for (size_t i = 0; i < msg.data.size(); ++i) {
    const int v = msg.data[i];
    out.cells[i] = v >= 65 ? MapCell::kOccupied : (v >= 0 && v < 20 ? MapCell::kFree : MapCell::kUnknown);
  }
  return {};
}

nav_msgs::OccupancyGrid occupancyGridToMsg(const RouteGrid& grid) {
  nav_msgs::OccupancyGrid msg;
  msg.info.resolution = static_cast<float>(grid.resolution_m);
  msg.info.width = static_cast<uint32_t>(grid.width);
  msg.info.height = static_cast<uint32_t>(grid.height);
  msg.info.origin = poseToMsg(grid.origin);
  msg.data.resize(grid.cells.size());
  for (size_t i = 0; i < grid.cells.size(); ++i) msg.data[i] = grid.cells[i] < 0 ? -1 : grid.cells[i];
  return msg;
}

bool poseFromTransform(const geometry_msgs::Transform& t, Pose2& out) {
  const auto& q = t.rotation;
  if (!std::isfinite(t.translation.x) || !std::isfinite(t.translation.y) || !std::isfinite(q.x) ||
      !std::isfinite(q.y) || !std::isfinite(q.z) || !std::isfinite(q.w)) {
    return false;
  }
  const double n = std::sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w);
  if (n < 1e-9) return false;
  out.x = t.translation.x;
  out.y = t.translation.y;
  out.theta = std::atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z));
  return true;
}

nav_msgs::Path pathToMsg(const std::vector<Vec2>& points, const std_msgs::Header& header) {
  nav_msgs::Path path;
  path.header = header;
  path.poses.reserve(points.size());
  for (const Vec2& p : points) {
    geometry_msgs::PoseStamped ps;
    ps.header = header;
    ps.pose.position.x = p.x();
    ps.pose.position.y = p.y();
    ps.pose.orientation.w = 1.0;
    path.poses.push_back(ps);
  }
  return path;
}

std::string pathPointsFromMsg(const nav_msgs::Path& msg, std::vector<Vec2>& out) {
  out.clear();
  out.reserve(msg.poses.size());
  for (size_t i = 0; i < msg.poses.size(); ++i) {
    const Vec2 v(msg.poses[i].pose.position.x, msg.poses[i].pose.position.y);
    if (!v.allFinite()) return "pose " + std::to_string(i) + " has a NaN/inf position";
    out.push_back(v);
  }
  return {};
}

geometry_msgs::Pose poseToMsg(const Pose2& p) {
  geometry_msgs::Pose m;
  m.position.x = p.x;
  m.position.y = p.y;
  m.orientation.z = std::sin(p.theta / 2.0);
  m.orientation.w = std::cos(p.theta / 2.0);
  return m;
}

namespace {
ObstacleSegment segmentToMsg(const Segment& s) {
  ObstacleSegment m;
  m.first_point.x = s.a.x();
  m.first_point.y = s.a.y();
  m.last_point.x = s.b.x();
  m.last_point.y = s.b.y();
  return m;
}
}  // namespace

TrackedObstacleArray trackedSceneToMsg(const TrackedScene& scene) {
  TrackedObstacleArray msg;
  msg.obstacles.reserve(scene.obstacles.size());
  for (const auto& o : scene.obstacles) {
    ObstacleTrack m;
    m.id = o.id;
    m.center.x = o.center.x();
    m.center.y = o.center.y();
    m.radius = o.radius;
    m.heading = o.heading;
    m.speed = o.speed;
    m.turn_rate = o.turn_rate;
    for (int r = 0; r < 5; ++r)
      for (int c = 0; c < 5; ++c) m.covariance[static_cast<size_t>(r * 5 + c)] = o.covariance(r, c);
    m.is_static = o.is_static;
    m.age = o.age_s;
    m.hits = static_cast<uint32_t>(std::max(0, o.hits));
    msg.obstacles.push_back(m);
  }
  for (const auto& s : scene.segments) msg.segments.push_back(segmentToMsg(s));
  return msg;
}

TrackedObstacleArray movingObstaclesToMsg(const std::vector<MovingObstacle>& obstacles,
                                          const std::vector<Segment>& segments) {
  TrackedObstacleArray msg;
  int id = 0;
  for (const auto& o : obstacles) {
    ObstacleTrack m;
    m.id = id++;
    m.center.x = o.center.x();
    m.center.y = o.center.y();
    m.radius = o.radius;
    m.heading = o.heading;
    m.speed = o.speed;
    m.turn_rate = o.turn_rate;
    m.is_static = o.is_static;
    for (int i = 0; i < 5; ++i) m.covariance[static_cast<size_t>(i * 6)] = 0.0;
    msg.obstacles.push_back(m);
  }
  for (const auto& s : segments) msg.segments.push_back(segmentToMsg(s));
  return msg;
}

std::string observationObstaclesFromMsg(const TrackedObstacleArray& msg, std::vector<MovingObstacle>& obstacles,
                                        std::vector<Segment>& segments) {
  obstacles.clear();
  segments.clear();
  for (size_t i = 0; i < msg.obstacles.size(); ++i) {
    const auto& m = msg.obstacles[i];
    std::ostringstream why;
    if (!std::isfinite(m.center.x) || !std::isfinite(m.center.y) || !std::isfinite(m.heading) ||
        !std::isfinite(m.speed) || !std::isfinite(m.turn_rate) || !std::isfinite(m.radius)) {
      why << "obstacle " << i << " (id " << m.id << ") has a NaN/inf field";
      return why.str();
    }
    if (m.radius <= 0.0) {
      why << "obstacle " << i << " (id " << m.id << ") has a non-positive radius " << m.radius;
      return why.str();
    }
    MovingObstacle o;
    o.center = {m.center.x, m.center.y};
    o.radius = m.radius;
    o.heading = m.heading;
    o.speed = m.is_static ? 0.0 : m.speed;
    o.turn_rate = m.is_static ? 0.0 : m.turn_rate;
    o.is_static = m.is_static;
    o.id = m.id;
    o.age_s = std::isfinite(m.age) ? m.age : -1.0;
    const double variance = 0.5 * (m.covariance[0] + m.covariance[6]);  // x and y of the row-major 5 x 5
    o.position_sigma_m = std::isfinite(variance) && variance >= 0.0 ? std::sqrt(variance) : -1.0;
    obstacles.push_back(o);
  }
  for (size_t i = 0; i < msg.segments.size(); ++i) {
    const auto& s = msg.segments[i];
    if (!std::isfinite(s.first_point.x) || !std::isfinite(s.first_point.y) || !std::isfinite(s.last_point.x) ||
        !std::isfinite(s.last_point.y)) {
      return "segment " + std::to_string(i) + " has a NaN/inf end point";
    }
    segments.push_back({{s.first_point.x, s.first_point.y}, {s.last_point.x, s.last_point.y}});
  }
  return {};
}

visualization_msgs::MarkerArray obstacleMarkers(const TrackedObstacleArray& msg, const std::string& ns, float r,
                                                float g, float b) {
  visualization_msgs::MarkerArray out;
  visualization_msgs::Marker clear;
  clear.header = msg.header;
  clear.ns = ns;
  clear.action = visualization_msgs::Marker::DELETEALL;
  out.markers.push_back(clear);
  int marker_id = 0;
  for (const auto& o : msg.obstacles) {
    visualization_msgs::Marker cyl;
    cyl.header = msg.header;
    cyl.ns = ns;
    cyl.id = marker_id++;
    cyl.type = visualization_msgs::Marker::CYLINDER;
    cyl.pose.position = o.center;
    cyl.pose.position.z = 0.15;
    cyl.pose.orientation.w = 1.0;
    cyl.scale.x = cyl.scale.y = 2.0 * o.radius;
    cyl.scale.z = 0.3;
    cyl.color.r = r;
    cyl.color.g = g;
    cyl.color.b = b;
    cyl.color.a = o.is_static ? 0.4f : 0.8f;
    out.markers.push_back(cyl);

    visualization_msgs::Marker text = cyl;
    text.id = marker_id++;
    text.type = visualization_msgs::Marker::TEXT_VIEW_FACING;
    text.pose.position.z = 0.45;
    text.scale.x = text.scale.y = 0.0;
    text.scale.z = 0.18;
    text.color.r = text.color.g = text.color.b = 1.0f;
    text.color.a = 1.0f;
    std::ostringstream label;
    label.precision(2);
    label << std::fixed << o.id << ": " << o.speed << " m/s";
    text.text = label.str();
    out.markers.push_back(text);

    if (!o.is_static && o.speed > 0.05) {
      visualization_msgs::Marker arrow = cyl;
      arrow.id = marker_id++;
      arrow.type = visualization_msgs::Marker::ARROW;
      arrow.pose = geometry_msgs::Pose();
      arrow.pose.orientation.w = 1.0;
      geometry_msgs::Point p0 = o.center, p1 = o.center;
      p0.z = p1.z = 0.3;
      p1.x += o.speed * std::cos(o.heading);  // one second ahead
      p1.y += o.speed * std::sin(o.heading);
      arrow.points = {p0, p1};
      arrow.scale.x = 0.04;
      arrow.scale.y = 0.08;
      arrow.scale.z = 0.1;
      arrow.color.a = 1.0f;
      out.markers.push_back(arrow);
    }
  }
  for (size_t i = 0; i < msg.segments.size(); ++i) {
    visualization_msgs::Marker line;
    line.header = msg.header;
    line.ns = ns + "_segments";
    line.id = static_cast<int>(i);
    line.type = visualization_msgs::Marker::LINE_STRIP;
    line.pose.orientation.w = 1.0;
    line.points = {msg.segments[i].first_point, msg.segments[i].last_point};
    line.scale.x = 0.05;
    line.color.r = r;
    line.color.g = g;
    line.color.b = b;
    line.color.a = 0.9f;
    out.markers.push_back(line);
  }
  return out;
}

diagnostic_msgs::DiagnosticStatus plannerDiagnostics(const PlannerStatus& status, const PlannerStatus& previous,
                                                     const std::string& name, const std::string& hardware_id) {
  diagnostic_msgs::DiagnosticStatus d;
  d.name = name;
  d.hardware_id = hardware_id;
  d.level = diagnostic_msgs::DiagnosticStatus::OK;
  d.message = status.reason;
  auto warn = [&](const std::string& why) {
    if (d.level == diagnostic_msgs::DiagnosticStatus::OK) d.message = why;
    d.level = diagnostic_msgs::DiagnosticStatus::WARN;
  };
  if (status.state == PlannerStatus::STOPPED) warn("stopped: " + status.reason);
  if (status.state == PlannerStatus::ABORTED) warn("goal aborted: " + status.reason);
  if (!status.recovery.empty()) warn("recovering (" + status.recovery + "): " + status.last_trigger);
  if (status.deadline_misses > previous.deadline_misses) {
    warn(std::to_string(status.deadline_misses - previous.deadline_misses) + " control periods missed their deadline");
  }
  if (status.envelope_corrections > previous.envelope_corrections) {
    warn("commands corrected by the safety envelope: " + status.envelope_last);
  }
  auto add = [&](const std::string& key, const std::string& value) {
    diagnostic_msgs::KeyValue kv;
    kv.key = key;
    kv.value = value;
    d.values.push_back(kv);
  };
  static const char* const kStates[] = {"idle", "active", "reached", "stopped", "aborted"};
  add("state", status.state < 5 ? kStates[status.state] : std::to_string(status.state));
  add("reason", status.reason);
  add("goal frame", status.goal_frame);
  add("goal distance (m)", std::to_string(status.goal_distance));
  add("route remaining (m)", std::to_string(status.route_remaining));
  add("recovery", status.recovery);
  add("recovery rounds", std::to_string(status.recovery_rounds));
  add("last trigger", status.last_trigger);
  add("control periods", std::to_string(status.control_periods));
  add("deadline misses", std::to_string(status.deadline_misses));
  add("max period lateness (s)", std::to_string(status.max_period_lateness));
  add("envelope corrections", std::to_string(status.envelope_corrections));
  add("static corrections", std::to_string(status.static_corrections));
  return d;
}

}  // namespace dqn_dovs
