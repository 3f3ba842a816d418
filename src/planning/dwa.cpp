#include "dqn_dovs/planning/dwa.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <queue>
#include <sstream>
#include <utility>

namespace dqn_dovs {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
// A trajectory is never cut into more checked points than this (guards absurd speeds or granularities).
constexpr int kMaxPoints = 2000;

std::string bad(const char* field, double value, const std::string& why) {
  std::ostringstream os;
  os << "dwa parameter '" << field << "' = " << value << ": " << why;
  return os.str();
}

bool usable(const MovingObstacle& o) {
  return o.center.allFinite() && std::isfinite(o.radius) && std::isfinite(o.heading) && std::isfinite(o.speed) &&
         std::isfinite(o.turn_rate);
}

double obstacleSpeed(const MovingObstacle& o) { return o.is_static ? 0.0 : std::abs(o.speed); }

bool staticFor(const MovingObstacle& o, const DwaConfig& c) {
  return o.is_static || std::abs(o.speed) < c.static_speed_mps;
}

}  // namespace

DwaNavigationGrid::DwaNavigationGrid(const Observation& obs, const RobotLimits& limits, const DwaConfig& config)
    : goal_(obs.goal), resolution_(config.grid_resolution_m) {
  const Vec2 robot = obs.robot_pose.position();
  const Vec2 lo = robot.cwiseMin(goal_) - Vec2::Constant(config.grid_margin_m);
  const Vec2 hi = robot.cwiseMax(goal_) + Vec2::Constant(config.grid_margin_m);
  origin_ = lo;
  // The cap keeps absurd inputs (a goal kilometres away) from allocating without bound; points off the grid
  // then fall back to the straight distance.
  constexpr long kMaxCells = 600;
  cols_ = std::clamp(static_cast<long>(std::ceil((hi.x() - lo.x()) / resolution_)), 1L, kMaxCells);
  rows_ = std::clamp(static_cast<long>(std::ceil((hi.y() - lo.y()) / resolution_)), 1L, kMaxCells);
  const size_t n = static_cast<size_t>(cols_ * rows_);
  std::vector<char> blocked(n, 0);
  auto markAround = [&](const Vec2& box_lo, const Vec2& box_hi, const std::function<bool(const Vec2&)>& inside) {
    const long c0 = std::max(0L, static_cast<long>(std::floor((box_lo.x() - origin_.x()) / resolution_)));
    const long c1 = std::min(cols_ - 1, static_cast<long>(std::floor((box_hi.x() - origin_.x()) / resolution_)));
    const long r0 = std::max(0L, static_cast<long>(std::floor((box_lo.y() - origin_.y()) / resolution_)));
    const long r1 = std::min(rows_ - 1, static_cast<long>(std::floor((box_hi.y() - origin_.y()) / resolution_)));
    for (long r = r0; r <= r1; ++r) {
      for (long c = c0; c <= c1; ++c) {
        if (inside(centreOf(r * cols_ + c))) blocked[static_cast<size_t>(r * cols_ + c)] = 1;
      }
    }
  };
  for (const Segment& s : obs.segments) {
    if (!(s.a.allFinite() && s.b.allFinite())) continue;
    const Vec2 pad = Vec2::Constant(limits.radius);
    markAround(s.a.cwiseMin(s.b) - pad, s.a.cwiseMax(s.b) + pad,
               [&](const Vec2& p) { return pointSegmentDistance(p, s) < limits.radius; });
  }
  for (const MovingObstacle& o : obs.obstacles) {
    if (!usable(o) || !staticFor(o, config)) continue;
    const double r = o.radius + limits.radius;
    markAround(o.center - Vec2::Constant(r), o.center + Vec2::Constant(r),
               [&](const Vec2& p) { return (p - o.center).norm() < r; });
  }

  value_.assign(n, kInf);
  using Entry = std::pair<double, long>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> open;
  const long goal_cell = cellOf(goal_);
  if (goal_cell < 0) return;
  // Seeds: the goal's cell and its free neighbours, at their exact distance to the goal point.
  const long gr = goal_cell / cols_, gc = goal_cell % cols_;
  for (long dr = -1; dr <= 1; ++dr) {
    for (long dc = -1; dc <= 1; ++dc) {
      const long r = gr + dr, c = gc + dc;
      if (r < 0 || r >= rows_ || c < 0 || c >= cols_) continue;
      const long cell = r * cols_ + c;
      if (cell != goal_cell && blocked[static_cast<size_t>(cell)]) continue;
      value_[static_cast<size_t>(cell)] = (centreOf(cell) - goal_).norm();
      open.emplace(value_[static_cast<size_t>(cell)], cell);
    }
  }
  const double diagonal = resolution_ * std::sqrt(2.0);
  while (!open.empty()) {
    const auto [d, cell] = open.top();
    open.pop();
    if (d > value_[static_cast<size_t>(cell)]) continue;
    const long r = cell / cols_, c = cell % cols_;
    for (long dr = -1; dr <= 1; ++dr) {
      for (long dc = -1; dc <= 1; ++dc) {
        if (dr == 0 && dc == 0) continue;
        const long nr = r + dr, nc = c + dc;
        if (nr < 0 || nr >= rows_ || nc < 0 || nc >= cols_) continue;
        const long next = nr * cols_ + nc;
        if (blocked[static_cast<size_t>(next)]) continue;
        // No corner cutting: a diagonal step needs both cells it squeezes between free.
        if (dr != 0 && dc != 0 &&
            (blocked[static_cast<size_t>(r * cols_ + nc)] || blocked[static_cast<size_t>(nr * cols_ + c)])) {
          continue;
        }
        const double nd = d + (dr != 0 && dc != 0 ? diagonal : resolution_);
        if (nd < value_[static_cast<size_t>(next)]) {
          value_[static_cast<size_t>(next)] = nd;
          open.emplace(nd, next);
        }
      }
    }
  }
}

long DwaNavigationGrid::cellOf(const Vec2& p) const {
  if (!p.allFinite()) return -1;
  const double fc = std::floor((p.x() - origin_.x()) / resolution_);
  const double fr = std::floor((p.y() - origin_.y()) / resolution_);
  if (fc < 0.0 || fr < 0.0 || fc >= static_cast<double>(cols_) || fr >= static_cast<double>(rows_)) return -1;
  return static_cast<long>(fr) * cols_ + static_cast<long>(fc);
}

Vec2 DwaNavigationGrid::centreOf(long cell) const {
  return origin_ + resolution_ * Vec2(static_cast<double>(cell % cols_) + 0.5, static_cast<double>(cell / cols_) + 0.5);
}

bool DwaNavigationGrid::reachable(const Vec2& p) const {
  const long cell = cellOf(p);
  return cell >= 0 && std::isfinite(value_[static_cast<size_t>(cell)]);
}

double DwaNavigationGrid::distance(const Vec2& p) const {
  const double straight = (p - goal_).norm();
  if (straight <= 1.5 * resolution_) return straight;
  const double penalty = resolution_ * std::hypot(static_cast<double>(cols_), static_cast<double>(rows_));
  const long cell = cellOf(p);
  if (cell < 0 || !std::isfinite(value_[static_cast<size_t>(cell)])) return straight + penalty;
  // Bilinear between the four surrounding cell centres when all are reachable: a smooth value makes nearby
  // trajectories rank by how far they really get.
  const double x = (p.x() - origin_.x()) / resolution_ - 0.5, y = (p.y() - origin_.y()) / resolution_ - 0.5;
  const long c0 = static_cast<long>(std::floor(x)), r0 = static_cast<long>(std::floor(y));
  if (c0 >= 0 && r0 >= 0 && c0 + 1 < cols_ && r0 + 1 < rows_) {
    const double v00 = value_[static_cast<size_t>(r0 * cols_ + c0)],
                 v01 = value_[static_cast<size_t>(r0 * cols_ + c0 + 1)];
    const double v10 = value_[static_cast<size_t>((r0 + 1) * cols_ + c0)];
    const double v11 = value_[static_cast<size_t>((r0 + 1) * cols_ + c0 + 1)];
    if (std::isfinite(v00) && std::isfinite(v01) && std::isfinite(v10) && std::isfinite(v11)) {
      const double fx = x - static_cast<double>(c0), fy = y - static_cast<double>(r0);
      return (1 - fy) * ((1 - fx) * v00 + fx * v01) + fy * ((1 - fx) * v10 + fx * v11);
    }
  }
  return value_[static_cast<size_t>(cell)] + (p - centreOf(cell)).norm();
}

Vec2 DwaNavigationGrid::descent(const Vec2& p) const {
  const Vec2 to_goal = goal_ - p;
  const Vec2 straight = to_goal.norm() > 1e-12 ? Vec2(to_goal.normalized()) : Vec2::UnitX();
  if (to_goal.norm() <= 1.5 * resolution_ || !reachable(p)) return straight;
  const double h = resolution_;
  const Vec2 g(distance(p + Vec2(h, 0.0)) - distance(p - Vec2(h, 0.0)),
               distance(p + Vec2(0.0, h)) - distance(p - Vec2(0.0, h)));
  if (!g.allFinite() || g.norm() < 1e-9) return straight;
  return -g.normalized();
}

std::string DwaConfig::validate() const {
  if (vx_samples < 1 || vx_samples > 200) return bad("vx_samples", vx_samples, "must be in [1, 200]");
  if (vth_samples < 1 || vth_samples > 200) return bad("vth_samples", vth_samples, "must be in [1, 200]");
  if (!(std::isfinite(sim_time_s) && sim_time_s > 0.0 && sim_time_s <= 20.0)) {
    return bad("sim_time_s", sim_time_s, "must be in (0, 20] s");
  }
  if (!(std::isfinite(sim_granularity_m) && sim_granularity_m > 0.0)) {
    return bad("sim_granularity_m", sim_granularity_m, "must be > 0 m");
  }
  if (!(std::isfinite(angular_sim_granularity_rad) && angular_sim_granularity_rad > 0.0)) {
    return bad("angular_sim_granularity_rad", angular_sim_granularity_rad, "must be > 0 rad");
  }
  const std::pair<const char*, double> weights[] = {{"goal_distance_bias", goal_distance_bias},
                                                    {"heading_bias", heading_bias},
                                                    {"occdist_scale", occdist_scale},
                                                    {"speed_bias", speed_bias}};
  for (const auto& [field, value] : weights) {
    if (!(std::isfinite(value) && value >= 0.0)) return bad(field, value, "must be finite and >= 0");
  }
  if (!(std::isfinite(inflation_radius_m) && inflation_radius_m > 0.0)) {
    return bad("inflation_radius_m", inflation_radius_m, "must be > 0 m");
  }
  if (!(std::isfinite(forward_point_distance_m) && forward_point_distance_m >= 0.0)) {
    return bad("forward_point_distance_m", forward_point_distance_m, "must be >= 0 m");
  }
  if (!(std::isfinite(safety_margin_m) && safety_margin_m >= 0.0))
    return bad("safety_margin_m", safety_margin_m, "must be >= 0 m");
  if (!(std::isfinite(stop_time_buffer_s) && stop_time_buffer_s >= 0.0)) {
    return bad("stop_time_buffer_s", stop_time_buffer_s, "must be >= 0 s");
  }
  if (!(std::isfinite(goal_tolerance_m) && goal_tolerance_m >= 0.0))
    return bad("goal_tolerance_m", goal_tolerance_m, "must be >= 0 m");
  if (!(std::isfinite(braking_fraction) && braking_fraction > 0.0 && braking_fraction <= 1.0)) {
    return bad("braking_fraction", braking_fraction, "must be in (0, 1]");
  }
  if (!(std::isfinite(grid_resolution_m) && grid_resolution_m >= 0.01 && grid_resolution_m <= 1.0)) {
    return bad("grid_resolution_m", grid_resolution_m, "must be in [0.01, 1] m");
  }
  if (!(std::isfinite(grid_margin_m) && grid_margin_m >= 0.0 && grid_margin_m <= 20.0)) {
    return bad("grid_margin_m", grid_margin_m, "must be in [0, 20] m");
  }
  if (!(std::isfinite(static_speed_mps) && static_speed_mps >= 0.0)) {
    return bad("static_speed_mps", static_speed_mps, "must be >= 0 m/s");
  }
  return {};
}

DwaPlanner::DwaPlanner(const DwaConfig& config) : config_(config) {
  const std::string error = config_.validate();
  if (!error.empty()) throw PlannerError(error);
}

DwaTrajectory DwaPlanner::simulate(const Observation& obs, const RobotLimits& limits, const Twist2& velocity,
                                   const std::vector<size_t>& nearby, double v_ref, const DwaNavigationGrid& grid,
                                   double clearance_floor) const {
  const DwaConfig& c = config_;
  DwaTrajectory t;
  t.velocity = velocity;
  double fastest = 0.0;
  if (c.predict_obstacles) {
    for (size_t i : nearby) fastest = std::max(fastest, obstacleSpeed(obs.obstacles[i]));
  }
  const double T = c.sim_time_s;
  const double by_distance = (std::abs(velocity.v) + fastest) * T / c.sim_granularity_m;
  const double by_angle = std::abs(velocity.w) * T / c.angular_sim_granularity_rad;
  const int n =
      static_cast<int>(std::min<double>(kMaxPoints, std::max({1.0, std::ceil(by_distance), std::ceil(by_angle)})));

  // Follows a roll-out of the robot (its pose as a function of time) against the predicted obstacles and the
  // walls up to sim_time_s; stops at the first contact.
  struct Rollout {
    bool contact = false;
    double contact_time_s = kInf;
    double min_clearance = kInf;
    Pose2 end;
  };
  auto follow = [&](const std::function<Pose2(double)>& pose_at) {
    Rollout r;
    double previous = kInf;
    for (int k = 0; k <= n; ++k) {
      const double time = T * k / n;
      const Pose2 p = pose_at(time);
      double here = kInf;
      for (size_t i : nearby) {
        const MovingObstacle& o = obs.obstacles[i];
        Vec2 centre = o.center;
        if (c.predict_obstacles && !o.is_static) {
          centre =
              integrateUnicycle(Pose2{o.center.x(), o.center.y(), o.heading}, o.speed, o.turn_rate, time).position();
        }
        here = std::min(here, (p.position() - centre).norm() - o.radius - limits.radius);
      }
      for (const Segment& s : obs.segments) {
        if (s.a.allFinite() && s.b.allFinite())
          here = std::min(here, pointSegmentDistance(p.position(), s) - limits.radius);
      }
      r.min_clearance = std::min(r.min_clearance, here);
      r.end = p;
      // Moving away from something already too close is not a new contact (the robot may start inside the margin).
      if (k > 0 && here < c.safety_margin_m && here < previous) {
        r.contact = true;
        r.contact_time_s = time;
        break;
      }
      previous = here;
    }
    return r;
  };

  // The velocity is reached within the first control period and then held (the simulator's model): the
  // trajectory is the exact arc from the current pose.
  const Rollout held =
      follow([&](double time) { return integrateUnicycle(obs.robot_pose, velocity.v, velocity.w, time); });
  const Pose2 end = held.end;
  const double clearance = held.min_clearance;
  const double v = std::abs(velocity.v);
  t.contact = held.contact;
  t.contact_distance_m = held.contact ? v * held.contact_time_s : 0.0;
  t.contact_time_s = held.contact_time_s;
  t.min_clearance_m = clearance;
  if (!held.contact) {
    t.admissible = true;
  } else {
    // Fox's admissibility, for moving obstacles too: hold the velocity for stop_time_buffer_s, then brake at a_v
    // along the same arc to a stop and stay; the sample is kept when nothing touches the robot on the way.
    const double buffer = c.stop_time_buffer_s;
    const double curvature = v > 1e-9 ? velocity.w / velocity.v : 0.0;
    const double stop_after = v / limits.a_v;
    const Rollout braking = follow([&](double time) {
      double s_m;
      if (time <= buffer) {
        s_m = v * time;
      } else {
        const double tb = std::min(time - buffer, stop_after);
        s_m = v * buffer + v * tb - 0.5 * limits.a_v * tb * tb;
      }
      return v > 1e-9 ? integrateUnicycle(obs.robot_pose, s_m, curvature * s_m, 1.0) : obs.robot_pose;
    });
    t.admissible = !braking.contact;
  }

  // Cost terms (lower is better).
  const Vec2 heading_dir(std::cos(end.theta), std::sin(end.theta));
  const double d_end = (obs.goal - end.position()).norm();
  const Vec2 forward = end.position() + std::min(c.forward_point_distance_m, d_end) * heading_dir;
  const double goal_term = grid.distance(forward);
  const Vec2 descent = grid.descent(end.position());
  const double bearing =
      d_end < c.goal_tolerance_m ? 0.0 : std::abs(angleDiff(std::atan2(descent.y(), descent.x()), end.theta));
  const double clearance_level =
      t.contact ? 1.0 : std::clamp(1.0 - (clearance - c.safety_margin_m) / c.inflation_radius_m, 0.0, 1.0);
  const double clearance_term = std::max(0.0, clearance_level - clearance_floor);
  const double speed_term = std::abs(v_ref - v) / limits.v_max;
  t.cost = c.goal_distance_bias * goal_term + c.heading_bias * bearing / kPi + c.occdist_scale * clearance_term +
           c.speed_bias * speed_term;
  return t;
}

std::vector<DwaTrajectory> DwaPlanner::evaluate(const Observation& obs, const RobotLimits& limits) const {
  const DwaConfig& c = config_;
  const Twist2 current = limits.clipToFeasible(obs.robot_twist);
  const double d_goal = (obs.goal - obs.robot_pose.position()).norm();
  const double v_cap = std::sqrt(2.0 * c.braking_fraction * limits.a_v * std::max(0.0, d_goal - c.goal_tolerance_m));
  const double v_ref = std::min(limits.v_max, v_cap);

  // Only obstacles that can come within the inflation radius of any trajectory matter.
  std::vector<size_t> nearby;
  const double reach = limits.v_max * c.sim_time_s + limits.radius + c.inflation_radius_m;
  for (size_t i = 0; i < obs.obstacles.size(); ++i) {
    const MovingObstacle& o = obs.obstacles[i];
    if (!usable(o)) continue;
    const double moves = c.predict_obstacles ? obstacleSpeed(o) * c.sim_time_s : 0.0;
    if ((o.center - obs.robot_pose.position()).norm() - o.radius <= reach + moves) nearby.push_back(i);
  }

  const DwaNavigationGrid grid(obs, limits, c);
  // The clearance level the goal itself has against what does not move: the term only counts what is worse.
  double goal_clearance = kInf;
  for (const Segment& s : obs.segments) {
    if (s.a.allFinite() && s.b.allFinite())
      goal_clearance = std::min(goal_clearance, pointSegmentDistance(obs.goal, s) - limits.radius);
  }
  for (const MovingObstacle& o : obs.obstacles) {
    if (usable(o) && staticFor(o, c))
      goal_clearance = std::min(goal_clearance, (obs.goal - o.center).norm() - o.radius - limits.radius);
  }
  const double clearance_floor =
      std::clamp(1.0 - (goal_clearance - c.safety_margin_m) / c.inflation_radius_m, 0.0, 1.0);

  const double dv = limits.dv(), dw = limits.dw();
  const double v_lo = std::max(0.0, current.v - dv);
  const double v_hi = std::min(limits.v_max, current.v + dv);
  // Braking rule: nothing faster than the cap, unless the window holds nothing slower.
  const double v_top = std::max(v_lo, std::min(v_hi, v_cap));
  std::vector<DwaTrajectory> out;
  out.reserve(static_cast<size_t>(c.vx_samples * c.vth_samples));
  for (int i = 0; i < c.vx_samples; ++i) {
    const double v = c.vx_samples == 1 ? v_lo : v_lo + (v_top - v_lo) * i / (c.vx_samples - 1);
    // The rhombus narrows away from the current speed; the triangle bounds |w| at speed v.
    const double half = dw * std::max(0.0, 1.0 - std::abs(v - current.v) / dv);
    const double w_limit = limits.wLimitAt(v);
    const double w_lo = std::max(current.w - half, -w_limit);
    const double w_hi = std::min(current.w + half, w_limit);
    if (w_lo > w_hi + 1e-12) continue;
    for (int j = 0; j < c.vth_samples; ++j) {
      const double w =
          c.vth_samples == 1 ? std::clamp(current.w, w_lo, w_hi) : w_lo + (w_hi - w_lo) * j / (c.vth_samples - 1);
      const Twist2 sample{v, w};
      if (!limits.feasible(sample, 1e-9) || !makeDynamicWindow(current, limits).containsRhombus(sample, 1e-9)) continue;
      out.push_back(simulate(obs, limits, sample, nearby, v_ref, grid, clearance_floor));
    }
  }
  return out;
}

PlannerDecision DwaPlanner::decide(const PlannerInput& input) {
  if (input.observation == nullptr) throw PlannerError("dwa: the observation is missing");
  const Observation& obs = *input.observation;
  if (!obs.robot_pose.isFinite() || !std::isfinite(obs.robot_twist.v) || !std::isfinite(obs.robot_twist.w) ||
      !obs.goal.allFinite()) {
    throw PlannerError("dwa: the robot pose, twist or goal is not finite");
  }
  const RobotLimits& limits = input.limits;
  PlannerDecision d;
  if ((obs.goal - obs.robot_pose.position()).norm() < config_.goal_tolerance_m) {
    d.command = decelerationCommand(obs.robot_twist, limits);
    d.note = "stop_on_goal";
    return d;
  }
  const std::vector<DwaTrajectory> candidates = evaluate(obs, limits);
  const DwaTrajectory* best = nullptr;
  for (const DwaTrajectory& t : candidates) {
    if (t.admissible && (best == nullptr || t.cost < best->cost)) best = &t;
  }
  if (best == nullptr) {
    // Every sample runs into something the robot cannot brake for (a moving obstacle coming at it): put the
    // contact off as long as possible, which leaves the obstacle the most time to pass.
    for (const DwaTrajectory& t : candidates) {
      if (best == nullptr || t.contact_time_s > best->contact_time_s + 1e-9 ||
          (std::abs(t.contact_time_s - best->contact_time_s) <= 1e-9 && t.cost < best->cost)) {
        best = &t;
      }
    }
    d.command = best != nullptr ? best->velocity : decelerationCommand(obs.robot_twist, limits);
    d.note = "no_admissible_velocity";
    return d;
  }
  d.command = best->velocity;
  d.note = best->contact ? "dwa_braking_distance" : "dwa";
  return d;
}

std::unique_ptr<Planner> makeDwaPlanner() { return std::make_unique<DwaPlanner>(); }

}  // namespace dqn_dovs
