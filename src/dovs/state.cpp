#include "dqn_dovs/dovs/state.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "dqn_dovs/common/parse.h"
#include "dqn_dovs/dovs/actions.h"

namespace dqn_dovs {

static_assert(kPreviousChoiceInputs == kNumActions + 1 && kPreviousChoiceOther == kNumActions,
              "one previous-choice input per action, then one for any other command");

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
  if (grid_contact_horizon_s != 0.0f) out.emplace_back(kGridContactHorizonField, grid_contact_horizon_s);
  return out;
}

StateNormalization StateNormalization::fromFields(const std::vector<std::pair<std::string, float>>& fields) {
  if (fields.size() != static_cast<size_t>(kNumFields) && fields.size() != static_cast<size_t>(kNumFields) + 1) {
    std::ostringstream os;
    os << "state normalisation: expected " << kNumFields << " fields (" << kNumFields + 1
       << " with a graded grid), got " << fields.size();
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
  if (fields.size() > static_cast<size_t>(kNumFields)) {
    const auto& [name, value] = fields.back();
    if (name != kGridContactHorizonField) {
      throw StateError("state normalisation: field " + std::to_string(kNumFields) + " is '" + name + "', expected '" +
                       kGridContactHorizonField + "'");
    }
    n.grid_contact_horizon_s = value;
  }
  return n;
}

bool StateNormalization::fromValues(const std::vector<float>& values, StateNormalization& out, std::string& why) {
  if (values.size() != static_cast<size_t>(kNumFields) && values.size() != static_cast<size_t>(kNumFields) + 1) {
    why = "state_normalization has " + std::to_string(values.size()) + " values, expected " +
          std::to_string(kNumFields) + " (or " + std::to_string(kNumFields + 1) + " with a graded grid)";
    return false;
  }
  std::vector<std::pair<std::string, float>> named;
  for (size_t i = 0; i < values.size(); ++i)
    named.emplace_back(i < static_cast<size_t>(kNumFields) ? kFieldNames[i] : kGridContactHorizonField, values[i]);
  out = fromFields(named);
  why.clear();
  return true;
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
  if (grid_channels < 1 || grid_channels > kMaxStateGridChannels)
    return "state grid_channels = " + std::to_string(grid_channels) + ": " + kGridChannelsRule;
  if (previous_action != 0 && previous_action != 1)
    return "state previous_action = " + std::to_string(previous_action) + ": must be 0 (off) or 1 (on)";
  if (wall_rays < 0 || wall_rays > kMaxWallRays)
    return "state wall_rays = " + std::to_string(wall_rays) + ": must be in [0, " + std::to_string(kMaxWallRays) + "]";
  if (route_points < 0 || route_points > kMaxRoutePoints)
    return "state route_points = " + std::to_string(route_points) + ": must be in [0, " +
           std::to_string(kMaxRoutePoints) + "]";
  if (person_tokens < 0 || person_tokens > kMaxPersonTokens)
    return "state person_tokens = " + std::to_string(person_tokens) + ": must be in [0, " +
           std::to_string(kMaxPersonTokens) + "]";
  const float t = grid_contact_horizon_s;
  if (!(std::isfinite(t) && (t == 0.0f || (t >= 0.5f && t <= 30.0f)))) {
    std::ostringstream os;
    os << "state normalisation field '" << kGridContactHorizonField << "' = " << t
       << ": must be 0 (the +1 / -1 grid) or in [0.5, 30] s";
    return os.str();
  }
  return {};
}

std::vector<float> gradedGrid(const VelocitySpace& dovs, const Observation& obs, double horizon_s) {
  if (!(std::isfinite(horizon_s) && horizon_s >= 0.5 && horizon_s <= 30.0))
    throw StateError("state: the graded grid's horizon must be in [0.5, 30] s, got " + std::to_string(horizon_s));
  const RobotLimits& limits = dovs.limits();
  const DovsConfig& config = dovs.config();
  const Pose2& pose = obs.robot_pose;
  constexpr double kStep = 0.1;  // s
  const int steps = static_cast<int>(std::ceil(horizon_s / kStep - 1e-9));
  // Obstacles as the DOVS models them (docs/dovs.md): within range, enlarged, constant (v, w) unless static; their
  // centres at every step, in the robot frame. Contact inside a disc of squared radius r2.
  struct Disc {
    std::vector<Vec2> at;  // one entry when static
    double r2;
  };
  std::vector<Disc> discs;
  for (const MovingObstacle& o : obs.obstacles) {
    const Vec2 p0 = pose.toLocal(o.center);
    const double d0 = p0.norm();
    if (!(d0 <= config.obstacle_range_m)) continue;
    const double r = modelDiscRadius(limits, config, o.radius, d0);
    Disc disc{{}, r * r};
    if (modelAsStatic(config, o)) {
      disc.at.push_back(p0);
    } else {
      const Pose2 start{o.center.x(), o.center.y(), o.heading};
      for (int k = 1; k <= steps; ++k)
        disc.at.push_back(pose.toLocal(integrateUnicycle(start, o.speed, o.turn_rate, k * kStep).position()));
    }
    discs.push_back(std::move(disc));
  }
  std::vector<std::pair<Segment, double>> walls;  // robot frame, the band's half-width
  for (const Segment& s_world : obs.segments) {
    const Segment segment{pose.toLocal(s_world.a), pose.toLocal(s_world.b)};
    const double d0 = pointSegmentDistance(Vec2::Zero(), segment);
    if (d0 <= config.obstacle_range_m) walls.emplace_back(segment, modelWallHalfWidth(limits, config, d0));
  }
  const int n = dovs.gridSize();
  // The robot's position at every step of every cell's velocity depends on the limits only: kept per thread.
  struct RobotPaths {
    int n = 0, steps = 0;
    double v_max = 0.0, w_max = 0.0;
    std::vector<Vec2> at;  // [cell][step - 1]
  };
  thread_local RobotPaths paths;
  if (paths.n != n || paths.steps != steps || paths.v_max != limits.v_max || paths.w_max != limits.w_max) {
    paths = RobotPaths{n, steps, limits.v_max, limits.w_max, {}};
    paths.at.reserve(static_cast<size_t>(n * n * steps));
    for (int cell = 0; cell < n * n; ++cell) {
      const Twist2 t = dovs.gridCellVelocity(cell / n, cell % n);
      for (int k = 1; k <= steps; ++k)
        paths.at.push_back(integrateUnicycle(Pose2{0.0, 0.0, 0.0}, t.v, t.w, k * kStep).position());
    }
  }
  std::vector<float> grid(static_cast<size_t>(n * n), -1.0f);
  const double horizon = steps * kStep;
  for (int row = 0; row < n; ++row) {
    for (int col = 0; col < n; ++col) {
      const Twist2 cell = dovs.gridCellVelocity(row, col);
      if (!dovs.isFeasible(cell)) continue;  // -1
      // Free cells too: a velocity heading for a wall is free while it can still brake.
      const bool free = dovs.gridCell(row, col) > 0.0f;
      const Vec2* path = &paths.at[static_cast<size_t>((row * n + col) * steps)];
      auto touches = [&](int k) {  // at step k (1..steps)
        const Vec2& p = path[k - 1];
        for (const Disc& d : discs) {
          if ((p - (d.at.size() == 1 ? d.at.front() : d.at[static_cast<size_t>(k - 1)])).squaredNorm() < d.r2)
            return true;
        }
        for (const auto& [segment, half_width] : walls) {
          if (pointSegmentDistance(p, segment) < half_width) return true;
        }
        return false;
      };
      int k = 1;
      while (k <= steps && !touches(k)) ++k;
      const double contact = std::min(k, steps) * kStep;  // horizon when nothing is touched
      const float t = static_cast<float>(contact / horizon);
      grid[static_cast<size_t>(row * n + col)] = free ? t : t - 1.0f;
    }
  }
  return grid;
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

namespace {

void requireStateGrid(const VelocitySpace& dovs) {
  if (dovs.gridSize() != kStateGridSize) {
    std::ostringstream os;
    os << "state: DOVS grid_size is " << dovs.gridSize() << ", the network state needs " << kStateGridSize;
    throw StateError(os.str());
  }
}

}  // namespace

std::vector<float> windowGoalChannels(const VelocitySpace& dovs, const Observation& obs) {
  requireStateGrid(dovs);
  const Twist2& now = obs.robot_twist;
  if (!std::isfinite(now.v) || !std::isfinite(now.w)) throw StateError("state: robot twist must be finite");
  if (!std::isfinite(obs.goal.x()) || !std::isfinite(obs.goal.y())) throw StateError("state: goal must be finite");
  const RobotLimits& limits = dovs.limits();
  const int n = kStateGridSize;
  const double cell_v = limits.v_max / n, cell_w = 2.0 * limits.w_max / n;
  // The window the actions are taken from: the rhombus around the current velocity clipped into the triangle.
  const DynamicWindow window = makeDynamicWindow(limits.clipToFeasible(now), limits);
  const GoalLine line = goalLine(obs.robot_pose.toLocal(obs.goal));
  std::vector<float> out(static_cast<size_t>(2 * kStateGridCells), -1.0f);
  for (int row = 0; row < n; ++row) {
    const double v_lo = limits.v_max * (n - row - 1) / n, v_hi = v_lo + cell_v;
    for (int col = 0; col < n; ++col) {
      const double w_lo = -limits.w_max + col * cell_w, w_hi = w_lo + cell_w;
      const size_t i = static_cast<size_t>(row * n + col);
      // The cell meets the rhombus when its point nearest the centre (in the rhombus's separable norm) is inside.
      const double dv = std::max({v_lo - window.center.v, window.center.v - v_hi, 0.0}) / window.dv;
      const double dw = std::max({w_lo - window.center.w, window.center.w - w_hi, 0.0}) / window.dw;
      if (dv + dw <= 1.0) out[i] = 1.0f;
      bool on_line = false;
      if (line.kind == GoalLine::Kind::kArc) {
        // w = k v over the cell's speeds [v_lo, v_hi], boundaries included (straight ahead, w = 0 is the edge
        // between the two middle columns and both hold the line; 1e-9 absorbs rounding of the goal's bearing).
        const double a = line.curvature_1pm * v_lo, b = line.curvature_1pm * v_hi;
        on_line = std::max(a, b) >= w_lo - 1e-9 && std::min(a, b) <= w_hi + 1e-9;
      } else if (line.kind == GoalLine::Kind::kTurnInPlace) {
        on_line = row == n - 1 && (line.turn_sign > 0.0 ? w_hi > 0.0 : w_lo < 0.0);
      }
      if (on_line) out[static_cast<size_t>(kStateGridCells) + i] = 1.0f;
    }
  }
  return out;
}

void TrackHistory::clear() {
  tracks_.clear();
  last_stamp_s_ = -1e300;
}

void TrackHistory::update(double stamp_s, const std::vector<MovingObstacle>& obstacles) {
  if (!std::isfinite(stamp_s)) throw StateError("track history: the stamp is NaN or infinite");
  if (stamp_s < last_stamp_s_) clear();
  last_stamp_s_ = stamp_s;
  // Keep a little more than the history reaches so that the sample nearest 1 s before is there.
  const double keep_from = stamp_s - kTokenHistory_s - 0.5;
  std::vector<std::pair<int, std::vector<Sample>>> kept;
  kept.reserve(obstacles.size());
  for (const MovingObstacle& o : obstacles) {
    if (o.id < 0 || !o.center.allFinite()) continue;
    auto it = std::find_if(tracks_.begin(), tracks_.end(), [&o](const auto& t) { return t.first == o.id; });
    std::vector<Sample> samples;
    if (it != tracks_.end()) samples = std::move(it->second);
    samples.erase(
        std::remove_if(samples.begin(), samples.end(), [keep_from](const Sample& x) { return x.stamp_s < keep_from; }),
        samples.end());
    if (samples.empty() || samples.back().stamp_s < stamp_s) samples.push_back({stamp_s, o.center});
    kept.emplace_back(o.id, std::move(samples));
  }
  tracks_ = std::move(kept);  // tracks not seen now are forgotten
}

bool TrackHistory::positionBefore(int id, Vec2& out) const {
  auto it = std::find_if(tracks_.begin(), tracks_.end(), [id](const auto& t) { return t.first == id; });
  if (it == tracks_.end() || it->second.empty()) return false;
  const double want = last_stamp_s_ - kTokenHistory_s;
  const Sample* best = &it->second.front();
  for (const Sample& x : it->second)
    if (std::abs(x.stamp_s - want) < std::abs(best->stamp_s - want)) best = &x;
  out = best->position;
  return true;
}

std::vector<float> personTokens(const Observation& obs, const StateNormalization& norm, const TrackHistory* history) {
  const int k = norm.person_tokens;
  std::vector<float> out(static_cast<size_t>(std::max(k, 0) * kPersonTokenSize), 0.0f);
  if (k <= 0) return out;
  const Pose2& robot = obs.robot_pose;
  if (!std::isfinite(robot.x) || !std::isfinite(robot.y) || !std::isfinite(robot.theta))
    throw StateError("person tokens: the robot pose must be finite");
  std::vector<std::pair<double, size_t>> order;
  for (size_t i = 0; i < obs.obstacles.size(); ++i) {
    const MovingObstacle& o = obs.obstacles[i];
    if (!o.center.allFinite() || !std::isfinite(o.radius) || !std::isfinite(o.heading) || !std::isfinite(o.speed) ||
        !std::isfinite(o.turn_rate))
      throw StateError("person tokens: obstacle " + std::to_string(i) + " has a NaN/inf value");
    order.emplace_back((o.center - robot.position()).norm() - o.radius, i);
  }
  std::stable_sort(order.begin(), order.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  const float pos_scale = norm.obstacle_clearance_scale_m, speed_scale = norm.obstacle_speed_scale_mps;
  auto put = [](float* t, int i, double value, float scale) {
    t[i] = std::clamp(static_cast<float>(value / scale), -kTokenClip, kTokenClip);
  };
  const double c = std::cos(robot.theta), sn = std::sin(robot.theta);
  for (int slot = 0; slot < k && slot < static_cast<int>(order.size()); ++slot) {
    const MovingObstacle& o = obs.obstacles[order[static_cast<size_t>(slot)].second];
    float* t = out.data() + static_cast<size_t>(slot) * kPersonTokenSize;
    t[0] = 1.0f;
    const Vec2 p = robot.toLocal(o.center);
    put(t, 1, p.x(), pos_scale);
    put(t, 2, p.y(), pos_scale);
    const double speed = o.is_static ? 0.0 : o.speed, turn = o.is_static ? 0.0 : o.turn_rate;
    const Vec2 v_world(speed * std::cos(o.heading), speed * std::sin(o.heading));
    put(t, 3, c * v_world.x() + sn * v_world.y(), speed_scale);
    put(t, 4, -sn * v_world.x() + c * v_world.y(), speed_scale);
    put(t, 5, o.radius, kTokenRadiusScale_m);
    Vec2 before = o.center;
    if (history != nullptr && o.id >= 0) history->positionBefore(o.id, before);
    const Vec2 b = robot.toLocal(before);
    put(t, 6, b.x(), pos_scale);
    put(t, 7, b.y(), pos_scale);
    const Pose2 start{o.center.x(), o.center.y(), o.heading};
    for (int step = 1; step <= 2; ++step) {
      const Vec2 ahead = robot.toLocal(integrateUnicycle(start, speed, turn, static_cast<double>(step)).position());
      put(t, 6 + 2 * step, ahead.x(), pos_scale);
      put(t, 7 + 2 * step, ahead.y(), pos_scale);
    }
    put(t, 12, o.age_s >= 0.0 && std::isfinite(o.age_s) ? o.age_s : kTokenAgeScale_s, kTokenAgeScale_s);
    t[12] = std::min(t[12], 1.0f);
    put(t, 13, o.position_sigma_m >= 0.0 && std::isfinite(o.position_sigma_m) ? o.position_sigma_m : 0.0,
        kTokenSigmaScale_m);
    t[13] = std::min(t[13], 1.0f);
  }
  return out;
}

std::vector<float> wallRays(const Observation& obs, const StateNormalization& norm) {
  const int n = norm.wall_rays;
  std::vector<float> out(static_cast<size_t>(std::max(n, 0)), 1.0f);
  const double range = norm.obstacle_clearance_scale_m;
  const Vec2 origin = obs.robot_pose.position();
  for (int k = 0; k < n; ++k) {
    const double a = obs.robot_pose.theta + 2.0 * M_PI * k / n;
    const Vec2 d(std::cos(a), std::sin(a));
    double best = range;
    for (const Segment& seg : obs.segments) {
      if (const auto hit = raySegment(origin, d, seg); hit && *hit < best) best = *hit;
    }
    out[static_cast<size_t>(k)] = static_cast<float>(best / range);
  }
  return out;
}

std::vector<float> routePoints(const Observation& obs, const StateNormalization& norm) {
  const int n = norm.route_points;
  std::vector<float> out(static_cast<size_t>(std::max(n, 0)) * kRoutePointInputs, 0.0f);
  if (n <= 0) return out;
  std::vector<Vec2> line = obs.route_ahead;
  if (line.empty()) line = {obs.robot_pose.position(), obs.goal};
  for (size_t i = 0; i < line.size(); ++i) {
    if (!line[i].allFinite()) throw StateError("state: route point " + std::to_string(i) + " is NaN/inf");
  }
  const double scale = norm.obstacle_clearance_scale_m;
  const double clip = kTokenClip;
  size_t seg = 0;       // the route segment line[seg] -> line[seg + 1] being walked
  double seg_from = 0;  // arc length at line[seg]
  for (int k = 0; k < n; ++k) {
    const double arc = kRoutePointSpacing_m * (k + 1);
    while (seg + 1 < line.size() && seg_from + (line[seg + 1] - line[seg]).norm() < arc) {
      seg_from += (line[seg + 1] - line[seg]).norm();
      ++seg;
    }
    Vec2 p = line[seg];
    if (seg + 1 < line.size()) {
      const double len = (line[seg + 1] - line[seg]).norm();
      if (len > 0.0) p += (line[seg + 1] - line[seg]) * ((arc - seg_from) / len);
    }
    const Vec2 local = obs.robot_pose.toLocal(p);
    out[static_cast<size_t>(kRoutePointInputs * k)] = static_cast<float>(std::clamp(local.x() / scale, -clip, clip));
    out[static_cast<size_t>(kRoutePointInputs * k + 1)] =
        static_cast<float>(std::clamp(local.y() / scale, -clip, clip));
  }
  return out;
}

StateVector buildState(const VelocitySpace& dovs, const Observation& obs, const StateNormalization& norm,
                       const std::vector<float>* previous_grid, int previous_choice, const TrackHistory* history) {
  requireStateGrid(dovs);
  const FeatureVector f = computeFeatures(dovs, obs, norm);  // validates norm and the robot state first
  if (previous_choice < kNoPreviousChoice || previous_choice > kPreviousChoiceOther)
    throw StateError("state: the previous choice " + std::to_string(previous_choice) + " is not in [-1, " +
                     std::to_string(kPreviousChoiceOther) + "]");
  const int grid_values = norm.grid_channels * kStateGridCells;
  StateVector s(norm.stateSize());
  if (norm.grid_contact_horizon_s > 0.0f) {
    const std::vector<float> grid = gradedGrid(dovs, obs, norm.grid_contact_horizon_s);
    for (int i = 0; i < kStateGridCells; ++i) s(i) = grid[static_cast<size_t>(i)];
  } else {
    const std::vector<float>& grid = dovs.grid();
    for (int i = 0; i < kStateGridCells; ++i) s(i) = grid[static_cast<size_t>(i)];
  }
  if (norm.grid_channels == kWindowGoalGridChannels) {
    const std::vector<float> extra = windowGoalChannels(dovs, obs);
    for (int i = 0; i < 2 * kStateGridCells; ++i) s(kStateGridCells + i) = extra[static_cast<size_t>(i)];
  } else if (norm.grid_channels == kHistoryGridChannels) {
    if (previous_grid == nullptr) {
      for (int i = 0; i < kStateGridCells; ++i) s(kStateGridCells + i) = s(i);  // first decision: no history yet
    } else {
      if (previous_grid->size() != static_cast<size_t>(kStateGridCells))
        throw StateError("state: the previous grid has " + std::to_string(previous_grid->size()) + " values, not " +
                         std::to_string(kStateGridCells));
      for (int i = 0; i < kStateGridCells; ++i) {
        const float v = (*previous_grid)[static_cast<size_t>(i)];
        if (!std::isfinite(v)) throw StateError("state: the previous grid has a NaN/inf value at " + std::to_string(i));
        s(kStateGridCells + i) = v;
      }
    }
  }
  for (int i = 0; i < kNumFeatures; ++i) s(grid_values + i) = f[static_cast<size_t>(i)];
  if (norm.previous_action != 0) {
    s.segment(grid_values + kNumFeatures, kPreviousChoiceInputs).setZero();
    if (previous_choice != kNoPreviousChoice) s(grid_values + kNumFeatures + previous_choice) = 1.0f;
  }
  int at = grid_values + norm.featureInputs();
  for (float r : wallRays(obs, norm)) s(at++) = r;
  for (float r : routePoints(obs, norm)) s(at++) = r;
  for (float t : personTokens(obs, norm, history)) s(at++) = t;
  return s;
}

void buildVelocitySpaceStep(const Observation& obs, const RobotLimits& limits, const StateNormalization& norm,
                            DovsBuilder& builder, VelocitySpace& dovs, VelocitySpaceStep& out, TrackHistory* history,
                            const std::vector<float>* previous_grid, int previous_choice) {
  builder.build(obs, dovs);
  out.actions = computeActions(obs.robot_twist, obs.robot_pose.toLocal(obs.goal), limits);
  if (history != nullptr && norm.person_tokens > 0) history->update(obs.stamp_s, obs.obstacles);
  out.state = buildState(dovs, obs, norm, previous_grid, previous_choice, history);
}

namespace {

// (name, value) of every state parameter, in stateParametersText's order.
std::vector<std::pair<std::string, std::string>> stateParameters(const RobotLimits& limits, const DovsConfig& dovs) {
  std::vector<std::pair<std::string, std::string>> out;
  for (const std::string& name : dovsParameterNames()) out.emplace_back("dovs/" + name, dovsParameter(dovs, name));
  out.emplace_back("robot/a_v", formatRoundTrip(limits.a_v));
  out.emplace_back("robot/a_w", formatRoundTrip(limits.a_w));
  out.emplace_back("robot/dt", formatRoundTrip(limits.dt));
  out.emplace_back("robot/radius", formatRoundTrip(limits.radius));
  return out;
}

}  // namespace

std::string stateParametersText(const RobotLimits& limits, const DovsConfig& dovs) {
  std::string text;
  for (const auto& [name, value] : stateParameters(limits, dovs))
    text += (text.empty() ? "" : " ") + name + "=" + value;
  return text;
}

std::string stateParametersMismatch(const std::string& metadata, const RobotLimits& limits, const DovsConfig& dovs,
                                    double rel_tol) {
  const std::string key = std::string(kStateParametersKey) + ":";
  std::istringstream lines(metadata);
  std::string line, trained;
  bool found = false;
  while (std::getline(lines, line)) {
    if (line.rfind(key, 0) == 0) {
      trained = line.substr(key.size());
      found = true;
    }
  }
  if (!found) return {};
  const auto here = stateParameters(limits, dovs);
  std::istringstream words(trained);
  std::string word, problems;
  while (words >> word) {
    const size_t eq = word.find('=');
    const std::string name = eq == std::string::npos ? word : word.substr(0, eq);
    const auto it = std::find_if(here.begin(), here.end(), [&](const auto& p) { return p.first == name; });
    const std::optional<double> was = eq == std::string::npos ? std::nullopt : parseNumber(word.substr(eq + 1));
    if (it == here.end() || !was) {
      problems += (problems.empty() ? "" : "; ") + std::string("'") + word + "' cannot be read";
      continue;
    }
    const double now = *parseNumber(it->second);
    if (std::abs(now - *was) > rel_tol * std::max(1.0, std::abs(*was))) {
      problems += (problems.empty() ? "" : "; ") + name + " is " + it->second + " here, the model was trained with " +
                  word.substr(eq + 1);
    }
  }
  return problems;
}

StateNormalization stateNormalization(const RobotLimits& limits, const DovsConfig& dovs) {
  StateNormalization n;
  n.v_scale_mps = static_cast<float>(limits.v_max);
  n.w_scale_rps = static_cast<float>(limits.w_max);
  n.obstacle_clearance_scale_m = static_cast<float>(dovs.obstacle_range_m);
  n.grid_contact_horizon_s = static_cast<float>(dovs.grid_contact_horizon_s);
  n.grid_channels = dovs.grid_channels;
  n.previous_action = dovs.previous_action;
  n.wall_rays = dovs.wall_rays;
  n.person_tokens = dovs.person_tokens;
  n.route_points = dovs.route_points;
  return n;
}

}  // namespace dqn_dovs
