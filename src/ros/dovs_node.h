// ROS wrapper of the DOVS: tracked obstacles + robot state (tf, odom) + goal -> Dovs message, the
// network state, and an image of the velocity space for rviz.
#pragma once

#include <geometry_msgs/PoseStamped.h>
#include <image_transport/image_transport.h>
#include <nav_msgs/OccupancyGrid.h>
#include <nav_msgs/Odometry.h>
#include <nav_msgs/Path.h>
#include <ros/ros.h>
#include <std_msgs/Int8.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "dqn_dovs/TrackedObstacleArray.h"
#include "dqn_dovs/dovs/actions.h"
#include "dqn_dovs/dovs/dovs.h"
#include "dqn_dovs/dovs/state.h"
#include "dqn_dovs/perception/people_predictor.h"
#include "dqn_dovs/planning/planner.h"
#include "dqn_dovs/policy/action_shield.h"
#include "transform_wait.h"

namespace dqn_dovs {

class DovsNode {
 public:
  /// Reads and validates parameters (throws ParameterError naming the culprit), then subscribes.
  DovsNode(ros::NodeHandle nh, ros::NodeHandle pnh);

 private:
  void onObstacles(const TrackedObstacleArray::ConstPtr& msg);
  void onOdom(const nav_msgs::Odometry::ConstPtr& msg);
  void onGoal(const geometry_msgs::PoseStamped::ConstPtr& msg);
  void onChosenAction(const std_msgs::Int8::ConstPtr& msg);
  void onMap(const nav_msgs::OccupancyGrid::ConstPtr& msg);
  void onRouteAhead(const nav_msgs::Path::ConstPtr& msg);
  /// The map's walls within map_range_m of `robot` (fixed frame), in the fixed frame at `stamp`, appended to
  /// `obstacles`. No map, or no transform from it: nothing appended (the scan's own walls still count).
  void addMapWalls(TrackedObstacleArray& obstacles, const Pose2& robot, const ros::Time& stamp);

  ros::NodeHandle nh_, pnh_;
  std::string fixed_frame_, base_frame_;
  double max_input_age_s_ = 0.5, tf_timeout_s_ = 0.05;
  int image_size_px_ = 400;
  RobotLimits limits_;
  DovsBuilder builder_;
  StateNormalization normalization_;
  ActionShieldConfig shield_;
  VelocitySpace dovs_;
  std::unique_ptr<PredictedArcs> predicted_arcs_;  ///< people_predictor: moving tracks on their predicted arcs
  TrackHistory track_history_;  ///< where the tracks were, for the person tokens (dovs/person_tokens > 0)
  // `planner` other than dqn_dovs (s_dovs, dwa, orca_diffdrive; the registry's): it decides on each velocity space
  // here, where the observation is, and the Dovs message carries its command to planner_node.
  std::string planner_name_ = "dqn_dovs";
  std::unique_ptr<Planner> planner_;

  // The map's walls (map frame), when `use_map`: static geometry beside the scan's, for what the LIDAR cannot see.
  bool use_map_ = false;
  double map_range_m_ = 4.0;
  bool map_unknown_is_occupied_ = false;
  std::string map_frame_;
  std::vector<Segment> map_walls_;

  std::optional<Vec2> goal_;  // in fixed_frame_
  ros::Time goal_stamp_;      // header.stamp of the goal message
  // The route's next metres (fixed frame) for the state's route points (dovs/route_points > 0), from planner_node's
  // planner/route_ahead: used only while its stamp is the goal's (empty: the straight line to the goal).
  std::vector<Vec2> route_ahead_;
  ros::Time route_ahead_stamp_;
  nav_msgs::Odometry last_odom_;
  bool have_odom_ = false;
  int chosen_action_ = -1;

  tf2_ros::Buffer tf_buffer_;
  // The waiter before the listener: the listener's thread, which calls the waiter, stops first.
  TransformWaiter tf_waiter_;
  tf2_ros::TransformListener tf_listener_;
  ros::Subscriber obstacles_sub_, odom_sub_, goal_sub_, action_sub_, map_sub_, route_ahead_sub_;
  ros::Publisher dovs_pub_;
  // dovs/image through image_transport: compressed and theora transports when their plugins are installed.
  image_transport::ImageTransport image_transport_;
  image_transport::Publisher image_pub_;
};

}  // namespace dqn_dovs
