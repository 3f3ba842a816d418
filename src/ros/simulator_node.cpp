#include "simulator_node.h"

#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/OccupancyGrid.h>
#include <nav_msgs/Odometry.h>
#include <rosgraph_msgs/Clock.h>
#include <sensor_msgs/LaserScan.h>

#include <cmath>
#include <optional>
#include <sstream>
#include <vector>

#include "conversions.h"
#include "dqn_dovs/SimStatus.h"
#include "dqn_dovs/TrackedObstacleArray.h"
#include "dqn_dovs/planning/route.h"
#include "dqn_dovs/sim/collision_kind.h"
#include "dqn_dovs/sim/worlds.h"
#include "ros_params.h"

namespace dqn_dovs {

namespace {

sim::LidarConfig loadLidarConfig(const ros::NodeHandle& pnh) {
  const std::string profile = param<std::string>(pnh, "lidar/profile", "sim");
  sim::LidarConfig c;
  try {
    c = sim::LidarConfig::profile(profile);
  } catch (const sim::SimConfigError& e) {
    throw ParameterError("parameter '" + pnh.resolveName("lidar/profile") + "': " + e.what());
  }
  c.fov_rad = param<double>(pnh, "lidar/fov", c.fov_rad);
  c.beams = param<int>(pnh, "lidar/beams", c.beams);
  c.range_min_m = param<double>(pnh, "lidar/range_min", c.range_min_m);
  c.range_max_m = param<double>(pnh, "lidar/range_max", c.range_max_m);
  c.noise_std_m = param<double>(pnh, "lidar/noise_std", c.noise_std_m);
  c.dropout_probability = param<double>(pnh, "lidar/dropout_probability", c.dropout_probability);
  c.grazing_limit_rad = param<double>(pnh, "lidar/grazing_limit", c.grazing_limit_rad);
  c.mixed_pixel_probability = param<double>(pnh, "lidar/mixed_pixel_probability", c.mixed_pixel_probability);
  const std::string error = c.validate();
  if (!error.empty()) throw ParameterError(pnh.resolveName("lidar") + ": " + error);
  return c;
}

/// The LIDAR's mount on the base and the height of its scan plane (the people's legs are cut there): the robot
/// description's laser link when there is one, else the profile's mount and the people model's default height.
/// An explicitly set lidar/mount_x, mount_y, mount_yaw or mount_height wins over the description, with a warning
/// naming both values.
void loadLaserMount(const ros::NodeHandle& pnh, const std::optional<RobotGeometry>& description,
                    const std::string& laser_frame, sim::WorldConfig& c) {
  if (description) {
    if (!(description->laser_height_m >= 0.0)) {
      std::ostringstream os;
      os << "robot_description: link '" << laser_frame << "' is " << -description->laser_height_m
         << " m below the base frame: the LIDAR must scan above the floor";
      throw ParameterError(os.str());
    }
    c.lidar.mount = description->laser_mount;
    c.people.scan_height_m = description->laser_height_m;
  }
  struct MountField {
    const char* name;
    const char* unit;
    double* value;
  };
  for (const MountField& f :
       {MountField{"lidar/mount_x", "m", &c.lidar.mount.x}, MountField{"lidar/mount_y", "m", &c.lidar.mount.y},
        MountField{"lidar/mount_yaw", "rad", &c.lidar.mount.theta},
        MountField{"lidar/mount_height", "m", &c.people.scan_height_m}}) {
    noteParameter(pnh, f.name);
    if (!pnh.hasParam(f.name)) continue;
    const double value = f.value == &c.people.scan_height_m ? paramInRange(pnh, f.name, *f.value, 0.0, 10.0)
                                                            : param<double>(pnh, f.name, *f.value);
    if (description && std::abs(value - *f.value) > 1e-9) {
      ROS_WARN(
          "simulator: parameter '%s' = %g %s differs from the robot description's link '%s' (%g %s); the "
          "parameter wins",
          pnh.resolveName(f.name).c_str(), value, f.unit, laser_frame.c_str(), *f.value, f.unit);
    }
    *f.value = value;
  }
}

geometry_msgs::TransformStamped makeTransform(const Pose2& p, const ros::Time& stamp, const std::string& parent,
                                              const std::string& child) {
  geometry_msgs::TransformStamped t;
  t.header.stamp = stamp;
  t.header.frame_id = parent;
  t.child_frame_id = child;
  t.transform.translation.x = p.x;
  t.transform.translation.y = p.y;
  t.transform.rotation.z = std::sin(p.theta / 2.0);
  t.transform.rotation.w = std::cos(p.theta / 2.0);
  return t;
}

}  // namespace

SimulatorNode::SimulatorNode(ros::NodeHandle nh, ros::NodeHandle pnh) : nh_(nh), pnh_(pnh) {
  odom_frame_ = param<std::string>(pnh_, "odom_frame", "odom");
  base_frame_ = param<std::string>(pnh_, "base_frame", "base_footprint");
  laser_frame_ = param<std::string>(pnh_, "laser_frame", "laser");
  if (odom_frame_.empty() || base_frame_.empty() || laser_frame_.empty()) {
    throw ParameterError("frame parameters (odom_frame, base_frame, laser_frame) must not be empty");
  }
  // Empty: no map frame, and the odom frame is the room frame (which it then is only without odometry drift).
  map_frame_ = param<std::string>(pnh_, "map_frame", "");
  if (!map_frame_.empty() && (map_frame_ == odom_frame_ || map_frame_ == base_frame_ || map_frame_ == laser_frame_)) {
    throw ParameterError("parameter '" + pnh_.resolveName("map_frame") + "' = '" + map_frame_ +
                         "' must differ from odom_frame, base_frame and laser_frame");
  }
  truth_frame_ = map_frame_.empty() ? odom_frame_ : map_frame_;
  // false where robot_state_publisher publishes the robot description's base -> laser chain (sim.launch).
  publish_laser_tf_ = param<bool>(pnh_, "publish_laser_tf", true);
  period_s_ = paramInRange(pnh_, "period", 0.05, 1e-3, 0.5);
  realtime_factor_ = paramInRange(pnh_, "realtime_factor", 1.0, 0.0, 1000.0);
  cmd_timeout_s_ = paramInRange(pnh_, "cmd_timeout", 0.5, 0.05, 10.0);
  dynamic_fraction_ = paramInRange(pnh_, "dynamic_fraction", 0.85, 0.0, 1.0);
  publish_clock_ = param<bool>(pnh_, "publish_clock", false);
  publish_map_ = param<bool>(pnh_, "publish_map", false);
  map_resolution_m_ = paramInRange(pnh_, "map_resolution", 0.05, 0.01, 1.0);

  world_config_.robot = loadRobotLimits(pnh_);
  world_config_.lidar = loadLidarConfig(pnh_);
  const std::optional<RobotGeometry> description =
      loadRobotDescription(nh_, world_config_.robot, base_frame_, laser_frame_);
  loadLaserMount(pnh_, description, laser_frame_, world_config_);
  const std::string odometry_level = param<std::string>(pnh_, "odometry/level", "none");
  try {
    world_config_.odometry = sim::OdometryConfig::level(odometry_level);
  } catch (const sim::SimConfigError& e) {
    throw ParameterError("parameter '" + pnh_.resolveName("odometry/level") + "': " + e.what());
  }
  if (world_config_.odometry.enabled() && map_frame_.empty()) {
    ROS_WARN(
        "simulator: odometry/level '%s' makes '%s' drift from the room frame, but map_frame is empty: the ground "
        "truth and sim/status, in the room frame, are stamped '%s'; set map_frame to name the room frame",
        odometry_level.c_str(), odom_frame_.c_str(), odom_frame_.c_str());
  }
  // The scanner's own period unless overridden.
  scan_period_s_ = paramInRange(pnh_, "scan_period", world_config_.lidar.scan_period_s, period_s_, 1.0);
  world_config_.stop_on_collision = param<bool>(pnh_, "stop_on_collision", true);
  obstacle_radius_m_ = paramInRange(pnh_, "obstacle_radius", 0.2, 0.05, 1.0);
  const std::string world_error = world_config_.validate();
  if (!world_error.empty()) throw ParameterError(world_error);

  generator_config_.obstacle_count_min = generator_config_.obstacle_count_max =
      static_cast<int>(paramInRange(pnh_, "generator/obstacles", 8, 0, 40));
  generator_config_.obstacle_type = sim::ObstacleType::kBoth;
  generator_config_.dynamic_fraction = dynamic_fraction_;
  // World family of generated scenarios (sim/worlds.h): "room" is the paper's; the others hold
  // generator/obstacles people, moved by people/model, who see the robot when people/see_robot.
  world_family_ = param<std::string>(pnh_, "world", "room");
  try {
    sim::parseWorldFamily(world_family_);
    world_config_.people.model = sim::parsePeopleModel(param<std::string>(pnh_, "people/model", "social_force"));
  } catch (const sim::SimConfigError& e) {
    throw ParameterError(std::string("simulator: ") + e.what());
  }
  world_config_.people.see_robot = param<bool>(pnh_, "people/see_robot", false);
  // How people treat the robot (sim::PeopleMix: attentive, impassive, oblivious shares); empty: all oblivious.
  const std::string mix = param<std::string>(pnh_, "people/mix", "");
  if (!mix.empty()) {
    try {
      world_config_.people.mix = sim::PeopleMix::parse(mix);
    } catch (const sim::SimConfigError& e) {
      throw ParameterError("parameter '" + pnh_.resolveName("people/mix") + "': " + e.what());
    }
  }

  // First scenario: a .dovs file when `scenario` is set, else the generator with `seed`.
  const std::string scenario_path = param<std::string>(pnh_, "scenario", "");
  const int seed = param<int>(pnh_, "seed", 1);
  if (seed < 0) throw ParameterError("parameter '" + pnh_.resolveName("seed") + "' must be >= 0");
  sim::Scenario scenario;
  if (!scenario_path.empty()) {
    scenario = loadFile(scenario_path, dynamic_fraction_);
  } else {
    scenario = generate(generator_config_.obstacle_count_min, dynamic_fraction_, static_cast<uint64_t>(seed));
  }

  scan_pub_ = nh_.advertise<sensor_msgs::LaserScan>("scan", 5);
  odom_pub_ = nh_.advertise<nav_msgs::Odometry>("odom", 10);
  truth_pub_ = nh_.advertise<TrackedObstacleArray>("ground_truth/obstacles", 5);
  truth_odom_pub_ = nh_.advertise<nav_msgs::Odometry>("ground_truth/odom", 10);
  truth_markers_pub_ = nh_.advertise<visualization_msgs::MarkerArray>("ground_truth/markers", 5);
  // Latched: the scenario's goal, for the planner when publish_goal is set (sim.launch), else for tools.
  const bool publish_goal = param<bool>(pnh_, "publish_goal", false);
  // Every parameter is read above: a key under this node that none of them names is a typo (ParameterError).
  refuseUnknownParameters(pnh_);
  goal_pub_ = nh_.advertise<geometry_msgs::PoseStamped>(publish_goal ? "move_base_simple/goal" : "sim/goal", 1, true);
  status_pub_ = nh_.advertise<SimStatus>("sim/status", 10);
  if (publish_clock_) clock_pub_ = nh_.advertise<rosgraph_msgs::Clock>("/clock", 10);
  // Latched, as map_server publishes it: the map a robot would be given of this world.
  if (publish_map_) map_pub_ = nh_.advertise<nav_msgs::OccupancyGrid>("map", 1, true);

  try {
    loadScenario(scenario, static_cast<uint64_t>(seed));
  } catch (const RouteError& e) {
    throw ParameterError("parameter '" + pnh_.resolveName("publish_map") + "': no map of scenario '" + scenario.name +
                         "': " + e.what());
  }

  cmd_sub_ = nh_.subscribe("cmd_vel", 5, &SimulatorNode::onCmdVel, this, ros::TransportHints().tcpNoDelay());
  reset_srv_ = pnh_.advertiseService("reset", &SimulatorNode::onReset, this);
  load_srv_ = pnh_.advertiseService("load_scenario", &SimulatorNode::onLoadScenario, this);
  ROS_INFO("simulator: scenario '%s' with %zu obstacles, step %.3f s, scan every %.3f s%s", scenario_.name.c_str(),
           scenario_.obstacles.size(), period_s_, scan_period_s_, publish_clock_ ? ", publishing /clock" : "");
  const Pose2& mount = world_config_.lidar.mount;
  ROS_INFO(
      "simulator: LIDAR at (%.3f m, %.3f m, %.3f rad) on '%s', scanning %.3f m above the floor (%s); %s the "
      "'%s' -> '%s' transform; odometry drift '%s'%s%s",
      mount.x, mount.y, mount.theta, base_frame_.c_str(), world_config_.people.scan_height_m,
      description ? "robot description" : "parameters", publish_laser_tf_ ? "publishing" : "not publishing",
      base_frame_.c_str(), laser_frame_.c_str(), odometry_level.c_str(), map_frame_.empty() ? "" : ", ground truth in ",
      map_frame_.c_str());
}

sim::Scenario SimulatorNode::loadFile(const std::string& path, double dynamic_fraction) const {
  sim::Scenario scenario = sim::loadScenarioFile(path, obstacle_radius_m_);
  // The protocol's dynamic fraction applies to the .dovs files; text scenarios say which obstacles are static.
  if (path.size() >= 5 && path.compare(path.size() - 5, 5, ".dovs") == 0) {
    sim::applyDynamicFraction(scenario, dynamic_fraction);
  }
  return scenario;
}

sim::Scenario SimulatorNode::generate(int count, double dynamic_fraction, uint64_t seed) const {
  if (world_family_ != "room") {
    sim::WorldFamilyConfig w;
    w.family = sim::parseWorldFamily(world_family_);
    w.people = count;
    return sim::generateWorld(w, seed);
  }
  sim::GeneratorConfig g = generator_config_;
  g.obstacle_count_min = g.obstacle_count_max = count;
  g.dynamic_fraction = dynamic_fraction;
  return sim::generateScenario(g, seed);
}

ros::Time SimulatorNode::simNow() const {
  if (!publish_clock_) return ros::Time::now();
  return ros::Time(clock_offset_s_ + world_->time_s());
}

void SimulatorNode::loadScenario(const sim::Scenario& scenario, uint64_t seed) {
  auto world = std::make_unique<sim::World>(scenario, world_config_, seed);
  // The map first: a world that has none (RouteError) leaves the running scenario as it was.
  nav_msgs::OccupancyGrid map;
  if (publish_map_) {
    map = occupancyGridToMsg(knownWorldGrid(world->walls(), sim::furnitureOf(scenario),
                                            {world->robotPose().position(), scenario.goal}, map_resolution_m_));
  }
  if (world_) clock_offset_s_ += world_->time_s() + period_s_;          // time never goes backwards across resets
  if (clock_offset_s_ == 0.0 && publish_clock_) clock_offset_s_ = 1.0;  // ros::Time(0) means "unset"
  scenario_ = scenario;
  seed_ = seed;
  world_ = std::move(world);
  command_ = Twist2{};
  command_stamp_s_ = -1e9;
  next_scan_s_ = 0.0;
  collided_reported_ = false;
  // In the room frame: map_frame when there is one (odometry drifts from it; the planner re-transforms the goal
  // through map -> odom every control period), else odom, which then is the room frame.
  geometry_msgs::PoseStamped goal;
  goal.header.stamp = simNow();
  goal.header.frame_id = truth_frame_;
  goal.pose = poseToMsg(Pose2{scenario_.goal.x(), scenario_.goal.y(), 0.0});
  goal_pub_.publish(goal);
  if (publish_map_) {
    // The walls and the furniture, never the people, in the room frame: what map_server would give from a
    // building's map (odometry drifts from it; localisation's map -> odom closes the loop).
    map.header.stamp = goal.header.stamp;
    map.header.frame_id = truth_frame_;
    map.info.map_load_time = goal.header.stamp;
    map_pub_.publish(map);
  }
}

void SimulatorNode::onCmdVel(const geometry_msgs::Twist::ConstPtr& msg) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!std::isfinite(msg->linear.x) || !std::isfinite(msg->angular.z)) {
    ROS_WARN_THROTTLE(1.0, "simulator: cmd_vel with NaN/inf ignored; the robot decelerates");
    return;
  }
  command_ = {msg->linear.x, msg->angular.z};
  command_stamp_s_ = world_->time_s();
}

bool SimulatorNode::onReset(std_srvs::Empty::Request&, std_srvs::Empty::Response&) {
  std::lock_guard<std::mutex> lock(mutex_);
  loadScenario(scenario_, seed_);
  ROS_INFO("simulator: reset scenario '%s'", scenario_.name.c_str());
  return true;
}

bool SimulatorNode::onLoadScenario(LoadScenario::Request& req, LoadScenario::Response& res) {
  std::lock_guard<std::mutex> lock(mutex_);
  try {
    const double fraction = req.dynamic_fraction < 0.0 ? dynamic_fraction_ : req.dynamic_fraction;
    if (fraction > 1.0) throw sim::ScenarioError("dynamic_fraction " + std::to_string(fraction) + " is above 1");
    sim::Scenario scenario;
    if (!req.path.empty()) {
      scenario = loadFile(req.path, fraction);
    } else {
      if (req.seed < 0) throw sim::ScenarioError("seed must be >= 0");
      if (req.obstacle_count < 0 || req.obstacle_count > 40) {
        throw sim::ScenarioError("obstacle_count " + std::to_string(req.obstacle_count) + " is outside [0, 40]");
      }
      scenario = generate(req.obstacle_count, fraction, static_cast<uint64_t>(req.seed));
    }
    loadScenario(scenario, static_cast<uint64_t>(std::max<int64_t>(0, req.seed)));
    res.success = true;
    res.message = "loaded '" + scenario_.name + "' with " + std::to_string(scenario_.obstacles.size()) + " obstacles";
    res.goal.header.frame_id = truth_frame_;
    res.goal.header.stamp = simNow();
    res.goal.pose = poseToMsg(Pose2{scenario_.goal.x(), scenario_.goal.y(), 0.0});
    ROS_INFO("simulator: %s", res.message.c_str());
  } catch (const std::exception& e) {
    res.success = false;
    res.message = e.what();
    ROS_ERROR("simulator: load_scenario failed: %s", e.what());
  }
  return true;
}

void SimulatorNode::step() {
  Twist2 command = command_;
  if (world_->time_s() - command_stamp_s_ > cmd_timeout_s_) {
    if (command.v != 0.0 || command.w != 0.0) {
      ROS_WARN_THROTTLE(2.0, "simulator: no cmd_vel for %.2f s; commanding zero", cmd_timeout_s_);
    }
    command = Twist2{};
  }
  world_->step(command, period_s_);
  const bool with_scan = world_->time_s() + 1e-9 >= next_scan_s_;
  if (with_scan) next_scan_s_ += scan_period_s_;
  publishState(with_scan);
}

void SimulatorNode::publishState(bool with_scan) {
  const ros::Time stamp = simNow();
  if (publish_clock_) {
    rosgraph_msgs::Clock clock;
    clock.clock = stamp;
    clock_pub_.publish(clock);
  }
  const Pose2 pose = world_->robotPose();  // the truth, in the room frame
  const Pose2 odom_pose = world_->odomPose();
  const Twist2 twist = world_->robotTwist();

  // odom -> base is the wheel odometry; map -> odom closes the loop to the truth (map -> base = truth), as a
  // localisation would.
  std::vector<geometry_msgs::TransformStamped> transforms{makeTransform(odom_pose, stamp, odom_frame_, base_frame_)};
  if (!map_frame_.empty()) {
    transforms.push_back(makeTransform(pose.compose(odom_pose.inverse()), stamp, map_frame_, odom_frame_));
  }
  if (publish_laser_tf_) {
    transforms.push_back(makeTransform(world_config_.lidar.mount, stamp, base_frame_, laser_frame_));
  }
  tf_broadcaster_.sendTransform(transforms);

  nav_msgs::Odometry odom;
  odom.header.stamp = stamp;
  odom.header.frame_id = odom_frame_;
  odom.child_frame_id = base_frame_;
  odom.pose.pose = poseToMsg(odom_pose);
  odom.twist.twist.linear.x = twist.v;
  odom.twist.twist.angular.z = twist.w;
  for (int i = 0; i < 6; ++i) {
    odom.pose.covariance[static_cast<size_t>(i * 7)] = 1e-4;
    odom.twist.covariance[static_cast<size_t>(i * 7)] = 1e-4;
  }
  odom_pub_.publish(odom);
  if (truth_odom_pub_.getNumSubscribers() > 0) {
    odom.header.frame_id = truth_frame_;
    odom.pose.pose = poseToMsg(pose);
    odom.pose.covariance = {};
    odom.twist.covariance = {};
    truth_odom_pub_.publish(odom);
  }

  if (with_scan && scan_pub_.getNumSubscribers() > 0) {
    sensor_msgs::LaserScan scan;
    laserScanToMsg(world_->scan(), scan);
    scan.header.stamp = stamp;
    scan.header.frame_id = laser_frame_;
    scan.scan_time = static_cast<float>(scan_period_s_);
    scan_pub_.publish(scan);
  }
  if (with_scan && (truth_pub_.getNumSubscribers() > 0 || truth_markers_pub_.getNumSubscribers() > 0)) {
    TrackedObstacleArray truth = movingObstaclesToMsg(world_->groundTruthObstacles(), world_->walls());
    truth.header.stamp = stamp;
    truth.header.frame_id = truth_frame_;
    truth_pub_.publish(truth);
    if (truth_markers_pub_.getNumSubscribers() > 0) {
      truth_markers_pub_.publish(obstacleMarkers(truth, "ground_truth", 0.2f, 0.8f, 0.2f));
    }
  }

  SimStatus status;
  status.header.stamp = stamp;
  status.header.frame_id = truth_frame_;
  status.scenario = scenario_.name;
  status.collided = world_->collided();
  if (status.collided) {
    status.collision_kind = collisionKindName(classifyCollision(world_->collision()));
    status.contact_speed = world_->collision().robot_speed_mps;
  }
  status.min_clearance = world_->minClearance_m();
  status.goal_distance = (pose.position() - scenario_.goal).norm();
  status.speed = twist.v;
  status.episode_time = world_->time_s();
  status_pub_.publish(status);
  if (status.collided && !collided_reported_) {
    ROS_WARN("simulator: collision (%s, robot at %.2f m/s) in scenario '%s' at t = %.2f s",
             status.collision_kind.c_str(), status.contact_speed, scenario_.name.c_str(), status.episode_time);
    collided_reported_ = true;
  }
}

void SimulatorNode::run() {
  ros::AsyncSpinner spinner(1);
  spinner.start();
  ros::WallTime next = ros::WallTime::now();
  while (ros::ok()) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      step();
    }
    if (realtime_factor_ > 0.0) {
      next += ros::WallDuration(period_s_ / realtime_factor_);
      const ros::WallTime now = ros::WallTime::now();
      if (next > now) {
        (next - now).sleep();
      } else if ((now - next).toSec() > 1.0) {
        ROS_WARN_THROTTLE(5.0, "simulator: running %.2f s behind real time", (now - next).toSec());
        next = now;
      }
    }
  }
  spinner.stop();
}

}  // namespace dqn_dovs
