// ROS wrapper of the simulator core: steps the world at a fixed period; cmd_vel in; scan, odom (the wheel
// odometry, drifting when asked), tf, the ground truth (robot and obstacles), (optionally) the map a robot would be
// given of the world and /clock out; services to reset and to load a scenario.
#pragma once

#include <geometry_msgs/Twist.h>
#include <ros/ros.h>
#include <std_srvs/Empty.h>
#include <tf2_ros/transform_broadcaster.h>

#include <memory>
#include <mutex>
#include <string>

#include "dqn_dovs/LoadScenario.h"
#include "dqn_dovs/sim/scenario.h"
#include "dqn_dovs/sim/world.h"

namespace dqn_dovs {

class SimulatorNode {
 public:
  /// Reads and validates parameters (throws ParameterError / ScenarioError naming the culprit).
  SimulatorNode(ros::NodeHandle nh, ros::NodeHandle pnh);
  /// Runs the stepping loop until shutdown (wall-clock paced by `realtime_factor`).
  void run();

 private:
  void onCmdVel(const geometry_msgs::Twist::ConstPtr& msg);
  bool onReset(std_srvs::Empty::Request&, std_srvs::Empty::Response&);
  bool onLoadScenario(LoadScenario::Request& req, LoadScenario::Response& res);
  void loadScenario(const sim::Scenario& scenario, uint64_t seed);
  /// A scenario file of either format (sim::loadScenarioFile), the dynamic fraction applied to .dovs files.
  sim::Scenario loadFile(const std::string& path, double dynamic_fraction) const;
  /// A generated scenario of the configured world family: `count` obstacles (room) or people, from `seed`.
  sim::Scenario generate(int count, double dynamic_fraction, uint64_t seed) const;
  void step();
  void publishState(bool with_scan);
  ros::Time simNow() const;

  ros::NodeHandle nh_, pnh_;
  std::string odom_frame_, base_frame_, laser_frame_;
  std::string map_frame_;    // empty: no map -> odom transform
  std::string truth_frame_;  // the frame of the ground truth and sim/status: map_frame_, else odom_frame_
  bool publish_laser_tf_ = true;
  double period_s_ = 0.05, scan_period_s_ = 0.1, realtime_factor_ = 1.0, cmd_timeout_s_ = 0.5;
  double dynamic_fraction_ = 0.85;
  double obstacle_radius_m_ = 0.2;
  bool publish_clock_ = false;
  bool publish_map_ = false;  // the known walls and furniture as a latched occupancy grid on `map`
  double map_resolution_m_ = 0.05;
  sim::WorldConfig world_config_;
  sim::GeneratorConfig generator_config_;
  std::string world_family_ = "room";

  std::mutex mutex_;  // guards the world, the scenario and the command (services run on the spinner thread)
  std::unique_ptr<sim::World> world_;
  sim::Scenario scenario_;
  uint64_t seed_ = 0;
  Twist2 command_;
  double command_stamp_s_ = -1e9;  // sim time of the last cmd_vel
  double next_scan_s_ = 0.0;
  double clock_offset_s_ = 0.0;  // sim time = offset + world time (keeps time monotonic across resets)
  bool collided_reported_ = false;

  ros::Subscriber cmd_sub_;
  ros::Publisher scan_pub_, odom_pub_, truth_odom_pub_, truth_pub_, truth_markers_pub_, clock_pub_, goal_pub_,
      status_pub_, map_pub_;
  ros::ServiceServer reset_srv_, load_srv_;
  tf2_ros::TransformBroadcaster tf_broadcaster_;
};

}  // namespace dqn_dovs
