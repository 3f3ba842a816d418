#include "pipeline_steps.h"

#include <cmath>
#include <stdexcept>

#include "conversions.h"

namespace dqn_dovs {

std::string trackScan(ObstacleTracker& tracker, const LaserScan2& scan, const Pose2& laser_pose, const ros::Time& stamp,
                      const std::string& fixed_frame, TrackedObstacleArray& out, std::string& reset_note) {
  reset_note.clear();
  const TrackerResult result = tracker.update(scan, laser_pose);
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
                          const std::string& base_frame, DovsBuilder& builder, VelocitySpace& dovs, DovsStep& out) {
  Observation& obs = out.observation;
  obs.robot_pose = robot_pose;
  obs.stamp_s = obstacles.header.stamp.toSec();
  obs.robot_twist = limits.clipToFeasible(odom_twist);
  obs.goal = goal.value_or(obs.robot_pose.position());
  const std::string obstacle_error = observationObstaclesFromMsg(obstacles, obs.obstacles, obs.segments);
  if (!obstacle_error.empty()) return obstacle_error;

  builder.build(obs, dovs);
  out.actions = computeActions(obs.robot_twist, obs.robot_pose.toLocal(obs.goal), limits);
  const ActionSet& actions = out.actions;
  // Without a goal there is no goal line: the shield chooses among the window actions only.
  ActionSet choosable = actions;
  if (!goal) {
    for (size_t i = static_cast<size_t>(kActionGoalHigh); i < choosable.valid.size(); ++i) choosable.valid[i] = false;
  }
  const ShieldedMask shielded = shieldActions(choosable, dovs, obs, shield);
  out.shield_level = shielded.level;

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
  for (size_t i = 0; i < static_cast<size_t>(kNumActions); ++i) {
    m.action_v[i] = actions.velocities[i].v;
    m.action_w[i] = actions.velocities[i].w;
    m.action_valid[i] = shielded.mask[i];
  }
  m.escape = shielded.has_escape;
  m.escape_v = shielded.has_escape ? shielded.escape.v : 0.0;
  m.escape_w = shielded.has_escape ? shielded.escape.w : 0.0;
  m.escape_tier = static_cast<uint8_t>(shielded.has_escape ? shielded.escape_tier : EscapeTier::kFree);
  if (shield.statics.enabled) {
    const StaticScene statics(obs, limits, shield.statics);
    m.static_frame = obstacles.header.frame_id;
    m.static_segments = statics.flatSegments(obs.robot_pose);
    m.static_discs = statics.flatDiscs(obs.robot_pose);
  }
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
  const StateVector state = buildState(dovs, obs, normalization);
  m.state.assign(state.data(), state.data() + state.size());
  for (const auto& field : normalization.fields()) m.state_normalization.push_back(field.second);
  return {};
}

std::string staticObservationFromDovs(const Dovs& dovs, const std::string& fixed_frame, const Pose2& robot_pose,
                                      const Twist2& twist, Observation& out) {
  out = Observation();
  out.robot_pose = robot_pose;
  out.robot_twist = twist;
  out.goal = robot_pose.position();
  if (dovs.static_segments.empty() && dovs.static_discs.empty()) return {};
  if (dovs.static_frame != fixed_frame) {
    return "dovs static geometry is in frame '" + dovs.static_frame + "', the planner's fixed_frame is '" +
           fixed_frame + "'";
  }
  if (dovs.static_segments.size() % 4 != 0) return "dovs static_segments length is not a multiple of 4";
  if (dovs.static_discs.size() % 3 != 0) return "dovs static_discs length is not a multiple of 3";
  for (float x : dovs.static_segments) {
    if (!std::isfinite(x)) return "dovs static_segments has NaN/inf";
  }
  for (float x : dovs.static_discs) {
    if (!std::isfinite(x)) return "dovs static_discs has NaN/inf";
  }
  const auto& s = dovs.static_segments;
  for (size_t i = 0; i + 3 < s.size(); i += 4)
    out.segments.push_back(Segment{Vec2(s[i], s[i + 1]), Vec2(s[i + 2], s[i + 3])});
  const auto& d = dovs.static_discs;
  for (size_t i = 0; i + 2 < d.size(); i += 3) {
    MovingObstacle m;
    m.center = Vec2(d[i], d[i + 1]);
    m.radius = d[i + 2];
    m.speed = 0.0;
    m.is_static = true;
    out.obstacles.push_back(m);
  }
  return {};
}

Twist2 choiceVelocity(const Dovs& dovs, int choice) {
  if (choice == kEscapeChoice) return {dovs.escape_v, dovs.escape_w};
  if (choice < 0 || choice >= kNumActions) throw std::out_of_range("choiceVelocity: choice " + std::to_string(choice));
  return {dovs.action_v[static_cast<size_t>(choice)], dovs.action_w[static_cast<size_t>(choice)]};
}

int chooseAction(const QNetwork& network, const Dovs& dovs, std::string& why) {
  why.clear();
  if (dovs.state.size() != static_cast<size_t>(QNetwork::kStateSize)) {
    why = "dovs state has the wrong size";
    return -1;
  }
  // The state must be normalised the way the network was trained (dovs_node builds it from its own robot/* and
  // dovs/* parameters, which may differ from the planner's).
  const std::vector<std::pair<std::string, float>> expected = StateNormalization{}.fields();
  if (dovs.state_normalization.size() != expected.size()) {
    why = "dovs state_normalization has " + std::to_string(dovs.state_normalization.size()) + " values, expected " +
          std::to_string(expected.size());
    return -1;
  }
  std::vector<std::pair<std::string, float>> used = expected;
  for (size_t i = 0; i < used.size(); ++i) used[i].second = dovs.state_normalization[i];
  if (const std::string mismatch = network.normalizationMismatch(used, 1e-4f); !mismatch.empty()) {
    why =
        "planner error: the dovs states are normalised differently from the model's training (check robot/* and "
        "dovs/obstacle_range of dovs_node): " +
        mismatch;
    return -1;
  }
  // An action whose velocity is NaN/inf cannot be commanded (clipping it into the feasible set would turn it
  // into a silent stop while the planner reports itself active): it is never chosen.
  if (dovs.escape) {
    // Boxed in: the shield's escape velocity, not the network's choice.
    if (!std::isfinite(dovs.escape_v) || !std::isfinite(dovs.escape_w)) {
      why = "planner error: the shield's escape velocity is NaN/inf";
      return -1;
    }
    return kEscapeChoice;
  }
  QNetwork::ActionMask mask;
  int non_finite = -1;
  for (size_t i = 0; i < mask.size(); ++i) {
    const bool finite = std::isfinite(dovs.action_v[i]) && std::isfinite(dovs.action_w[i]);
    if (dovs.action_valid[i] && !finite && non_finite < 0) non_finite = static_cast<int>(i);
    mask[i] = dovs.action_valid[i] && finite;
  }
  const Eigen::Map<const Eigen::VectorXf> state(dovs.state.data(), static_cast<Eigen::Index>(dovs.state.size()));
  int a = -1;
  try {
    a = network.selectAction(state, mask);
  } catch (const std::exception& e) {
    why = std::string("planner error: ") + e.what();
    return -1;
  }
  if (a < 0) {
    why = non_finite < 0 ? std::string("planner error: every action is masked")
                         : "planner error: every action is masked or has a NaN/inf velocity (action " +
                               std::to_string(non_finite) + ")";
  }
  return a;
}

}  // namespace dqn_dovs
