#include "obstacle_tracker_node.h"

#include <tf2/exceptions.h>

#include "conversions.h"
#include "dqn_dovs/TrackedObstacleArray.h"
#include "pipeline_steps.h"
#include "ros_params.h"

namespace dqn_dovs {

TrackerConfig loadTrackerConfig(const ros::NodeHandle& pnh) {
  TrackerConfig c;
  const std::string p = "tracker/";
  c.cluster_distance_base_m = param<double>(pnh, p + "cluster_distance_base", c.cluster_distance_base_m);
  c.cluster_distance_beam_factor =
      param<double>(pnh, p + "cluster_distance_beam_factor", c.cluster_distance_beam_factor);
  c.min_cluster_points = param<int>(pnh, p + "min_cluster_points", c.min_cluster_points);
  c.segment_min_length_m = param<double>(pnh, p + "segment_min_length", c.segment_min_length_m);
  c.max_circle_radius_m = param<double>(pnh, p + "max_circle_radius", c.max_circle_radius_m);
  c.measurement_noise_m = param<double>(pnh, p + "measurement_noise", c.measurement_noise_m);
  c.accel_noise_mps2 = param<double>(pnh, p + "accel_noise", c.accel_noise_mps2);
  c.turn_accel_noise_rps2 = param<double>(pnh, p + "turn_accel_noise", c.turn_accel_noise_rps2);
  c.gate_mahalanobis2 = param<double>(pnh, p + "gate_mahalanobis2", c.gate_mahalanobis2);
  c.confirm_hits = param<int>(pnh, p + "confirm_hits", c.confirm_hits);
  c.deletion_timeout_s = param<double>(pnh, p + "deletion_timeout", c.deletion_timeout_s);
  c.max_time_gap_s = param<double>(pnh, p + "max_time_gap", c.max_time_gap_s);
  c.static_speed_threshold_mps = param<double>(pnh, p + "static_speed_threshold", c.static_speed_threshold_mps);
  c.pair_legs = param<bool>(pnh, p + "pair_legs", c.pair_legs);
  c.leg_max_radius_m = param<double>(pnh, p + "leg_max_radius", c.leg_max_radius_m);
  c.leg_pair_max_distance_m = param<double>(pnh, p + "leg_pair_max_distance", c.leg_pair_max_distance_m);
  c.person_radius_m = param<double>(pnh, p + "person_radius", c.person_radius_m);
  c.leg_min_points = param<int>(pnh, p + "leg_min_points", c.leg_min_points);
  c.lone_leg_std_m = param<double>(pnh, p + "lone_leg_std", c.lone_leg_std_m);
  c.range_noise_m = param<double>(pnh, p + "range_noise", c.range_noise_m);
  c.range_noise_fraction = param<double>(pnh, p + "range_noise_fraction", c.range_noise_fraction);
  c.structure_memory_s = param<double>(pnh, p + "structure_memory", c.structure_memory_s);
  c.structure_cell_m = param<double>(pnh, p + "structure_cell", c.structure_cell_m);
  c.structure_min_scans = param<int>(pnh, p + "structure_min_scans", c.structure_min_scans);
  c.structure_max_fraction = param<double>(pnh, p + "structure_max_fraction", c.structure_max_fraction);
  c.structure_line_extension_m = param<double>(pnh, p + "structure_line_extension", c.structure_line_extension_m);
  const std::string error = c.validate();
  if (!error.empty()) throw ParameterError(pnh.resolveName("tracker") + ": " + error);
  return c;
}

ObstacleTrackerNode::ObstacleTrackerNode(ros::NodeHandle nh, ros::NodeHandle pnh)
    : nh_(nh), pnh_(pnh), tf_listener_(tf_buffer_) {
  fixed_frame_ = param<std::string>(pnh_, "fixed_frame", "odom");
  if (fixed_frame_.empty()) throw ParameterError("parameter '" + pnh_.resolveName("fixed_frame") + "' is empty");
  tf_timeout_s_ = paramInRange(pnh_, "tf_timeout", 0.1, 0.0, 2.0);
  publish_markers_ = param<bool>(pnh_, "publish_markers", true);
  tracker_ = std::make_unique<ObstacleTracker>(loadTrackerConfig(pnh_));

  obstacles_pub_ = nh_.advertise<TrackedObstacleArray>("obstacles", 5);
  markers_pub_ = nh_.advertise<visualization_msgs::MarkerArray>("obstacles/markers", 5);
  scan_sub_ = nh_.subscribe("scan", 5, &ObstacleTrackerNode::onScan, this, ros::TransportHints().tcpNoDelay());
  ROS_INFO("obstacle_tracker: tracking in frame '%s'", fixed_frame_.c_str());
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

  geometry_msgs::TransformStamped tf;
  try {
    tf =
        tf_buffer_.lookupTransform(fixed_frame_, msg->header.frame_id, msg->header.stamp, ros::Duration(tf_timeout_s_));
  } catch (const tf2::TransformException& e) {
    ROS_WARN_THROTTLE(2.0, "obstacle_tracker: no transform %s <- %s at the scan time: %s", fixed_frame_.c_str(),
                      msg->header.frame_id.c_str(), e.what());
    return;
  }
  Pose2 laser_pose;
  if (!poseFromTransform(tf.transform, laser_pose)) {
    ROS_WARN_THROTTLE(2.0, "obstacle_tracker: transform %s <- %s has NaN/inf; scan dropped", fixed_frame_.c_str(),
                      msg->header.frame_id.c_str());
    return;
  }

  TrackedObstacleArray out;
  std::string reset_note;
  const std::string rejected = trackScan(*tracker_, scan, laser_pose, msg->header.stamp, fixed_frame_, out, reset_note);
  if (!rejected.empty()) {
    ROS_WARN_THROTTLE(2.0, "obstacle_tracker: scan rejected: %s", rejected.c_str());
    return;
  }
  if (!reset_note.empty()) {
    ROS_WARN_THROTTLE(2.0, "obstacle_tracker: %s", reset_note.c_str());  // the note begins "tracks reset: "
  }

  obstacles_pub_.publish(out);
  if (publish_markers_ && markers_pub_.getNumSubscribers() > 0) {
    markers_pub_.publish(obstacleMarkers(out, "tracks", 0.9f, 0.4f, 0.1f));
  }
}

}  // namespace dqn_dovs
