// DWA: admissibility and scoring of the simulated samples, and closed-loop episodes (empty room, a static obstacle on
// the way, a crossing obstacle), with every command checked against the dynamic window.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "dqn_dovs/evaluation/episode.h"
#include "dqn_dovs/planning/dwa.h"
#include "dqn_dovs/sim/scenario.h"

namespace dqn_dovs {
namespace {

EpisodeConfig perfectInfo() {
  EpisodeConfig c;
  c.perfect_info = true;
  return c;
}

sim::Scenario scenario(const Pose2& start, const Vec2& goal, std::vector<MovingObstacle> obstacles = {}) {
  sim::Scenario s;
  s.name = "dwa test";
  s.robot_start = start;
  s.goal = goal;
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

/// Runs the episode to its end; every command must lie in the dynamic window and the feasible set.
void drive(Episode& ep, DwaPlanner& planner) {
  planner.reset();
  while (!ep.done()) {
    const PlannerDecision d = planner.decide(ep.plannerInput());
    const RobotLimits& limits = ep.config().world.robot;
    ASSERT_TRUE(makeDynamicWindow(ep.observation().robot_twist, limits).contains(d.command, limits, 1e-9))
        << "step " << ep.steps() << " note " << d.note;
    ep.step(d.command);
  }
}

TEST(Dwa, StopsOnTheGoalInAnEmptyRoom) {
  struct Case {
    Pose2 start;
    Vec2 goal;
  };
  // Ahead, to the side, behind (turn first), and close to a wall.
  const Case cases[] = {{{-3.0, 0.0, 0.0}, {3.0, 0.5}},
                        {{-2.0, -2.0, 0.0}, {-1.0, 2.5}},
                        {{2.0, 0.0, 0.0}, {-2.5, -1.0}},
                        {{0.0, 0.0, 0.0}, {3.5, 3.5}}};
  for (const Case& c : cases) {
    Episode ep(perfectInfo());
    ep.reset(scenario(c.start, c.goal), 1);
    DwaPlanner planner;
    drive(ep, planner);
    ASSERT_EQ(ep.outcome(), Outcome::kSuccess) << "goal (" << c.goal.transpose() << "): " << outcomeName(ep.outcome())
                                               << " at " << ep.world().robotPose().position().transpose();
    EXPECT_LT((ep.world().robotPose().position() - c.goal).norm(), 0.15);
    EXPECT_LT(ep.world().robotTwist().v, 0.2);
    EXPECT_GT(ep.minClearance_m(), 0.0);
    const double d = (c.start.position() - c.goal).norm();
    EXPECT_LT(ep.time_s(), 2.0 * d / 0.7 + 4.0);
    EXPECT_LT(ep.pathLength_m(), 1.4 * d);
  }
}

TEST(Dwa, AvoidsAStaticObstacleOnTheWay) {
  for (const Vec2& c : {Vec2(0.0, 0.0), Vec2(0.0, 0.1), Vec2(-1.0, -0.15)}) {
    Episode ep(perfectInfo());
    ep.reset(scenario({-3.0, 0.0, 0.0}, {3.0, 0.0}, {staticDisc(c)}), 1);
    DwaPlanner planner;
    drive(ep, planner);
    EXPECT_EQ(ep.outcome(), Outcome::kSuccess) << "obstacle at " << c.transpose() << ": " << outcomeName(ep.outcome())
                                               << " at " << ep.world().robotPose().position().transpose();
    EXPECT_GT(ep.minClearance_m(), 0.0);
    // It went around: at x = obstacle's x the robot was off the line by more than the two radii.
    double offset_at_obstacle = 0.0;
    for (const Pose2& p : ep.trajectory()) {
      if (std::abs(p.x - c.x()) < 0.1) offset_at_obstacle = std::max(offset_at_obstacle, std::abs(p.y - c.y()));
    }
    EXPECT_GT(offset_at_obstacle, 0.4);
    std::printf("static obstacle at (%.2f, %.2f): %d steps, min clearance %.3f m\n", c.x(), c.y(), ep.steps(),
                ep.minClearance_m());
  }
}

TEST(Dwa, PredictsACrossingObstacle) {
  MovingObstacle o;
  o.radius = 0.2;
  o.heading = kPi / 2.0;
  o.speed = 0.5;
  o.center = Vec2(0.0, -0.5 * (3.0 / 0.7 + 0.9));  // meets a robot driving straight at v_max near x = 0
  Episode ep(perfectInfo());
  ep.reset(scenario({-3.0, 0.0, 0.0}, {3.0, 0.0}, {o}), 1);
  DwaPlanner planner;
  drive(ep, planner);
  EXPECT_EQ(ep.outcome(), Outcome::kSuccess) << outcomeName(ep.outcome());
  EXPECT_GT(ep.minClearance_m(), 0.0);
}

TEST(Dwa, BrakingAdmissibilityBeforeAWall) {
  // 0.45 m from touching the wall (robot radius 0.2, wall at x = 4), moving at 0.5 m/s straight at it.
  Observation obs;
  obs.robot_pose = Pose2{3.35, 0.0, 0.0};
  obs.robot_twist = Twist2{0.5, 0.0};
  obs.goal = Vec2(3.9, 0.0);  // behind the wall's inflation: every straight sample runs into the wall
  obs.segments = {Segment{Vec2(4.0, -4.0), Vec2(4.0, 4.0)}};
  DwaConfig config;
  config.vth_samples = 1;  // straight samples only
  config.vx_samples = 5;   // 0.4, 0.45, ..., 0.6 m/s
  config.braking_fraction = 1.0;
  config.goal_tolerance_m = 0.0;
  DwaPlanner planner(config);
  const RobotLimits limits;
  const std::vector<DwaTrajectory> samples = planner.evaluate(obs, limits);
  ASSERT_EQ(samples.size(), 5u);
  for (const DwaTrajectory& t : samples) {
    EXPECT_TRUE(t.contact);
    // Contact where the clearance falls below the 0.05 m margin: 0.40 m ahead (to the sampling step).
    EXPECT_NEAR(t.contact_distance_m, 0.40, 0.03);
    const double v = t.velocity.v;
    EXPECT_EQ(t.admissible, v * v / (2.0 * limits.a_v) + v * config.stop_time_buffer_s <= t.contact_distance_m)
        << "v = " << v;
  }
  EXPECT_TRUE(samples.front().admissible);  // 0.4 m/s: 0.16 + 0.08 m of braking
  EXPECT_FALSE(samples.back().admissible);  // 0.6 m/s: 0.36 + 0.12 m > 0.40 m
}

TEST(Dwa, ClearanceTermPrefersTheWiderPassage) {
  // Two static discs ahead, a narrow gap on the left side of the line and open space on the right.
  Observation obs;
  obs.robot_pose = Pose2{0.0, 0.0, 0.0};
  obs.robot_twist = Twist2{0.3, 0.0};
  obs.goal = Vec2(3.0, 0.0);
  obs.obstacles = {staticDisc(Vec2(1.0, 0.15)), staticDisc(Vec2(1.0, 0.75))};
  DwaPlanner planner;
  const PlannerDecision d = planner.decide([&] {
    PlannerInput in;
    in.observation = &obs;
    return in;
  }());
  EXPECT_LT(d.command.w, 0.0) << d.note;  // turns right, away from both discs
}

TEST(Dwa, StopsInsideTheGoalToleranceAndRejectsBadInput) {
  Observation obs;
  obs.robot_pose = Pose2{1.0, 1.0, 0.3};
  obs.robot_twist = Twist2{0.3, 0.5};
  obs.goal = Vec2(1.05, 1.0);
  DwaPlanner planner;
  PlannerInput in;
  in.observation = &obs;
  const PlannerDecision d = planner.decide(in);
  EXPECT_EQ(d.note, "stop_on_goal");
  EXPECT_NEAR(d.command.v, 0.2, 1e-12);
  in.observation = nullptr;
  EXPECT_THROW(planner.decide(in), PlannerError);
  obs.robot_twist.v = std::nan("");
  in.observation = &obs;
  EXPECT_THROW(planner.decide(in), PlannerError);
  // A non-finite obstacle is ignored.
  obs.robot_twist.v = 0.3;
  obs.goal = Vec2(3.0, 1.0);
  MovingObstacle bad;
  bad.center = Vec2(1.5, std::nan(""));
  obs.obstacles = {bad};
  const PlannerDecision ok = planner.decide(in);
  EXPECT_TRUE(std::isfinite(ok.command.v) && std::isfinite(ok.command.w));
  EXPECT_EQ(ok.note, "dwa");
}

TEST(Dwa, ConfigValidateNamesTheField) {
  DwaConfig c;
  EXPECT_EQ(c.validate(), "");
  c.vx_samples = 0;
  EXPECT_NE(c.validate().find("vx_samples"), std::string::npos);
  c = DwaConfig();
  c.occdist_scale = -1.0;
  EXPECT_NE(c.validate().find("occdist_scale"), std::string::npos);
  c = DwaConfig();
  c.sim_time_s = std::nan("");
  EXPECT_NE(c.validate().find("sim_time_s"), std::string::npos);
  EXPECT_THROW(DwaPlanner{c}, PlannerError);
  EXPECT_EQ(makeDwaPlanner()->name(), "dwa");
}

}  // namespace
}  // namespace dqn_dovs
