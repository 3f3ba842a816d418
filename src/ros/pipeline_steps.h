// The per-message work of obstacle_tracker_node, dovs_node and planner_node, once their inputs are gathered
// (scan converted, transforms looked up). The nodes and the offline bag replay (bag_replay.h) call the same
// functions, so a replayed bag makes exactly the decisions the running pipeline makes.
#pragma once

#include <nav_msgs/OccupancyGrid.h>
#include <ros/time.h>

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "dqn_dovs/Dovs.h"
#include "dqn_dovs/TrackedObstacleArray.h"
#include "dqn_dovs/dovs/actions.h"
#include "dqn_dovs/dovs/dovs.h"
#include "dqn_dovs/dovs/state.h"
#include "dqn_dovs/perception/known_structure.h"
#include "dqn_dovs/perception/people_predictor.h"
#include "dqn_dovs/perception/tracker.h"
#include "dqn_dovs/policy/action_shield.h"
#include "dqn_dovs/policy/dovs_decision.h"
#include "dqn_dovs/policy/qnetwork.h"

namespace dqn_dovs {

/// obstacle_tracker_node's step after the scan check and the laser pose lookup: one tracker update.
/// Returns why the scan was not used (the tracks are untouched, nothing is published), else "" with `out`
/// filled (stamp = the scan's, frame = fixed_frame). `reset_note` gets the reason when the tracks were
/// dropped first (time went backwards or jumped), else it is cleared. `map`: the map's structure as this scan sees
/// it (ObstacleTracker::update), none by default.
std::string trackScan(ObstacleTracker& tracker, const LaserScan2& scan, const Pose2& laser_pose, const ros::Time& stamp,
                      const std::string& fixed_frame, TrackedObstacleArray& out, std::string& reset_note,
                      const MapStructureView& map = {});

/// obstacle_tracker_node's map (use_map): what an occupancy grid shows, as the tracker's known structure (its walls
/// as segments, in the grid's frame, within tolerance_m). Returns why the grid is unusable (occupancyMapFromMsg's
/// reasons, a bad tolerance), else "" with `out` set.
std::string trackerMapFromMsg(const nav_msgs::OccupancyGrid& msg, bool unknown_is_occupied, double tolerance_m,
                              std::unique_ptr<KnownStructure>& out);

/// dovs_node's map (use_map): the walls of an occupancy grid as segments in its frame. Returns why the grid is
/// unusable, else "" with `out` set.
std::string mapWallsFromMsg(const nav_msgs::OccupancyGrid& msg, bool unknown_is_occupied, std::vector<Segment>& out);

/// dovs_node's step before the velocity space with use_map: the map's walls (map frame) that come within range_m of
/// `robot` (fixed frame), placed in the fixed frame by `map_in_fixed`, appended to the obstacles' segments.
void addMapWalls(const std::vector<Segment>& map_walls, const Pose2& map_in_fixed, const Pose2& robot, double range_m,
                 TrackedObstacleArray& obstacles);

/// Everything dovs_node derives from one obstacles message.
struct DovsStep {
  Observation observation;  ///< robot pose, clipped velocity, goal and obstacles (fixed frame)
  ActionSet actions;
  ShieldLevel shield_level = ShieldLevel::kDisabled;
  Dovs msg;  ///< ready to publish (stamp = the obstacles' stamp, frame = base frame)
};

/// dovs_node's step after the odom and transform checks: builds the observation (the odom velocity clipped
/// into the feasible set; without a goal, the goal is the robot's own position), the velocity space, the
/// actions and the Dovs message, whose action_valid is the mask the network chooses under: the validity mask
/// narrowed by the action shield (action_shield.h; the shield's level goes into `out.shield_level`). With
/// `predicted_arcs`, the moving tracks move on the arcs of their learned prediction (by track id, among the message's
/// static segments). With person tokens in `normalization`, `history` (the node's) remembers the tracks for the
/// tokens' 1 s of history; `route_ahead` (fixed frame, null or empty: the straight line to the goal) the state's route
/// points. Returns why the obstacles were dropped (NaN fields, non-positive radius), else "". Throws
/// (DovsError, ActionError, StateError, PeoplePredictorError) when the core rejects the observation.
std::string buildDovsStep(const TrackedObstacleArray& obstacles, const Pose2& robot_pose, const Twist2& odom_twist,
                          const std::optional<Vec2>& goal, const RobotLimits& limits,
                          const StateNormalization& normalization, const ActionShieldConfig& shield,
                          const std::string& base_frame, DovsBuilder& builder, VelocitySpace& dovs, DovsStep& out,
                          PredictedArcs* predicted_arcs = nullptr, TrackHistory* history = nullptr,
                          const std::vector<Vec2>* route_ahead = nullptr);

/// planner_node's choice for one Dovs message: the core's chooseAction (policy/dovs_decision.h) on the message's
/// decision fields.
int chooseAction(const QNetwork& network, const Dovs& dovs, std::string& why);

/// The velocity a choice of chooseAction commands (core choiceVelocity). Throws std::out_of_range for non-choices.
Twist2 choiceVelocity(const Dovs& dovs, int choice);

/// Why a Dovs message was not built for the planner's goal (`goal_stamp`, `goal` in the fixed frame): it has no
/// goal, another goal stamp, or a goal more than `tolerance_m` away. "" when it was. Right after a new goal the
/// previous goal's velocity space is still in flight; acting on it would steer toward the old goal.
std::string dovsGoalFault(const Dovs& dovs, double goal_stamp_s, const Vec2& goal, double tolerance_m = 0.25);

/// Why the static geometry of a Dovs message cannot be used in `fixed_frame` ("" when it can: none, or in that
/// frame).
std::string staticFrameFault(const Dovs& dovs, const std::string& fixed_frame);

/// The static geometry a Dovs message carries (static_frame), as an observation seen from `robot_pose` (the
/// robot now, in the same frame) moving at `twist`. Returns why it cannot be used ("" when fine): a frame other
/// than `fixed_frame`, then the core's staticObservation checks (lengths not a multiple of 4 / 3, NaN/inf values).
std::string staticObservationFromDovs(const Dovs& dovs, const std::string& fixed_frame, const Pose2& robot_pose,
                                      const Twist2& twist, Observation& out);

}  // namespace dqn_dovs
