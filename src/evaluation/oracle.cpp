#include "dqn_dovs/evaluation/oracle.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <queue>
#include <sstream>
#include <unordered_map>

#include "dqn_dovs/common/parse.h"
#include "dqn_dovs/common/robot_model.h"

namespace dqn_dovs {
namespace {

constexpr int kSubsteps = 4;  // collision checks per control period
// Among people who react to the robot: searches per decision, each against the people's motion around the best
// candidate of the one before (OraclePlanner::decide).
constexpr int kReactionSearches = 3;
constexpr float kInf = std::numeric_limits<float>::infinity();
// Half a cell's diagonal, in cells: how far a point of a cell may lie from its centre.
constexpr double kCellReach = 0.7072;
// Added to the cost of a sequence whose end has no way on (terminal_periods): more than any horizon's time and path
// to go, so every end with a way on ranks first.
constexpr double kUnsafeEndPenalty_s = 1.0e4;

}  // namespace

std::string OracleConfig::validate() const {
  std::ostringstream os;
  if (horizon_periods < 1 || horizon_periods > 100)
    os << "oracle horizon_periods " << horizon_periods << " not in [1, 100]";
  else if (terminal_periods < 0 || horizon_periods + terminal_periods > 100)
    os << "oracle terminal_periods " << terminal_periods << " must be >= 0 and, with horizon_periods, at most 100";
  else if (beam_width < 1)
    os << "oracle beam_width " << beam_width << " must be >= 1";
  else if (window_samples < 1 || window_samples > 10)
    os << "oracle window_samples " << window_samples << " not in [1, 10]";
  else if (!(grid_cell_m > 0.0 && std::isfinite(grid_cell_m)))
    os << "oracle grid_cell_m " << grid_cell_m << " must be > 0";
  else if (!(clearance_margin_m >= 0.0 && std::isfinite(clearance_margin_m)))
    os << "oracle clearance_margin_m " << clearance_margin_m << " must be >= 0";
  else if (true_future_periods < -1)
    os << "oracle true_future_periods " << true_future_periods << " must be >= 0, or -1 for the whole horizon";
  else if (!(prediction_growth_mps >= 0.0))
    os << "oracle prediction_growth_mps " << prediction_growth_mps << " must be >= 0";
  else if (!(acceleration_prediction_s >= 0.0))
    os << "oracle acceleration_prediction_s " << acceleration_prediction_s << " must be >= 0";
  else if (acceleration_prediction_s > 0.0 && true_future_periods != 0)
    os << "oracle acceleration_prediction_s needs true_future_periods = 0 (a prediction from now)";
  else if (acceleration_prediction_s > 0.0 && social_prediction)
    os << "oracle acceleration_prediction_s and social_prediction are two predictions of the people: choose one";
  else if (!learned_prediction.empty() &&
           (true_future_periods != 0 || social_prediction || acceleration_prediction_s > 0.0))
    os << "oracle learned_prediction needs true_future_periods = 0 and no other prediction of the people";
  else if (!(scan_period_s > 0.0 && std::isfinite(scan_period_s)))
    os << "oracle scan_period_s " << scan_period_s << " must be > 0";
  else if (!(goal_tolerance_m > 0.0) || !(goal_speed_mps > 0.0))
    os << "oracle goal_tolerance_m and goal_speed_mps must be > 0";
  return os.str();
}

std::string setOracleParameter(OracleConfig& config, const std::string& name, const std::string& value) {
  if (name == "learned_prediction") {
    if (value.empty()) return "oracle parameter 'learned_prediction' is empty (a people predictor file)";
    config.learned_prediction = value;
    return {};
  }
  const std::optional<double> parsed = parseNumber(value);
  if (!parsed || !std::isfinite(*parsed)) return "oracle parameter '" + name + "' = '" + value + "' is not a number";
  const double x = *parsed;
  if (name == "horizon_periods")
    config.horizon_periods = static_cast<int>(x);
  else if (name == "terminal_periods")
    config.terminal_periods = static_cast<int>(x);
  else if (name == "beam_width")
    config.beam_width = static_cast<int>(x);
  else if (name == "window_samples")
    config.window_samples = static_cast<int>(x);
  else if (name == "grid_cell_m")
    config.grid_cell_m = x;
  else if (name == "clearance_margin_m")
    config.clearance_margin_m = x;
  else if (name == "true_future_periods")
    config.true_future_periods = static_cast<int>(x);
  else if (name == "prediction_growth_mps")
    config.prediction_growth_mps = x;
  else if (name == "acceleration_prediction_s")
    config.acceleration_prediction_s = x;
  else if (name == "social_prediction" && (x == 0.0 || x == 1.0))
    config.social_prediction = x == 1.0;
  else if (name == "social_prediction")
    return "oracle parameter 'social_prediction' = '" + value + "' is not 0 or 1";
  else
    return "unknown oracle parameter '" + name +
           "' (horizon_periods, terminal_periods, beam_width, window_samples, grid_cell_m, clearance_margin_m, "
           "true_future_periods, social_prediction, prediction_growth_mps, acceleration_prediction_s, "
           "learned_prediction)";
  return {};
}

std::vector<std::string> defaultOracleRetries() {
  return {"terminal_periods=10", "horizon_periods=30,beam_width=320",
          "horizon_periods=30,beam_width=320,terminal_periods=10"};
}

std::string applyOracleParameters(OracleConfig& config, const std::string& spec) {
  size_t begin = 0;
  while (begin <= spec.size()) {
    const size_t end = std::min(spec.find(',', begin), spec.size());
    const std::string item = spec.substr(begin, end - begin);
    const size_t eq = item.find('=');
    if (eq == std::string::npos || eq == 0) return "'" + item + "' is not NAME=VALUE";
    if (std::string e = setOracleParameter(config, item.substr(0, eq), item.substr(eq + 1)); !e.empty()) return e;
    begin = end + 1;
  }
  return {};
}

std::string oracleRetrySearches(const OracleConfig& base, const std::vector<std::string>& specs,
                                std::vector<OracleConfig>& searches) {
  searches.clear();
  for (const std::string& spec : specs) {
    OracleConfig c = base;
    std::string e = applyOracleParameters(c, spec);
    if (e.empty()) e = c.validate();
    if (!e.empty()) return "oracle retry '" + spec + "': " + e;
    searches.push_back(c);
  }
  return {};
}

OraclePlanner::OraclePlanner(const OracleConfig& config, std::vector<OracleConfig> retries)
    : config_(config), retries_(std::move(retries)) {
  for (const OracleConfig& r : retries_) {
    if (const std::string e = r.validate(); !e.empty()) throw PlannerError("oracle retry: " + e);
  }
  if (const std::string e = config_.validate(); !e.empty()) throw PlannerError(e);
  if (!config_.learned_prediction.empty()) {
    try {
      learned_ = std::make_unique<PredictedArcs>(
          std::make_shared<const PeoplePredictor>(PeoplePredictor::load(config_.learned_prediction)));
    } catch (const PeoplePredictorError& e) {
      throw PlannerError(std::string("oracle learned_prediction: ") + e.what());
    }
  }
}

void OraclePlanner::reset() {
  statics_ready_ = false;
  future_.clear();
  previous_velocities_.clear();
  if (learned_) learned_->reset();
}

std::vector<std::vector<Vec2>> OraclePlanner::learnedFuture(const sim::World& world) {
  const double step = learned_->predictor().stepSeconds();
  if (std::abs(world.config().robot.dt - step) > 1e-6) {
    throw PlannerError("oracle learned_prediction: the predictor steps " + std::to_string(step) +
                       " s but the control period is " + std::to_string(world.config().robot.dt) + " s");
  }
  // The people as the planners would see them with perfect information, each one's id its index.
  std::vector<MovingObstacle> people;
  std::vector<int> ids;
  for (const sim::Person& p : world.crowd().people()) {
    MovingObstacle o;
    o.center = p.position;
    o.speed = p.velocity.norm();
    o.heading = o.speed > 1e-9 ? std::atan2(p.velocity.y(), p.velocity.x()) : p.heading_rad;
    ids.push_back(static_cast<int>(people.size()));
    people.push_back(o);
  }
  return learned_->predictPaths(people, ids, world.time_s(), world.walls());
}

void OraclePlanner::prepareStatics(const sim::World& world) {
  goal_ = world.goal();
  const double radius = world.config().robot.radius + config_.clearance_margin_m;
  Vec2 lo = world.robotPose().position().cwiseMin(goal_), hi = world.robotPose().position().cwiseMax(goal_);
  for (const Segment& w : world.walls()) {
    lo = lo.cwiseMin(w.a).cwiseMin(w.b);
    hi = hi.cwiseMax(w.a).cwiseMax(w.b);
  }
  const double h = config_.grid_cell_m;
  grid_origin_ = lo - Vec2(0.5, 0.5);
  grid_w_ = static_cast<int>(std::ceil((hi.x() - lo.x() + 1.0) / h)) + 1;
  grid_h_ = static_cast<int>(std::ceil((hi.y() - lo.y() + 1.0) / h)) + 1;
  const size_t n = static_cast<size_t>(grid_w_) * static_cast<size_t>(grid_h_);
  clearance_.assign(n, kInf);
  for (int j = 0; j < grid_h_; ++j) {
    for (int i = 0; i < grid_w_; ++i) {
      const Vec2 c = grid_origin_ + Vec2((i + 0.5) * h, (j + 0.5) * h);
      float best = kInf;
      for (const Segment& w : world.walls()) best = std::min(best, static_cast<float>(pointSegmentDistance(c, w)));
      // Static discs (chairs, posts) never move: they belong to the static geometry, so that the path to the goal
      // goes round them instead of through them.
      for (const sim::SimObstacle& o : world.obstacles()) {
        if (o.body.is_static) best = std::min(best, static_cast<float>((c - o.body.center).norm() - o.body.radius));
      }
      clearance_[static_cast<size_t>(j) * grid_w_ + i] = best;
    }
  }
  // Shortest free path to the goal (8-connected Dijkstra over cells the robot's centre may occupy).
  to_goal_.assign(n, kInf);
  using Item = std::pair<float, int>;
  std::priority_queue<Item, std::vector<Item>, std::greater<Item>> open;
  const int gi = std::clamp(static_cast<int>((goal_.x() - grid_origin_.x()) / h), 0, grid_w_ - 1);
  const int gj = std::clamp(static_cast<int>((goal_.y() - grid_origin_.y()) / h), 0, grid_h_ - 1);
  to_goal_[static_cast<size_t>(gj) * grid_w_ + gi] = 0.0f;
  open.push({0.0f, gj * grid_w_ + gi});
  const float diagonal = static_cast<float>(std::sqrt(2.0) * h);
  while (!open.empty()) {
    const auto [d, k] = open.top();
    open.pop();
    if (d > to_goal_[static_cast<size_t>(k)]) continue;
    const int i = k % grid_w_, j = k / grid_w_;
    for (int dj = -1; dj <= 1; ++dj) {
      for (int di = -1; di <= 1; ++di) {
        if (di == 0 && dj == 0) continue;
        const int ni = i + di, nj = j + dj;
        if (ni < 0 || nj < 0 || ni >= grid_w_ || nj >= grid_h_) continue;
        const size_t nk = static_cast<size_t>(nj) * grid_w_ + ni;
        // Passable as the search checks a pose (wallClearance): a gap the search cannot pass would otherwise draw it
        // into a dead end it never leaves.
        if (clearance_[nk] - kCellReach * h < radius) continue;
        const float nd = d + (di != 0 && dj != 0 ? diagonal : static_cast<float>(h));
        if (nd < to_goal_[nk]) {
          to_goal_[nk] = nd;
          open.push({nd, static_cast<int>(nk)});
        }
      }
    }
  }
  statics_ready_ = true;
}

double OraclePlanner::wallClearance(const Vec2& p) const {
  const int i = static_cast<int>(std::floor((p.x() - grid_origin_.x()) / config_.grid_cell_m));
  const int j = static_cast<int>(std::floor((p.y() - grid_origin_.y()) / config_.grid_cell_m));
  if (i < 0 || j < 0 || i >= grid_w_ || j >= grid_h_) return 0.0;
  // The cell centre's clearance, less half a cell diagonal: never more than the point's own.
  return clearance_[static_cast<size_t>(j) * grid_w_ + i] - kCellReach * config_.grid_cell_m;
}

double OraclePlanner::pathToGoal(const Vec2& p) const {
  const int i = static_cast<int>(std::floor((p.x() - grid_origin_.x()) / config_.grid_cell_m));
  const int j = static_cast<int>(std::floor((p.y() - grid_origin_.y()) / config_.grid_cell_m));
  const double straight = (p - goal_).norm();
  if (i < 0 || j < 0 || i >= grid_w_ || j >= grid_h_) return straight + 100.0;
  const float d = to_goal_[static_cast<size_t>(j) * grid_w_ + i];
  return std::isfinite(d) ? std::max<double>(d, straight) : straight + 100.0;
}

void OraclePlanner::rollObstacles(const sim::World& world, double sub_dt, int substeps) {
  sim::World future = world;  // the robot stands aside; the obstacles ignore it
  future_.resize(static_cast<size_t>(substeps));
  const int known =
      config_.true_future_periods < 0 ? substeps : std::min(substeps, config_.true_future_periods * kSubsteps);
  for (int k = 0; k < known; ++k) {
    future.step(Twist2{}, sub_dt);
    std::vector<Circle>& bodies = future_[static_cast<size_t>(k)];
    bodies.clear();
    for (const MovingObstacle& o : future.groundTruthObstacles()) bodies.push_back({o.center, o.radius});
  }
  if (known == substeps) return;
  // Beyond what it may read: every body on at its constant (speed, turn rate) of that moment, or the people by the
  // social force model toward no destination.
  const std::vector<MovingObstacle> then = future.groundTruthObstacles();
  // The people's acceleration over the last control period (the discs' is their turn rate, already in their arcs).
  std::vector<Vec2> acceleration(then.size(), Vec2::Zero());
  if (config_.acceleration_prediction_s > 0.0) {
    const std::vector<sim::Person>& persons = world.crowd().people();
    const size_t first = then.size() - persons.size();
    const double since = world.time_s() - previous_time_s_;
    if (previous_velocities_.size() == persons.size() && since > 0.0) {
      for (size_t i = 0; i < persons.size(); ++i) {
        acceleration[first + i] = (persons[i].velocity - previous_velocities_[i]) / since;
      }
    }
    previous_velocities_.clear();
    for (const sim::Person& p : persons) previous_velocities_.push_back(p.velocity);
    previous_time_s_ = world.time_s();
  }
  std::vector<std::vector<Vec2>> learned;
  if (learned_) learned = learnedFuture(world);
  const size_t people = config_.social_prediction || learned_ ? future.crowd().people().size() : 0;
  sim::Crowd crowd;
  if (people > 0) {
    std::vector<sim::PersonSpec> specs;
    for (const sim::Person& p : future.crowd().people()) {
      sim::PersonSpec spec;
      spec.position = p.position;
      spec.heading_rad = p.velocity.norm() > 1e-6 ? std::atan2(p.velocity.y(), p.velocity.x()) : p.heading_rad;
      spec.body_radius_m = p.spec.body_radius_m;
      spec.preferred_speed_mps = std::max(p.velocity.norm(), 1e-3);
      specs.push_back(spec);
    }
    sim::PeopleConfig pc = future.crowd().config();
    pc.model = sim::PeopleModel::kSocialForce;
    pc.see_robot = false;
    pc.mix = sim::PeopleMix();  // the prediction's people do not react to the robot
    crowd = sim::Crowd(specs, pc);
  }
  for (int k = known; k < substeps; ++k) {
    std::vector<Circle>& bodies = future_[static_cast<size_t>(k)];
    bodies.clear();
    const double ahead_s = (k + 1 - known) * sub_dt, growth = config_.prediction_growth_mps * ahead_s;
    for (size_t i = 0; i + people < then.size(); ++i) {
      const MovingObstacle& o = then[i];
      const double moving = o.is_static ? 0.0 : 1.0;
      Pose2 at = integrateUnicycle(Pose2{o.center.x(), o.center.y(), o.heading}, moving * o.speed, moving * o.turn_rate,
                                   ahead_s);
      if (config_.acceleration_prediction_s > 0.0) {
        // p += a (t^2 / 2) while accelerating, then a T (t - T / 2).
        const double t = ahead_s, ta = config_.acceleration_prediction_s;
        const double shift = t <= ta ? 0.5 * t * t : ta * (t - 0.5 * ta);
        at.x += moving * acceleration[i].x() * shift;
        at.y += moving * acceleration[i].y() * shift;
      }
      bodies.push_back({at.position(), o.radius + moving * growth});
    }
    if (learned_) {
      // Linear between the predictor's steps (its step 0 is now), then on at its last step's velocity.
      const double step = learned_->predictor().stepSeconds();
      const size_t first = then.size() - people;
      for (size_t i = 0; i < people; ++i) {
        const std::vector<Vec2>& path = learned[i];
        const double u = ahead_s / step;
        const size_t last = path.size();
        Vec2 at;
        if (u >= static_cast<double>(last)) {
          const Vec2 before = last >= 2 ? path[last - 2] : then[first + i].center;
          at = path[last - 1] + (u - static_cast<double>(last)) * (path[last - 1] - before);
        } else {
          const size_t s = static_cast<size_t>(std::floor(u));
          const Vec2 a = s == 0 ? then[first + i].center : path[s - 1];
          at = a + (u - static_cast<double>(s)) * (path[s] - a);
        }
        bodies.push_back({at, then[first + i].radius + growth});
      }
    } else if (people > 0) {
      crowd.step(sub_dt, future.walls(), Circle{}, Vec2::Zero());
      for (const Circle& b : crowd.bodies()) bodies.push_back({b.center, b.radius + growth});
    }
  }
}

const std::vector<std::vector<Circle>>& OraclePlanner::futureBodies(const sim::World& world) {
  rollObstacles(world, world.config().robot.dt / kSubsteps,
                (config_.horizon_periods + config_.terminal_periods) * kSubsteps);
  return future_;
}

bool OraclePlanner::touches(const Vec2& p, double radius, int substep) const {
  if (wallClearance(p) < radius) return true;
  for (const Circle& b : future_[static_cast<size_t>(substep)]) {
    if ((p - b.center).squaredNorm() < (radius + b.radius) * (radius + b.radius)) return true;
  }
  return false;
}

bool OraclePlanner::terminalSafe(const Pose2& pose, const Twist2& twist, const RobotLimits& limits,
                                 int from_substep) const {
  const double sub_dt = limits.dt / kSubsteps, radius = limits.radius + config_.clearance_margin_m;
  const Twist2 held[] = {decelerationCommand(twist, limits), twist, Twist2{twist.v, limits.w_max},
                         Twist2{twist.v, -limits.w_max}, Twist2{limits.v_max, twist.w}};
  for (const Twist2& u : held) {
    Pose2 q = pose;
    Twist2 v = twist;
    bool hit = false;
    for (int s = 0; s < config_.terminal_periods * kSubsteps && !hit; ++s) {
      v = applyAccelerationLimits(v, u, limits, sub_dt);
      q = integrateUnicycle(q, v.v, v.w, sub_dt);
      hit = touches(q.position(), radius, from_substep + s);
    }
    if (!hit) return true;
  }
  return false;
}

PlannerDecision OraclePlanner::search(const sim::World& world, std::vector<Candidate>* candidates) {
  const RobotLimits& limits = world.config().robot;
  const double dt = limits.dt, sub_dt = dt / kSubsteps;
  const int periods = config_.horizon_periods;
  const double radius = limits.radius + config_.clearance_margin_m;
  const bool ramp = world.config().ramp_velocity;
  const int chunks = std::max(1, static_cast<int>(std::lround(dt / config_.scan_period_s)));
  const int substeps_per_chunk = std::max(1, kSubsteps / chunks);
  if (candidates != nullptr) candidates->clear();

  // Two sequences reaching the same state (5 cm, 7.5 deg, 0.05 m/s, 0.2 rad/s) at a depth are one node.
  auto keyOf = [](const Node& n) {
    const auto q = [](double x, double s) { return static_cast<int64_t>(std::llround(x / s)) & 0xfff; };
    return (q(n.pose.x, 0.05) << 48) | (q(n.pose.y, 0.05) << 36) | (q(n.pose.theta, kPi / 24.0) << 24) |
           (q(n.twist.v, 0.05) << 12) | q(n.twist.w, 0.2);
  };
  const Twist2 now_twist = world.robotTwist();
  std::vector<Twist2> first_commands = makeDynamicWindow(now_twist, limits).samples(config_.window_samples, limits);
  if (first_commands.empty()) first_commands.push_back(decelerationCommand(now_twist, limits));

  // The pruned beam of every depth, so that a node's command sequence can be read back through its parents.
  std::vector<std::vector<Node>>& history = history_;
  history.assign(1, {Node{world.robotPose(), now_twist, 0.0, -1, -1, Twist2{}}});
  // The command sequence that leads to a node of depth `depth` (its parent in history[depth]) with `last`.
  auto sequence = [&](int depth, int parent, const Twist2& last) {
    std::vector<Twist2> commands(static_cast<size_t>(depth + 1));
    commands[static_cast<size_t>(depth)] = last;
    for (int d = depth; d > 0; --d) {
      const Node& n = history[static_cast<size_t>(d)][static_cast<size_t>(parent)];
      commands[static_cast<size_t>(d - 1)] = n.command;
      parent = n.parent;
    }
    return commands;
  };
  int best_dead_first = -1, deepest = -1, best_dead_parent = -1;
  Twist2 best_dead_command;
  bool all_dead = false;
  double best_dead_cost = std::numeric_limits<double>::infinity();
  std::vector<Node> next;
  std::unordered_map<int64_t, size_t> seen;
  for (int depth = 0; depth < periods; ++depth) {
    next.clear();
    seen.clear();
    const double t_end = (depth + 1) * dt;
    const std::vector<Node>& beam = history.back();
    for (size_t b = 0; b < beam.size(); ++b) {
      const Node& node = beam[b];
      const std::vector<Twist2> commands =
          depth == 0 ? first_commands : makeDynamicWindow(node.twist, limits).samples(config_.window_samples, limits);
      for (size_t c = 0; c < commands.size(); ++c) {
        Node child;
        child.first = depth == 0 ? static_cast<int>(c) : node.first;
        child.parent = static_cast<int>(b);
        child.command = commands[c];
        child.twist = node.twist;
        child.pose = node.pose;
        bool hit = false;
        for (int s = 0; s < kSubsteps && !hit; ++s) {
          // As the episode steps the world: one World::step per scan period, each moving the velocity toward the
          // command within the acceleration limits (or, ramping, every physics sub-step).
          if (ramp) {
            child.twist = applyAccelerationLimits(child.twist, commands[c], limits, sub_dt);
          } else if (s % substeps_per_chunk == 0) {
            child.twist = applyAccelerationLimits(child.twist, commands[c], limits, sub_dt * substeps_per_chunk);
          }
          child.pose = integrateUnicycle(child.pose, child.twist.v, child.twist.w, sub_dt);
          hit = touches(child.pose.position(), radius, depth * kSubsteps + s);
        }
        if (hit) {
          // The trajectory that stays free longest, should every one collide.
          const double cost = node.cost;
          if (depth > deepest || (depth == deepest && cost < best_dead_cost)) {
            deepest = depth;
            best_dead_cost = cost;
            best_dead_first = child.first;
            best_dead_parent = child.parent;
            best_dead_command = child.command;
          }
          continue;
        }
        const double to_go = pathToGoal(child.pose.position());
        if (to_go < config_.goal_tolerance_m && child.twist.v < config_.goal_speed_mps &&
            (child.pose.position() - goal_).norm() < config_.goal_tolerance_m) {
          if (candidates != nullptr) {
            // Reaching the goal ranks before every other sequence.
            candidates->push_back({sequence(depth, child.parent, child.command), t_end - 1.0e6});
            continue;
          }
          PlannerDecision d;
          d.command = first_commands[static_cast<size_t>(child.first)];
          d.note = "oracle: goal in " + std::to_string(depth + 1) + " periods";
          return d;
        }
        child.cost = t_end + to_go / limits.v_max;
        if (config_.terminal_periods > 0 && depth == periods - 1 &&
            !terminalSafe(child.pose, child.twist, limits, periods * kSubsteps))
          child.cost += kUnsafeEndPenalty_s;
        const int64_t k = keyOf(child);
        const auto it = seen.find(k);
        if (it == seen.end()) {
          seen.emplace(k, next.size());
          next.push_back(child);
        } else if (child.cost < next[it->second].cost) {
          next[it->second] = child;
        }
      }
    }
    if (next.empty()) {
      all_dead = true;
      break;
    }
    std::vector<Node> kept;
    if (static_cast<int>(next.size()) > config_.beam_width) {
      // Half the beam goes to the best few of every first command, the rest to the best overall: a beam of the
      // fastest progress alone loses the waiting and detouring sequences that a crossing later requires.
      std::sort(next.begin(), next.end(), [](const Node& a, const Node& b) { return a.cost < b.cost; });
      const size_t groups = first_commands.size();
      const int quota = std::max(1, config_.beam_width / (2 * static_cast<int>(groups)));
      std::vector<int> taken(groups, 0);
      std::vector<bool> keep(next.size(), false);
      int count = 0;
      for (size_t i = 0; i < next.size() && count < config_.beam_width; ++i) {
        int& t = taken[static_cast<size_t>(next[i].first)];
        if (t < quota) {
          ++t;
          keep[i] = true;
          ++count;
        }
      }
      for (size_t i = 0; i < next.size() && count < config_.beam_width; ++i) {
        if (!keep[i]) {
          keep[i] = true;
          ++count;
        }
      }
      for (size_t i = 0; i < next.size(); ++i) {
        if (keep[i]) kept.push_back(next[i]);
      }
    } else {
      kept = next;
    }
    history.push_back(std::move(kept));
  }
  PlannerDecision d;
  if (!all_dead) {
    const std::vector<Node>& beam = history.back();
    const auto best =
        std::min_element(beam.begin(), beam.end(), [](const Node& a, const Node& b) { return a.cost < b.cost; });
    d.command = first_commands[static_cast<size_t>(best->first)];
    d.note = "oracle: best progress over the horizon";
    if (candidates != nullptr) {
      // The best sequence of every first command.
      std::vector<int> best_of(first_commands.size(), -1);
      for (size_t i = 0; i < beam.size(); ++i) {
        int& k = best_of[static_cast<size_t>(beam[i].first)];
        if (k < 0 || beam[i].cost < beam[static_cast<size_t>(k)].cost) k = static_cast<int>(i);
      }
      const int depth = static_cast<int>(history.size()) - 1;
      for (const int k : best_of) {
        if (k < 0) continue;
        const Node& n = beam[static_cast<size_t>(k)];
        candidates->push_back({sequence(depth - 1, n.parent, n.command), n.cost});
      }
    }
  } else {
    // Every searched trajectory collides: the one that stays free longest.
    d.command = best_dead_first >= 0 ? first_commands[static_cast<size_t>(best_dead_first)]
                                     : decelerationCommand(now_twist, limits);
    d.note = "oracle: every searched trajectory collides";
  }
  if (candidates != nullptr) {
    if (best_dead_first >= 0) {
      candidates->push_back({sequence(deepest, best_dead_parent, best_dead_command), 1.0e9});
    }
    std::stable_sort(candidates->begin(), candidates->end(),
                     [](const Candidate& a, const Candidate& b) { return a.cost < b.cost; });
  }
  return d;
}

OraclePlanner::Rollout OraclePlanner::rollTrue(const sim::World& world, const std::vector<Twist2>& commands,
                                               int substeps, std::vector<std::vector<Circle>>* bodies) const {
  const RobotLimits& limits = world.config().robot;
  const int chunks = std::max(1, static_cast<int>(std::lround(limits.dt / config_.scan_period_s)));
  const int per_chunk = std::max(1, kSubsteps / chunks);
  sim::World w = world;
  Rollout r;
  std::vector<Circle> before, after;
  auto snapshot = [&](std::vector<Circle>& out) {
    out.clear();
    for (const MovingObstacle& o : w.groundTruthObstacles()) out.push_back({o.center, o.radius});
  };
  if (bodies != nullptr) {
    bodies->assign(static_cast<size_t>(substeps), {});
    snapshot(before);
  }
  const int periods = (substeps + kSubsteps - 1) / kSubsteps;
  for (int k = 0; k < periods; ++k) {
    // As the episode steps it: the command clipped to the window, one World::step per scan period. After the
    // sequence (it reached the goal or ends at the horizon) the robot brakes.
    const bool planned = k < static_cast<int>(commands.size());
    const Twist2 target =
        clipToWindow(w.robotTwist(),
                     planned ? commands[static_cast<size_t>(k)] : decelerationCommand(w.robotTwist(), limits), limits);
    for (int c = 0; c < chunks; ++c) {
      w.step(target, limits.dt / chunks);
      if (bodies == nullptr) continue;
      snapshot(after);
      // The bodies at the chunk's end, and linearly between for the checks inside it.
      for (int s = 1; s <= per_chunk; ++s) {
        const int index = k * kSubsteps + c * per_chunk + s - 1;
        if (index >= substeps) break;
        std::vector<Circle>& at = (*bodies)[static_cast<size_t>(index)];
        const double u = static_cast<double>(s) / per_chunk;
        for (size_t i = 0; i < after.size(); ++i) {
          at.push_back({before[i].center + u * (after[i].center - before[i].center), after[i].radius});
        }
      }
      before.swap(after);
    }
    if (!planned) continue;
    if (w.collided() && !r.collided) {
      r.collided = true;
      r.free_periods = k;
      if (bodies == nullptr) return r;
    }
    if (!r.collided && (w.robotPose().position() - w.goal()).norm() < config_.goal_tolerance_m &&
        w.robotTwist().v < config_.goal_speed_mps) {
      r.goal = true;
      r.free_periods = k + 1;
      if (bodies == nullptr) return r;
    }
  }
  if (!r.collided && !r.goal) r.free_periods = static_cast<int>(commands.size());
  return r;
}

PlannerDecision OraclePlanner::decide(const PlannerInput& /*input: the oracle reads the world itself*/) {
  if (world_ == nullptr) throw PlannerError("oracle: no world to read (setWorld)");
  const sim::World& world = *world_;
  if (!statics_ready_) prepareStatics(world);
  futureBodies(world);
  const bool reacting = config_.true_future_periods < 0 && !world.crowd().people().empty() &&
                        world.crowd().config().effectiveMix().anyReacts();
  if (!reacting) return search(world, nullptr);
  // People who react to the robot: the future above has the robot braking where it is. Each candidate (the best
  // sequence of every first command, best first) is stepped in a copy of the true simulator, the people reacting
  // to the robot as it follows it; the first that reaches the goal or stays free over the horizon is taken.
  // When none does, the people's motion around the sequence that stayed free longest becomes the future searched
  // next, up to kReactionSearches searches.
  const int substeps = (config_.horizon_periods + config_.terminal_periods) * kSubsteps;
  std::vector<Candidate> candidates;
  PlannerDecision fallback;
  int longest = -1;
  std::vector<std::vector<Circle>> longest_bodies;
  for (int round = 0; round < kReactionSearches; ++round) {
    const PlannerDecision plain = search(world, &candidates);
    if (round == 0) fallback = plain;
    for (const Candidate& c : candidates) {
      const Rollout r = rollTrue(world, c.commands, substeps, nullptr);
      if (r.goal || !r.collided) {
        PlannerDecision d;
        d.command = c.commands.front();
        d.note = std::string("oracle: ") + (r.goal ? "goal" : "free over the horizon") +
                 " in the true simulator (search " + std::to_string(round + 1) + ")";
        return d;
      }
      if (r.free_periods > longest) {
        // Only a candidate that stays free longer than every one before is stepped again for the people's motion
        // around it (a rollout without them stops at the first contact, and most candidates are never the longest).
        longest = r.free_periods;
        fallback.command = c.commands.front();
        fallback.note = "oracle: every candidate collides in the true simulator; the one free longest";
        rollTrue(world, c.commands, substeps, &longest_bodies);
      }
    }
    if (longest_bodies.empty()) break;
    future_ = longest_bodies;
  }
  return fallback;
}

}  // namespace dqn_dovs
