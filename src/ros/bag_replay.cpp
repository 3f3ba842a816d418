#include "bag_replay.h"

#include <geometry_msgs/PoseStamped.h>
#include <nav_msgs/OccupancyGrid.h>
#include <nav_msgs/Odometry.h>
#include <nav_msgs/Path.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/LaserScan.h>
#include <tf2/buffer_core.h>
#include <tf2/exceptions.h>
#include <tf2_msgs/TFMessage.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <memory>
#include <optional>
#include <sstream>

#include "conversions.h"
#include "pipeline_steps.h"

namespace dqn_dovs {

namespace {

/// Transform `frame` -> fixed at `stamp` as a planar pose; nullopt when tf has nothing usable.
std::optional<Pose2> lookupPose(const tf2::BufferCore& tf, const std::string& fixed, const std::string& frame,
                                const ros::Time& stamp) {
  try {
    Pose2 p;
    if (!poseFromTransform(tf.lookupTransform(fixed, frame, stamp).transform, p)) return std::nullopt;
    return p;
  } catch (const tf2::TransformException&) {
    return std::nullopt;
  }
}

}  // namespace

ReplayResult replayBag(const std::string& bag_path, const ReplayConfig& config) {
  const QNetwork network = QNetwork::load(config.model_path);
  ObstacleTracker tracker(config.tracker);
  DovsBuilder builder(config.limits, config.dovs);
  const StateNormalization normalization = stateNormalization(config.limits, config.dovs);
  VelocitySpace dovs;
  std::unique_ptr<PredictedArcs> predicted_arcs;
  TrackHistory track_history;
  if (!config.people_predictor.empty()) {
    predicted_arcs = std::make_unique<PredictedArcs>(
        std::make_shared<const PeoplePredictor>(PeoplePredictor::load(config.people_predictor)));
  }

  rosbag::Bag bag;
  try {
    bag.open(bag_path, rosbag::bagmode::Read);
  } catch (const rosbag::BagException& e) {
    throw ReplayError("bag '" + bag_path + "' cannot be read: " + e.what());
  }

  // Every transform first: lookups then never depend on when a transform was recorded.
  rosbag::View all(bag);
  const ros::Duration span = all.size() > 0 ? all.getEndTime() - all.getBeginTime() : ros::Duration(0.0);
  tf2::BufferCore tf(span + ros::Duration(60.0));
  rosbag::View tf_view(bag, rosbag::TopicQuery(std::vector<std::string>{"/tf", "/tf_static"}));
  for (const rosbag::MessageInstance& m : tf_view) {
    const auto msg = m.instantiate<tf2_msgs::TFMessage>();
    if (!msg) continue;
    for (const auto& t : msg->transforms) tf.setTransform(t, "bag", m.getTopic() == "/tf_static");
  }

  ReplayResult result;
  std::optional<nav_msgs::Odometry> odom;
  std::optional<Vec2> goal;
  // The last usable map, as each node keeps it (a malformed one is ignored and the previous one kept).
  std::unique_ptr<KnownStructure> tracker_structure;
  std::string tracker_map_frame, dovs_map_frame;
  std::vector<Segment> map_walls;
  std::vector<Vec2> route_ahead;  // the latest planner/route_ahead (fixed frame); empty: the straight line
  rosbag::View view(bag,
                    rosbag::TopicQuery(std::vector<std::string>{config.scan_topic, config.odom_topic, config.goal_topic,
                                                                config.map_topic, config.route_ahead_topic}));
  for (const rosbag::MessageInstance& m : view) {
    if (m.getTopic() == config.map_topic) {
      const auto msg = m.instantiate<nav_msgs::OccupancyGrid>();
      if (!msg) continue;
      std::unique_ptr<KnownStructure> structure;
      if (config.tracker_map &&
          trackerMapFromMsg(*msg, config.tracker_map_unknown_is_occupied, config.tracker.map_tolerance_m, structure)
              .empty()) {
        tracker_structure = std::move(structure);
        tracker_map_frame = msg->header.frame_id;
      }
      std::vector<Segment> walls;
      if (config.dovs_map && mapWallsFromMsg(*msg, config.dovs_map_unknown_is_occupied, walls).empty()) {
        map_walls = std::move(walls);
        dovs_map_frame = msg->header.frame_id;
      }
      continue;
    }
    if (m.getTopic() == config.odom_topic) {
      const auto msg = m.instantiate<nav_msgs::Odometry>();
      if (msg && std::isfinite(msg->twist.twist.linear.x) && std::isfinite(msg->twist.twist.angular.z)) odom = *msg;
      continue;
    }
    if (m.getTopic() == config.route_ahead_topic) {
      const auto msg = m.instantiate<nav_msgs::Path>();
      if (!msg || (msg->header.frame_id != config.fixed_frame && !msg->poses.empty())) continue;
      if (std::vector<Vec2> points; pathPointsFromMsg(*msg, points).empty()) route_ahead = std::move(points);
      continue;
    }
    if (m.getTopic() == config.goal_topic) {
      const auto msg = m.instantiate<geometry_msgs::PoseStamped>();
      if (!msg || !std::isfinite(msg->pose.position.x) || !std::isfinite(msg->pose.position.y)) continue;
      // The nodes take the latest transform when the goal arrives: here, the one at its recording time.
      auto frame_pose = lookupPose(tf, config.fixed_frame, msg->header.frame_id, m.getTime());
      if (!frame_pose) frame_pose = lookupPose(tf, config.fixed_frame, msg->header.frame_id, ros::Time(0));
      if (frame_pose) goal = frame_pose->toWorld(Vec2(msg->pose.position.x, msg->pose.position.y));
      continue;
    }
    const auto scan_msg = m.instantiate<sensor_msgs::LaserScan>();
    if (!scan_msg) continue;

    // obstacle_tracker_node
    LaserScan2 scan;
    const ros::Time stamp = scan_msg->header.stamp;
    const auto laser_pose = lookupPose(tf, config.fixed_frame, scan_msg->header.frame_id, stamp);
    TrackedObstacleArray obstacles;
    std::string reset_note;
    MapStructureView map_view;
    if (tracker_structure) {
      if (const auto fixed_in_map = lookupPose(tf, tracker_map_frame, config.fixed_frame, stamp)) {
        map_view = {tracker_structure.get(), *fixed_in_map};
      }
    }
    if (!laserScanFromMsg(*scan_msg, scan).empty() || !laser_pose ||
        !trackScan(tracker, scan, *laser_pose, stamp, config.fixed_frame, obstacles, reset_note, map_view).empty()) {
      ++result.scans_dropped;
      continue;
    }
    result.scans_with_map += map_view.structure != nullptr;
    result.scans.push_back(
        {stamp.toSec(), static_cast<int>(obstacles.obstacles.size()), static_cast<int>(obstacles.segments.size())});
    for (const auto& o : obstacles.obstacles) {
      result.tracks.push_back({stamp.toSec(), o.id, o.center.x, o.center.y, o.radius, o.heading, o.speed, o.turn_rate,
                               static_cast<bool>(o.is_static)});
    }

    // dovs_node
    if (!odom || std::abs((stamp - odom->header.stamp).toSec()) > config.max_input_age_s) continue;
    const auto robot_pose = lookupPose(tf, config.fixed_frame, config.base_frame, stamp);
    if (!robot_pose) continue;
    if (!map_walls.empty()) {
      if (const auto map_in_fixed = lookupPose(tf, config.fixed_frame, dovs_map_frame, stamp)) {
        addMapWalls(map_walls, *map_in_fixed, *robot_pose, config.dovs_map_range_m, obstacles);
        ++result.steps_with_map_walls;
      }
    }
    DovsStep step;
    const Twist2 odom_twist{odom->twist.twist.linear.x, odom->twist.twist.angular.z};
    if (!buildDovsStep(obstacles, *robot_pose, odom_twist, goal, config.limits, normalization, config.shield,
                       config.base_frame, builder, dovs, step, predicted_arcs.get(), &track_history, &route_ahead)
             .empty()) {
      continue;
    }

    // planner_node (its choice for this velocity space)
    const Dovs& d = step.msg;
    if (!goal || !d.has_goal) continue;
    DecisionRow row;
    row.stamp_s = stamp.toSec();
    row.v = d.v;
    row.w = d.w;
    row.goal_distance_m = (robot_pose->position() - *goal).norm();
    for (size_t i = 0; i < row.valid.size(); ++i) row.valid[i] = d.action_valid[i];
    std::string why;
    row.action = chooseAction(network, d, why);
    if (row.action >= 0) {
      const Twist2 u = choiceVelocity(d, row.action);
      row.target_v = u.v;
      row.target_w = u.w;
      row.q_gap = 1e9;  // the escape is no network choice: a different one on replay is a real difference
    }
    if (row.action >= 0 && row.action != kEscapeChoice) {
      const Eigen::Map<const Eigen::VectorXf> state(d.state.data(), static_cast<Eigen::Index>(d.state.size()));
      const QNetwork::QValues q = network.actionValues(state);
      double second = -std::numeric_limits<double>::infinity();
      for (size_t i = 0; i < q.size(); ++i) {
        if (row.valid[i] && static_cast<int>(i) != row.action) second = std::max(second, static_cast<double>(q[i]));
      }
      row.q_gap = std::isfinite(second) ? q[static_cast<size_t>(row.action)] - second : 1e9;
    }
    for (int i = 0; i < kStateGridCells; ++i) row.free_cells += d.state[static_cast<size_t>(i)] > 0.0f ? 1 : 0;
    const size_t features_at = static_cast<size_t>(network.gridChannels() * kStateGridCells);  // after the grid
    for (int i = 0; i < kNumFeatures; ++i)
      row.features[static_cast<size_t>(i)] = d.state[features_at + static_cast<size_t>(i)];
    result.decisions.push_back(row);
  }
  return result;
}

namespace {

std::ofstream openOut(const std::string& path) {
  std::ofstream out(path);
  if (!out) throw ReplayError("cannot write '" + path + "'");
  return out;
}

std::string fmt(double x) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.6f", x);
  return buf;
}

std::vector<std::string> splitCsv(const std::string& line) {
  std::vector<std::string> out;
  std::stringstream ss(line);
  std::string cell;
  while (std::getline(ss, cell, ',')) out.push_back(cell);
  return out;
}

double toDouble(const std::string& s, const std::string& file, size_t line) {
  try {
    size_t used = 0;
    const double v = std::stod(s, &used);
    if (used != s.size()) throw std::invalid_argument(s);
    return v;
  } catch (const std::exception&) {
    throw ReplayError(file + ":" + std::to_string(line) + ": '" + s + "' is not a number");
  }
}

}  // namespace

void writeReplayCsv(const ReplayResult& r, const std::string& tracks_csv, const std::string& decisions_csv) {
  // Tracks: a `scan` row per used scan (count of tracks and segments), then a `track` row per track.
  std::ofstream t = openOut(tracks_csv);
  t << "kind,stamp_s,id_or_tracks,x_or_segments,y,radius,heading,speed,turn_rate,is_static\n";
  size_t k = 0;
  for (const ScanRow& s : r.scans) {
    t << "scan," << fmt(s.stamp_s) << "," << s.tracks << "," << s.segments << ",,,,,,\n";
    for (; k < r.tracks.size() && r.tracks[k].stamp_s == s.stamp_s; ++k) {
      const TrackRow& o = r.tracks[k];
      t << "track," << fmt(o.stamp_s) << "," << o.id << "," << fmt(o.x) << "," << fmt(o.y) << "," << fmt(o.radius)
        << "," << fmt(o.heading) << "," << fmt(o.speed) << "," << fmt(o.turn_rate) << "," << (o.is_static ? 1 : 0)
        << "\n";
    }
  }
  std::ofstream d = openOut(decisions_csv);
  d << "stamp_s,v,w,goal_distance_m,valid,action,target_v,target_w,q_gap,free_cells,f0,f1,f2,f3,f4,f5,f6,f7\n";
  for (const DecisionRow& x : r.decisions) {
    std::string mask;
    for (bool b : x.valid) mask += b ? '1' : '0';
    d << fmt(x.stamp_s) << "," << fmt(x.v) << "," << fmt(x.w) << "," << fmt(x.goal_distance_m) << "," << mask << ","
      << x.action << "," << fmt(x.target_v) << "," << fmt(x.target_w) << "," << fmt(x.q_gap) << "," << x.free_cells;
    for (float f : x.features) d << "," << fmt(f);
    d << "\n";
  }
  if (!t || !d) throw ReplayError("writing '" + tracks_csv + "' or '" + decisions_csv + "' failed");
}

ReplayResult readReplayCsv(const std::string& tracks_csv, const std::string& decisions_csv) {
  ReplayResult r;
  std::ifstream t(tracks_csv);
  if (!t) throw ReplayError("cannot read '" + tracks_csv + "'");
  std::string line;
  size_t n = 0;
  std::getline(t, line);
  while (std::getline(t, line)) {
    ++n;
    const auto c = splitCsv(line);
    if (c.size() >= 4 && c[0] == "scan") {
      r.scans.push_back({toDouble(c[1], tracks_csv, n), static_cast<int>(toDouble(c[2], tracks_csv, n)),
                         static_cast<int>(toDouble(c[3], tracks_csv, n))});
    } else if (c.size() == 10 && c[0] == "track") {
      TrackRow o;
      o.stamp_s = toDouble(c[1], tracks_csv, n);
      o.id = static_cast<int>(toDouble(c[2], tracks_csv, n));
      o.x = toDouble(c[3], tracks_csv, n);
      o.y = toDouble(c[4], tracks_csv, n);
      o.radius = toDouble(c[5], tracks_csv, n);
      o.heading = toDouble(c[6], tracks_csv, n);
      o.speed = toDouble(c[7], tracks_csv, n);
      o.turn_rate = toDouble(c[8], tracks_csv, n);
      o.is_static = c[9] == "1";
      r.tracks.push_back(o);
    } else {
      throw ReplayError(tracks_csv + ":" + std::to_string(n + 1) + ": expected a scan or track row");
    }
  }
  std::ifstream d(decisions_csv);
  if (!d) throw ReplayError("cannot read '" + decisions_csv + "'");
  n = 0;
  std::getline(d, line);
  while (std::getline(d, line)) {
    ++n;
    const auto c = splitCsv(line);
    if (c.size() != 18 || c[4].size() != 8) {
      throw ReplayError(decisions_csv + ":" + std::to_string(n + 1) + ": expected 18 columns and an 8-action mask");
    }
    DecisionRow x;
    x.stamp_s = toDouble(c[0], decisions_csv, n);
    x.v = toDouble(c[1], decisions_csv, n);
    x.w = toDouble(c[2], decisions_csv, n);
    x.goal_distance_m = toDouble(c[3], decisions_csv, n);
    for (size_t i = 0; i < 8; ++i) x.valid[i] = c[4][i] == '1';
    x.action = static_cast<int>(toDouble(c[5], decisions_csv, n));
    x.target_v = toDouble(c[6], decisions_csv, n);
    x.target_w = toDouble(c[7], decisions_csv, n);
    x.q_gap = toDouble(c[8], decisions_csv, n);
    x.free_cells = static_cast<int>(toDouble(c[9], decisions_csv, n));
    for (size_t i = 0; i < 8; ++i) x.features[i] = static_cast<float>(toDouble(c[10 + i], decisions_csv, n));
    r.decisions.push_back(x);
  }
  return r;
}

std::vector<std::string> compareReplay(const ReplayResult& e, const ReplayResult& a, const ReplayTolerance& tol) {
  std::vector<std::string> diffs;
  auto differ = [&](double x, double y, double t) { return !(std::abs(x - y) <= t); };
  auto add = [&](double stamp, const std::string& what) {
    std::ostringstream os;
    os << "t = " << fmt(stamp) << " s: " << what;
    diffs.push_back(os.str());
  };
  if (e.scans.size() != a.scans.size()) {
    diffs.push_back("used scans: expected " + std::to_string(e.scans.size()) + ", got " +
                    std::to_string(a.scans.size()));
  }
  for (size_t i = 0; i < std::min(e.scans.size(), a.scans.size()); ++i) {
    const ScanRow &x = e.scans[i], &y = a.scans[i];
    if (differ(x.stamp_s, y.stamp_s, 1e-6)) add(x.stamp_s, "scan stamp differs: " + fmt(y.stamp_s));
    if (x.tracks != y.tracks) {
      add(x.stamp_s, "tracks: expected " + std::to_string(x.tracks) + ", got " + std::to_string(y.tracks));
    }
    if (x.segments != y.segments) {
      add(x.stamp_s, "segments: expected " + std::to_string(x.segments) + ", got " + std::to_string(y.segments));
    }
  }
  if (e.tracks.size() != a.tracks.size()) {
    diffs.push_back("track rows: expected " + std::to_string(e.tracks.size()) + ", got " +
                    std::to_string(a.tracks.size()));
  } else {
    for (size_t i = 0; i < e.tracks.size(); ++i) {
      const TrackRow &x = e.tracks[i], &y = a.tracks[i];
      const std::string who = "track " + std::to_string(x.id) + ": ";
      if (x.id != y.id || differ(x.stamp_s, y.stamp_s, 1e-6)) {
        add(x.stamp_s, who + "got id " + std::to_string(y.id) + " at " + fmt(y.stamp_s));
        continue;
      }
      if (differ(x.x, y.x, tol.position_m) || differ(x.y, y.y, tol.position_m)) {
        add(x.stamp_s,
            who + "centre (" + fmt(y.x) + ", " + fmt(y.y) + "), expected (" + fmt(x.x) + ", " + fmt(x.y) + ")");
      }
      if (differ(x.radius, y.radius, tol.radius_m))
        add(x.stamp_s, who + "radius " + fmt(y.radius) + ", expected " + fmt(x.radius));
      if (differ(x.speed, y.speed, tol.speed_mps))
        add(x.stamp_s, who + "speed " + fmt(y.speed) + ", expected " + fmt(x.speed));
      if (x.speed > 0.2 && differ(normalizeAngle(x.heading - y.heading), 0.0, tol.heading_rad)) {
        add(x.stamp_s, who + "heading " + fmt(y.heading) + ", expected " + fmt(x.heading));
      }
      if (differ(x.turn_rate, y.turn_rate, tol.turn_rate_rps)) {
        add(x.stamp_s, who + "turn rate " + fmt(y.turn_rate) + ", expected " + fmt(x.turn_rate));
      }
      if (x.is_static != y.is_static) add(x.stamp_s, who + "static flag differs");
    }
  }
  if (e.decisions.size() != a.decisions.size()) {
    diffs.push_back("decisions: expected " + std::to_string(e.decisions.size()) + ", got " +
                    std::to_string(a.decisions.size()));
    return diffs;
  }
  for (size_t i = 0; i < e.decisions.size(); ++i) {
    const DecisionRow &x = e.decisions[i], &y = a.decisions[i];
    if (differ(x.stamp_s, y.stamp_s, 1e-6)) {
      add(x.stamp_s, "decision stamp differs: " + fmt(y.stamp_s));
      continue;
    }
    if (differ(x.v, y.v, tol.velocity) || differ(x.w, y.w, tol.velocity)) {
      add(x.stamp_s,
          "robot velocity (" + fmt(y.v) + ", " + fmt(y.w) + "), expected (" + fmt(x.v) + ", " + fmt(x.w) + ")");
    }
    if (x.valid != y.valid) add(x.stamp_s, "action mask differs");
    if (x.action != y.action) {
      if (x.q_gap >= tol.q_tie) {
        add(x.stamp_s, "action " + std::to_string(y.action) + ", expected " + std::to_string(x.action) +
                           " (Q-value gap " + fmt(x.q_gap) + ")");
      }
    } else if (differ(x.target_v, y.target_v, tol.velocity) || differ(x.target_w, y.target_w, tol.velocity)) {
      add(x.stamp_s, "target (" + fmt(y.target_v) + ", " + fmt(y.target_w) + "), expected (" + fmt(x.target_v) + ", " +
                         fmt(x.target_w) + ")");
    }
    if (std::abs(x.free_cells - y.free_cells) > tol.free_cells) {
      add(x.stamp_s, "free cells " + std::to_string(y.free_cells) + ", expected " + std::to_string(x.free_cells));
    }
    for (size_t f = 0; f < x.features.size(); ++f) {
      if (differ(x.features[f], y.features[f], tol.feature)) {
        add(x.stamp_s,
            "feature " + std::to_string(f) + " = " + fmt(y.features[f]) + ", expected " + fmt(x.features[f]));
      }
    }
  }
  return diffs;
}

}  // namespace dqn_dovs
