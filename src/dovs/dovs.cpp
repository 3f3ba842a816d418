#include "dqn_dovs/dovs/dovs.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "dqn_dovs/common/named_fields.h"

namespace dqn_dovs {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
// Deepest trajectory subdivision; bounds the precomputed tree to 2^13 - 1 nodes per trajectory.
constexpr int kMaxDepth = 12;
// Windows kept per (piece, obstacle); later revolutions of a fast-turning obstacle are folded into the last one.
constexpr int kMaxWindows = 8;
// How far inside its inflation an obstacle must be before it counts as touching the robot (see docs/dovs.md).
constexpr double kContactShrink_m = 1e-3;
// Obstacles whose arc strays less than this from a straight line over the horizon are modelled as lines, m.
constexpr double kStraightSlack_m = 0.005;
// Sub-pieces per leaf when locating the first contact with a static obstacle.
constexpr int kStaticRefine = 8;
// Growing prediction on an arc: the horizon is cut into time slices over which the radius grows at most this
// much (each slice uses its largest radius), at most kMaxGrowthSlices of them, m.
constexpr double kGrowthPerSlice_m = 0.05;
constexpr int kMaxGrowthSlices = 8;

std::string fieldError(const char* name, double value, const char* why) {
  std::ostringstream os;
  os << "DOVS parameter '" << name << "' = " << value << ": " << why;
  return os.str();
}

bool finite2(const Vec2& p) { return std::isfinite(p.x()) && std::isfinite(p.y()); }

[[noreturn]] void throwInput(const char* kind, size_t index, const char* field, double value, const char* why) {
  std::ostringstream os;
  os << "DOVS input: " << kind << " " << index << " field '" << field << "' = " << value << ": " << why;
  throw DovsError(os.str());
}

}  // namespace

std::string DovsConfig::validate() const {
  if (!(std::isfinite(obstacle_range_m) && obstacle_range_m > 0.0))
    return fieldError("obstacle_range_m", obstacle_range_m, "must be a finite positive distance (m)");
  if (!(std::isfinite(safety_factor) && safety_factor >= 1.0 && safety_factor <= 3.0))
    return fieldError("safety_factor", safety_factor, "must be in [1, 3] (an inflation, never a shrink)");
  if (num_trajectories < 5 || num_trajectories > 1001 || num_trajectories % 2 == 0)
    return fieldError("num_trajectories", num_trajectories,
                      "must be odd (so that w = 0 is a trajectory) and in [5, 1001]");
  if (!(std::isfinite(time_horizon_s) && time_horizon_s > 0.0 && time_horizon_s <= 30.0))
    return fieldError("time_horizon_s", time_horizon_s, "must be in (0, 30] s");
  if (!(std::isfinite(max_leaf_length_m) && max_leaf_length_m >= 0.005 && max_leaf_length_m <= 1.0))
    return fieldError("max_leaf_length_m", max_leaf_length_m, "must be in [0.005, 1] m");
  if (!(std::isfinite(static_speed_threshold_mps) && static_speed_threshold_mps >= 0.0 &&
        static_speed_threshold_mps <= 0.5))
    return fieldError("static_speed_threshold_mps", static_speed_threshold_mps, "must be in [0, 0.5] m/s");
  if (!(std::isfinite(static_reaction_time_s) && static_reaction_time_s >= 0.0 && static_reaction_time_s <= 5.0))
    return fieldError("static_reaction_time_s", static_reaction_time_s, "must be in [0, 5] s");
  if (!(std::isfinite(static_margin_m) && static_margin_m >= 0.0 && static_margin_m <= 2.0))
    return fieldError("static_margin_m", static_margin_m, "must be in [0, 2] m");
  if (grid_size < 2 || grid_size > 256) return fieldError("grid_size", grid_size, "must be in [2, 256] cells");
  if (!(std::isfinite(prediction_growth_mps) && prediction_growth_mps >= 0.0 && prediction_growth_mps <= 2.0))
    return fieldError("prediction_growth_mps", prediction_growth_mps, "must be in [0, 2] m/s");
  if (!(std::isfinite(grid_contact_horizon_s) &&
        (grid_contact_horizon_s == 0.0 || (grid_contact_horizon_s >= 0.5 && grid_contact_horizon_s <= 30.0))))
    return fieldError("grid_contact_horizon_s", grid_contact_horizon_s,
                      "must be 0 (the +1 / -1 grid) or in [0.5, 30] s (the graded grid)");
  if (grid_channels < 1 || grid_channels > kMaxStateGridChannels)
    return fieldError("grid_channels", grid_channels, kGridChannelsRule);
  if (previous_action != 0 && previous_action != 1)
    return fieldError("previous_action", previous_action, "must be 0 (off) or 1 (the previous choice in the state)");
  if (wall_rays < 0 || wall_rays > 32) return fieldError("wall_rays", wall_rays, "must be in [0, 32] (0: none)");
  if (person_tokens < 0 || person_tokens > 16)
    return fieldError("person_tokens", person_tokens, "must be in [0, 16] (0: none)");
  if (route_points < 0 || route_points > 16)
    return fieldError("route_points", route_points, "must be in [0, 16] (0: none)");
  return {};
}

namespace {

using DovsField = NamedField<DovsConfig>;

const std::vector<DovsField>& dovsFields() {
  static const std::vector<DovsField> fields = {
      {"obstacle_range", &DovsConfig::obstacle_range_m},
      {"safety_factor", &DovsConfig::safety_factor},
      {"num_trajectories", nullptr, &DovsConfig::num_trajectories},
      {"time_horizon", &DovsConfig::time_horizon_s},
      {"static_reaction_time", &DovsConfig::static_reaction_time_s},
      {"static_margin", &DovsConfig::static_margin_m},
      {"prediction_growth", &DovsConfig::prediction_growth_mps},
      {"grid_contact_horizon", &DovsConfig::grid_contact_horizon_s},
      {"grid_channels", nullptr, &DovsConfig::grid_channels},
      {"previous_action", nullptr, &DovsConfig::previous_action},
      {"wall_rays", nullptr, &DovsConfig::wall_rays},
      {"person_tokens", nullptr, &DovsConfig::person_tokens},
      {"route_points", nullptr, &DovsConfig::route_points},
  };
  return fields;
}

}  // namespace

std::string setDovsParameter(DovsConfig& config, const std::string& name, const std::string& value) {
  std::string known;
  for (const std::string& n : dovsParameterNames()) known += (known.empty() ? "" : ", ") + n;
  return setNamedField(dovsFields(), config, "DOVS parameter", name, value, "(known: " + known + ")");
}

const std::vector<std::string>& dovsParameterNames() {
  static const std::vector<std::string> names = namedFieldNames(dovsFields());
  return names;
}

std::string dovsParameter(const DovsConfig& config, const std::string& name) {
  if (const std::optional<std::string> text = namedFieldText(dovsFields(), config, name)) return *text;
  throw DovsError("unknown DOVS parameter '" + name + "'");
}

// ---------------------------------------------------------------------------------------------------------------
// VelocitySpace queries
// ---------------------------------------------------------------------------------------------------------------

IntervalRange VelocitySpace::unsafeIntervals(int i) const {
  const size_t r = static_cast<size_t>(i);
  if (i < 0 || r + 1 >= interval_begin_.size())
    throw DovsError("VelocitySpace::unsafeIntervals: trajectory index out of range");
  return {intervals_.data() + interval_begin_[r], intervals_.data() + interval_begin_[r + 1]};
}

bool VelocitySpace::rayUnsafeAt(size_t ray, double radius_normalised) const {
  const Trajectory& tr = trajectories_[ray];
  if (tr.pure_rotation) return stationary_unsafe_;
  // The neighbour of a feasible velocity may end earlier at the triangle edge: compare against its last point.
  const double v = std::min(radius_normalised * limits_.v_max * std::sin(tr.angle_rad), tr.v_top_mps);
  for (size_t k = interval_begin_[ray]; k < interval_begin_[ray + 1]; ++k) {
    if (v < intervals_[k].lo_mps) return false;  // sorted
    if (v <= intervals_[k].hi_mps) return true;
  }
  return false;
}

namespace {

constexpr double kOnRay = 1e-9;

// Neighbouring trajectories of a velocity: lower index, distance from the origin in the normalised plane, and
// which neighbours count (0 both, 1 lower only, 2 upper only, -1 infeasible, -2 at v = 0).
struct RayPosition {
  size_t ray = 0;
  double radius = 0.0;
  int which = -1;
};

RayPosition locate(const Twist2& t, const RobotLimits& limits, size_t num_rays) {
  RayPosition p;
  if (!limits.feasible(t, 1e-9) || num_rays < 2) return p;
  const double a = t.v / limits.v_max, b = t.w / limits.w_max;
  if (a <= 0.0) {
    p.which = -2;
    return p;
  }
  p.radius = std::hypot(a, b);
  const double x = std::atan2(a, -b) / (kPi / static_cast<double>(num_rays - 1));  // angle in (0, pi)
  size_t i = static_cast<size_t>(std::floor(x));
  if (i > num_rays - 2) i = num_rays - 2;
  const double frac = x - static_cast<double>(i);
  p.ray = i;
  p.which = frac <= kOnRay ? 1 : frac >= 1.0 - kOnRay ? 2 : 0;
  return p;
}

}  // namespace

bool VelocitySpace::freeBetween(size_t ray, double radius, int which) const {
  switch (which) {
    case -2:
      return !stationary_unsafe_;
    case 0:
      return !rayUnsafeAt(ray, radius) && !rayUnsafeAt(ray + 1, radius);
    case 1:
      return !rayUnsafeAt(ray, radius);
    case 2:
      return !rayUnsafeAt(ray + 1, radius);
    default:
      return false;
  }
}

bool VelocitySpace::isFree(const Twist2& t) const {
  const RayPosition p = locate(t, limits_, trajectories_.size());
  return freeBetween(p.ray, p.radius, p.which);
}

float VelocitySpace::gridCell(int row, int col) const {
  if (row < 0 || col < 0 || row >= grid_size_ || col >= grid_size_)
    throw DovsError("VelocitySpace::gridCell: cell out of range");
  return grid_[static_cast<size_t>(row * grid_size_ + col)];
}

Twist2 VelocitySpace::gridCellVelocity(int row, int col) const {
  const double n = static_cast<double>(grid_size_);
  return {limits_.v_max * (n - static_cast<double>(row) - 0.5) / n,
          limits_.w_max * (2.0 * (static_cast<double>(col) + 0.5) / n - 1.0)};
}

// ---------------------------------------------------------------------------------------------------------------
// Builder
// ---------------------------------------------------------------------------------------------------------------

DovsBuilder::DovsBuilder(const RobotLimits& limits, const DovsConfig& config) : limits_(limits), config_(config) {
  if (const std::string e = limits_.validate(); !e.empty()) throw DovsError("DovsBuilder: " + e);
  if (const std::string e = config_.validate(); !e.empty()) throw DovsError("DovsBuilder: " + e);
  precomputeRays();
}

double DovsBuilder::enlargedRadius(double obstacle_radius_m) const {
  return (obstacle_radius_m + limits_.radius) * config_.safety_factor;
}

double DovsBuilder::wallHalfWidth_m() const { return limits_.radius * config_.safety_factor; }

double modelDiscRadius(const RobotLimits& limits, const DovsConfig& config, double obstacle_radius_m,
                       double distance_m) {
  const double enlarged = (obstacle_radius_m + limits.radius) * config.safety_factor;
  const double touching = obstacle_radius_m + limits.radius;
  // Inside the inflation but not touching: shrink to just inside the current distance so that moving away stays
  // possible; touching: keep the inflation (everything that moves toward it is unsafe).
  if (distance_m < enlarged && distance_m > touching) return std::max(touching, distance_m - kContactShrink_m);
  return enlarged;
}

double modelWallHalfWidth(const RobotLimits& limits, const DovsConfig& config, double distance_m) {
  const double band = limits.radius * config.safety_factor;
  if (distance_m < band && distance_m > limits.radius) return std::max(limits.radius, distance_m - kContactShrink_m);
  return band;
}

bool modelAsStatic(const DovsConfig& config, const MovingObstacle& o) {
  // A floor on the threshold keeps 1 / speed^2 finite in the line model.
  return o.is_static || std::abs(o.speed) <= std::max(config.static_speed_threshold_mps, 1e-6);
}

double DovsBuilder::brakingSpeedLimit(double contact_distance_m) const {
  const double room = contact_distance_m - config_.static_margin_m;
  if (!(room > 0.0)) return 0.0;
  const double tau = config_.static_reaction_time_s, a = limits_.a_v;
  // Positive root of v^2 / (2 a) + v tau = room.
  return a * (-tau + std::sqrt(tau * tau + 2.0 * room / a));
}

Vec2 DovsBuilder::pathPoint(double curvature, double s) const {
  if (std::abs(curvature) < 1e-12) return {s, 0.0};
  const double half = 0.5 * curvature * s;
  const double sh = std::sin(half);
  // (1 - cos(ks)) / k written as 2 sin^2(ks / 2) / k keeps precision at small curvature.
  return {std::sin(curvature * s) / curvature, 2.0 * sh * sh / curvature};
}

void DovsBuilder::precomputeRays() {
  const size_t n = static_cast<size_t>(config_.num_trajectories);
  trajectories_.assign(n, Trajectory{});
  ray_geometry_.assign(n, RayGeometry{});
  nodes_.clear();
  const size_t middle = (n - 1) / 2;
  for (size_t i = 0; i < n; ++i) {
    Trajectory& tr = trajectories_[i];
    tr.angle_rad = kPi * static_cast<double>(i) / static_cast<double>(n - 1);
    double b = -std::cos(tr.angle_rad), a = std::sin(tr.angle_rad);
    if (i == middle) b = 0.0;
    if (i == 0 || i == n - 1) a = 0.0;
    const double reach = 1.0 / (a + std::abs(b));  // normalised distance to the triangle edge a + |b| = 1
    tr.v_top_mps = reach * a * limits_.v_max;
    tr.w_top_rps = reach * b * limits_.w_max;
    tr.pure_rotation = (a == 0.0);
    tr.curvature_1pm = tr.pure_rotation ? 0.0 : tr.w_top_rps / tr.v_top_mps;
    RayGeometry& g = ray_geometry_[i];
    g.node_begin = nodes_.size();
    if (tr.pure_rotation) {
      g.depth = -1;
      continue;
    }
    const double v = tr.v_top_mps;
    const double brake = v * v / (2.0 * limits_.a_v) + v * config_.static_reaction_time_s + config_.static_margin_m;
    g.s_max = std::max(v * config_.time_horizon_s, brake);
    int depth = 0;
    while (depth < kMaxDepth && g.s_max / std::ldexp(1.0, depth) > config_.max_leaf_length_m) ++depth;
    g.depth = depth;
    for (int level = 0; level <= depth; ++level) {
      const size_t count = size_t{1} << level;
      const double len = g.s_max / static_cast<double>(count);
      for (size_t j = 0; j < count; ++j) {
        Node node;
        node.s_a = len * static_cast<double>(j);
        node.s_b = node.s_a + len;
        const Vec2 m = pathPoint(tr.curvature_1pm, 0.5 * (node.s_a + node.s_b));
        node.mx = m.x();
        node.my = m.y();
        node.h = 0.5 * len;  // arc distance bounds chord distance
        nodes_.push_back(node);
      }
    }
  }
  // Grid cell centres (same formula as VelocitySpace::gridCellVelocity).
  const int g = config_.grid_size;
  grid_lookup_.clear();
  for (int r = 0; r < g; ++r) {
    for (int c = 0; c < g; ++c) {
      const Twist2 t{limits_.v_max * (g - r - 0.5) / g, limits_.w_max * (2.0 * (c + 0.5) / g - 1.0)};
      const RayPosition p = locate(t, limits_, n);
      grid_lookup_.push_back({p.ray, p.radius, static_cast<signed char>(p.which)});
    }
  }
}

void DovsBuilder::validateObservation(const Observation& obs) const {
  if (!obs.robot_pose.isFinite()) {
    const double bad = !std::isfinite(obs.robot_pose.x)   ? obs.robot_pose.x
                       : !std::isfinite(obs.robot_pose.y) ? obs.robot_pose.y
                                                          : obs.robot_pose.theta;
    throwInput("robot pose", 0, "x/y/theta", bad, "must be finite");
  }
  for (size_t i = 0; i < obs.obstacles.size(); ++i) {
    const MovingObstacle& o = obs.obstacles[i];
    if (!std::isfinite(o.center.x())) throwInput("obstacle", i, "center.x", o.center.x(), "must be finite");
    if (!std::isfinite(o.center.y())) throwInput("obstacle", i, "center.y", o.center.y(), "must be finite");
    if (!(std::isfinite(o.radius) && o.radius > 0.0))
      throwInput("obstacle", i, "radius", o.radius, "must be finite and positive");
    if (!std::isfinite(o.heading)) throwInput("obstacle", i, "heading", o.heading, "must be finite");
    if (!std::isfinite(o.speed)) throwInput("obstacle", i, "speed", o.speed, "must be finite");
    if (!std::isfinite(o.turn_rate)) throwInput("obstacle", i, "turn_rate", o.turn_rate, "must be finite");
  }
  for (size_t i = 0; i < obs.segments.size(); ++i) {
    const Segment& s = obs.segments[i];
    if (!finite2(s.a)) throwInput("segment", i, "a", std::isfinite(s.a.x()) ? s.a.y() : s.a.x(), "must be finite");
    if (!finite2(s.b)) throwInput("segment", i, "b", std::isfinite(s.b.x()) ? s.b.y() : s.b.x(), "must be finite");
  }
}

int DovsBuilder::windows(const Motion& mo, const Vec2& m, double q, Window* out, int max_out) const {
  const double horizon = config_.time_horizon_s;
  const double growth = config_.prediction_growth_mps;
  switch (mo.kind) {
    case Motion::Kind::kStatic: {
      if ((m - mo.p0).squaredNorm() >= q * q) return 0;
      out[0] = {0.0, horizon};
      return 1;
    }
    case Motion::Kind::kLine: {
      if (growth > 0.0) return growingLineWindow(mo, m, q, out);
      // |p0 + vel t - m|^2 < q^2, a quadratic in t.
      const Vec2 d = m - mo.p0;
      const double b = mo.vel.dot(d);
      const double c = d.squaredNorm() - q * q;
      const double disc = b * b - mo.vel_sq * c;
      if (disc <= 0.0) return 0;
      const double sq = std::sqrt(disc);
      const double t1 = std::max((b - sq) / mo.vel_sq, 0.0);
      const double t2 = std::min((b + sq) / mo.vel_sq, horizon);
      if (t1 > t2) return 0;
      out[0] = {t1, t2};
      return 1;
    }
    case Motion::Kind::kArc: {
      if (growth <= 0.0) return arcWindows(mo, m, q, 0.0, horizon, out, 0, max_out);
      // The radius grows with t: slices of the horizon, each with the radius at its end (a cover, never less).
      const double q_end = q + growth * horizon;
      if ((m - mo.bound_center).squaredNorm() >= (mo.bound_radius + q_end) * (mo.bound_radius + q_end)) return 0;
      const int slices =
          std::clamp(static_cast<int>(std::ceil(growth * horizon / kGrowthPerSlice_m)), 1, kMaxGrowthSlices);
      int count = 0;
      for (int k = 0; k < slices; ++k) {
        const double t_from = horizon * k / slices;
        const double t_to = horizon * (k + 1) / slices;
        count = arcWindows(mo, m, q + growth * t_to, t_from, t_to, out, count, max_out);
      }
      return count;
    }
  }
  return 0;
}

int DovsBuilder::growingLineWindow(const Motion& mo, const Vec2& m, double q, Window* out) const {
  // |p0 + vel t - m| < q + g t. For t >= 0 both sides are non-negative, so it is the quadratic
  // f(t) = (|vel|^2 - g^2) t^2 - 2 (vel.d + q g) t + (|d|^2 - q^2) < 0, and since |p0 + vel t - m| - g t is
  // convex in t its solutions in [0, horizon] form one interval: the hull of f's pieces there.
  const double horizon = config_.time_horizon_s;
  const double g = config_.prediction_growth_mps;
  const Vec2 d = m - mo.p0;
  const double a = mo.vel_sq - g * g;
  const double bh = mo.vel.dot(d) + q * g;
  const double c = d.squaredNorm() - q * q;
  double t1 = 0.0, t2 = 0.0;
  if (std::abs(a) < 1e-12) {
    // -2 bh t + c < 0
    if (bh > 0.0) {
      t1 = std::max(0.5 * c / bh, 0.0);
      t2 = horizon;
    } else if (c < 0.0) {
      t1 = 0.0;
      t2 = horizon;
    } else {
      return 0;
    }
  } else {
    const double disc = bh * bh - a * c;
    if (a > 0.0) {
      if (disc <= 0.0) return 0;
      const double sq = std::sqrt(disc);
      t1 = std::max((bh - sq) / a, 0.0);
      t2 = std::min((bh + sq) / a, horizon);
    } else if (disc <= 0.0) {
      t1 = 0.0;  // a < 0 and no real root: f < 0 everywhere
      t2 = horizon;
    } else {
      // a < 0: f < 0 outside [r_small, r_big].
      const double sq = std::sqrt(disc);
      const double r_small = (bh + sq) / a;
      const double r_big = (bh - sq) / a;
      t1 = r_small > 0.0 ? 0.0 : std::max(r_big, 0.0);
      t2 = r_big < horizon ? horizon : std::min(r_small, horizon);
    }
  }
  if (t1 > t2) return 0;
  out[0] = {t1, t2};
  return 1;
}

int DovsBuilder::arcWindows(const Motion& mo, const Vec2& m, double q, double t_from, double t_to, Window* out,
                            int count, int max_out) const {
  const double horizon = config_.time_horizon_s;
  auto add = [&](double t1, double t2) {
    t1 = std::max(t1, t_from);
    t2 = std::min(t2, t_to);
    if (t1 > t2) return true;
    if (count > 0 && t1 <= out[count - 1].t2 + 1e-12) {  // continues the previous window (the previous slice)
      out[count - 1].t2 = std::max(out[count - 1].t2, t2);
      return true;
    }
    if (count == max_out) {
      out[count - 1].t2 = t_to >= horizon ? horizon : std::max(out[count - 1].t2, t_to);  // fold the rest in
      return false;
    }
    out[count++] = {t1, t2};
    return true;
  };
  if ((m - mo.bound_center).squaredNorm() >= (mo.bound_radius + q) * (mo.bound_radius + q)) return count;
  const Vec2 d = m - mo.arc_center;
  const double dist = d.norm();
  const double rho = mo.arc_radius;
  if (std::abs(dist - rho) >= q) return count;  // m is outside the annulus the centre can come within q of
  double alpha = kPi;
  double delta0 = 0.0;
  if (dist > 1e-12) {
    const double cstar = (rho * rho + dist * dist - q * q) / (2.0 * rho * dist);
    alpha = cstar <= -1.0 ? kPi : std::acos(std::min(cstar, 1.0));
    delta0 = normalizeAngle(mo.beta0 - std::atan2(d.y(), d.x()));
  }
  if (alpha >= kPi) {
    add(0.0, horizon);
    return count;
  }
  double w = mo.turn_rate;
  if (w < 0.0) {
    w = -w;
    delta0 = -delta0;
  }
  // The centre's angle offset delta0 + w t lies in (2 pi n - alpha, 2 pi n + alpha) during window n.
  for (double n = std::ceil((delta0 - alpha) / kTwoPi);; n += 1.0) {
    const double start = (kTwoPi * n - alpha - delta0) / w;
    if (start > t_to) break;
    if (!add(start, (kTwoPi * n + alpha - delta0) / w)) break;
  }
  return count;
}

void DovsBuilder::addDynamicIntervals(size_t ray, const Motion& mo) {
  const Trajectory& tr = trajectories_[ray];
  const RayGeometry& g = ray_geometry_[ray];
  const double v_top = tr.v_top_mps;
  const Node* nodes = nodes_.data() + g.node_begin;
  // Depth-first, left child first, so leaves come in increasing arc length and the intervals of one crossing
  // arrive in a run that merges on the fly.
  struct Item {
    size_t index;
    int level;
  };
  Item stack[2 * kMaxDepth + 4];
  int top = 0;
  stack[top++] = {0, 0};
  Window win[kMaxWindows];
  bool have_run = false;
  SpeedInterval run{};
  while (top > 0) {
    const Item it = stack[--top];
    const Node& nd = nodes[it.index];
    const int nw = windows(mo, Vec2(nd.mx, nd.my), mo.radius + mo.slack + nd.h, win, kMaxWindows);
    // The robot cannot be on this piece before s_a / v_top.
    const double t_earliest = nd.s_a / v_top;
    bool any = false;
    for (int k = 0; k < nw; ++k) any = any || win[k].t2 >= t_earliest;
    if (!any) continue;
    if (it.level < g.depth) {
      const size_t first_child = 2 * it.index + 1;
      stack[top++] = {first_child + 1, it.level + 1};
      stack[top++] = {first_child, it.level + 1};
      continue;
    }
    for (int k = 0; k < nw; ++k) {
      const double t1 = win[k].t1, t2 = win[k].t2;
      if (t2 < t_earliest) continue;
      // Robot on [s_a, s_b] during [s_a / v, s_b / v]; it meets the window [t1, t2] iff s_a / t2 <= v <= s_b / t1.
      double lo = t2 > 0.0 ? nd.s_a / t2 : (nd.s_a > 0.0 ? kInf : 0.0);
      double hi = t1 > 0.0 ? nd.s_b / t1 : kInf;
      lo = std::max(lo, 0.0);
      hi = std::min(hi, v_top);
      if (lo > hi) continue;
      if (have_run && lo <= run.hi_mps && hi >= run.lo_mps) {
        run.lo_mps = std::min(run.lo_mps, lo);
        run.hi_mps = std::max(run.hi_mps, hi);
      } else {
        if (have_run) ray_scratch_.push_back(run);
        run = {lo, hi};
        have_run = true;
      }
    }
  }
  if (have_run) ray_scratch_.push_back(run);
}

void DovsBuilder::addStaticInterval(size_t ray, const Motion* disc, const Wall* wall) {
  const Trajectory& tr = trajectories_[ray];
  const RayGeometry& g = ray_geometry_[ray];
  const double v_top = tr.v_top_mps;
  const double s_limit =
      v_top * v_top / (2.0 * limits_.a_v) + v_top * config_.static_reaction_time_s + config_.static_margin_m;
  const double radius = disc ? disc->radius : wall->half_width;
  auto distance = [&](const Vec2& m) { return disc ? (m - disc->p0).norm() : pointSegmentDistance(m, wall->segment); };
  const Node* nodes = nodes_.data() + g.node_begin;
  struct Item {
    size_t index;
    int level;
  };
  Item stack[2 * kMaxDepth + 4];
  int top = 0;
  stack[top++] = {0, 0};
  double contact = kInf;
  while (top > 0 && contact == kInf) {
    const Item it = stack[--top];
    const Node& nd = nodes[it.index];
    if (nd.s_a > s_limit) continue;
    if (distance(Vec2(nd.mx, nd.my)) >= radius + nd.h) continue;
    if (it.level < g.depth) {
      const size_t first_child = 2 * it.index + 1;
      stack[top++] = {first_child + 1, it.level + 1};
      stack[top++] = {first_child, it.level + 1};
      continue;
    }
    // Locate the contact inside the leaf more finely; a leaf whose sub-pieces all miss was a loose bound.
    const double len = (nd.s_b - nd.s_a) / kStaticRefine;
    for (int j = 0; j < kStaticRefine; ++j) {
      const double sa = nd.s_a + len * j;
      if (distance(pathPoint(tr.curvature_1pm, sa + 0.5 * len)) < radius + 0.5 * len) {
        contact = sa;
        break;
      }
    }
  }
  if (contact == kInf) return;
  const double v_limit = brakingSpeedLimit(contact);
  if (v_limit <= v_top) ray_scratch_.push_back({v_limit, v_top});
}

void DovsBuilder::build(const Observation& obs, VelocitySpace& out) {
  validateObservation(obs);
  out.limits_ = limits_;
  out.config_ = config_;
  out.trajectories_ = trajectories_;
  out.intervals_.clear();
  out.interval_begin_.clear();
  out.stationary_unsafe_ = false;
  out.closest_ = ClosestObstacle{};
  out.num_in_model_ = 0;

  const Pose2& pose = obs.robot_pose;
  const double range = config_.obstacle_range_m;
  const double horizon = config_.time_horizon_s;
  const double contact_radius_robot = limits_.radius;
  dynamic_.clear();
  static_discs_.clear();
  walls_.clear();

  for (size_t i = 0; i < obs.obstacles.size(); ++i) {
    const MovingObstacle& o = obs.obstacles[i];
    Motion mo;
    mo.p0 = pose.toLocal(o.center);
    const double d0 = mo.p0.norm();
    if (d0 > range) continue;
    const bool is_static = modelAsStatic(config_, o);
    const double heading = normalizeAngle(o.heading - pose.theta);

    const double clearance = d0 - o.radius - contact_radius_robot;
    if (!out.closest_.found || clearance < out.closest_.clearance_m) {
      ClosestObstacle& c = out.closest_;
      c.found = true;
      c.index = static_cast<int>(i);
      c.center_robot = mo.p0;
      c.clearance_m = clearance;
      c.bearing_rad = std::atan2(mo.p0.y(), mo.p0.x());
      c.speed_mps = is_static ? 0.0 : o.speed;
      c.relative_heading_rad = is_static ? 0.0 : heading;
    }

    // Inside the inflation but not touching: shrink to just inside the current distance so that moving away
    // stays possible; touching: keep the inflation (everything that moves toward it is unsafe).
    mo.radius = modelDiscRadius(limits_, config_, o.radius, d0);

    if (is_static) {
      mo.kind = Motion::Kind::kStatic;
      static_discs_.push_back(mo);
      continue;
    }
    const double w = o.turn_rate;
    const double v = o.speed;
    // Over the horizon an arc strays at most |v| T (|w| T) / 2 from its tangent line.
    const double straying = std::abs(v) * horizon * std::abs(w) * horizon * 0.5;
    if (straying <= kStraightSlack_m) {
      // A barely turning obstacle: a straight line inflated by the straying is cheaper and still covers it.
      mo.kind = Motion::Kind::kLine;
      mo.vel = v * Vec2(std::cos(heading), std::sin(heading));
      mo.vel_sq = mo.vel.squaredNorm();
      mo.slack = straying;
    } else {
      mo.kind = Motion::Kind::kArc;
      const double r = v / w;  // signed: centre to the left of the heading for r > 0
      mo.arc_center = mo.p0 + r * Vec2(-std::sin(heading), std::cos(heading));
      mo.arc_radius = std::abs(r);
      const Vec2 rel = mo.p0 - mo.arc_center;
      mo.beta0 = std::atan2(rel.y(), rel.x());
      mo.turn_rate = w;
      // An arc of angle <= pi lies in the disc whose diameter is its chord; a longer one in its full circle.
      const double sweep = std::abs(w) * horizon;
      if (sweep <= kPi) {
        const Vec2 end = integrateUnicycle(Pose2{mo.p0.x(), mo.p0.y(), heading}, v, w, horizon).position();
        mo.bound_center = 0.5 * (mo.p0 + end);
        mo.bound_radius = 0.5 * (end - mo.p0).norm() + 1e-9;
      } else {
        mo.bound_center = mo.arc_center;
        mo.bound_radius = mo.arc_radius + 1e-9;
      }
    }
    dynamic_.push_back(mo);
  }
  for (const Segment& s_world : obs.segments) {
    Wall wall{{pose.toLocal(s_world.a), pose.toLocal(s_world.b)}, 0.0};
    const double d0 = pointSegmentDistance(Vec2::Zero(), wall.segment);
    if (d0 > range) continue;
    wall.half_width = modelWallHalfWidth(limits_, config_, d0);  // the same in-contact rule as for discs
    walls_.push_back(wall);
  }
  out.num_in_model_ = static_cast<int>(dynamic_.size() + static_discs_.size() + walls_.size());

  Window win[kMaxWindows];
  for (const Motion& mo : dynamic_) {
    if (windows(mo, Vec2::Zero(), mo.radius + mo.slack, win, kMaxWindows) > 0) out.stationary_unsafe_ = true;
  }

  const size_t n = trajectories_.size();
  out.interval_begin_.reserve(n + 1);
  for (size_t ray = 0; ray < n; ++ray) {
    out.interval_begin_.push_back(out.intervals_.size());
    if (trajectories_[ray].pure_rotation) continue;
    ray_scratch_.clear();
    for (const Motion& mo : dynamic_) addDynamicIntervals(ray, mo);
    for (const Motion& mo : static_discs_) addStaticInterval(ray, &mo, nullptr);
    for (const Wall& w : walls_) addStaticInterval(ray, nullptr, &w);
    // Insertion sort: a handful of intervals per trajectory.
    for (size_t a = 1; a < ray_scratch_.size(); ++a) {
      const SpeedInterval key = ray_scratch_[a];
      size_t b = a;
      while (b > 0 && ray_scratch_[b - 1].lo_mps > key.lo_mps) {
        ray_scratch_[b] = ray_scratch_[b - 1];
        --b;
      }
      ray_scratch_[b] = key;
    }
    for (const SpeedInterval& iv : ray_scratch_) {
      if (out.intervals_.size() > out.interval_begin_.back() && iv.lo_mps <= out.intervals_.back().hi_mps) {
        out.intervals_.back().hi_mps = std::max(out.intervals_.back().hi_mps, iv.hi_mps);
      } else {
        out.intervals_.push_back(iv);
      }
    }
  }
  out.interval_begin_.push_back(out.intervals_.size());

  out.grid_size_ = config_.grid_size;
  out.grid_.resize(static_cast<size_t>(config_.grid_size * config_.grid_size));
  for (size_t i = 0; i < grid_lookup_.size(); ++i) {
    const GridLookup& gl = grid_lookup_[i];
    out.grid_[i] = out.freeBetween(gl.ray, gl.radius, gl.which) ? 1.0f : -1.0f;
  }
}

VelocitySpace DovsBuilder::build(const Observation& obs) {
  VelocitySpace out;
  build(obs, out);
  return out;
}

VelocitySpace buildDovs(const Observation& obs, const RobotLimits& limits, const DovsConfig& config) {
  DovsBuilder builder(limits, config);
  return builder.build(obs);
}

}  // namespace dqn_dovs
