// ORCA: the linear program against brute force, the velocity-obstacle half-planes, both planners in closed-loop
// episodes, the differential-drive mapping, and the holonomic execution path of World and Episode.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "dqn_dovs/evaluation/episode.h"
#include "dqn_dovs/planning/orca.h"
#include "dqn_dovs/sim/scenario.h"
#include "dqn_dovs/sim/world.h"

namespace dqn_dovs {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

OrcaLine randomLine(std::mt19937_64& rng, double spread) {
  std::uniform_real_distribution<double> u(-spread, spread), angle(-kPi, kPi);
  const double a = angle(rng);
  return OrcaLine{Vec2(u(rng), u(rng)), Vec2(std::cos(a), std::sin(a))};
}

/// Brute-force optimum of the program on a grid of spacing h over the speed disc: the best feasible distance to
/// `preferred` (inf when no grid point is feasible) and the least largest violation of the soft lines among the
/// grid points that keep the hard ones (inf when none does).
struct Brute {
  double best_feasible_distance = kInf;
  double least_soft_violation = kInf;
};

Brute bruteForce(const std::vector<OrcaLine>& lines, size_t num_hard, double radius, const Vec2& preferred, double h) {
  Brute out;
  for (double x = -radius; x <= radius; x += h) {
    for (double y = -radius; y <= radius; y += h) {
      const Vec2 v(x, y);
      if (v.norm() > radius) continue;
      double hard = 0.0, soft = 0.0;
      for (size_t i = 0; i < lines.size(); ++i) {
        const double violation = std::max(0.0, -lines[i].margin(v));
        (i < num_hard ? hard : soft) = std::max(i < num_hard ? hard : soft, violation);
      }
      if (hard > 0.0) continue;
      out.least_soft_violation = std::min(out.least_soft_violation, soft);
      if (soft == 0.0) out.best_feasible_distance = std::min(out.best_feasible_distance, (v - preferred).norm());
    }
  }
  return out;
}

TEST(OrcaLp, MatchesBruteForceOnRandomProblems) {
  std::mt19937_64 rng(42);
  std::uniform_int_distribution<int> count(1, 6);
  std::uniform_real_distribution<double> u(-1.5, 1.5);
  const double radius = 1.0, h = 0.01;
  int feasible = 0, infeasible = 0;
  for (int trial = 0; trial < 300; ++trial) {
    std::vector<OrcaLine> lines;
    const int n = count(rng);
    for (int i = 0; i < n; ++i) lines.push_back(randomLine(rng, 1.2));
    const Vec2 preferred(u(rng), u(rng));
    std::mt19937_64 order(static_cast<uint64_t>(trial));
    const OrcaLpResult lp = solveOrcaLp(lines, 0, radius, preferred, &order);
    const Brute brute = bruteForce(lines, 0, radius, preferred, h);
    ASSERT_TRUE(lp.velocity.allFinite());
    EXPECT_LE(lp.velocity.norm(), radius + 1e-9) << "trial " << trial;
    // The reported violation is the real one (recomputed here, independently of the solver).
    double violation = 0.0;
    for (const OrcaLine& l : lines) violation = std::max(violation, -l.margin(lp.velocity));
    EXPECT_NEAR(lp.max_violation, violation, 1e-12);
    if (lp.feasible) {
      ++feasible;
      EXPECT_LE(violation, 1e-9) << "trial " << trial;
      // The exact optimum is at least as close to the preferred velocity as the best feasible grid point (a
      // feasible sliver thinner than the grid may hold no grid point at all).
      if (std::isfinite(brute.best_feasible_distance)) {
        EXPECT_LE((lp.velocity - preferred).norm(), brute.best_feasible_distance + 1e-9) << "trial " << trial;
      }
    } else {
      ++infeasible;
      // No grid point may satisfy every line, and the 3-D fallback must reach the least largest violation.
      EXPECT_FALSE(std::isfinite(brute.best_feasible_distance)) << "trial " << trial;
      EXPECT_GT(violation, 0.0);
      EXPECT_LE(violation, brute.least_soft_violation + 1e-6) << "trial " << trial;
    }
  }
  // The random problems exercise both branches.
  EXPECT_GT(feasible, 50);
  EXPECT_GT(infeasible, 30);
}

TEST(OrcaLp, KeepsHardLinesWhenTheSoftOnesConflict) {
  std::mt19937_64 rng(7);
  const double radius = 1.0, h = 0.01;
  int checked = 0;
  for (int trial = 0; trial < 300 && checked < 60; ++trial) {
    std::vector<OrcaLine> lines;
    for (int i = 0; i < 2; ++i) lines.push_back(randomLine(rng, 0.5));  // hard: usually compatible near the origin
    for (int i = 0; i < 4; ++i) lines.push_back(randomLine(rng, 1.2));
    const Vec2 preferred(0.3, -0.2);
    const Brute brute = bruteForce(lines, 2, radius, preferred, h);
    if (!std::isfinite(brute.least_soft_violation) || std::isfinite(brute.best_feasible_distance)) continue;
    ++checked;  // hard lines compatible, soft ones not
    const OrcaLpResult lp = solveOrcaLp(lines, 2, radius, preferred);
    EXPECT_FALSE(lp.feasible);
    for (size_t i = 0; i < 2; ++i) EXPECT_GE(lines[i].margin(lp.velocity), -1e-6) << "trial " << trial;
    double soft = 0.0;
    for (size_t i = 2; i < lines.size(); ++i) soft = std::max(soft, -lines[i].margin(lp.velocity));
    EXPECT_LE(soft, brute.least_soft_violation + 1e-6) << "trial " << trial;
  }
  EXPECT_GE(checked, 20);
}

TEST(OrcaLp, ReturnsThePreferredVelocityWhenUnconstrained) {
  const OrcaLpResult inside = solveOrcaLp({}, 0, 1.0, Vec2(0.3, 0.4));
  EXPECT_NEAR((inside.velocity - Vec2(0.3, 0.4)).norm(), 0.0, 1e-12);
  const OrcaLpResult outside = solveOrcaLp({}, 0, 1.0, Vec2(3.0, 4.0));
  EXPECT_NEAR((outside.velocity - Vec2(0.6, 0.8)).norm(), 0.0, 1e-12);
  const OrcaLpResult nan = solveOrcaLp({}, 0, 1.0, Vec2(std::nan(""), 0.0));
  EXPECT_TRUE(nan.velocity.allFinite());
  // A non-finite line is dropped; a non-finite speed limit stops the robot.
  const std::vector<OrcaLine> odd = {OrcaLine{Vec2(std::nan(""), 0.0), Vec2::UnitX()},
                                     OrcaLine{Vec2(0.0, 0.5), Vec2(-1.0, 0.0)}};  // allowed: y <= 0.5
  const OrcaLpResult dropped = solveOrcaLp(odd, 1, 1.0, Vec2(0.0, 0.9));
  EXPECT_TRUE(dropped.feasible);
  EXPECT_NEAR((dropped.velocity - Vec2(0.0, 0.5)).norm(), 0.0, 1e-12);
  const OrcaLpResult stopped = solveOrcaLp({}, 0, std::nan(""), Vec2(0.3, 0.0));
  EXPECT_NEAR(stopped.velocity.norm(), 0.0, 1e-12);
}

/// Robot at the origin moving at v: does it come within R of segment [a, b] within the horizon? (Time sampling.)
bool collidesWithin(const Vec2& a, const Vec2& b, double R, double horizon, const Vec2& v) {
  for (int k = 1; k <= 600; ++k) {
    const double t = horizon * k / 600.0;
    if (pointSegmentDistance(v * t, Segment{a, b}) < R) return true;
  }
  return false;
}

TEST(OrcaHalfPlane, HeadOnDiscCutOffAndLeg) {
  // Obstacle 5 m ahead, combined radius 1 m, horizon 2 s: the cut-off disc is centred at (2.5, 0) with radius 0.5.
  const Vec2 p(5.0, 0.0);
  VelocityObstacleProjection slow = projectOnVelocityObstacle(p, p, 1.0, 2.0, Vec2(1.0, 0.0), 0.2);
  EXPECT_FALSE(slow.inside);
  EXPECT_FALSE(slow.overlapping);
  EXPECT_NEAR((slow.boundary_point - Vec2(2.0, 0.0)).norm(), 0.0, 1e-9);
  EXPECT_NEAR((slow.normal - Vec2(-1.0, 0.0)).norm(), 0.0, 1e-9);

  // 3 m/s straight at it: inside; the legs (half-angle asin(0.2)) are 3 sin(asin 0.2) = 0.6 away, the cut-off 1.
  VelocityObstacleProjection fast = projectOnVelocityObstacle(p, p, 1.0, 2.0, Vec2(3.0, 0.0), 0.2);
  EXPECT_TRUE(fast.inside);
  EXPECT_NEAR((fast.boundary_point - Vec2(3.0, 0.0)).norm(), 0.6, 1e-9);
  EXPECT_NEAR(std::abs(fast.normal.y()), std::cos(std::asin(0.2)), 1e-9);
  EXPECT_GT(fast.normal.y() * fast.boundary_point.y(), 0.0);  // points away from the obstacle's axis

  // The ORCA line of the robot for the slow case: full responsibility, the line passes through (2, 0).
  const OrcaLine line = orcaLineForDisc(Vec2::Zero(), Vec2(1.0, 0.0), 0.5, p, Vec2::Zero(), 0.5, 2.0, 0.2);
  EXPECT_GT(line.margin(Vec2(1.0, 0.0)), 0.0);
  EXPECT_NEAR(line.margin(Vec2(2.0, 0.7)), 0.0, 1e-9);
  EXPECT_LT(line.margin(Vec2(2.5, 0.0)), 0.0);
  // A moving obstacle shifts the line by its velocity.
  const OrcaLine moving = orcaLineForDisc(Vec2::Zero(), Vec2(1.5, 0.0), 0.5, p, Vec2(0.5, 0.0), 0.5, 2.0, 0.2);
  EXPECT_NEAR(moving.margin(Vec2(2.5, 0.3)), 0.0, 1e-9);
}

TEST(OrcaHalfPlane, OverlappingDiscAsksToLeaveWithinOneStep) {
  // Centres 0.8 apart, combined radius 1: the robot must move away at (1 - 0.8) / 0.2 = 1 m/s at least.
  const OrcaLine line = orcaLineForDisc(Vec2::Zero(), Vec2::Zero(), 0.5, Vec2(0.8, 0.0), Vec2::Zero(), 0.5, 2.0, 0.2);
  EXPECT_LT(line.margin(Vec2::Zero()), 0.0);
  EXPECT_NEAR(line.margin(Vec2(-1.0, 0.0)), 0.0, 1e-9);
  EXPECT_GT(line.margin(Vec2(-1.2, 0.0)), 0.0);
}

TEST(OrcaHalfPlane, NearestBoundaryMatchesBruteForceForDiscsAndSegments) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-3.0, 3.0);
  const double horizon = 1.5, R = 0.5, h = 0.03;
  int checked = 0;
  for (int trial = 0; trial < 40; ++trial) {
    const Vec2 a(u(rng), u(rng));
    const Vec2 b = trial % 2 == 0 ? a : Vec2(a + Vec2(u(rng), u(rng)) * 0.5);
    if (pointSegmentDistance(Vec2::Zero(), Segment{a, b}) < R + 0.1) continue;
    const Vec2 v(u(rng) * 0.7, u(rng) * 0.7);
    const VelocityObstacleProjection proj = projectOnVelocityObstacle(a, b, R, horizon, v, 0.2);
    const bool v_inside = collidesWithin(a, b, R, horizon, v);
    if (std::abs((proj.boundary_point - v).norm()) < 0.03) continue;  // too close to the boundary for sampling
    ++checked;
    EXPECT_EQ(proj.inside, v_inside) << "trial " << trial;
    // The boundary point separates: a little along the normal is free, a little against it is in the obstacle.
    EXPECT_FALSE(collidesWithin(a, b, R, horizon, proj.boundary_point + 0.01 * proj.normal)) << "trial " << trial;
    EXPECT_TRUE(collidesWithin(a, b, R, horizon, proj.boundary_point - 0.01 * proj.normal)) << "trial " << trial;
    // No velocity of the other kind (inside vs outside) is closer to v than the boundary point.
    const double d = (proj.boundary_point - v).norm();
    for (double x = -d; x <= d; x += h) {
      for (double y = -d; y <= d; y += h) {
        const Vec2 q = v + Vec2(x, y);
        if ((q - v).norm() >= d - h) continue;
        ASSERT_EQ(collidesWithin(a, b, R, horizon, q), v_inside) << "trial " << trial << " probe " << q.transpose();
      }
    }
  }
  EXPECT_GE(checked, 15);
}

TEST(OrcaHalfPlane, WallLineStopsTheRobotBeforeTheWall) {
  // A wall 1 m ahead across the path; robot radius 0.2, horizon 1 s: at most 0.8 m/s toward it.
  const Segment wall{Vec2(1.0, -2.0), Vec2(1.0, 2.0)};
  const OrcaLine line = orcaLineForSegment(Vec2::Zero(), Vec2(1.0, 0.0), 0.2, wall, 1.0, 0.2);
  EXPECT_NEAR(line.margin(Vec2(0.8, 0.0)), 0.0, 1e-9);
  EXPECT_NEAR(line.margin(Vec2(0.8, 0.5)), 0.0, 1e-9);
  EXPECT_GT(line.margin(Vec2(0.0, 1.0)), 0.0);  // sliding along it is allowed
  EXPECT_LT(line.margin(Vec2(1.0, 0.0)), 0.0);
}

TEST(OrcaConfig, ValidateNamesTheField) {
  OrcaConfig c;
  EXPECT_EQ(c.validate(), "");
  c.time_horizon_s = 0.0;
  EXPECT_NE(c.validate().find("time_horizon_s"), std::string::npos);
  c = OrcaConfig();
  c.max_neighbors = 0;
  EXPECT_NE(c.validate().find("max_neighbors"), std::string::npos);
  c = OrcaConfig();
  c.tracking_time_s = std::nan("");
  EXPECT_NE(c.validate().find("tracking_time_s"), std::string::npos);
  EXPECT_THROW(OrcaDiffDrivePlanner{c}, PlannerError);
}

TEST(OrcaDiffDrive, MappingStaysInTheDynamicWindow) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0), unit(0.0, 1.0);
  const RobotLimits limits;
  for (int trial = 0; trial < 500; ++trial) {
    Twist2 current{unit(rng) * limits.v_max, 0.0};
    current.w = u(rng) * limits.wLimitAt(current.v);
    const Pose2 pose{u(rng) * 3.0, u(rng) * 3.0, u(rng) * kPi};
    const Vec2 velocity(u(rng), u(rng));
    const Twist2 cmd = mapVelocityToWindow(pose, current, velocity, limits, 10, 0.8, 0.2);
    EXPECT_TRUE(makeDynamicWindow(current, limits).contains(cmd, limits, 1e-9)) << "trial " << trial;
  }
  // Straight ahead at full speed: accelerate without turning; straight behind: slow down and turn.
  const Twist2 ahead = mapVelocityToWindow(Pose2{}, Twist2{0.3, 0.0}, Vec2(0.7, 0.0), limits, 10, 0.8, 0.2);
  EXPECT_NEAR(ahead.v, 0.4, 1e-9);
  EXPECT_NEAR(ahead.w, 0.0, 1e-9);
  const Twist2 behind = mapVelocityToWindow(Pose2{}, Twist2{0.3, 0.0}, Vec2(-0.5, 0.1), limits, 10, 0.8, 0.2);
  EXPECT_LT(behind.v, 0.3);
  // At rest with the velocity straight behind: turn toward it (the effective centre moves; the axle could not).
  const Twist2 turn = mapVelocityToWindow(Pose2{}, Twist2{0.0, 0.0}, Vec2(-0.5, 0.01), limits, 10, 0.8, 0.2);
  EXPECT_GT(std::abs(turn.w), 0.3);
  // Non-finite input falls back to braking.
  const Twist2 nan = mapVelocityToWindow(Pose2{}, Twist2{0.3, 0.0}, Vec2(std::nan(""), 0.0), limits, 10, 0.8, 0.2);
  EXPECT_NEAR(nan.v, 0.2, 1e-9);
}

EpisodeConfig perfectInfo() {
  EpisodeConfig c;
  c.perfect_info = true;
  return c;
}

sim::Scenario scenarioWith(std::vector<MovingObstacle> obstacles) {
  sim::Scenario s;
  s.name = "orca test";
  s.robot_start = Pose2{-3.0, 0.0, 0.0};
  s.goal = Vec2(3.0, 0.0);
  s.obstacles = std::move(obstacles);
  return s;
}

MovingObstacle staticDisc(const Vec2& c) {
  MovingObstacle o;
  o.center = c;
  o.radius = 0.2;
  o.is_static = true;
  return o;
}

/// An obstacle crossing the start-goal line from below, timed to meet a robot driving straight at v_max.
MovingObstacle crossingDisc() {
  MovingObstacle o;
  o.radius = 0.2;
  o.heading = kPi / 2.0;
  o.speed = 0.5;
  // The robot needs about 4.3 s (+0.3 s warm-up) to reach x = 0; the obstacle crosses y = 0 then.
  o.center = Vec2(0.0, -0.5 * (3.0 / 0.7 + 0.3 + 0.6));
  return o;
}

/// Drives the episode with `planner`; checks every diff-drive command lies in the dynamic window.
void drive(Episode& ep, Planner& planner, bool holonomic) {
  planner.reset();
  while (!ep.done()) {
    const PlannerDecision d = planner.decide(ep.plannerInput());
    const RobotLimits& limits = ep.config().world.robot;
    if (!holonomic) {
      ASSERT_TRUE(makeDynamicWindow(ep.observation().robot_twist, limits).contains(d.command, limits, 1e-9))
          << "step " << ep.steps();
      ASSERT_FALSE(d.holonomic_velocity.has_value());
    } else {
      ASSERT_TRUE(d.holonomic_velocity.has_value());
      ASSERT_LE(d.holonomic_velocity->norm(), limits.v_max + 1e-9);
    }
    ep.stepDecision(d);
  }
}

TEST(OrcaEpisode, TheCrossingObstacleIsOnACollisionCourse) {
  Episode ep(perfectInfo());
  ep.reset(scenarioWith({crossingDisc()}), 1);
  while (!ep.done()) ep.stepHolonomic(Vec2(0.7, 0.0));
  EXPECT_EQ(ep.outcome(), Outcome::kCollision);
}

TEST(OrcaEpisode, BothVariantsReachTheGoalPastAStaticAndACrossingDisc) {
  const std::vector<std::vector<MovingObstacle>> cases = {
      {}, {staticDisc(Vec2(0.0, 0.0))}, {crossingDisc()}, {staticDisc(Vec2(-0.5, 0.05)), crossingDisc()}};
  for (size_t k = 0; k < cases.size(); ++k) {
    for (bool holonomic : {true, false}) {
      Episode ep(perfectInfo());
      ep.reset(scenarioWith(cases[k]), 1);
      OrcaHolonomicPlanner hol;
      OrcaDiffDrivePlanner diff;
      drive(ep, holonomic ? static_cast<Planner&>(hol) : static_cast<Planner&>(diff), holonomic);
      EXPECT_EQ(ep.outcome(), Outcome::kSuccess)
          << (holonomic ? "orca_holonomic" : "orca_diffdrive") << " case " << k << ": " << outcomeName(ep.outcome())
          << " after " << ep.steps() << " steps at " << ep.world().robotPose().position().transpose();
      EXPECT_GT(ep.minClearance_m(), 0.0);
      // A sensible path: at most 1.5 times the straight line, driven at no more than v_max.
      EXPECT_LT(ep.pathLength_m(), 1.5 * 6.0);
      EXPECT_GE(ep.pathLength_m(), 6.0 - 0.15);
      EXPECT_GE(ep.steps(), static_cast<int>((6.0 - 0.15) / (0.7 * 0.2)));
      std::printf("%s case %zu: %d steps, path %.2f m, min clearance %.3f m\n",
                  holonomic ? "orca_holonomic" : "orca_diffdrive", k, ep.steps(), ep.pathLength_m(),
                  ep.minClearance_m());
    }
  }
}

TEST(OrcaPlanner, NamesAndBadInput) {
  EXPECT_EQ(makeOrcaHolonomicPlanner()->name(), "orca_holonomic");
  EXPECT_EQ(makeOrcaDiffDrivePlanner()->name(), "orca_diffdrive");
  OrcaDiffDrivePlanner planner;
  PlannerInput in;
  EXPECT_THROW(planner.decide(in), PlannerError);
  Observation obs;
  obs.goal = Vec2(std::nan(""), 0.0);
  in.observation = &obs;
  EXPECT_THROW(planner.decide(in), PlannerError);
  // A NaN obstacle is skipped, not a crash.
  obs.goal = Vec2(2.0, 0.0);
  MovingObstacle bad;
  bad.center = Vec2(std::nan(""), 1.0);
  obs.obstacles.push_back(bad);
  const PlannerDecision d = planner.decide(in);
  EXPECT_TRUE(std::isfinite(d.command.v) && std::isfinite(d.command.w));
  EXPECT_GT(d.command.v, 0.0);
}

// --- Holonomic execution path (World::stepHolonomic, Episode::stepHolonomic / stepDecision) ---

sim::Scenario emptyRoom() {
  sim::Scenario s;
  s.name = "empty";
  s.robot_start = Pose2{0.0, 0.0, 0.0};
  s.goal = Vec2(3.0, 3.0);
  return s;
}

TEST(HolonomicMode, WorldMovesSidewaysWithoutAccelerationLimit) {
  sim::World world(emptyRoom(), sim::WorldConfig(), 1);
  world.stepHolonomic(Vec2(0.0, 0.5), 0.2);  // sideways at once: impossible for the unicycle
  EXPECT_NEAR(world.robotPose().x, 0.0, 1e-12);
  EXPECT_NEAR(world.robotPose().y, 0.1, 1e-12);
  EXPECT_NEAR(world.robotPose().theta, kPi / 2.0, 1e-12);
  EXPECT_NEAR(world.robotTwist().v, 0.5, 1e-12);
  EXPECT_NEAR(world.robotTwist().w, 0.0, 1e-12);
  world.stepHolonomic(Vec2(-3.0, 0.0), 0.2);  // clipped to v_max = 0.7
  EXPECT_NEAR(world.robotPose().x, -0.14, 1e-12);
  EXPECT_NEAR(world.robotTwist().v, 0.7, 1e-12);
  EXPECT_NEAR(std::abs(world.robotPose().theta), kPi, 1e-12);
  world.stepHolonomic(Vec2::Zero(), 0.2);  // a stop keeps the heading
  EXPECT_NEAR(std::abs(world.robotPose().theta), kPi, 1e-12);
  EXPECT_NEAR(world.robotTwist().v, 0.0, 1e-12);
  EXPECT_THROW(world.stepHolonomic(Vec2(1.0, 0.0), -0.1), sim::SimConfigError);
}

TEST(HolonomicMode, WorldStopsOnCollision) {
  sim::Scenario s = emptyRoom();
  s.obstacles.push_back(staticDisc(Vec2(1.0, 0.0)));
  sim::World world(s, sim::WorldConfig(), 1);
  for (int i = 0; i < 20; ++i) world.stepHolonomic(Vec2(0.7, 0.0), 0.2);
  EXPECT_TRUE(world.collided());
  EXPECT_LT(world.robotPose().x, 0.6 + 1e-9);  // put back to the last contact-free sub-step
  EXPECT_GT(world.robotPose().x, 0.5);
  EXPECT_NEAR(world.robotTwist().v, 0.0, 1e-12);
}

TEST(HolonomicMode, EpisodeDispatchesOnTheDecision) {
  Episode ep(perfectInfo());
  ep.reset(emptyRoom(), 1);
  PlannerDecision hol;
  hol.command = Twist2{0.1, 0.0};
  hol.holonomic_velocity = Vec2(0.0, 0.5);
  ep.stepDecision(hol);
  EXPECT_NEAR(ep.world().robotPose().y, 0.1, 1e-9);
  EXPECT_NEAR(ep.world().robotPose().x, 0.0, 1e-9);
  EXPECT_NEAR(ep.observation().robot_twist.v, 0.5, 1e-12);
  PlannerDecision diff;
  diff.command = Twist2{0.1, 0.0};
  ep.stepDecision(diff);  // back to the unicycle: the heading set by the holonomic step is kept
  // From 0.5 m/s the command is clipped to 0.4 m/s, which the world reaches at a_v over its two scan periods.
  EXPECT_NEAR(ep.world().robotPose().y, 0.1 + 0.45 * 0.1 + 0.4 * 0.1, 1e-9);
  EXPECT_EQ(ep.steps(), 2);
}

}  // namespace
}  // namespace dqn_dovs
