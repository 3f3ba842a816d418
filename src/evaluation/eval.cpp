#include "dqn_dovs/evaluation/eval.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <deque>
#include <fstream>
#include <iomanip>
#include <limits>
#include <map>
#include <mutex>
#include <sstream>
#include <thread>

#include "dqn_dovs/common/random.h"
#include "dqn_dovs/evaluation/oracle.h"
#include "dqn_dovs/perception/hungarian.h"
#include "dqn_dovs/planning/planner.h"
#include "dqn_dovs/sim/worlds.h"

namespace dqn_dovs {

namespace {

/// The behaviours in force in an evaluation: everybody attentive with people_see_robot, else EvalConfig::people_mix
/// (empty: everybody oblivious). Throws sim::SimError naming a mix text it cannot read.
sim::PeopleMix peopleMixOf(const EvalConfig& c) {
  if (c.people_see_robot) return sim::PeopleMix::allAttentive();
  return c.people_mix.empty() ? sim::PeopleMix() : sim::PeopleMix::parse(c.people_mix);
}

/// Why an evaluation's people mix cannot be read ("" when it can).
std::string peopleMixError(const EvalConfig& c) {
  try {
    peopleMixOf(c);
  } catch (const sim::SimError& e) {
    return e.what();
  }
  return {};
}

std::string oracleRetriesError(const OracleConfig& base, const std::vector<std::string>& specs) {
  std::vector<OracleConfig> searches;
  return oracleRetrySearches(base, specs, searches);
}

}  // namespace

std::string EvalConfig::validate() const {
  std::ostringstream os;
  if (methods.empty()) return "methods is empty";
  if (world != "room" && !scenarios_dir.empty()) {
    return "world '" + world + "' is generated: scenario files hold only the room (use the generator)";
  }
  for (size_t i = 0; i < methods.size(); ++i) {
    if (methods[i].empty()) return "methods[" + std::to_string(i) + "] is empty";
    for (size_t j = 0; j < i; ++j) {
      if (methods[j] == methods[i]) return "methods lists '" + methods[i] + "' twice";
    }
  }
  if (obstacles_min < 0) {
    os << "obstacles_min = " << obstacles_min << ": must be >= 0";
  } else if (obstacles_max < obstacles_min) {
    os << "obstacles_max = " << obstacles_max << ": must be >= obstacles_min (" << obstacles_min << ")";
  } else if (episodes < 1) {
    os << "episodes = " << episodes << ": must be >= 1";
  } else if (!(dynamic_fraction >= 0.0 && dynamic_fraction <= 1.0)) {
    os << "dynamic_fraction = " << dynamic_fraction << ": must be in [0, 1]";
  } else if (!(std::isfinite(generated_goal_distance_min_m) && generated_goal_distance_min_m >= 0.0)) {
    os << "generated_goal_distance_min_m = " << generated_goal_distance_min_m << ": must be finite and >= 0";
  } else if (!(std::isfinite(generated_start_clear_s) && generated_start_clear_s >= 0.0 &&
               generated_start_clear_s <= 60.0)) {
    os << "generated_start_clear_s = " << generated_start_clear_s << ": must be in [0, 60]";
  } else if (route != "on" && route != "off") {
    os << "route = '" << route << "': must be on or off";
  } else if (threads < 1 || threads > 256) {
    os << "threads = " << threads << ": must be in [1, 256]";
  } else if (const std::string e = episode.validate(); !e.empty()) {
    os << "episode: " << e;
  } else if (const std::string e = shield.validate(); !e.empty()) {
    os << "shield: " << e;
  } else if (const std::string e = oracleRetriesError(oracle, oracle_retries); !e.empty()) {
    os << e;
  } else if (const std::string e = bound.validate(); !e.empty()) {
    os << e;
  } else if (const std::string e = peopleMixError(*this); !e.empty()) {
    os << e;
  } else if (peopleMixOf(*this).anyReacts() && std::find(methods.begin(), methods.end(), "bound") != methods.end()) {
    os << "method bound needs people who ignore the robot (their future is then fixed by the seed): "
          "drop people_see_robot, or a people mix where anyone reacts";
  }
  return os.str();
}

namespace {

uint64_t episodeSeed(uint64_t base, int obstacles, int episode) {
  return sim::mixSeed(sim::mixSeed(base) ^ (static_cast<uint64_t>(obstacles) << 32 | static_cast<uint32_t>(episode)));
}

}  // namespace

void applyWorldOptions(EvalConfig& config) {
  try {
    config.episode.world.lidar = sim::LidarConfig::profile(config.sensor);
    config.episode.world.people.model = sim::parsePeopleModel(config.people_model);
    config.episode.world.odometry = sim::OdometryConfig::level(config.odom_noise);
  } catch (const sim::SimError& e) {
    throw EvalError(e.what());
  }
  if (config.route != "on" && config.route != "off") {
    throw EvalError("route '" + config.route + "' is not one of on, off");
  }
  config.episode.route.enabled = config.route == "on";
  config.episode.world.people.see_robot = config.people_see_robot;
  try {
    config.episode.world.people.mix = peopleMixOf(config);
  } catch (const sim::SimError& e) {
    throw EvalError(e.what());
  }
  // People are seen by their legs: the tracker pairs them (the paper's room has none).
  config.episode.tracker.pair_legs = config.world != "room";
  // The tracker's straightness thresholds follow the scanner's range noise.
  config.episode.tracker.range_noise_m = config.episode.world.lidar.noise_std_m;
  config.episode.tracker.range_noise_fraction = config.episode.world.lidar.noise_std_fraction;
  // One scan every control period / n: the scanner's period, or the next slower one that divides the period.
  const double dt = config.episode.world.robot.dt;
  const int n = std::max(1, static_cast<int>(std::floor(dt / config.episode.world.lidar.scan_period_s + 1e-9)));
  config.episode.scan_period_s = dt / n;
}

std::vector<EvalScenario> loadEvalScenarios(const EvalConfig& config) {
  if (const std::string e = config.validate(); !e.empty()) throw EvalError("evaluation configuration: " + e);
  std::vector<EvalScenario> out;
  for (int n = config.obstacles_min; n <= config.obstacles_max; ++n) {
    for (int k = 1; k <= config.episodes; ++k) {
      EvalScenario s;
      s.obstacles = n;
      s.episode = k;
      s.seed = episodeSeed(config.seed, n, k);
      if (!config.scenarios_dir.empty()) {
        const std::string path = config.scenarios_dir + "/1-" + std::to_string(n) + "/" + std::to_string(k) + ".dovs";
        try {
          s.scenario = sim::loadDovsScenario(path);
          sim::applyDynamicFraction(s.scenario, config.dynamic_fraction);
        } catch (const std::exception& e) {
          throw EvalError("scenario " + path + ": " + e.what());
        }
        if (static_cast<int>(s.scenario.obstacles.size()) != n) {
          throw EvalError("scenario " + path + ": holds " + std::to_string(s.scenario.obstacles.size()) +
                          " obstacles, the folder 1-" + std::to_string(n) + " promises " + std::to_string(n));
        }
        s.scenario.name = "1-" + std::to_string(n) + "/" + std::to_string(k);
      } else if (config.world != "room") {
        sim::WorldFamilyConfig w;
        try {
          w.family = sim::parseWorldFamily(config.world);
        } catch (const sim::SimError& e) {
          throw EvalError(e.what());
        }
        w.people = n;
        const uint64_t scenario_seed = episodeSeed(config.seed ^ 0x5CE7A210ULL, n, k);
        try {
          s.scenario = sim::generateWorld(w, scenario_seed);
        } catch (const std::exception& e) {
          throw EvalError("generated " + config.world + " world (seed " + std::to_string(config.seed) + ", " +
                          std::to_string(n) + " people, episode " + std::to_string(k) + "): " + e.what());
        }
        s.scenario.name =
            config.world + "/" + std::to_string(config.seed) + "/" + std::to_string(n) + "/" + std::to_string(k);
      } else {
        sim::GeneratorConfig g;
        g.obstacle_count_min = n;
        g.obstacle_count_max = n;
        g.obstacle_type = sim::ObstacleType::kBoth;
        g.dynamic_fraction = config.dynamic_fraction;
        g.goal_distance_min_m = config.generated_goal_distance_min_m;
        g.start_clear_s = config.generated_start_clear_s;
        g.random_robot_heading = false;  // as in the evaluation files
        const uint64_t scenario_seed = episodeSeed(config.seed ^ 0x5CE7A210ULL, n, k);
        try {
          s.scenario = sim::generateScenario(g, scenario_seed);
        } catch (const std::exception& e) {
          throw EvalError("generated scenario (seed " + std::to_string(config.seed) + ", " + std::to_string(n) +
                          " obstacles, episode " + std::to_string(k) + "): " + e.what());
        }
        s.scenario.name =
            "generated/" + std::to_string(config.seed) + "/" + std::to_string(n) + "/" + std::to_string(k);
      }
      out.push_back(std::move(s));
    }
  }
  return out;
}

namespace {

/// One worker's tools: a planner per method and one episode, built once and reused for every job it runs.
struct Worker {
  std::vector<std::unique_ptr<Planner>> planners;
  std::unique_ptr<Episode> episode;
};

}  // namespace

std::vector<std::string> evalMethodNames() {
  std::vector<std::string> names = plannerNames();
  names.push_back("oracle");
  names.push_back("bound");
  return names;
}

std::unique_ptr<Planner> makeEvalPlanner(const std::string& method, const EvalConfig& config) {
  if (method == "oracle") {
    OracleConfig oracle = config.oracle;
    oracle.goal_tolerance_m = config.episode.reward.goal_tolerance_m;
    oracle.goal_speed_mps = config.episode.reward.goal_speed_mps;
    oracle.scan_period_s = config.episode.scan_period_s;
    // Retries only where the oracle reads the whole future: over a prediction (a diagnostic of what a planner with
    // it could do) the best of several whole runs would be hindsight.
    std::vector<OracleConfig> retries;
    if (oracle.true_future_periods < 0) {
      if (const std::string e = oracleRetrySearches(oracle, config.oracle_retries, retries); !e.empty())
        throw EvalError(e);
    }
    return std::make_unique<OraclePlanner>(oracle, retries);
  }
  if (method == "bound") {
    ReachBoundConfig bound = config.bound;
    bound.goal_tolerance_m = config.episode.reward.goal_tolerance_m;
    bound.max_periods = config.episode.reward.max_steps;
    bound.scan_period_s = config.episode.scan_period_s;
    return std::make_unique<ReachBoundPlanner>(bound);
  }
  // The network is checked against the states the episodes build (robot limits, DOVS range, grid encoding).
  const StateNormalization normalization = stateNormalization(config.episode.world.robot, config.episode.dovs);
  return makePlanner(method, config.model_path, &config.shield, &normalization);
}

DecisionView decisionView(const Episode& ep) {
  DecisionView v;
  const sim::World& world = ep.world();
  v.time_s = world.time_s();
  v.robot = world.robotPose();
  // world <- odom: the identity without odometry drift.
  const Pose2 world_from_odom = world.robotPose().compose(world.odomPose().inverse());
  v.shown = ep.observation().obstacles;
  for (MovingObstacle& o : v.shown) {
    o.center = world_from_odom.toWorld(o.center);
    o.heading = normalizeAngle(o.heading + world_from_odom.theta);
  }
  for (const MovingObstacle& b : world.groundTruthObstacles()) v.truth.push_back(b.center);
  return v;
}

namespace {

/// The shown obstacle that stands for body `b` in `view`, or -1: the tracks and the bodies paired one to one within
/// kTrackTruthMatch_m as --track-truth pairs them (matchWithin).
int shownFor(const DecisionView& view, size_t b) {
  if (b >= view.truth.size() || view.shown.empty()) return -1;
  std::vector<Vec2> shown;
  shown.reserve(view.shown.size());
  for (const MovingObstacle& o : view.shown) shown.push_back(o.center);
  return matchWithin(view.truth, shown, kTrackTruthMatch_m)[b];
}

}  // namespace

HitAttribution attributeHit(const std::deque<DecisionView>& views, size_t body, const Vec2& at_contact,
                            double contact_time_s) {
  HitAttribution h;
  if (views.empty() || body >= views.back().truth.size()) return h;
  const DecisionView& last = views.back();
  const Vec2 seen_from = last.robot.toLocal(last.truth[body]);
  h.bearing_deg = std::abs(std::atan2(seen_from.y(), seen_from.x())) * 180.0 / M_PI;
  // Shown without a break, back from the last decision.
  double first_seen = std::numeric_limits<double>::quiet_NaN();
  for (auto it = views.rbegin(); it != views.rend() && shownFor(*it, body) >= 0; ++it) first_seen = it->time_s;
  h.seen_s = std::isfinite(first_seen) ? contact_time_s - first_seen : 0.0;
  if (!std::isfinite(first_seen)) {
    h.cause = HitCause::kUnseen;
    return h;
  }
  // Where the body's motion as shown at the last decision at least `ahead_s` before the contact put it at the
  // contact, against where it was; NaN when it was not shown then (or no decision is that old).
  auto predictionError = [&](double ahead_s) {
    const DecisionView* then = nullptr;
    for (const DecisionView& v : views) {
      if (v.time_s <= contact_time_s - ahead_s + 1e-9) then = &v;
    }
    const int j = then ? shownFor(*then, body) : -1;
    if (j < 0) return std::numeric_limits<double>::quiet_NaN();
    const MovingObstacle& o = then->shown[static_cast<size_t>(j)];
    const Pose2 from{o.center.x(), o.center.y(), o.heading};
    const double dt = contact_time_s - then->time_s;
    const Vec2 predicted = o.is_static ? o.center : integrateUnicycle(from, o.speed, o.turn_rate, dt).position();
    return (predicted - at_contact).norm();
  };
  h.prediction_error_m = predictionError(kHitForesight_s);
  h.prediction_error_long_m = predictionError(kHitLongForesight_s);
  if (!std::isfinite(h.prediction_error_m)) {
    h.cause = HitCause::kLate;
  } else {
    h.cause = h.prediction_error_m > kHitPredictionMiss_m ? HitCause::kMispredicted : HitCause::kForeseen;
  }
  return h;
}

namespace {

/// attributeHit for an episode that ended in a collision with a moving body; `views` holds its last decisions.
void recordHit(const Episode& ep, const std::deque<DecisionView>& views, EpisodeRecord& r) {
  const sim::CollisionInfo& c = ep.world().collision();
  if (c.kind != sim::CollisionInfo::Kind::kObstacle || c.static_contact) return;
  const std::vector<MovingObstacle> bodies = ep.world().groundTruthObstacles();
  if (c.index < 0 || static_cast<size_t>(c.index) >= bodies.size()) return;
  // The body at the contact: the world runs on to the end of its scan period, so step back along its motion.
  const MovingObstacle& body = bodies[static_cast<size_t>(c.index)];
  const double back_s = std::max(ep.world().time_s() - c.time_s, 0.0);
  const Pose2 now{body.center.x(), body.center.y(), body.heading};
  const Vec2 at_contact = integrateUnicycle(now, -body.speed, -body.turn_rate, back_s).position();
  const HitAttribution h = attributeHit(views, static_cast<size_t>(c.index), at_contact, c.time_s);
  r.hit_cause = h.cause;
  r.hit_seen_s = h.seen_s;
  r.hit_prediction_error_m = h.prediction_error_m;
  r.hit_prediction_error_2s_m = h.prediction_error_long_m;
  r.hit_bearing_deg = h.bearing_deg;
}

/// Decisions kept for attributeHit: 3 s at the 0.2 s control period, and one more.
constexpr size_t kHitViews = 16;

}  // namespace

const char* hitCauseName(HitCause cause) {
  switch (cause) {
    case HitCause::kNone:
      return "";
    case HitCause::kUnseen:
      return "unseen";
    case HitCause::kLate:
      return "late";
    case HitCause::kMispredicted:
      return "mispredicted";
    case HitCause::kForeseen:
      return "foreseen";
  }
  return "";
}

namespace {

/// The record of method `bound`: the reachability bound's verdict on the episode as it starts (after the warm-up).
EpisodeRecord boundRecord(const ReachBoundPlanner& bound, const Episode& ep) {
  EpisodeRecord r;
  const ReachBoundResult b = reachBound(ep.world(), bound.config());
  r.time_s = b.time_s;
  r.steps = b.periods;
  r.path_length_m = std::numeric_limits<double>::quiet_NaN();
  r.min_clearance_m = std::numeric_limits<double>::quiet_NaN();
  std::ostringstream note;
  switch (b.verdict) {
    case ReachBoundResult::Verdict::kReachable:
      r.outcome = Outcome::kSuccess;
      note << "bound: goal reachable after " << b.periods << " periods"
           << (b.left_grid ? " (the set left the grid: not ruled out)" : "");
      break;
    case ReachBoundResult::Verdict::kBoxedIn:
      r.outcome = Outcome::kCollision;
      note << "bound: no clear position within reach after " << b.periods << " periods (unavoidable)";
      break;
    case ReachBoundResult::Verdict::kOutOfTime:
      r.outcome = Outcome::kTimeout;
      note << "bound: goal out of reach within " << b.periods << " periods";
      break;
  }
  r.last_decision = note.str();
  return r;
}

}  // namespace

namespace {

EpisodeRecord runOnce(Planner& planner, Episode& ep, const std::string& method, const EvalScenario& s,
                      bool keep_paths) {
  planner.reset();
  ep.reset(s.scenario, s.seed);
  if (const auto* bound = dynamic_cast<const ReachBoundPlanner*>(&planner)) {
    EpisodeRecord r = boundRecord(*bound, ep);
    r.method = method;
    r.obstacles = s.obstacles;
    r.episode = s.episode;
    r.scenario = s.scenario.name;
    return r;
  }
  // The oracle reads the world itself (its future); every other planner sees only the observation.
  if (auto* oracle = dynamic_cast<OraclePlanner*>(&planner)) oracle->setWorld(&ep.world());
  EpisodeRecord r;
  r.method = method;
  r.obstacles = s.obstacles;
  r.episode = s.episode;
  r.scenario = s.scenario.name;
  // Obstacles, then people (the order of World::groundTruthObstacles).
  if (keep_paths) r.obstacle_paths.resize(ep.world().obstacles().size() + ep.world().crowd().people().size());
  auto recordObstacles = [&]() {
    if (!keep_paths) return;
    const auto& obs = ep.world().obstacles();
    const auto& people = ep.world().crowd().people();
    for (size_t i = 0; i < r.obstacle_paths.size(); ++i)
      r.obstacle_paths[i].push_back(i < obs.size() ? obs[i].body.center : people[i - obs.size()].position);
    if (!ep.config().perfect_info) r.tracks.push_back(ep.trackedScene().obstacles);
  };
  recordObstacles();
  const RobotLimits& limits = ep.config().world.robot;
  // Cost to others and efficiency: the people's progress along their plans with the robot and without it, the
  // route length at the start.
  PlanProgress progress, shadow_progress;
  std::vector<bool> noticed(ep.world().crowd().people().size(), false);  // attentive people who noticed the robot
  progress.reset(ep.world().crowd());
  if (const sim::Crowd* shadow = ep.world().shadowCrowd()) shadow_progress.reset(*shadow);
  const double route_length_m = ep.routeGuide().distanceToGo(ep.world().robotPose().position(), ep.world().goal());
  // The oracle reads the world, not what the observation shows: nothing to attribute, no views to keep.
  const bool attribute_hits = dynamic_cast<OraclePlanner*>(&planner) == nullptr;
  std::deque<DecisionView> views;
  while (!ep.done()) {
    if (attribute_hits) {
      views.push_back(decisionView(ep));
      if (views.size() > kHitViews) views.pop_front();
    }
    const PlannerInput in = ep.plannerInput();
    PlannerDecision decision;
    try {
      decision = planner.decide(in);
    } catch (const PlannerError&) {
      // The interface's contract: the caller decelerates when a planner cannot decide.
      ++r.planner_errors;
      decision = PlannerDecision{};
      decision.command = decelerationCommand(ep.observation().robot_twist, limits);
      decision.note = "planner error";
    }
    r.last_decision = decision.note;
    r.actions.push_back(decision.action);
    ep.stepDecision(decision);  // holonomic baselines move the robot holonomically
    recordObstacles();
    // Comfort: the time a person spends this close to the moving robot (body to body, per decision period); cost to
    // others: standing in a passage while someone waits for it or detours around it.
    if (std::abs(ep.world().robotTwist().v) >= kRestSpeedMps) {
      const double nearest =
          nearestPersonGap(ep.world().crowd().people(), Circle{ep.world().robotPose().position(), limits.radius});
      if (nearest < kIntimateDistance_m) r.intimate_s += limits.dt;
      if (nearest < kPersonalDistance_m) r.personal_s += limits.dt;
    } else if (blocksPassage(ep.world(), limits.radius)) {
      r.blocking_s += limits.dt;
    }
    progress.update(ep.world().crowd());
    for (size_t i = 0; i < noticed.size(); ++i) noticed[i] = noticed[i] || ep.world().crowd().people()[i].noticed;
    if (const sim::Crowd* shadow = ep.world().shadowCrowd()) shadow_progress.update(*shadow);
  }
  r.outcome = ep.outcome();
  r.time_s = ep.time_s();
  r.path_length_m = ep.pathLength_m();
  r.min_clearance_m = ep.minClearance_m();
  r.danger_steps = ep.dangerSteps();
  r.steps = ep.steps();
  if (r.outcome == Outcome::kSuccess && route_length_m > 0.0) r.time_ratio = r.time_s / (route_length_m / limits.v_max);
  r.path_irregularity = pathIrregularity(ep.trajectory());
  if (ep.world().shadowCrowd() != nullptr) {
    const auto& people = ep.world().crowd().people();
    bool any = false;
    double delay = 0.0;
    for (size_t i = 0; i < people.size(); ++i) {
      if (people[i].behavior != sim::PersonBehavior::kAttentive || !noticed[i]) continue;
      any = true;
      delay += (shadow_progress.metres()[i] - progress.metres()[i]) / people[i].spec.preferred_speed_mps;
    }
    if (any) r.delay_s = delay;
  }
  if (r.outcome == Outcome::kCollision && ep.world().collided()) {
    r.collision_kind = classifyCollision(ep.world().collision());
    r.contact_speed_mps = ep.world().collision().robot_speed_mps;
    r.contact = classifyContact(ep.world().collision());
    r.at_fault = robotAtFault(ep.world().collision());
    if (attribute_hits) recordHit(ep, views, r);
  }
  if (keep_paths) r.robot_path = ep.trajectory();
  return r;
}

}  // namespace

EpisodeRecord runEpisode(Planner& planner, Episode& ep, const std::string& method, const EvalScenario& s,
                         bool keep_paths) {
  EpisodeRecord r = runOnce(planner, ep, method, s, keep_paths);
  const auto* oracle = dynamic_cast<const OraclePlanner*>(&planner);
  if (oracle == nullptr || r.outcome == Outcome::kSuccess || oracle->retries().empty()) return r;
  // Every search runs in the true simulator (people who react to the robot react to it there too): a later search
  // that reaches the goal shows the episode solvable, and its record stands; when none does, the first search's
  // failure does.
  const size_t searches = oracle->retries().size() + 1;
  for (size_t k = 0; k < oracle->retries().size(); ++k) {
    OraclePlanner retry(oracle->retries()[k]);
    EpisodeRecord again = runOnce(retry, ep, method, s, keep_paths);
    if (again.outcome == Outcome::kSuccess) {
      again.last_decision += " (search " + std::to_string(k + 2) + " of " + std::to_string(searches) + ")";
      return again;
    }
  }
  r.last_decision += " (" + std::to_string(searches) + " searches failed)";
  return r;
}

std::vector<EpisodeRecord> runEvaluation(const EvalConfig& config, const std::vector<EvalScenario>& scenarios,
                                         const EvalProgress& progress) {
  if (const std::string e = config.validate(); !e.empty()) throw EvalError("evaluation configuration: " + e);
  const size_t num_methods = config.methods.size();
  const size_t total = num_methods * scenarios.size();
  std::vector<EpisodeRecord> records(total);
  // Jobs run scenario-major (every method on a scenario before the next) so that partial progress is
  // comparable across methods; records are stored method-major.
  std::atomic<size_t> next{0};
  std::atomic<bool> failed{false};
  std::mutex mutex;
  size_t done = 0;
  std::string first_error;

  auto work = [&]() {
    Worker w;
    try {
      for (const std::string& m : config.methods) w.planners.push_back(makeEvalPlanner(m, config));
      // The delay the robot causes attentive people is measured against their shadow (EpisodeRecord::delay_s).
      EpisodeConfig episode = config.episode;
      episode.world.shadow_people = episode.world.people.effectiveMix().attentive > 0.0;
      w.episode = std::make_unique<Episode>(episode);
    } catch (const std::exception& e) {
      std::lock_guard<std::mutex> lock(mutex);
      if (first_error.empty()) first_error = std::string("cannot set up a worker: ") + e.what();
      failed = true;
      return;
    }
    while (!failed) {
      const size_t job = next.fetch_add(1);
      if (job >= total) break;
      const size_t si = job / num_methods, mi = job % num_methods;
      const EvalScenario& s = scenarios[si];
      const bool keep = std::find(config.keep_paths.begin(), config.keep_paths.end(),
                                  std::make_pair(s.obstacles, s.episode)) != config.keep_paths.end();
      try {
        EpisodeRecord r = runEpisode(*w.planners[mi], *w.episode, config.methods[mi], s, keep);
        std::lock_guard<std::mutex> lock(mutex);
        records[mi * scenarios.size() + si] = std::move(r);
        ++done;
        if (progress) progress(records[mi * scenarios.size() + si], done, total);
      } catch (const std::exception& e) {
        std::lock_guard<std::mutex> lock(mutex);
        if (first_error.empty()) {
          first_error = "method '" + config.methods[mi] + "' on scenario " + s.scenario.name + ": " + e.what();
        }
        failed = true;
      }
    }
  };

  const int threads = std::min<int>(config.threads, static_cast<int>(std::max<size_t>(total, 1)));
  if (threads <= 1) {
    work();
  } else {
    std::vector<std::thread> pool;
    for (int t = 0; t < threads; ++t) pool.emplace_back(work);
    for (std::thread& t : pool) t.join();
  }
  if (failed) throw EvalError("evaluation failed: " + first_error);
  return records;
}

const char* verdictName(const EpisodeRecord& r) {
  switch (r.outcome) {
    case Outcome::kSuccess:
      return "success";
    case Outcome::kCollision:
      return r.at_fault ? "collision_robot_at_fault" : "hit_at_rest";
    case Outcome::kTimeout:
      return "timeout";
    case Outcome::kRunning:
      break;
  }
  return "running";
}

namespace {

std::ofstream openOut(const std::string& path) {
  std::ofstream out(path, std::ios::trunc);
  if (!out) throw EvalError("cannot open '" + path + "' for writing");
  out << std::setprecision(6);
  return out;
}

void closeOut(std::ofstream& out, const std::string& path) {
  out.close();
  if (!out) throw EvalError("cannot write '" + path + "'");
}

}  // namespace

void writeResultsCsv(const std::vector<EpisodeRecord>& records, const std::string& path) {
  std::ofstream out = openOut(path);
  out << "method,obstacles,episode,scenario,outcome,time_s,path_length_m,min_clearance_m,danger_steps,steps,"
         "planner_errors,collision_kind,contact_speed_mps,last_decision,hit_cause,hit_seen_s,hit_prediction_error_m,"
         "hit_prediction_error_2s_m,hit_bearing_deg,contact,at_fault,intimate_s,personal_s,verdict,blocking_s,delay_s,"
         "time_ratio,path_irregularity\n";
  for (const EpisodeRecord& r : records) {
    out << r.method << ',' << r.obstacles << ',' << r.episode << ',' << r.scenario << ',' << outcomeName(r.outcome)
        << ',' << r.time_s << ',' << r.path_length_m << ',' << r.min_clearance_m << ',' << r.danger_steps << ','
        << r.steps << ',' << r.planner_errors << ',' << collisionKindName(r.collision_kind) << ',';
    if (std::isfinite(r.contact_speed_mps)) out << r.contact_speed_mps;
    // The note is free text: commas become semicolons and quotes and line breaks spaces, so the row stays plain.
    std::string note = r.last_decision;
    for (char& ch : note) {
      if (ch == ',')
        ch = ';';
      else if (ch == '"' || ch == '\n' || ch == '\r')
        ch = ' ';
    }
    out << ',' << note << ',' << hitCauseName(r.hit_cause);
    for (const double x : {r.hit_seen_s, r.hit_prediction_error_m, r.hit_prediction_error_2s_m, r.hit_bearing_deg}) {
      out << ',';
      if (std::isfinite(x)) out << x;
    }
    out << ',' << contactClassName(r.contact) << ',';
    if (r.outcome == Outcome::kCollision) out << (r.at_fault ? 1 : 0);
    out << ',' << r.intimate_s << ',' << r.personal_s << ',' << verdictName(r) << ',' << r.blocking_s << ',';
    if (std::isfinite(r.delay_s)) out << r.delay_s;
    out << ',';
    if (std::isfinite(r.time_ratio)) out << r.time_ratio;
    out << ',' << r.path_irregularity << '\n';
  }
  closeOut(out, path);
}

namespace {

/// A JSON string literal: quotes, backslashes and control characters escaped.
std::string jsonString(const std::string& text) {
  std::ostringstream os;
  os << '"';
  for (const char ch : text) {
    const auto c = static_cast<unsigned char>(ch);
    if (ch == '"' || ch == '\\') {
      os << '\\' << ch;
    } else if (c < 0x20) {
      os << "\\u" << std::hex << std::setw(4) << std::setfill('0') << static_cast<int>(c) << std::dec
         << std::setfill(' ');
    } else {
      os << ch;
    }
  }
  os << '"';
  return os.str();
}

/// A JSON number; NaN and infinities (which JSON cannot hold) become null.
std::string jsonNumber(double x, int digits = 10) {
  if (!std::isfinite(x)) return "null";
  std::ostringstream os;
  os << std::setprecision(digits) << x;
  return os.str();
}

}  // namespace

void writeRunJson(const EvalConfig& config, const EvalRunInfo& info, const std::string& path) {
  std::ofstream out = openOut(path);
  out << "{\n  \"command\": " << jsonString(info.command)
      << ",\n  \"scenarios\": " << jsonString(config.scenarios_dir.empty() ? "generated" : config.scenarios_dir)
      << ",\n  \"seed\": " << config.seed << ",\n  \"obstacles_min\": " << config.obstacles_min
      << ",\n  \"obstacles_max\": " << config.obstacles_max << ",\n  \"episodes\": " << config.episodes
      << ",\n  \"dynamic_fraction\": " << jsonNumber(config.dynamic_fraction)
      << ",\n  \"world\": " << jsonString(config.world) << ",\n  \"sensor\": " << jsonString(config.sensor)
      << ",\n  \"people_model\": " << jsonString(config.people_model)
      << ",\n  \"people_see_robot\": " << (config.people_see_robot ? "true" : "false")
      << ",\n  \"people_mix\": " << jsonString(peopleMixOf(config).str())
      << ",\n  \"odom_noise\": " << jsonString(config.odom_noise) << ",\n  \"route\": " << jsonString(config.route)
      << ",\n  \"perfect_info\": " << (config.episode.perfect_info ? "true" : "false")
      << ",\n  \"track_truth\": " << jsonString(trackTruthName(config.episode.track_truth))
      << ",\n  \"sensor_warmup_s\": " << jsonNumber(config.episode.sensor_warmup_s)
      << ",\n  \"people_predictor\": " << jsonString(config.episode.people_predictor)
      << ",\n  \"tracker_map\": " << (config.episode.tracker_map ? "true" : "false")
      << ",\n  \"dovs_map\": " << (config.episode.dovs_map ? "true" : "false")
      << ",\n  \"step_s\": " << jsonNumber(config.episode.world.robot.dt)
      << ",\n  \"max_steps\": " << config.episode.reward.max_steps << ",\n  \"wall_s\": " << jsonNumber(info.wall_s)
      << ",\n  \"threads\": " << config.threads << ",\n  \"methods\": [";
  for (size_t i = 0; i < config.methods.size(); ++i) out << (i ? ", " : "") << jsonString(config.methods[i]);
  out << "],\n  \"oracle_retries\": [";
  for (size_t i = 0; i < config.oracle_retries.size(); ++i)
    out << (i ? ", " : "") << jsonString(config.oracle_retries[i]);
  out << "],\n  \"reference\": " << jsonString(info.reference)
      << ",\n  \"goal_tolerance_m\": " << jsonNumber(config.episode.reward.goal_tolerance_m) << "\n}\n";
  closeOut(out, path);
}

void writePathsJson(const std::vector<EpisodeRecord>& records, const std::vector<EvalScenario>& scenarios,
                    double goal_tolerance_m, const std::string& path) {
  std::ofstream out = openOut(path);
  out << "{\"episodes\": [";
  bool first = true;
  for (const EpisodeRecord& r : records) {
    if (r.robot_path.empty()) continue;
    const auto s = std::find_if(scenarios.begin(), scenarios.end(), [&](const EvalScenario& e) {
      return e.obstacles == r.obstacles && e.episode == r.episode;
    });
    if (s == scenarios.end()) {
      throw EvalError("cannot write '" + path + "': no scenario for the record of " + r.method +
                      " at N=" + std::to_string(r.obstacles) + ", episode " + std::to_string(r.episode));
    }
    const sim::Scenario& sc = s->scenario;
    out << (first ? "\n" : ",\n") << "{\"method\": " << jsonString(r.method) << ", \"obstacles\": " << r.obstacles
        << ", \"episode\": " << r.episode << ", \"scenario\": " << jsonString(r.scenario)
        << ", \"outcome\": " << jsonString(outcomeName(r.outcome)) << ", \"time_s\": " << jsonNumber(r.time_s)
        << ", \"path_length_m\": " << jsonNumber(r.path_length_m)
        << ", \"min_clearance_m\": " << jsonNumber(r.min_clearance_m) << ",\n \"goal\": [" << jsonNumber(sc.goal.x())
        << ", " << jsonNumber(sc.goal.y()) << "], \"goal_tolerance_m\": " << jsonNumber(goal_tolerance_m)
        << ", \"room_half_size_m\": " << jsonNumber(sc.room_half_size_m) << ", \"walls\": [";
    for (size_t i = 0; i < sc.static_segments.size(); ++i) {
      const Segment& w = sc.static_segments[i];
      out << (i ? ", [" : "[") << jsonNumber(w.a.x()) << ", " << jsonNumber(w.a.y()) << ", " << jsonNumber(w.b.x())
          << ", " << jsonNumber(w.b.y()) << "]";
    }
    out << "],\n \"robot_path\": [";
    for (size_t k = 0; k < r.robot_path.size(); ++k) {
      const Pose2& p = r.robot_path[k];
      out << (k ? ", [" : "[") << jsonNumber(p.x, 6) << ", " << jsonNumber(p.y, 6) << ", " << jsonNumber(p.theta, 6)
          << "]";
    }
    out << "],\n \"obstacle_paths\": [";
    for (size_t i = 0; i < r.obstacle_paths.size(); ++i) {
      const bool disc = i < sc.obstacles.size(), person = !disc && i - sc.obstacles.size() < sc.people.size();
      const double radius = disc     ? sc.obstacles[i].radius
                            : person ? sc.people[i - sc.obstacles.size()].body_radius_m
                                     : 0.2;
      out << (i ? ",\n  " : "\n  ") << "{\"radius\": " << jsonNumber(radius)
          << ", \"static\": " << (disc && sc.obstacles[i].is_static ? "true" : "false") << ", \"path\": [";
      const std::vector<Vec2>& trail = r.obstacle_paths[i];
      for (size_t k = 0; k < trail.size(); ++k) {
        out << (k ? ", [" : "[") << jsonNumber(trail[k].x(), 6) << ", " << jsonNumber(trail[k].y(), 6) << "]";
      }
      out << "]}";
    }
    out << "]";
    if (!r.tracks.empty()) {
      // [id, x, y, speed, heading, static] of every confirmed track, per step.
      out << ",\n \"tracks\": [";
      for (size_t k = 0; k < r.tracks.size(); ++k) {
        out << (k ? ",\n  [" : "\n  [");
        for (size_t j = 0; j < r.tracks[k].size(); ++j) {
          const TrackedObstacle& t = r.tracks[k][j];
          out << (j ? ", [" : "[") << t.id << ", " << jsonNumber(t.center.x(), 6) << ", " << jsonNumber(t.center.y(), 6)
              << ", " << jsonNumber(t.speed, 6) << ", " << jsonNumber(t.heading, 6) << ", " << (t.is_static ? 1 : 0)
              << "]";
        }
        out << "]";
      }
      out << "]";
    }
    out << "}";
    first = false;
  }
  out << "\n]}\n";
  closeOut(out, path);
}

}  // namespace dqn_dovs
