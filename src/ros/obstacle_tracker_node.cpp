#include "obstacle_tracker_node.h"

#include <boost/make_shared.hpp>
#include <utility>

#include "conversions.h"
#include "dqn_dovs/TrackedObstacleArray.h"
#include "dqn_dovs/maps/occupancy_map.h"
#include "pipeline_steps.h"
#include "ros_params.h"

namespace dqn_dovs {

TrackerConfig loadTrackerConfig(const ros::NodeHandle& pnh) {
  // Every TrackerConfig field by its config/tracker.yaml name; a key under tracker/ that names none is a typo.
  TrackerConfig c;
  XmlRpc::XmlRpcValue block;
  if (!pnh.getParam("tracker", block)) return c;
  if (block.getType() != XmlRpc::XmlRpcValue::TypeStruct) {
    throw ParameterError(pnh.resolveName("tracker") + ": expected a dictionary of tracker parameters");
  }
  for (const auto& entry : block) {
    const std::string& name = entry.first;
    std::string text;
    paramText(pnh, "tracker/" + name, text);
    const std::string why = setTrackerParameter(c, name, text);
    if (!why.empty()) throw ParameterError("parameter '" + pnh.resolveName("tracker/" + name) + "': " + why);
  }
  const std::string error = c.validate();
  if (!error.empty()) throw ParameterError(pnh.resolveName("tracker") + ": " + error);
  return c;
}

ObstacleTrackerNode::ObstacleTrackerNode(ros::NodeHandle nh, ros::NodeHandle pnh)
    : nh_(nh), pnh_(pnh), tf_waiter_(tf_buffer_), tf_listener_(tf_buffer_) {
  fixed_frame_ = param<std::string>(pnh_, "fixed_frame", "odom");
  if (fixed_frame_.empty()) throw ParameterError("parameter '" + pnh_.resolveName("fixed_frame") + "' is empty");
  tf_timeout_s_ = paramInRange(pnh_, "tf_timeout", 0.1, 0.0, 2.0);
  publish_markers_ = param<bool>(pnh_, "publish_markers", true);
  use_map_ = param<bool>(pnh_, "use_map", false);
  map_unknown_is_occupied_ = param<bool>(pnh_, "map_unknown_is_occupied", false);
  tracker_ = std::make_unique<ObstacleTracker>(loadTrackerConfig(pnh_));
  // Every parameter is read above: a key under this node that none of them names is a typo (ParameterError).
  refuseUnknownParameters(pnh_);

  obstacles_pub_ = nh_.advertise<TrackedObstacleArray>("obstacles", 5);
  markers_pub_ = nh_.advertise<visualization_msgs::MarkerArray>("obstacles/markers", 5);
  scan_sub_ = nh_.subscribe("scan", 5, &ObstacleTrackerNode::onScan, this, ros::TransportHints().tcpNoDelay());
  if (use_map_) map_sub_ = nh_.subscribe("map", 1, &ObstacleTrackerNode::onMap, this);
  ROS_INFO("obstacle_tracker: tracking in frame '%s'%s", fixed_frame_.c_str(),
           use_map_ ? "; what the map shows is never tracked" : "");
}

void ObstacleTrackerNode::onMap(const nav_msgs::OccupancyGrid::ConstPtr& msg) {
  std::unique_ptr<KnownStructure> structure;
  const std::string error =
      trackerMapFromMsg(*msg, map_unknown_is_occupied_, tracker_->config().map_tolerance_m, structure);
  if (!error.empty()) {
    ROS_ERROR("obstacle_tracker: map ignored (the previous one, if any, is kept): %s", error.c_str());
    return;
  }
  map_ = std::move(structure);
  map_frame_ = msg->header.frame_id;
  ROS_INFO("obstacle_tracker: map of %u x %u cells at %.3f m in '%s': what it shows is never tracked", msg->info.width,
           msg->info.height, msg->info.resolution, map_frame_.c_str());
}

MapStructureView ObstacleTrackerNode::mapView(const ros::Time& stamp) {
  if (!map_) return {};
  Pose2 fixed_in_map;
  const std::string why = tf_waiter_.lookupPose(map_frame_, fixed_frame_, stamp, tf_timeout_s_, fixed_in_map);
  if (!why.empty()) {
    ROS_WARN_THROTTLE(2.0, "obstacle_tracker: map left out of this scan: %s", why.c_str());
    return {};
  }
  return {map_.get(), fixed_in_map};
}

void ObstacleTrackerNode::onScan(const sensor_msgs::LaserScan::ConstPtr& msg) {
  LaserScan2 scan;
  size_t invalid_beams = 0;
  const std::string scan_error = laserScanFromMsg(*msg, scan, &invalid_beams);
  if (!scan_error.empty()) {
    ROS_WARN_THROTTLE(2.0, "obstacle_tracker: dropping scan: %s", scan_error.c_str());
    return;
  }
  if (invalid_beams == scan.ranges.size()) {
    ROS_WARN_THROTTLE(5.0, "obstacle_tracker: every beam of the scan is NaN/inf or out of range");
  }

  Pose2 laser_pose;
  const std::string why =
      tf_waiter_.lookupPose(fixed_frame_, msg->header.frame_id, msg->header.stamp, tf_timeout_s_, laser_pose);
  if (!why.empty()) {
    ROS_WARN_THROTTLE(2.0, "obstacle_tracker: scan dropped: %s (the scan's stamp)", why.c_str());
    return;
  }

  TrackedObstacleArray out;
  std::string reset_note;
  const std::string rejected = trackScan(*tracker_, scan, laser_pose, msg->header.stamp, fixed_frame_, out, reset_note,
                                         mapView(msg->header.stamp));
  if (!rejected.empty()) {
    ROS_WARN_THROTTLE(2.0, "obstacle_tracker: scan rejected: %s", rejected.c_str());
    return;
  }
  if (!reset_note.empty()) {
    ROS_WARN_THROTTLE(2.0, "obstacle_tracker: %s", reset_note.c_str());  // the note begins "tracks reset: "
  }

  // Published as a shared pointer: nodelets in the same manager get this very message, not a copy.
  const TrackedObstacleArray::ConstPtr shared = boost::make_shared<TrackedObstacleArray>(std::move(out));
  obstacles_pub_.publish(shared);
  if (publish_markers_ && markers_pub_.getNumSubscribers() > 0) {
    markers_pub_.publish(obstacleMarkers(*shared, "tracks", 0.9f, 0.4f, 0.1f));
  }
}

}  // namespace dqn_dovs
