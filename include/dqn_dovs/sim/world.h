// The simulated world: a square room with walls and any extra wall segments, a differential-drive robot with the
// limits of robot_model.h, disc obstacles on constant-(v, w) motions that turn around at the room border, people
// walking between destinations (people.h: bodies for contact, legs for the LIDAR), and a LIDAR.
// Deterministic: the same scenario, configuration, seed and command sequence give the same trajectory and
// the same scans, bit for bit.
#pragma once

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "dqn_dovs/common/geometry.h"
#include "dqn_dovs/common/robot_model.h"
#include "dqn_dovs/common/types.h"
#include "dqn_dovs/sim/errors.h"
#include "dqn_dovs/sim/lidar.h"
#include "dqn_dovs/sim/people.h"
#include "dqn_dovs/sim/scenario.h"

namespace dqn_dovs::sim {

/// Wheel odometry: how far the odom frame drifts from the truth. Per episode the odometry draws a speed scale
/// N(1, speed_scale_std), a turn-rate scale N(1, turn_scale_std) and a turn-rate bias N(0, turn_bias_std_rps)
/// (wheel radii, track width and gyro offsets a calibration misses); per sub-step the measured speed also gets a
/// relative noise N(0, step_noise_std) (slip). All zero (the default): the odom frame is the truth.
struct OdometryConfig {
  double speed_scale_std = 0.0;
  double turn_scale_std = 0.0;
  double turn_bias_std_rps = 0.0;
  double step_noise_std = 0.0;

  bool enabled() const {
    return speed_scale_std > 0.0 || turn_scale_std > 0.0 || turn_bias_std_rps > 0.0 || step_noise_std > 0.0;
  }
  /// "none", "low" (1 % / 2 % scales, 0.005 rad/s bias, 2 % slip) or "high" (3 %, 5 %, 0.02 rad/s, 5 %); throws
  /// SimConfigError naming another level.
  static OdometryConfig level(const std::string& name);
  /// The names level() accepts.
  static std::vector<std::string> levelNames() { return {"none", "low", "high"}; }
  /// Empty when consistent, otherwise a message naming the field and why.
  std::string validate() const;
};

/// Parameters of the world's physics and sensing.
struct WorldConfig {
  /// Robot kinodynamic limits (speeds, accelerations, radius). `robot.dt` is not used by the world: the
  /// caller chooses each step's duration.
  RobotLimits robot;
  /// Longest physics sub-step (s). Each step() is split into equal sub-steps no longer than this, at which
  /// obstacle border events and collisions are checked.
  double physics_step_s = 0.05;
  /// Tunnelling guard: sub-steps are also short enough that the robot and the fastest obstacle together
  /// move at most this far in one (m), so that no contact can be stepped over.
  double max_substep_travel_m = 0.05;
  /// The LIDAR mounted on the robot.
  LidarConfig lidar = LidarConfig::simProfile();
  /// Turn rate of an obstacle turning around in place at the room border (rad/s).
  double border_turn_rate_rps = 0.65;
  /// An obstacle starts its turn-around when its disc comes within this distance of a room wall (m).
  double border_margin_m = 0.0;
  /// false: at the start of each step the robot takes the velocity nearest the command that the
  /// acceleration limits allow over the whole step and holds it (the planners' model: a command inside the
  /// dynamic window is reached at once); true: the velocity ramps toward the command at the acceleration
  /// limits, sub-step by sub-step.
  bool ramp_velocity = false;
  /// Wheel odometry (the odom frame's drift from the truth).
  OdometryConfig odometry;
  /// How the scenario's people move, and their legs.
  PeopleConfig people;
  /// true: the world also steps a shadow of its people (World::shadowCrowd), the same people from the same start
  /// and seed with the robot absent, so that what the robot costs them can be measured (EpisodeRecord::delay_s).
  bool shadow_people = false;
  /// true: the LIDAR sees people's two legs (a scanner at leg height); false: their body discs.
  bool scan_legs = true;
  /// A wall's thickness as the LIDAR sees it at each free end (joined to no other wall: a door's jamb, the end of a
  /// partition): its end face, a segment this long across the wall (m). A segment seen edge-on returns nothing, and
  /// a robot in a doorway would not see the jamb beside it. Contact stays with the wall's segment. 0: thin walls.
  double wall_thickness_m = 0.1;
  /// true: on its first collision the robot is put back to its last collision-free sub-step pose, its
  /// velocity drops to zero and it ignores commands until reset(); false: it keeps driving through.
  bool stop_on_collision = true;

  /// Empty string when consistent, otherwise a message naming the offending field and why.
  std::string validate() const;
};

/// Motion phase of one obstacle.
enum class ObstacleMotion {
  kMoving,           ///< following its nominal (speed, turn_rate)
  kTurningAtBorder,  ///< stopped at the room border, turning in place before resuming its nominal motion
};

/// The true state of one simulated obstacle.
struct SimObstacle {
  /// Current centre and heading; speed and turn_rate are the nominal motion (unchanged by border turns).
  MovingObstacle body;
  ObstacleMotion motion = ObstacleMotion::kMoving;
  /// Heading change still to do in the current border turn (rad, >= 0).
  double turn_remaining_rad = 0.0;
  /// +1 turns counter-clockwise, -1 clockwise (the sense of the nominal turn rate; CCW when it is 0).
  double turn_direction = 1.0;
  /// How many border turn-arounds this obstacle has started since reset.
  int border_turns = 0;
};

/// Below this linear speed the robot is at rest (m/s): a contact then is the other's doing, unless the robot stopped
/// only just before it (CollisionInfo::robot_rest_s).
constexpr double kRobotRestSpeedMps = 0.05;

/// What the robot hit first.
struct CollisionInfo {
  enum class Kind { kNone, kObstacle, kWall };
  Kind kind = Kind::kNone;
  /// Index into groundTruthObstacles() (obstacles, then people) or walls().
  int index = -1;
  /// Simulation time of the sub-step at which the contact was found (s).
  double time_s = 0.0;
  /// The robot's linear speed at the contact, before the collision stopped it (m/s).
  double robot_speed_mps = 0.0;
  /// True when the robot hit something that stands still: a wall, a scenario segment or a static obstacle.
  bool static_contact = false;
  /// The robot's and the other body's velocities at the contact, in the world frame (m/s; a wall's is zero).
  Vec2 robot_velocity = Vec2::Zero();
  Vec2 other_velocity = Vec2::Zero();
  /// Unit vector from the robot's centre toward what it touched (the other's centre, or the wall's nearest point).
  Vec2 normal = Vec2::Zero();
  /// How long the robot had been at rest (below kRobotRestSpeedMps) at the contact, s: 0 when it was moving,
  /// +inf when it had not moved since the episode started.
  double robot_rest_s = 0.0;
};

class World {
 public:
  /// Throws SimConfigError when config.validate() fails and ScenarioError when the scenario is unusable.
  World(const Scenario& scenario, const WorldConfig& config, uint64_t seed);

  /// Restarts from `scenario` at time 0 with the robot at rest; `seed` drives the sensor noise.
  /// Throws ScenarioError (naming the scenario) for non-finite values, non-positive radii or room size,
  /// or a robot start outside the room.
  void reset(const Scenario& scenario, uint64_t seed);

  /// Advances the world by dt_s seconds with robot command `cmd` (held for the whole step). The command is
  /// limited by the robot's accelerations and feasible set; a non-finite command keeps the current velocity.
  /// dt_s = 0 does nothing; a negative or non-finite dt_s throws SimConfigError.
  void step(const Twist2& cmd, double dt_s);

  /// Holonomic robot mode, used only by the `orca_holonomic` baseline (the paper ran CrowdNav's ORCA on a
  /// holonomic robot). Advances the world by dt_s seconds with the robot moving at the fixed-frame velocity
  /// `velocity` (m/s) in any direction, its norm clipped to robot.v_max, with no acceleration limit. The heading
  /// snaps to the direction of motion (unchanged below 1e-9 m/s) and robotTwist() reads (speed, 0), so pose and
  /// twist still describe the motion exactly. Obstacles, sub-steps and collisions work as in step(). A non-finite
  /// velocity keeps the current one; a negative or non-finite dt_s throws SimConfigError.
  void stepHolonomic(const Vec2& velocity, double dt_s);

  double time_s() const { return time_s_; }
  const Pose2& robotPose() const { return robot_pose_; }
  const Twist2& robotTwist() const { return robot_twist_; }
  const Vec2& goal() const { return scenario_.goal; }
  const Scenario& scenario() const { return scenario_; }
  const WorldConfig& config() const { return config_; }
  double roomHalfSize_m() const { return scenario_.room_half_size_m; }

  /// True states of the obstacles, including the border state machine.
  const std::vector<SimObstacle>& obstacles() const { return obstacles_; }
  /// The people (bodies, legs, plans).
  const Crowd& crowd() const { return crowd_; }
  /// WorldConfig::shadow_people: the same people stepped as crowd() is, with the robot absent (else null).
  const Crowd* shadowCrowd() const { return config_.shadow_people ? &shadow_crowd_ : nullptr; }
  /// The obstacles with their instantaneous motion: while turning at the border, speed 0 and turn rate
  /// +-border_turn_rate_rps; otherwise the nominal (speed, turn_rate); then the people's bodies (index
  /// obstacles().size() + person).
  std::vector<MovingObstacle> groundTruthObstacles() const;
  /// The four room walls (counter-clockwise from the bottom wall) followed by the scenario's static segments.
  const std::vector<Segment>& walls() const { return walls_; }

  /// True once the robot has touched an obstacle or a wall (latched until reset()).
  bool collided() const { return collision_.kind != CollisionInfo::Kind::kNone; }
  const CollisionInfo& collision() const { return collision_; }
  /// Distance from the robot's surface to the nearest obstacle or wall surface (m); negative when overlapping.
  double minClearance_m() const;

  /// The robot's pose as its wheel odometry has it (the odom frame starts on the true start pose and drifts with
  /// WorldConfig::odometry; the truth when that is off).
  const Pose2& odomPose() const { return odom_pose_; }
  /// Pose of the laser in the room frame: the robot pose composed with the LIDAR mount.
  Pose2 laserPose() const { return robot_pose_.compose(config_.lidar.mount); }
  /// A noisy scan at the current time (advances the noise stream).
  LaserScan2 scan();
  /// Same as scan(), reusing `out`'s storage.
  void scanInto(LaserScan2& out);
  const Lidar& lidar() const { return lidar_; }

 private:
  void advanceObstacle(SimObstacle& o, double dt_s) const;
  void stepPeople(double dt_s);
  /// Integrates the odometry over one sub-step of the robot's motion at its current twist.
  void stepOdometry(double dt_s);
  /// The fastest any obstacle or person can move (m/s): it bounds the sub-step length.
  double fastestObstacleSpeed() const;
  void startBorderTurn(SimObstacle& o) const;
  /// Earliest time in [0, dt_s] at which the obstacle, moving nominally, reaches the border while heading
  /// out of the room; a negative value when it does not within dt_s.
  /// The end faces of the walls' free ends, for the LIDAR (WorldConfig::wall_thickness_m).
  void addWallEndFaces();
  double borderEventTime(const SimObstacle& o, double dt_s) const;
  /// Fills collision_ (first contact only) and returns true when the robot overlaps something now.
  bool checkCollision();

  WorldConfig config_;
  Scenario scenario_;
  Lidar lidar_;
  double time_s_ = 0.0;
  /// The last time the robot moved at kRobotRestSpeedMps or faster (-inf: not since the start), s.
  double last_moving_s_ = -std::numeric_limits<double>::infinity();
  Pose2 robot_pose_;
  Twist2 robot_twist_;
  bool robot_stopped_ = false;
  std::vector<SimObstacle> obstacles_;
  Crowd crowd_;
  Crowd shadow_crowd_;  ///< WorldConfig::shadow_people
  Pose2 odom_pose_;
  Rng odom_rng_;
  double odom_speed_scale_ = 1.0, odom_turn_scale_ = 1.0, odom_turn_bias_rps_ = 0.0;
  std::vector<Segment> walls_;
  CollisionInfo collision_;
  LidarScene lidar_scene_;
};

}  // namespace dqn_dovs::sim
