#include "dqn_dovs/dovs/state.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace dqn_dovs {

namespace {

const char* const kFieldNames[StateNormalization::kNumFields] = {"v_scale_mps",
                                                                 "w_scale_rps",
                                                                 "goal_distance_scale_m",
                                                                 "goal_angle_scale_rad",
                                                                 "obstacle_heading_scale_rad",
                                                                 "obstacle_speed_scale_mps",
                                                                 "obstacle_bearing_scale_rad",
                                                                 "obstacle_clearance_scale_m",
                                                                 "far_heading",
                                                                 "far_speed",
                                                                 "far_bearing",
                                                                 "far_clearance",
                                                                 "clip"};

// Field pointers in the same order as kFieldNames.
std::array<float StateNormalization::*, StateNormalization::kNumFields> fieldPointers() {
  return {&StateNormalization::v_scale_mps,
          &StateNormalization::w_scale_rps,
          &StateNormalization::goal_distance_scale_m,
          &StateNormalization::goal_angle_scale_rad,
          &StateNormalization::obstacle_heading_scale_rad,
          &StateNormalization::obstacle_speed_scale_mps,
          &StateNormalization::obstacle_bearing_scale_rad,
          &StateNormalization::obstacle_clearance_scale_m,
          &StateNormalization::far_heading,
          &StateNormalization::far_speed,
          &StateNormalization::far_bearing,
          &StateNormalization::far_clearance,
          &StateNormalization::clip};
}

}  // namespace

std::vector<std::pair<std::string, float>> StateNormalization::fields() const {
  std::vector<std::pair<std::string, float>> out;
  const auto ptrs = fieldPointers();
  for (int i = 0; i < kNumFields; ++i) out.emplace_back(kFieldNames[i], this->*ptrs[static_cast<size_t>(i)]);
  return out;
}

StateNormalization StateNormalization::fromFields(const std::vector<std::pair<std::string, float>>& fields) {
  if (fields.size() != static_cast<size_t>(kNumFields)) {
    std::ostringstream os;
    os << "state normalisation: expected " << kNumFields << " fields, got " << fields.size();
    throw StateError(os.str());
  }
  StateNormalization n;
  const auto ptrs = fieldPointers();
  for (int i = 0; i < kNumFields; ++i) {
    if (fields[static_cast<size_t>(i)].first != kFieldNames[i]) {
      std::ostringstream os;
      os << "state normalisation: field " << i << " is '" << fields[static_cast<size_t>(i)].first << "', expected '"
         << kFieldNames[i] << "'";
      throw StateError(os.str());
    }
    n.*ptrs[static_cast<size_t>(i)] = fields[static_cast<size_t>(i)].second;
  }
  return n;
}

std::string StateNormalization::validate() const {
  const auto ptrs = fieldPointers();
  auto bad = [](int i, float value, const char* why) {
    std::ostringstream os;
    os << "state normalisation field '" << kFieldNames[i] << "' = " << value << ": " << why;
    return os.str();
  };
  for (int i = 0; i < 8; ++i) {
    const float v = this->*ptrs[static_cast<size_t>(i)];
    if (!(std::isfinite(v) && v > 0.0f)) return bad(i, v, "scale must be finite and positive");
  }
  if (!(std::isfinite(clip) && clip > 0.0f)) return bad(12, clip, "must be finite and positive");
  for (int i = 8; i < 12; ++i) {
    const float v = this->*ptrs[static_cast<size_t>(i)];
    if (!(std::isfinite(v) && std::abs(v) <= clip)) return bad(i, v, "far-away value must be finite and within clip");
  }
  return {};
}

FeatureVector computeFeatures(const VelocitySpace& dovs, const Observation& obs, const StateNormalization& norm) {
  if (const std::string e = norm.validate(); !e.empty()) throw StateError(e);
  if (!std::isfinite(obs.robot_twist.v) || !std::isfinite(obs.robot_twist.w))
    throw StateError("state: robot_twist must be finite");
  if (!obs.robot_pose.isFinite()) throw StateError("state: robot_pose must be finite");
  if (!std::isfinite(obs.goal.x()) || !std::isfinite(obs.goal.y())) throw StateError("state: goal must be finite");
  auto scaled = [&](double raw, float scale) {
    return std::clamp(static_cast<float>(raw / static_cast<double>(scale)), -norm.clip, norm.clip);
  };
  FeatureVector f{};
  const Vec2 goal = obs.robot_pose.toLocal(obs.goal);
  f[kFeatureV] = scaled(obs.robot_twist.v, norm.v_scale_mps);
  f[kFeatureW] = scaled(obs.robot_twist.w, norm.w_scale_rps);
  f[kFeatureGoalDistance] = scaled(goal.norm(), norm.goal_distance_scale_m);
  f[kFeatureGoalAngle] =
      scaled(goal.squaredNorm() > 0.0 ? std::atan2(goal.y(), goal.x()) : 0.0, norm.goal_angle_scale_rad);
  const ClosestObstacle& c = dovs.closestObstacle();
  if (c.found) {
    f[kFeatureObstacleHeading] = scaled(c.relative_heading_rad, norm.obstacle_heading_scale_rad);
    f[kFeatureObstacleSpeed] = scaled(c.speed_mps, norm.obstacle_speed_scale_mps);
    f[kFeatureObstacleBearing] = scaled(c.bearing_rad, norm.obstacle_bearing_scale_rad);
    f[kFeatureObstacleClearance] = scaled(c.clearance_m, norm.obstacle_clearance_scale_m);
  } else {
    f[kFeatureObstacleHeading] = norm.far_heading;
    f[kFeatureObstacleSpeed] = norm.far_speed;
    f[kFeatureObstacleBearing] = norm.far_bearing;
    f[kFeatureObstacleClearance] = norm.far_clearance;
  }
  return f;
}

StateVector buildState(const VelocitySpace& dovs, const Observation& obs, const StateNormalization& norm) {
  if (dovs.gridSize() != kStateGridSize) {
    std::ostringstream os;
    os << "state: DOVS grid_size is " << dovs.gridSize() << ", the network state needs " << kStateGridSize;
    throw StateError(os.str());
  }
  StateVector s;
  const std::vector<float>& grid = dovs.grid();
  for (int i = 0; i < kStateGridCells; ++i) s(i) = grid[static_cast<size_t>(i)];
  const FeatureVector f = computeFeatures(dovs, obs, norm);
  for (int i = 0; i < kNumFeatures; ++i) s(kStateGridCells + i) = f[static_cast<size_t>(i)];
  return s;
}

StateNormalization stateNormalization(const RobotLimits& limits, const DovsConfig& dovs) {
  StateNormalization n;
  n.v_scale_mps = static_cast<float>(limits.v_max);
  n.w_scale_rps = static_cast<float>(limits.w_max);
  n.obstacle_clearance_scale_m = static_cast<float>(dovs.obstacle_range_m);
  return n;
}

}  // namespace dqn_dovs
