// Passive safety: the static braking rule (static_safety.h) and the escape's order (action_shield.h).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include "dqn_dovs/dovs/actions.h"
#include "dqn_dovs/dovs/dovs.h"
#include "dqn_dovs/evaluation/episode.h"
#include "dqn_dovs/planning/planner.h"
#include "dqn_dovs/policy/action_shield.h"
#include "dqn_dovs/policy/rollout.h"
#include "dqn_dovs/policy/static_safety.h"
#include "obstacle_test_helpers.h"

namespace dqn_dovs {
namespace {

using test::movingDisc;

Observation wallAhead(double clearance_m, double v, double w = 0.0) {
  // A wall across the robot's path, clearance_m from its surface (robot radius 0.2).
  Observation obs;
  obs.robot_twist = {v, w};
  obs.goal = {-4.0, 0.0};
  const double x = 0.2 + clearance_m;
  obs.segments = {Segment{{x, -3.0}, {x, 3.0}}};
  return obs;
}

TEST(StaticSafety, BrakingTrajectoryFollowsItsThreePhases) {
  const RobotLimits limits;
  const StaticSafetyConfig config;
  // 0.5 m/s straight, command "keep": 0.1 s reaction + 0.2 s command at 0.5, then 0.5 / (0.8 * 0.5) s of braking.
  const std::vector<BrakingSample> s = brakingSamples({0.5, 0.0}, {0.5, 0.0}, limits, config);
  ASSERT_FALSE(s.empty());
  const double brake = 0.5 / (config.braking_fraction * limits.a_v);
  EXPECT_NEAR(s.back().t_s, config.latency_s + limits.dt + brake, 0.021);
  EXPECT_NEAR(s.back().position.x(), 0.5 * (config.latency_s + limits.dt) + 0.5 * 0.5 * brake, 0.01);
  EXPECT_NEAR(s.back().position.y(), 0.0, 1e-9);
  EXPECT_NEAR(s.back().speed_mps, 0.0, 1e-9);
  // Speeds never rise while braking.
  for (size_t i = 1; i < s.size(); ++i) {
    if (s[i - 1].t_s >= config.latency_s + limits.dt - 1e-9) {
      EXPECT_LE(s[i].speed_mps, s[i - 1].speed_mps + 1e-12);
    }
  }
}

TEST(StaticSafety, FastTowardAWallIsUnsafeAndBrakingIsSafe) {
  const RobotLimits limits;
  const StaticSafetyConfig config;
  const Observation obs = wallAhead(0.60, 0.5);
  const StaticScene scene(obs, limits, config);
  ASSERT_EQ(scene.size(), 1u);
  EXPECT_NEAR(scene.clearance(Vec2::Zero()), 0.60, 1e-12);
  const BrakingPath faster = brakingPath(scene, obs.robot_twist, {0.6, 0.0}, limits, config);
  const BrakingPath brake =
      brakingPath(scene, obs.robot_twist, decelerationCommand(obs.robot_twist, limits), limits, config);
  EXPECT_FALSE(faster.safe);
  EXPECT_TRUE(brake.safe);
  EXPECT_LT(faster.min_clearance_m, brake.min_clearance_m);
  // The replacement the planner node sends for the unsafe target is safe and inside the window.
  const Twist2 sent = staticSafeCommand(scene, obs.robot_twist, {0.6, 0.0}, limits, config);
  EXPECT_TRUE(brakingPath(scene, obs.robot_twist, sent, limits, config).safe);
  EXPECT_TRUE(makeDynamicWindow(obs.robot_twist, limits).contains(sent, limits, 1e-9));
  // A safe target passes unchanged.
  const Twist2 slow{0.4, 0.0};
  ASSERT_TRUE(brakingPath(scene, obs.robot_twist, slow, limits, config).safe);
  const Twist2 same = staticSafeCommand(scene, obs.robot_twist, slow, limits, config);
  EXPECT_EQ(same.v, slow.v);
  EXPECT_EQ(same.w, slow.w);
}

TEST(StaticSafety, MovingDiscsAreNotStaticGeometryAndFarThingsAreLeftOut) {
  const RobotLimits limits;
  const StaticSafetyConfig config;
  Observation obs;
  obs.obstacles = {movingDisc(0.8, 0.0, kPi, 0.5), movingDisc(0.0, 0.8), movingDisc(9.0, 0.0)};
  obs.segments = {Segment{{20.0, -1.0}, {20.0, 1.0}}};
  const StaticScene scene(obs, limits, config);
  EXPECT_EQ(scene.size(), 1u);  // only the static disc nearby
  EXPECT_NEAR(scene.clearance(Vec2::Zero()), 0.4, 1e-12);
}

TEST(StaticSafety, InsideTheMarginOnlyGettingCloserIsUnsafe) {
  const RobotLimits limits;
  const StaticSafetyConfig config;
  const Observation obs = wallAhead(0.02, 0.0);  // at rest, 2 cm from the wall
  const StaticScene scene(obs, limits, config);
  EXPECT_TRUE(brakingPath(scene, obs.robot_twist, {0.0, 0.0}, limits, config).safe);
  EXPECT_TRUE(brakingPath(scene, obs.robot_twist, {0.0, 0.4}, limits, config).safe);  // turning in place
  EXPECT_FALSE(brakingPath(scene, obs.robot_twist, {0.1, 0.0}, limits, config).safe);
}

TEST(StaticSafety, BadConfigurationIsNamed) {
  StaticSafetyConfig c;
  c.braking_fraction = 0.0;
  EXPECT_NE(c.validate().find("braking_fraction"), std::string::npos);
  c = StaticSafetyConfig{};
  c.latency_s = std::nan("");
  EXPECT_NE(c.validate().find("latency_s"), std::string::npos);
  c = StaticSafetyConfig{};
  c.margin_m = -0.1;
  EXPECT_NE(c.validate().find("margin_m"), std::string::npos);
  ActionShieldConfig s;
  s.statics.step_s = 0.0;
  EXPECT_NE(s.validate().find("static_safety.step_s"), std::string::npos);
}

// One control period of the robot as the simulator moves it: the command clipped into the window, then
// followed within the acceleration limits; returns the least static clearance on the way.
// The true static clearance of a robot of radius 0.2 centred at q (fixed frame), nothing left out.
double staticClearance(const Observation& world, const Vec2& q) {
  double best = std::numeric_limits<double>::infinity();
  for (const Segment& s : world.segments) best = std::min(best, pointSegmentDistance(q, s) - 0.2);
  for (const MovingObstacle& o : world.obstacles) {
    if (o.is_static) best = std::min(best, (q - o.center).norm() - o.radius - 0.2);
  }
  return best;
}

double drive(Pose2& pose, Twist2& twist, const Twist2& command, const RobotLimits& limits, const Observation& world) {
  const DynamicWindow window = makeDynamicWindow(twist, limits);
  Twist2 target = command;
  if (!window.contains(target, limits, 1e-6)) target = decelerationCommand(twist, limits);
  double least = std::numeric_limits<double>::infinity();
  for (int k = 0; k < 20; ++k) {
    const double h = limits.dt / 20;
    twist = applyAccelerationLimits(twist, target, limits, h);
    pose = integrateUnicycle(pose, twist.v, twist.w, h);
    least = std::min(least, staticClearance(world, pose.position()));
  }
  return least;
}

// The adversarial network: of what the shield allows, the action whose position after `ahead_s` scores lowest
// by `score` (the escape when the shield holds one).
template <typename Score>
Twist2 adversarialCommand(const Observation& obs, DovsBuilder& builder, const ActionShieldConfig& shield,
                          double ahead_s, Score&& score) {
  const RobotLimits& limits = builder.limits();
  const VelocitySpace dovs = builder.build(obs);
  const ActionSet actions = computeActions(obs.robot_twist, obs.robot_pose.toLocal(obs.goal), limits);
  const ShieldedMask m = shieldActions(actions, dovs, obs, shield);
  if (m.has_escape) return m.escape;
  Twist2 command = decelerationCommand(obs.robot_twist, limits);
  double worst = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < actions.velocities.size(); ++i) {
    if (!m.mask[i]) continue;
    const double sc =
        score(integrateUnicycle(obs.robot_pose, actions.velocities[i].v, actions.velocities[i].w, ahead_s));
    if (sc < worst) {
      worst = sc;
      command = actions.velocities[i];
    }
  }
  return command;
}

// The logged wall collision, reconstructed: 0.5 m/s with 0.30 m to the wall, heading 1.21 rad with the wall
// at pi/2 (the wall is the line y = y_wall), a person 0.57 m away moving off, the goal 6.5 m the other way.
// Whatever the network picks among what the shield allows (here the worst: the allowed action that closes on
// the wall fastest), and whenever it holds the escape, the robot never touches the wall.
TEST(StaticSafety, LoggedWallCollisionIsAvoidedWhateverTheNetworkPicks) {
  const RobotLimits limits;
  const ActionShieldConfig shield;
  const DovsConfig dovs_config;
  DovsBuilder builder(limits, dovs_config);
  const double y_wall = 0.2 + 0.30;
  const Segment wall{{-10.0, y_wall}, {10.0, y_wall}};
  Observation truth;
  truth.segments = {wall};
  Pose2 pose{0.0, 0.0, 1.21};  // as logged: closing on the wall at 0.5 sin(1.21) = 0.47 m/s
  Twist2 twist{0.5, 0.0};
  // The person: 0.57 m from the robot's surface, behind-left, walking away from it.
  MovingObstacle person = movingDisc(-0.6, -0.55, -2.6, 1.0);
  person.radius = 0.25;
  const Vec2 goal = pose.toWorld({-6.5, 0.0});
  double least = std::numeric_limits<double>::infinity();
  for (int step = 0; step < 25; ++step) {
    Observation obs;
    obs.robot_pose = pose;
    obs.robot_twist = twist;
    obs.goal = goal;
    obs.segments = {wall};
    obs.obstacles = {person};
    // The worst network: the allowed action that heads for the wall fastest.
    const Twist2 command =
        adversarialCommand(obs, builder, shield, limits.dt, [](const Pose2& next) { return -next.y; });
    least = std::min(least, drive(pose, twist, command, limits, truth));
    person.center += person.speed * limits.dt * Vec2(std::cos(person.heading), std::sin(person.heading));
  }
  EXPECT_GT(least, 0.0) << "the robot touched the wall";
  EXPECT_LT(pose.y + 0.2, y_wall);
}

// Property: from random states in which stopping is still possible, in random rooms with walls and static
// discs, the adversarial choice among the allowed actions (the one that brings the robot closest to static
// geometry), or the escape when there is one, never touches static geometry over 30 periods.
TEST(StaticSafety, AdversarialChoicesNeverTouchStaticGeometry) {
  std::mt19937 rng(13);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  const RobotLimits limits;
  const ActionShieldConfig shield;
  DovsBuilder builder(limits, DovsConfig{});
  int runs = 0, near_misses = 0;
  for (int k = 0; k < 60; ++k) {
    Observation world;
    const double half = 1.5 + 2.0 * u01(rng);
    world.segments = {Segment{{-half, -half}, {half, -half}}, Segment{{half, -half}, {half, half}},
                      Segment{{half, half}, {-half, half}}, Segment{{-half, half}, {-half, -half}}};
    const int discs = static_cast<int>(u01(rng) * 5);
    for (int i = 0; i < discs; ++i) {
      world.obstacles.push_back(movingDisc((u01(rng) * 2 - 1) * (half - 0.3), (u01(rng) * 2 - 1) * (half - 0.3)));
    }
    Pose2 pose{(u01(rng) * 2 - 1) * (half - 0.5), (u01(rng) * 2 - 1) * (half - 0.5), (u01(rng) * 2 - 1) * kPi};
    if (staticClearance(world, pose.position()) < 0.1) continue;
    const double v = u01(rng) * limits.v_max;
    Twist2 twist{v, (u01(rng) * 2 - 1) * limits.wLimitAt(v)};
    // Start only where the strongest braking (the real one, at the full limits) stops short of everything.
    {
      Observation here = world;
      here.robot_pose = pose;
      StaticSafetyConfig real;
      real.latency_s = 0.0;
      real.braking_fraction = 1.0;
      real.margin_m = 0.0;
      const StaticScene scene(here, limits, real);
      if (!brakingPath(scene, twist, decelerationCommand(twist, limits), limits, real).safe) continue;
    }
    ++runs;
    const Vec2 goal{(u01(rng) * 2 - 1) * half, (u01(rng) * 2 - 1) * half};
    double least = std::numeric_limits<double>::infinity();
    for (int step = 0; step < 30; ++step) {
      Observation obs = world;
      obs.robot_pose = pose;
      obs.robot_twist = twist;
      obs.goal = goal;
      const Twist2 command = adversarialCommand(obs, builder, shield, 2 * limits.dt, [&](const Pose2& next) {
        return staticClearance(world, next.position());
      });
      least = std::min(least, drive(pose, twist, command, limits, world));
    }
    ASSERT_GT(least, 0.0) << "run " << k << " touched static geometry";
    near_misses += least < 0.1 ? 1 : 0;
  }
  EXPECT_GT(runs, 30);
  EXPECT_GT(near_misses, 5);  // the adversary does press against the geometry
}

// The escape's order on constructed scenes: no contact > at rest before contact > lowest speed at contact.
TEST(PassiveEscape, PrefersRestBeforeContactOverTheLatestMovingContact) {
  // 0.6 m/s down a 0.9 m corridor; a disc comes head-on at 0.9 m/s from 2.5 m: no velocity avoids it (no room to
  // pass, no reverse), braking comes to rest well before it arrives, driving on meets it moving.
  const RobotLimits limits;
  Observation obs;
  obs.robot_twist = {0.6, 0.0};
  obs.goal = {4.0, 0.0};
  obs.obstacles = {movingDisc(2.5, 0.0, kPi, 0.9)};
  obs.segments = {Segment{{-3.0, 0.45}, {3.0, 0.45}}, Segment{{-3.0, -0.45}, {3.0, -0.45}}};
  ActionShieldConfig config;
  const Escape e = searchEscapeTiered(obs, limits, DovsConfig{}.safety_factor, config);
  ASSERT_EQ(e.tier, EscapeTier::kRest) << escapeTierName(e.tier);
  // The chosen velocity's braking comes to rest before any true contact.
  const LocalScene scene(obs, limits.radius, DovsConfig{}.safety_factor);
  for (const BrakingSample& s : brakingSamples(obs.robot_twist, e.velocity, limits, config.statics)) {
    if (s.speed_mps <= config.rest_speed_mps) break;
    bool inflated = false;
    EXPECT_GE(scene.clearance(s.position, s.t_s, inflated), 0.0) << "contact while moving at t = " << s.t_s;
  }
  // The escape of the previous release (latest contact) drives on.
  config.passive_escape = false;
  const Escape old = searchEscapeTiered(obs, limits, DovsConfig{}.safety_factor, config);
  EXPECT_GE(old.velocity.v, e.velocity.v);
}

TEST(PassiveEscape, WithNoStopBeforeContactTheLowestContactSpeedWins) {
  // A disc coming head-on, fast, from close by: no braking trajectory from 0.7 m/s ends before it arrives.
  const RobotLimits limits;
  Observation obs;
  obs.robot_twist = {0.7, 0.0};
  obs.goal = {4.0, 0.0};
  MovingObstacle big = movingDisc(0.75, 0.0, kPi, 1.2);
  big.radius = 0.6;
  obs.obstacles = {big};
  obs.segments = {Segment{{-3.0, 0.45}, {3.0, 0.45}}, Segment{{-3.0, -0.45}, {3.0, -0.45}}};  // a corridor
  const ActionShieldConfig config;
  const Escape e = searchEscapeTiered(obs, limits, DovsConfig{}.safety_factor, config);
  ASSERT_EQ(e.tier, EscapeTier::kSlowest) << escapeTierName(e.tier);
  // No lattice velocity of the window meets the disc slower than the escape.
  const LocalScene scene(obs, limits.radius, DovsConfig{}.safety_factor);
  const StaticScene statics(obs, limits, config.statics);
  auto contactSpeed = [&](const Twist2& u) {
    for (const BrakingSample& s : brakingSamples(obs.robot_twist, u, limits, StaticSafetyConfig{})) {
      if (s.speed_mps <= config.rest_speed_mps) return 0.0;
      bool inflated = false;
      if (scene.clearance(s.position, s.t_s, inflated) < 0.0) return s.speed_mps;
    }
    return 0.0;
  };
  EXPECT_GT(e.contact_speed_mps, 0.0);
  for (const Twist2& u : makeDynamicWindow(obs.robot_twist, limits).samples(5, limits)) {
    if (!brakingPath(statics, obs.robot_twist, u, limits, config.statics).safe) continue;
    EXPECT_GE(contactSpeed(u), e.contact_speed_mps - 0.02) << u.v << " " << u.w;
  }
  // And it brakes: the strongest braking of the window.
  EXPECT_NEAR(e.velocity.v, obs.robot_twist.v - limits.dv(), 1e-9);
}

TEST(PassiveEscape, NeverIntoAWallToDodgeAPerson) {
  // A wall 0.25 m to the left, a person closing fast from the right: the latest-contact escape of the previous
  // release swerved into the wall (the wall is "reached later"); the passive escape does not.
  const RobotLimits limits;
  Observation obs;
  obs.robot_twist = {0.4, 0.8};
  obs.goal = {4.0, 0.0};
  obs.segments = {Segment{{-3.0, 0.45}, {3.0, 0.45}}};
  obs.obstacles = {movingDisc(0.4, -0.9, kPi / 2, 1.2)};
  const ActionShieldConfig config;
  const Escape e = searchEscapeTiered(obs, limits, DovsConfig{}.safety_factor, config);
  ASSERT_NE(e.tier, EscapeTier::kUnsafe);
  const StaticScene statics(obs, limits, config.statics);
  EXPECT_TRUE(brakingPath(statics, obs.robot_twist, e.velocity, limits, config.statics).safe);
}

}  // namespace
}  // namespace dqn_dovs
