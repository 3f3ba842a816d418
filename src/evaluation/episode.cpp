#include "dqn_dovs/evaluation/episode.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "dqn_dovs/common/named_fields.h"
#include "dqn_dovs/evaluation/yardstick.h"
#include "dqn_dovs/perception/hungarian.h"
#include "dqn_dovs/perception/observation.h"

namespace dqn_dovs {

std::string RewardConfig::validate() const {
  std::ostringstream os;
  if (!(goal_reward > 0.0))
    os << "reward.goal_reward must be > 0";
  else if (!(collision_reward < 0.0))
    os << "reward.collision_reward must be < 0";
  else if (!(distance_weight >= 0.0))
    os << "reward.distance_weight must be >= 0";
  else if (!(safe_distance_m >= 0.0))
    os << "reward.safe_distance_m must be >= 0";
  else if (!(safe_weight >= 0.0))
    os << "reward.safe_weight must be >= 0";
  else if (!(goal_tolerance_m > 0.0))
    os << "reward.goal_tolerance_m must be > 0";
  else if (!(goal_speed_mps > 0.0))
    os << "reward.goal_speed_mps must be > 0";
  else if (max_steps < 1)
    os << "reward.max_steps must be >= 1";
  else if (!std::isnan(hit_at_rest_reward) && !(hit_at_rest_reward >= collision_reward && hit_at_rest_reward < 0.0))
    os << "reward.hit_at_rest_reward " << hit_at_rest_reward << " must lie in [collision_reward, 0) (a robot-at-fault "
       << "contact costs most)";
  else if (!(shaping_gamma > 0.0 && shaping_gamma <= 1.0))
    os << "reward.shaping_gamma " << shaping_gamma << " must lie in (0, 1]";
  else if (!(intimate_weight >= 0.0 && std::isfinite(intimate_weight)))
    os << "reward.intimate_weight must be finite and >= 0";
  else if (!(blocking_weight >= 0.0 && std::isfinite(blocking_weight)))
    os << "reward.blocking_weight must be finite and >= 0";
  return os.str();
}

namespace {

const std::vector<NamedField<RewardConfig>>& rewardFields() {
  static const std::vector<NamedField<RewardConfig>> fields = {
      {"goal_reward", &RewardConfig::goal_reward},
      {"collision_reward", &RewardConfig::collision_reward},
      {"distance_weight", &RewardConfig::distance_weight},
      {"safe_distance_m", &RewardConfig::safe_distance_m},
      {"safe_weight", &RewardConfig::safe_weight},
      {"goal_tolerance_m", &RewardConfig::goal_tolerance_m},
      {"goal_speed_mps", &RewardConfig::goal_speed_mps},
      {"max_steps", nullptr, &RewardConfig::max_steps},
      {"hit_at_rest_reward", &RewardConfig::hit_at_rest_reward},
      {"shaping_gamma", &RewardConfig::shaping_gamma},
      {"intimate_weight", &RewardConfig::intimate_weight},
      {"blocking_weight", &RewardConfig::blocking_weight},
  };
  return fields;
}

}  // namespace

std::string setRewardParameter(RewardConfig& config, const std::string& name, const std::string& value) {
  std::string known;
  for (const std::string& n : rewardParameterNames()) known += (known.empty() ? "" : ", ") + n;
  return setNamedField(rewardFields(), config, "reward parameter", name, value, "(known: " + known + ")");
}

std::vector<std::string> rewardParameterNames() { return namedFieldNames(rewardFields()); }

std::string EpisodeRouteConfig::validate() const {
  if (!(std::isfinite(resolution_m) && resolution_m >= 0.01 && resolution_m <= 0.5)) {
    std::ostringstream os;
    os << "route.resolution_m = " << resolution_m << " must be in [0.01, 0.5] m";
    return os.str();
  }
  if (const std::string e = planner.validate(); !e.empty()) return "route: " + e;
  if (const std::string e = guide.validate(); !e.empty()) return "route: " + e;
  return {};
}

std::string EpisodeConfig::validate() const {
  if (auto e = world.validate(); !e.empty()) return "world: " + e;
  if (auto e = tracker.validate(); !e.empty()) return "tracker: " + e;
  if (auto e = dovs.validate(); !e.empty()) return "dovs: " + e;
  if (auto e = reward.validate(); !e.empty()) return e;
  if (auto e = route.validate(); !e.empty()) return e;
  const double ratio = world.robot.dt / scan_period_s;
  if (!(scan_period_s > 0.0) || std::abs(ratio - std::round(ratio)) > 1e-6 || std::round(ratio) < 1.0) {
    std::ostringstream os;
    os << "scan_period_s = " << scan_period_s << " must divide the control period " << world.robot.dt << " s";
    return os.str();
  }
  if (!(sensor_warmup_s >= 0.0 && sensor_warmup_s <= 5.0)) return "sensor_warmup_s must be in [0, 5] s";
  if (tracker_map && perfect_info) return "tracker_map gives the tracker a map; with perfect_info there is no tracker";
  if (dovs_map && perfect_info)
    return "dovs_map adds the map's walls to the scan's; with perfect_info there is no scan";
  if (!(std::isfinite(map_range_m) && map_range_m > 0.0)) return "map_range_m must be > 0 (m)";
  if (track_truth != TrackTruth::kNone && perfect_info)
    return "track_truth corrects the tracker's tracks; with perfect_info there is no tracker";
  return {};
}

const char* trackTruthName(TrackTruth t) {
  switch (t) {
    case TrackTruth::kNone:
      return "none";
    case TrackTruth::kMotion:
      return "motion";
    case TrackTruth::kState:
      return "state";
  }
  return "unknown";
}

TrackTruth parseTrackTruth(const std::string& name) {
  for (TrackTruth t : {TrackTruth::kNone, TrackTruth::kMotion, TrackTruth::kState}) {
    if (name == trackTruthName(t)) return t;
  }
  throw std::invalid_argument("track truth '" + name + "' is none of none, motion, state");
}

const char* outcomeName(Outcome o) {
  switch (o) {
    case Outcome::kRunning:
      return "running";
    case Outcome::kSuccess:
      return "success";
    case Outcome::kCollision:
      return "collision";
    case Outcome::kTimeout:
      return "timeout";
  }
  return "unknown";
}

namespace {

const EpisodeConfig& checked(const EpisodeConfig& c) {
  const std::string error = c.validate();
  if (!error.empty()) throw std::invalid_argument("episode configuration: " + error);
  return c;
}

}  // namespace

Episode::Episode(const EpisodeConfig& config)
    : config_(checked(config)),
      world_(sim::Scenario{}, config_.world, 0),
      tracker_(config_.tracker),
      dovs_builder_(config_.world.robot, config_.dovs),
      normalization_(stateNormalization(config_.world.robot, config_.dovs)),
      route_guide_(config_.route.guide),
      state_(Eigen::VectorXf::Zero(normalization_.stateSize())) {
  if (!config_.people_predictor.empty()) {
    std::shared_ptr<const PeoplePredictor> predictor;
    try {
      predictor = std::make_shared<const PeoplePredictor>(PeoplePredictor::load(config_.people_predictor));
    } catch (const PeoplePredictorError& e) {
      throw std::invalid_argument(std::string("episode people_predictor: ") + e.what());
    }
    if (std::abs(predictor->stepSeconds() - config_.world.robot.dt) > 1e-6) {
      throw std::invalid_argument("episode people_predictor '" + config_.people_predictor + "' steps " +
                                  std::to_string(predictor->stepSeconds()) + " s, the control period is " +
                                  std::to_string(config_.world.robot.dt) + " s");
    }
    predicted_arcs_ = std::make_unique<PredictedArcs>(predictor);
  }
}

void Episode::reset(const sim::Scenario& scenario, uint64_t seed) {
  world_.reset(scenario, seed);
  tracker_.reset();
  if (predicted_arcs_) predicted_arcs_->reset();
  outcome_ = Outcome::kRunning;
  steps_ = 0;
  path_length_m_ = 0.0;
  danger_steps_ = 0;
  trajectory_.clear();
  route_planner_.reset();
  route_guide_.clear();
  guidance_ = RouteGuidance();
  route_error_.clear();
  previous_grid_.clear();  // the first decision's history channel is its own grid
  track_history_.clear();
  previous_choice_ = kNoPreviousChoice;
  known_structure_.reset();
  map_segments_.clear();
  if ((config_.tracker_map || config_.dovs_map) && !config_.perfect_info) {
    // The map the robot is localised on, from its first scan: the walls and the furniture (static discs).
    const std::vector<Circle> furniture = sim::furnitureOf(world_.scenario());
    if (config_.tracker_map) {
      known_structure_ = std::make_unique<KnownStructure>(world_.walls(), furniture, config_.tracker.map_tolerance_m);
    }
    if (config_.dovs_map) {
      // As an occupancy grid gives them: outlines, here an octagon around each disc.
      map_segments_ = world_.walls();
      for (const Circle& c : furniture) {
        const double r = c.radius / std::cos(kPi / 8.0);
        for (int k = 0; k < 8; ++k) {
          const double a = kPi / 8.0 + kPi / 4.0 * k, b = a + kPi / 4.0;
          map_segments_.push_back(
              {c.center + r * Vec2(std::cos(a), std::sin(a)), c.center + r * Vec2(std::cos(b), std::sin(b))});
        }
      }
    }
  }
  // The robot senses, standing still, before it is given the goal: the tracker needs a few scans to
  // confirm tracks and estimate their velocities. Obstacles move meanwhile, the same for every planner.
  const int warmup_scans = static_cast<int>(std::round(config_.sensor_warmup_s / config_.scan_period_s));
  sense();
  for (int i = 0; i < warmup_scans; ++i) {
    world_.step(Twist2{}, config_.scan_period_s);
    sense();
  }
  start_time_s_ = world_.time_s();
  // The goal is given now: a world with walls gets its route (the room of the paper none, as before).
  if (config_.route.enabled && !scenario.static_segments.empty()) planRoute();
  min_clearance_m_ = world_.minClearance_m();
  trajectory_.push_back(world_.robotPose());
  if (world_.collided()) {
    // A scenario that starts in contact ends at once; it is counted as a collision of the scenario.
    outcome_ = Outcome::kCollision;
  }
  buildContext();
}

void Episode::sense() {
  if (config_.perfect_info) return;
  world_.scanInto(scan_);
  // The robot knows where its laser is from its odometry: with drift, tracks live in the drifting odom frame.
  const Pose2 laser =
      config_.world.odometry.enabled() ? world_.odomPose().compose(config_.world.lidar.mount) : world_.laserPose();
  scan_laser_ = laser;
  // The map is in the world's frame; a perfect localisation places the odom frame in it.
  MapStructureView map;
  if (known_structure_) {
    map.structure = known_structure_.get();
    if (config_.world.odometry.enabled()) map.fixed_in_map = world_.robotPose().compose(world_.odomPose().inverse());
  }
  const TrackerResult result = tracker_.update(scan_, laser, map);
  if (result.status == TrackerStatus::kRejected) {
    throw std::runtime_error("episode: the tracker rejected a simulated scan: " + result.message);
  }
}

void Episode::buildContext() {
  observation_.stamp_s = world_.time_s();
  // Odometry: the pose the robot believes (the truth without drift). The goal, given at the start when the odom
  // frame and the world agree, keeps its coordinates: with drift the robot aims where it believes the goal is.
  observation_.robot_pose = world_.odomPose();
  observation_.robot_twist = world_.robotTwist();
  observation_.goal = world_.goal();
  observation_.obstacles.clear();
  observation_.segments.clear();
  observation_.route_ahead.clear();
  const Pose2 odom_from_world = world_.odomPose().compose(world_.robotPose().inverse());  // identity without drift
  // The world's walls as the robot places them: in the odom frame where odometry drifts.
  auto walls_in_odom = [&]() {
    std::vector<Segment> walls = world_.walls();
    if (config_.world.odometry.enabled()) {
      for (Segment& w : walls) w = {odom_from_world.toWorld(w.a), odom_from_world.toWorld(w.b)};
    }
    return walls;
  };
  // The true bodies seen from the odom frame (where the robot believes it is): every pose through odom <- world.
  auto truth_in_odom = [&]() {
    std::vector<MovingObstacle> truth = world_.groundTruthObstacles();
    if (config_.world.odometry.enabled()) {
      for (MovingObstacle& o : truth) {
        o.center = odom_from_world.toWorld(o.center);
        o.heading = normalizeAngle(o.heading + odom_from_world.theta);
      }
    }
    return truth;
  };
  if (config_.perfect_info) {
    observation_.obstacles = truth_in_odom();
    observation_.segments = walls_in_odom();
  } else {
    for (const TrackedObstacle& t : tracker_.scene().obstacles) observation_.obstacles.push_back(t.toMovingObstacle());
    if (config_.track_truth != TrackTruth::kNone) giveTracksTruth(truth_in_odom(), config_.track_truth);
    observation_.segments = tracker_.scene().segments;
    // The map's walls near the robot join the scan's, as dovs_node adds them with use_map.
    appendMapWalls(map_segments_, config_.world.odometry.enabled() ? odom_from_world : Pose2{},
                   observation_.robot_pose.position(), config_.map_range_m, observation_.segments);
  }
  // The learned prediction is of people: with perfect information the world's people (not the room's discs, whose
  // constant (v, w) it only blurs), with the tracker its tracks when it pairs legs into people (every track is one).
  if (predicted_arcs_ && (config_.perfect_info || config_.tracker.pair_legs)) {
    std::vector<int> ids;
    const size_t first = config_.perfect_info ? world_.obstacles().size() : 0;  // truth: the discs, then the people
    for (size_t k = first; k < observation_.obstacles.size(); ++k) {
      ids.push_back(config_.perfect_info ? static_cast<int>(k) : tracker_.scene().obstacles[k].id);
    }
    // The walls as a map gives them (the world's, as the route planner knows them; with perfect information they
    // are the observation's). dovs_node gives the scan's segments and, with use_map, the map's near the robot.
    predictArcs(*predicted_arcs_, observation_.obstacles, first, ids, world_.time_s(),
                config_.perfect_info ? observation_.segments : walls_in_odom());
  }
  if (route_planner_) {
    // The robot's decision step: the route's subgoal, once per control period, as planner_node gives it.
    guidance_ = route_guide_.update(route_planner_.get(), observation_.robot_pose.position(), world_.goal(),
                                    world_.time_s(), 0, [this]() { return routeScanPoints(); });
    observation_.goal = guidance_.local_goal;
    if (normalization_.route_points > 0)  // the state's route points; the straight line to the goal without a route
      observation_.route_ahead = route_guide_.ahead(kRoutePointSpacing_m * normalization_.route_points);
  }
  if (normalization_.person_tokens > 0 && config_.perfect_info) {
    // The world's bodies in a fixed order: their index is their id (the person tokens' history).
    for (size_t k = 0; k < observation_.obstacles.size(); ++k) observation_.obstacles[k].id = static_cast<int>(k);
  }
  // The velocity space, the actions and the state, as dovs_node builds them (dovs/state.h).
  VelocitySpaceStep step;
  buildVelocitySpaceStep(observation_, config_.world.robot, normalization_, dovs_builder_, dovs_, step, &track_history_,
                         previous_grid_.empty() ? nullptr : &previous_grid_, previous_choice_);
  actions_ = step.actions;
  state_ = std::move(step.state);
  if (normalization_.grid_channels == kHistoryGridChannels)  // one step of history: this decision's first channel
    previous_grid_.assign(state_.data(), state_.data() + kStateGridCells);
}

void Episode::giveTracksTruth(const std::vector<MovingObstacle>& truth, TrackTruth what) {
  std::vector<MovingObstacle>& tracks = observation_.obstacles;
  std::vector<Vec2> track_centres, body_centres;
  for (const MovingObstacle& t : tracks) track_centres.push_back(t.center);
  for (const MovingObstacle& b : truth) body_centres.push_back(b.center);
  const std::vector<int> match = matchWithin(track_centres, body_centres, kTrackTruthMatch_m);
  for (size_t i = 0; i < tracks.size(); ++i) {
    if (match[i] < 0) continue;
    const MovingObstacle& body = truth[static_cast<size_t>(match[i])];
    MovingObstacle& t = tracks[i];
    if (what == TrackTruth::kState) {
      t = body;
    } else {
      t.heading = body.heading;
      t.speed = body.speed;
      t.turn_rate = body.turn_rate;
      t.is_static = body.is_static;
    }
  }
}

void Episode::planRoute() {
  // The map the robot would have: the walls and the furniture (static discs included), not the people.
  const std::vector<Circle> furniture = sim::furnitureOf(world_.scenario());
  const Vec2 start = world_.odomPose().position();
  RouteConfig planner = config_.route.planner;
  planner.robot_radius_m = config_.world.robot.radius;
  route_planner_ = std::make_unique<RoutePlanner>(
      knownWorldGrid(world_.walls(), furniture, {start, world_.goal()}, config_.route.resolution_m), planner);
  // Without a route (start and goal not connected on the grid) the robot drives at the goal itself.
  route_error_ = route_guide_.plan(*route_planner_, start, world_.goal(), world_.time_s());
}

std::vector<Vec2> Episode::routeScanPoints() const {
  std::vector<Vec2> out;
  if (config_.perfect_info) {
    // No scan: the outlines of the true bodies the robot is told about, every 10 cm or so.
    for (const MovingObstacle& o : observation_.obstacles) {
      const int n = std::max(8, static_cast<int>(std::ceil(2.0 * kPi * o.radius / 0.1)));
      for (int k = 0; k < n; ++k) {
        const double a = 2.0 * kPi * k / n;
        out.push_back(o.center + o.radius * Vec2(std::cos(a), std::sin(a)));
      }
    }
    return out;
  }
  return scan_.returnsIn(scan_laser_);
}

PlannerInput Episode::plannerInput() const {
  PlannerInput in;
  in.observation = &observation_;
  in.dovs = &dovs_;
  in.actions = &actions_;
  in.state = &state_;
  in.limits = config_.world.robot;
  return in;
}

StepResult Episode::stepAction(int a) {
  if (a < 0 || a >= kNumActions) throw std::out_of_range("episode: action " + std::to_string(a) + " is not in [0, 8)");
  if (!actions_.valid[static_cast<size_t>(a)]) {
    throw std::invalid_argument("episode: action " + std::to_string(a) + " is masked out in this state");
  }
  return stepChoice(actions_.velocities[static_cast<size_t>(a)], a);
}

StepResult Episode::step(const Twist2& command) { return stepChoice(command, kPreviousChoiceOther); }

StepResult Episode::stepChoice(const Twist2& command, int choice) {
  if (done())
    throw std::logic_error("episode: step() after the episode ended (" + std::string(outcomeName(outcome_)) + ")");
  const Twist2 target = clipToWindow(world_.robotTwist(), command, config_.world.robot);
  previous_choice_ = choice;  // the next state's previous choice
  return advance([&](double dt_s) { world_.step(target, dt_s); });
}

StepResult Episode::stepHolonomic(const Vec2& velocity) {
  if (done()) {
    throw std::logic_error("episode: stepHolonomic() after the episode ended (" + std::string(outcomeName(outcome_)) +
                           ")");
  }
  previous_choice_ = kPreviousChoiceOther;
  return advance([&](double dt_s) { world_.stepHolonomic(velocity, dt_s); });
}

StepResult Episode::stepDecision(const PlannerDecision& d) {
  if (d.holonomic_velocity) return stepHolonomic(*d.holonomic_velocity);
  return stepChoice(d.command, d.action >= 0 && d.action < kNumActions ? d.action : kPreviousChoiceOther);
}

StepResult Episode::advance(const std::function<void(double)>& move_robot) {
  const RobotLimits& limits = config_.world.robot;
  // The reward's distance: along the route when there is one (the route in force at the start of the period).
  const double d_before = route_guide_.distanceToGo(world_.robotPose().position(), world_.goal());

  const int scans = static_cast<int>(std::round(limits.dt / config_.scan_period_s));
  for (int i = 0; i < scans; ++i) {
    const Vec2 before = world_.robotPose().position();
    move_robot(config_.scan_period_s);
    path_length_m_ += (world_.robotPose().position() - before).norm();
    sense();
    min_clearance_m_ = std::min(min_clearance_m_, world_.minClearance_m());
    if (world_.collided()) break;
  }
  ++steps_;
  trajectory_.push_back(world_.robotPose());

  const RewardConfig& rc = config_.reward;
  StepResult r;
  const double d_after = route_guide_.distanceToGo(world_.robotPose().position(), world_.goal());
  const double goal_distance = (world_.robotPose().position() - world_.goal()).norm();
  const double clearance = world_.minClearance_m();
  if (clearance < rc.safe_distance_m) ++danger_steps_;
  if (world_.collided()) {
    r.reward = rc.collisionReward(robotAtFault(world_.collision()));
    r.terminated = true;
    outcome_ = Outcome::kCollision;
  } else if (goal_distance < rc.goal_tolerance_m && world_.robotTwist().v < rc.goal_speed_mps) {
    r.reward = rc.goal_reward;
    r.terminated = true;
    outcome_ = Outcome::kSuccess;
  } else {
    r.reward = rc.distance_weight * (d_before - rc.shaping_gamma * d_after);
    if (clearance < rc.safe_distance_m) r.reward -= rc.safe_weight * std::abs(rc.safe_distance_m - clearance);
    if (rc.intimate_weight > 0.0 || rc.blocking_weight > 0.0) r.reward -= yardstickCost();
    if (steps_ >= rc.max_steps) {
      r.truncated = true;
      outcome_ = Outcome::kTimeout;
    }
  }
  r.outcome = outcome_;
  buildContext();
  return r;
}

double Episode::yardstickCost() const {
  const RewardConfig& rc = config_.reward;
  const RobotLimits& limits = config_.world.robot;
  if (world_.crowd().people().empty()) return 0.0;
  if (std::abs(world_.robotTwist().v) >= kRestSpeedMps) {
    const double nearest =
        nearestPersonGap(world_.crowd().people(), Circle{world_.robotPose().position(), limits.radius});
    return nearest < kIntimateDistance_m ? rc.intimate_weight * limits.dt : 0.0;
  }
  return rc.blocking_weight > 0.0 && blocksPassage(world_, limits.radius) ? rc.blocking_weight * limits.dt : 0.0;
}

}  // namespace dqn_dovs
