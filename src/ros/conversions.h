// Conversions between ROS messages and the ROS-free core types, with input checking.
#pragma once

#include <diagnostic_msgs/DiagnosticStatus.h>
#include <geometry_msgs/Pose.h>
#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/OccupancyGrid.h>
#include <nav_msgs/Path.h>
#include <sensor_msgs/LaserScan.h>
#include <visualization_msgs/MarkerArray.h>

#include <string>
#include <vector>

#include "dqn_dovs/PlannerStatus.h"
#include "dqn_dovs/TrackedObstacleArray.h"
#include "dqn_dovs/common/types.h"
#include "dqn_dovs/maps/occupancy_map.h"
#include "dqn_dovs/planning/route.h"

namespace dqn_dovs {

/// Checks a LaserScan and converts it. Returns an empty string on success, otherwise why the scan is
/// unusable (the caller drops it and warns). Individual NaN/inf/out-of-range beams are not errors: they
/// are kept (the tracker ignores them) and counted in `invalid_beams`.
std::string laserScanFromMsg(const sensor_msgs::LaserScan& msg, LaserScan2& out, size_t* invalid_beams = nullptr);

/// Fills a LaserScan message (frame and stamp set by the caller).
void laserScanToMsg(const LaserScan2& scan, sensor_msgs::LaserScan& msg);

/// An occupancy grid message as the core's map (values >= 65 occupied, 0..19 free, the rest and -1 unknown, as
/// map_server thresholds them). Returns why the message is unusable (empty or unknown frame, a resolution that
/// is not a positive number, no cells, a data size other than width x height, a non-finite origin), else "".
std::string occupancyMapFromMsg(const nav_msgs::OccupancyGrid& msg, OccupancyMap& out);

/// An occupancy grid of known geometry as a message (frame, stamps set by the caller): occupied 100, free 0,
/// unknown -1, rows bottom first, as map_server publishes a map.
nav_msgs::OccupancyGrid occupancyGridToMsg(const RouteGrid& grid);

/// Planar pose of a transform (yaw only). Returns false when the transform has NaN/inf.
bool poseFromTransform(const geometry_msgs::Transform& t, Pose2& out);

/// `points` as a nav_msgs/Path under `header` (each pose at a point, heading along x).
nav_msgs::Path pathToMsg(const std::vector<Vec2>& points, const std_msgs::Header& header);
/// The positions of `msg`'s poses; "" when usable, else why not (a NaN/inf position, naming its index).
std::string pathPointsFromMsg(const nav_msgs::Path& msg, std::vector<Vec2>& out);
geometry_msgs::Pose poseToMsg(const Pose2& p);

TrackedObstacleArray trackedSceneToMsg(const TrackedScene& scene);
TrackedObstacleArray movingObstaclesToMsg(const std::vector<MovingObstacle>& obstacles,
                                          const std::vector<Segment>& segments);
/// Inverse of trackedSceneToMsg; returns why a message is unusable (NaN fields, non-positive radius), else "".
std::string observationObstaclesFromMsg(const TrackedObstacleArray& msg, std::vector<MovingObstacle>& obstacles,
                                        std::vector<Segment>& segments);

/// Cylinders, id labels and velocity arrows for rviz (namespace `ns`); deletes stale markers first.
visualization_msgs::MarkerArray obstacleMarkers(const TrackedObstacleArray& msg, const std::string& ns, float r,
                                                float g, float b);

/// planner_node's health for /diagnostics from its last status: OK while idle, driving or on the goal; WARN while
/// stopped (the reason is the message), recovering, after an aborted goal, or when deadline misses or envelope
/// corrections grew since `previous` (the status of the last report); the status's figures as key-values.
diagnostic_msgs::DiagnosticStatus plannerDiagnostics(const PlannerStatus& status, const PlannerStatus& previous,
                                                     const std::string& name, const std::string& hardware_id);

}  // namespace dqn_dovs
