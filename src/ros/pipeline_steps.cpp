#include "pipeline_steps.h"

#include <cmath>
#include <sstream>
#include <stdexcept>

#include "conversions.h"
#include "dqn_dovs/maps/occupancy_map.h"
#include "dqn_dovs/perception/observation.h"

namespace dqn_dovs {

std::string trackerMapFromMsg(const nav_msgs::OccupancyGrid& msg, bool unknown_is_occupied, double tolerance_m,
                              std::unique_ptr<KnownStructure>& out) {
  OccupancyMap grid;
  if (std::string error = occupancyMapFromMsg(msg, grid); !error.empty()) return error;
  try {
    out = std::make_unique<KnownStructure>(mapSegments(grid, unknown_is_occupied), std::vector<Circle>{}, tolerance_m);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return {};
}

std::string mapWallsFromMsg(const nav_msgs::OccupancyGrid& msg, bool unknown_is_occupied, std::vector<Segment>& out) {
  OccupancyMap grid;
  if (std::string error = occupancyMapFromMsg(msg, grid); !error.empty()) return error;
  out = mapSegments(grid, unknown_is_occupied);
  return {};
}

void addMapWalls(const std::vector<Segment>& map_walls, const Pose2& map_in_fixed, const Pose2& robot, double range_m,
                 TrackedObstacleArray& obstacles) {
  std::vector<Segment> near;  // the core's choice (perception/observation.h), as the evaluation's Episode makes it
  appendMapWalls(map_walls, map_in_fixed, robot.position(), range_m, near);
  for (const Segment& s : near) {
    ObstacleSegment m;
    m.first_point.x = s.a.x();
    m.first_point.y = s.a.y();
    m.last_point.x = s.b.x();
    m.last_point.y = s.b.y();
    obstacles.segments.push_back(m);
  }
}

std::string trackScan(ObstacleTracker& tracker, const LaserScan2& scan, const Pose2& laser_pose, const ros::Time& stamp,
                      const std::string& fixed_frame, TrackedObstacleArray& out, std::string& reset_note,
                      const MapStructureView& map) {
  reset_note.clear();
  const TrackerResult result = tracker.update(scan, laser_pose, map);
  if (result.status == TrackerStatus::kRejected) return result.message.empty() ? "rejected" : result.message;
  if (result.status == TrackerStatus::kReset) reset_note = result.message;
  out = trackedSceneToMsg(result.scene);
  out.header.stamp = stamp;
  out.header.frame_id = fixed_frame;
  return {};
}

std::string buildDovsStep(const TrackedObstacleArray& obstacles, const Pose2& robot_pose, const Twist2& odom_twist,
                          const std::optional<Vec2>& goal, const RobotLimits& limits,
                          const StateNormalization& normalization, const ActionShieldConfig& shield,
                          const std::string& base_frame, DovsBuilder& builder, VelocitySpace& dovs, DovsStep& out,
                          PredictedArcs* predicted_arcs, TrackHistory* history, const std::vector<Vec2>* route_ahead) {
  Observation& obs = out.observation;
  obs.robot_pose = robot_pose;
  obs.stamp_s = obstacles.header.stamp.toSec();
  obs.robot_twist = limits.clipToFeasible(odom_twist);
  obs.goal = goal.value_or(obs.robot_pose.position());
  obs.route_ahead.clear();
  if (route_ahead != nullptr && normalization.route_points > 0) obs.route_ahead = *route_ahead;
  const std::string obstacle_error = observationObstaclesFromMsg(obstacles, obs.obstacles, obs.segments);
  if (!obstacle_error.empty()) return obstacle_error;
  if (predicted_arcs) {
    std::vector<int> ids;
    for (const ObstacleTrack& t : obstacles.obstacles) ids.push_back(t.id);
    predictArcs(*predicted_arcs, obs.obstacles, 0, ids, obs.stamp_s, obs.segments);
  }

  // The velocity space, the actions, the state and the shield, as the evaluation's Episode and planner make them.
  VelocitySpaceStep step;
  buildVelocitySpaceStep(obs, limits, normalization, builder, dovs, step, history);
  out.actions = step.actions;
  const ActionSet& actions = out.actions;
  const StateVector& state = step.state;
  const ShieldedMask shielded = shieldStep(actions, dovs, obs, shield, goal.has_value());
  out.shield_level = shielded.level;
  // The decision fields, as the evaluation's DQN-DOVS planner makes them (policy/dovs_decision.h).
  const DovsDecision fields = decisionFields(state, normalization, actions, shielded, obs, limits, shield.statics);

  Dovs& m = out.msg;
  m = Dovs();
  m.header.stamp = obstacles.header.stamp;
  m.header.frame_id = base_frame;
  m.has_goal = goal.has_value();
  m.v_max = limits.v_max;
  m.w_max = limits.w_max;
  m.dv = limits.dv();
  m.dw = limits.dw();
  m.v = obs.robot_twist.v;
  m.w = obs.robot_twist.w;
  switch (actions.goal_line.kind) {
    case GoalLine::Kind::kNone:
      m.goal_line_kind = Dovs::GOAL_NONE;
      break;
    case GoalLine::Kind::kArc:
      m.goal_line_kind = Dovs::GOAL_ARC;
      break;
    case GoalLine::Kind::kTurnInPlace:
      m.goal_line_kind = Dovs::GOAL_TURN_IN_PLACE;
      break;
  }
  m.goal_curvature = actions.goal_line.curvature_1pm;
  m.goal_turn_sign = actions.goal_line.turn_sign;
  dovsDecisionToMessage(fields, m);  // state, normalisation, actions and mask, escape, static geometry
  m.escape_tier = static_cast<uint8_t>(shielded.has_escape ? shielded.escape_tier : EscapeTier::kFree);
  if (shield.statics.enabled) m.static_frame = obstacles.header.frame_id;
  const int n = dovs.numTrajectories();
  m.trajectory_curvature.reserve(static_cast<size_t>(n));
  m.interval_begin.reserve(static_cast<size_t>(n) + 1);
  for (int i = 0; i < n; ++i) {
    const Trajectory& t = dovs.trajectory(i);
    m.trajectory_curvature.push_back(static_cast<float>(t.curvature_1pm));
    m.trajectory_pure_rotation.push_back(t.pure_rotation);
    m.trajectory_v_top.push_back(static_cast<float>(t.v_top_mps));
    m.trajectory_w_top.push_back(static_cast<float>(t.w_top_rps));
    m.interval_begin.push_back(static_cast<uint32_t>(m.interval_lo.size()));
    for (const SpeedInterval& s : dovs.unsafeIntervals(i)) {
      m.interval_lo.push_back(static_cast<float>(s.lo_mps));
      m.interval_hi.push_back(static_cast<float>(s.hi_mps));
    }
  }
  m.interval_begin.push_back(static_cast<uint32_t>(m.interval_lo.size()));
  m.grid_rows = m.grid_cols = static_cast<uint16_t>(dovs.gridSize());
  return {};
}

std::string dovsGoalFault(const Dovs& dovs, double goal_stamp_s, const Vec2& goal, double tolerance_m) {
  if (!dovs.has_goal) return "dovs has no goal yet";
  const double stamp_s = dovs.goal_stamp.toSec();
  const Vec2 built_for(dovs.goal_x, dovs.goal_y);
  if (stamp_s != goal_stamp_s || !built_for.allFinite() || (built_for - goal).norm() > tolerance_m) {
    std::ostringstream os;
    os.precision(3);
    os << std::fixed << "dovs was built for another goal ((" << built_for.x() << ", " << built_for.y() << ") stamped "
       << stamp_s << " s; the goal is (" << goal.x() << ", " << goal.y() << ") stamped " << goal_stamp_s << " s)";
    return os.str();
  }
  return {};
}

std::string staticFrameFault(const Dovs& dovs, const std::string& fixed_frame) {
  if (dovs.static_segments.empty() && dovs.static_discs.empty()) return {};
  if (dovs.static_frame == fixed_frame) return {};
  return "dovs static geometry is in frame '" + dovs.static_frame + "', the planner's fixed_frame is '" + fixed_frame +
         "'";
}

std::string staticObservationFromDovs(const Dovs& dovs, const std::string& fixed_frame, const Pose2& robot_pose,
                                      const Twist2& twist, Observation& out) {
  if (std::string fault = staticFrameFault(dovs, fixed_frame); !fault.empty()) {
    out = Observation();
    return fault;
  }
  return staticObservation(dovsDecisionFromMessage(dovs), robot_pose, twist, out);
}

Twist2 choiceVelocity(const Dovs& dovs, int choice) { return choiceVelocity(dovsDecisionFromMessage(dovs), choice); }

int chooseAction(const QNetwork& network, const Dovs& dovs, std::string& why) {
  return chooseAction(network, dovsDecisionFromMessage(dovs), why);
}

}  // namespace dqn_dovs
