// Plain data shapes that several core modules exchange (simulator, tracker, DOVS, planners).
// ROS-free. Units: metres, seconds, radians; all positions in one fixed frame unless a name says otherwise.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "dqn_dovs/common/geometry.h"
#include "dqn_dovs/common/robot_model.h"

namespace dqn_dovs {

/// A planar laser scan in the laser's own frame (ROS sensor_msgs/LaserScan semantics: beam i points at
/// angle_min + i * angle_increment, CCW from the laser's x axis). Non-returns are +inf or > range_max.
struct LaserScan2 {
  double stamp_s = 0.0;
  double angle_min = 0.0;
  double angle_increment = 0.0;
  double range_min = 0.0;
  double range_max = 0.0;
  std::vector<float> ranges;

  double angleOf(size_t i) const { return angle_min + static_cast<double>(i) * angle_increment; }
  /// The returns (finite ranges within [range_min, range_max]) as points placed by `laser_pose`, in beam order.
  std::vector<Vec2> returnsIn(const Pose2& laser_pose) const {
    std::vector<Vec2> out;
    for (size_t k = 0; k < ranges.size(); ++k) {
      const double r = ranges[k];
      if (!std::isfinite(r) || r < range_min || r > range_max) continue;
      const double a = angleOf(k);
      out.push_back(laser_pose.toWorld(Vec2(r * std::cos(a), r * std::sin(a))));
    }
    return out;
  }
};

/// A disc obstacle moving on its own constant-(v, w) motion model.
/// heading is the direction of travel; w = 0 is a straight line; v = 0 is static.
struct MovingObstacle {
  Vec2 center = Vec2::Zero();
  double radius = 0.2;
  double heading = 0.0;
  double speed = 0.0;      ///< m/s along heading
  double turn_rate = 0.0;  ///< rad/s
  bool is_static = false;
  /// What a tracker knows of it (the person tokens of the network state, dovs/state.h): its track id (-1: none, e.g.
  /// a simulated disc), the track's age in s (< 0: unknown) and the standard deviation of its position in m (< 0:
  /// unknown; sqrt of the mean of the x and y variances).
  int id = -1;
  double age_s = -1.0;
  double position_sigma_m = -1.0;
};

/// One tracked obstacle as the tracker reports it (fixed frame).
struct TrackedObstacle {
  int id = -1;
  Vec2 center = Vec2::Zero();
  double radius = 0.0;
  double heading = 0.0;    ///< rad, direction of travel (meaningless when speed ~ 0)
  double speed = 0.0;      ///< m/s
  double turn_rate = 0.0;  ///< rad/s
  /// Covariance of the filter state [x, y, heading, speed, turn_rate].
  Eigen::Matrix<double, 5, 5> covariance = Eigen::Matrix<double, 5, 5>::Identity();
  bool is_static = false;
  double age_s = 0.0;  ///< time since the track was born
  int hits = 0;        ///< number of measurements associated so far

  MovingObstacle toMovingObstacle() const {
    MovingObstacle m;
    m.center = center;
    m.radius = radius;
    m.heading = heading;
    m.speed = is_static ? 0.0 : speed;
    m.turn_rate = is_static ? 0.0 : turn_rate;
    m.is_static = is_static;
    m.id = id;
    m.age_s = age_s;
    m.position_sigma_m = std::sqrt(std::max(0.0, 0.5 * (covariance(0, 0) + covariance(1, 1))));
    return m;
  }
};

/// What the tracker reports after one scan (fixed frame).
struct TrackedScene {
  double stamp_s = 0.0;
  std::vector<TrackedObstacle> obstacles;  ///< confirmed tracks only
  std::vector<Segment> segments;           ///< walls and other long/static line features
};

/// What a planner or the DOVS sees of the world at one decision instant (fixed frame).
struct Observation {
  double stamp_s = 0.0;
  Pose2 robot_pose;
  Twist2 robot_twist;
  Vec2 goal = Vec2::Zero();
  std::vector<MovingObstacle> obstacles;
  std::vector<Segment> segments;
  /// The route ahead (fixed frame), from the robot's place on it to its end, for the network state's route points
  /// (DovsConfig::route_points); empty: the straight line from the robot to `goal`.
  std::vector<Vec2> route_ahead;
};

}  // namespace dqn_dovs
