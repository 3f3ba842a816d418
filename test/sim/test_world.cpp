#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "dqn_dovs/sim/world.h"
#include "source_paths.h"

namespace dqn_dovs::sim {
namespace {

const std::string kRoom = std::string(DQN_DOVS_SCENARIOS_DIR) + "/room";

Scenario emptyRoom(Pose2 start = {}) {
  Scenario s;
  s.name = "test room";
  s.robot_start = start;
  s.goal = Vec2(3.0, 3.0);
  return s;
}

MovingObstacle disc(double x, double y, double heading, double speed, double turn_rate, double radius = 0.2) {
  MovingObstacle o;
  o.center = Vec2(x, y);
  o.heading = heading;
  o.speed = speed;
  o.turn_rate = turn_rate;
  o.radius = radius;
  o.is_static = speed == 0.0 && turn_rate == 0.0;
  return o;
}

TEST(WorldConfig, ValidateNamesTheBadField) {
  EXPECT_EQ(WorldConfig().validate(), "");
  WorldConfig c;
  c.physics_step_s = 0.0;
  EXPECT_NE(c.validate().find("physics_step_s"), std::string::npos);
  c = WorldConfig();
  c.border_turn_rate_rps = -0.65;
  EXPECT_NE(c.validate().find("border_turn_rate_rps"), std::string::npos);
  c = WorldConfig();
  c.robot.a_v = 0.0;
  EXPECT_NE(c.validate().find("a_v"), std::string::npos);
  c = WorldConfig();
  c.lidar.beams = -3;
  EXPECT_NE(c.validate().find("beams"), std::string::npos);
  EXPECT_THROW(World(emptyRoom(), c, 0), SimConfigError);
}

TEST(World, RejectsUnusableScenariosAndSteps) {
  WorldConfig c;
  Scenario outside = emptyRoom({4.5, 0.0, 0.0});
  try {
    World w(outside, c, 0);
    FAIL() << "a robot outside the room must be rejected";
  } catch (const ScenarioError& e) {
    EXPECT_NE(std::string(e.what()).find("test room"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("outside the room"), std::string::npos);
  }
  Scenario nan_obstacle = emptyRoom();
  nan_obstacle.obstacles.push_back(disc(std::nan(""), 0.0, 0.0, 0.5, 0.0));
  EXPECT_THROW(World(nan_obstacle, c, 0), ScenarioError);
  World w(emptyRoom(), c, 0);
  EXPECT_THROW(w.step({0.1, 0.0}, -0.1), SimConfigError);
  EXPECT_THROW(w.step({0.1, 0.0}, std::nan("")), SimConfigError);
  w.step({0.1, 0.0}, 0.0);
  EXPECT_EQ(w.time_s(), 0.0);
}

TEST(World, RobotIntegratesExactlyWithCommandsInsideTheDynamicWindow) {
  WorldConfig c;
  const Pose2 start{-1.0, 0.5, 0.4};
  World w(emptyRoom(start), c, 1);
  // Each command lies inside the dynamic window of the previous velocity (|dv| <= 0.1, |dw| <= 0.4).
  const Twist2 commands[] = {{0.1, 0.4}, {0.2, 0.6}, {0.3, 0.3}, {0.3, -0.1}, {0.25, -0.4}, {0.35, 0.0}};
  Pose2 expected = start;
  for (const Twist2& cmd : commands) {
    w.step(cmd, 0.2);
    expected = integrateUnicycle(expected, cmd.v, cmd.w, 0.2);
    EXPECT_NEAR(w.robotTwist().v, cmd.v, 1e-12);
    EXPECT_NEAR(w.robotTwist().w, cmd.w, 1e-12);
    EXPECT_NEAR(w.robotPose().x, expected.x, 1e-12);
    EXPECT_NEAR(w.robotPose().y, expected.y, 1e-12);
    EXPECT_NEAR(angleDiff(w.robotPose().theta, expected.theta), 0.0, 1e-12);
  }
  EXPECT_NEAR(w.time_s(), 1.2, 1e-12);
  EXPECT_FALSE(w.collided());
}

TEST(World, AccelerationLimitsAreRespected) {
  WorldConfig c;
  World w(emptyRoom({-3.0, 0.0, 0.0}), c, 1);
  w.step({0.7, 3.0}, 0.2);
  EXPECT_NEAR(w.robotTwist().v, 0.1, 1e-12);
  EXPECT_NEAR(w.robotTwist().w, 0.4, 1e-12);
  for (int k = 0; k < 3; ++k) w.step({0.7, 0.0}, 0.2);
  EXPECT_NEAR(w.robotTwist().v, 0.4, 1e-12);
  EXPECT_NEAR(w.robotTwist().w, 0.0, 1e-12);
  // A request outside the triangle ends on it.
  for (int k = 0; k < 10; ++k) w.step({0.7, 3.0}, 0.2);
  EXPECT_TRUE(c.robot.feasible(w.robotTwist(), 1e-9));

  // Ramp mode: the velocity changes by at most a_v per sub-step inside each 0.2 s step, so the robot covers
  // less ground than when it takes each step's reachable velocity at once.
  WorldConfig ramp = c;
  ramp.ramp_velocity = true;
  World r(emptyRoom({-3.0, 0.0, 0.0}), ramp, 1);
  World s(emptyRoom({-3.0, 0.0, 0.0}), c, 1);
  for (int k = 0; k < 5; ++k) {
    r.step({0.7, 0.0}, 0.2);
    s.step({0.7, 0.0}, 0.2);
    EXPECT_NEAR(r.robotTwist().v, 0.1 * (k + 1), 1e-9);
  }
  // Step mode: 0.2 s at each of 0.1 .. 0.5 m/s = 0.3 m. Ramp mode (0.05 s sub-steps, +0.025 m/s each):
  // 0.05 * 0.025 * (1 + ... + 20) = 0.2625 m, close to the continuous a t^2 / 2 = 0.25 m.
  EXPECT_NEAR(s.robotPose().x + 3.0, 0.3, 1e-9);
  EXPECT_NEAR(r.robotPose().x + 3.0, 0.2625, 1e-9);
}

TEST(World, NonFiniteCommandKeepsTheCurrentVelocity) {
  World w(emptyRoom(), WorldConfig(), 1);
  w.step({0.1, 0.2}, 0.2);
  w.step({std::nan(""), 0.0}, 0.2);
  EXPECT_NEAR(w.robotTwist().v, 0.1, 1e-12);
  EXPECT_NEAR(w.robotTwist().w, 0.2, 1e-12);
  EXPECT_TRUE(w.robotPose().isFinite());
}

TEST(World, ObstaclesMoveOnArcsAndStaticOnesNeverMove) {
  Scenario s = emptyRoom({-3.0, -3.0, 0.0});
  s.obstacles.push_back(disc(0.0, 0.0, 0.3, 0.5, 0.3));
  s.obstacles.push_back(disc(1.0, -1.0, 0.0, 0.8, 0.0));
  s.obstacles.push_back(disc(-1.0, 2.0, 1.0, 0.0, 0.0));
  World w(s, WorldConfig(), 1);
  for (int k = 0; k < 10; ++k) w.step({}, 0.2);
  const Pose2 arc = integrateUnicycle({0.0, 0.0, 0.3}, 0.5, 0.3, 2.0);
  EXPECT_NEAR(w.obstacles()[0].body.center.x(), arc.x, 1e-9);
  EXPECT_NEAR(w.obstacles()[0].body.center.y(), arc.y, 1e-9);
  EXPECT_NEAR(angleDiff(w.obstacles()[0].body.heading, arc.theta), 0.0, 1e-9);
  EXPECT_NEAR(w.obstacles()[1].body.center.x(), 2.6, 1e-9);
  EXPECT_EQ(w.obstacles()[2].body.center, Vec2(-1.0, 2.0));
  const auto truth = w.groundTruthObstacles();
  ASSERT_EQ(truth.size(), 3u);
  EXPECT_DOUBLE_EQ(truth[0].speed, 0.5);
  EXPECT_DOUBLE_EQ(truth[0].turn_rate, 0.3);
  EXPECT_TRUE(truth[2].is_static);
}

TEST(World, ObstacleTurnsAroundAtTheBorder) {
  Scenario s = emptyRoom({-3.0, -3.0, 0.0});
  s.obstacles.push_back(disc(3.0, 0.0, 0.0, 0.5, 0.0));
  WorldConfig c;
  World w(s, c, 1);
  // The disc (radius 0.2) touches the wall x = 4 when its centre reaches 3.8, at t = 1.6 s.
  while (w.time_s() < 1.7 - 1e-9) w.step({}, 0.05);
  const SimObstacle& o = w.obstacles()[0];
  EXPECT_EQ(o.motion, ObstacleMotion::kTurningAtBorder);
  EXPECT_EQ(o.border_turns, 1);
  EXPECT_NEAR(o.body.center.x(), 3.8, 1e-9);
  EXPECT_LE(o.body.center.x(), 3.8);
  EXPECT_NEAR(o.body.heading, 0.65 * 0.1, 1e-9);  // CCW (turn rate 0) for 0.1 s
  const auto truth = w.groundTruthObstacles();
  EXPECT_EQ(truth[0].speed, 0.0);
  EXPECT_NEAR(truth[0].turn_rate, 0.65, 1e-12);
  EXPECT_DOUBLE_EQ(o.body.speed, 0.5);  // the nominal motion is kept for later
  // The turn by pi takes pi / 0.65 = 4.833 s; then it drives back with its original speed.
  const double turn_end = 1.6 + kPi / 0.65;
  while (w.time_s() < turn_end - 0.06) w.step({}, 0.05);
  EXPECT_EQ(w.obstacles()[0].motion, ObstacleMotion::kTurningAtBorder);
  while (w.time_s() < 8.0 - 1e-9) w.step({}, 0.05);
  EXPECT_EQ(w.obstacles()[0].motion, ObstacleMotion::kMoving);
  EXPECT_NEAR(std::abs(w.obstacles()[0].body.heading), kPi, 1e-9);
  EXPECT_NEAR(w.obstacles()[0].body.center.x(), 3.8 - 0.5 * (8.0 - turn_end), 1e-6);
  EXPECT_NEAR(w.obstacles()[0].body.center.y(), 0.0, 1e-9);
  EXPECT_EQ(w.groundTruthObstacles()[0].speed, 0.5);
}

TEST(World, BorderTurnFollowsTheSenseOfTheTurnRateAndTheMargin) {
  Scenario s = emptyRoom({-3.0, -3.0, 0.0});
  s.obstacles.push_back(disc(0.0, 3.0, kPi / 2, 1.0, -0.01));
  WorldConfig c;
  c.border_margin_m = 0.3;
  World w(s, c, 1);
  for (int k = 0; k < 20; ++k) w.step({}, 0.1);
  const SimObstacle& o = w.obstacles()[0];
  ASSERT_EQ(o.motion, ObstacleMotion::kTurningAtBorder);
  EXPECT_NEAR(o.body.center.y(), 4.0 - 0.3 - 0.2, 1e-6);
  EXPECT_LT(w.groundTruthObstacles()[0].turn_rate, 0.0);  // clockwise, like its own turn rate
}

TEST(World, ObstaclesStayInsideTheRoomAndKeepMoving) {
  WorldConfig c;
  c.lidar.beams = 8;  // the scan is not used here
  for (int n = 5; n <= 15; n += 5) {
    for (int k = 1; k <= 10; ++k) {
      const Scenario s = loadDovsScenario(kRoom + "/1-" + std::to_string(n) + "/" + std::to_string(k) + ".dovs");
      World w(s, c, 1);
      // Border turns take pi / 0.65 = 4.8 s (25 steps) and always end facing into the room, so an obstacle is
      // never still for longer than one turn; a longer standstill means it is trapped at a wall or corner.
      std::vector<int> still_steps(s.obstacles.size(), 0), longest_still(s.obstacles.size(), 0);
      for (int step = 0; step < 600; ++step) {  // 120 s
        std::vector<Vec2> before;
        for (const SimObstacle& o : w.obstacles()) before.push_back(o.body.center);
        w.step({}, 0.2);
        for (size_t i = 0; i < w.obstacles().size(); ++i) {
          const SimObstacle& o = w.obstacles()[i];
          ASSERT_LE(std::abs(o.body.center.x()) + o.body.radius, 4.0 + 1e-9) << s.name << " obstacle " << i;
          ASSERT_LE(std::abs(o.body.center.y()) + o.body.radius, 4.0 + 1e-9) << s.name << " obstacle " << i;
          still_steps[i] = (o.body.center - before[i]).norm() < 1e-9 ? still_steps[i] + 1 : 0;
          longest_still[i] = std::max(longest_still[i], still_steps[i]);
        }
      }
      for (size_t i = 0; i < longest_still.size(); ++i) {
        EXPECT_LE(longest_still[i], 25) << s.name << " obstacle " << i;
      }
    }
  }
}

TEST(World, ObstacleDrivingIntoACornerLeavesIt) {
  Scenario s = emptyRoom({-3.0, -3.0, 0.0});
  // Straight into the corner: both borders at once, turns by pi and comes back along the diagonal.
  s.obstacles.push_back(disc(3.0, 3.0, kPi / 4, 0.5, 0.0));
  // Sitting in the other corner, heading out through +x but in through -y: turning by pi would point it out
  // through -y and start another turn at once, forever; it turns to face the room centre instead.
  s.obstacles.push_back(disc(3.8, -3.8, 0.3, 0.6, 0.0));
  World w(s, WorldConfig(), 1);
  for (int k = 0; k < 200; ++k) w.step({}, 0.1);  // 20 s
  for (const SimObstacle& o : w.obstacles()) {
    EXPECT_EQ(o.border_turns, 1);
    EXPECT_EQ(o.motion, ObstacleMotion::kMoving);
    EXPECT_LE(std::abs(o.body.center.x()), 3.8 + 1e-9);
    EXPECT_LE(std::abs(o.body.center.y()), 3.8 + 1e-9);
  }
  EXPECT_NEAR(w.obstacles()[0].body.center.x(), w.obstacles()[0].body.center.y(), 1e-9);
  EXPECT_LT(w.obstacles()[0].body.center.x(), 3.0);
  EXPECT_NEAR(w.obstacles()[1].body.heading, 3.0 * kPi / 4, 1e-9);
  EXPECT_NEAR(w.obstacles()[1].body.center.x(), -w.obstacles()[1].body.center.y(), 1e-9);
  EXPECT_LT(w.obstacles()[1].body.center.x(), 3.0);
}

TEST(World, RobotDrivenIntoADiscCollides) {
  Scenario s = emptyRoom({0.0, 0.0, 0.0});
  s.obstacles.push_back(disc(1.0, 0.0, 0.0, 0.0, 0.0));
  World w(s, WorldConfig(), 1);
  EXPECT_NEAR(w.minClearance_m(), 1.0 - 0.4, 1e-12);
  for (int k = 0; k < 30 && !w.collided(); ++k) w.step({0.5, 0.0}, 0.2);
  ASSERT_TRUE(w.collided());
  EXPECT_EQ(w.collision().kind, CollisionInfo::Kind::kObstacle);
  EXPECT_EQ(w.collision().index, 0);
  // Stopped at the last contact-free sub-step, i.e. within one sub-step's travel of the disc.
  EXPECT_EQ(w.robotTwist().v, 0.0);
  EXPECT_GE(w.minClearance_m(), 0.0);
  EXPECT_LT(w.minClearance_m(), 0.05);
  const Pose2 stopped = w.robotPose();
  w.step({0.5, 0.0}, 0.2);  // commands are ignored after a collision
  EXPECT_EQ(w.robotPose().x, stopped.x);
  EXPECT_TRUE(w.collided());
  w.reset(s, 1);
  EXPECT_FALSE(w.collided());
  EXPECT_EQ(w.time_s(), 0.0);
}

TEST(World, RobotDrivenIntoAWallCollides) {
  World w(emptyRoom({3.0, 0.0, 0.0}), WorldConfig(), 1);
  for (int k = 0; k < 30 && !w.collided(); ++k) w.step({0.5, 0.0}, 0.2);
  ASSERT_TRUE(w.collided());
  EXPECT_EQ(w.collision().kind, CollisionInfo::Kind::kWall);
  EXPECT_EQ(w.collision().index, 1);  // walls: bottom, right (+x), top, left
  EXPECT_GE(w.robotPose().x, 3.75);
  EXPECT_LE(w.robotPose().x, 3.8);

  // Without stopping, the robot keeps going but the first contact stays recorded.
  WorldConfig through;
  through.stop_on_collision = false;
  World v(emptyRoom({3.0, 0.0, 0.0}), through, 1);
  for (int k = 0; k < 30; ++k) v.step({0.5, 0.0}, 0.2);
  EXPECT_TRUE(v.collided());
  EXPECT_GT(v.robotPose().x, 3.8);
  EXPECT_LT(v.minClearance_m(), 0.0);
}

TEST(World, LongStepsDoNotTunnelThroughThinObstacles) {
  // One 2 s step at 0.7 m/s crosses a 5 cm disc that lies between the start and end poses.
  Scenario s = emptyRoom({0.0, 0.0, 0.0});
  s.obstacles.push_back(disc(0.7, 0.0, 0.0, 0.0, 0.0, 0.05));
  World w(s, WorldConfig(), 1);
  w.step({0.7, 0.0}, 2.0);
  EXPECT_TRUE(w.collided());
  EXPECT_LT(w.robotPose().x, 0.7 - 0.25 + 1e-9);

  // A fast obstacle sweeping through a still robot within one long step.
  Scenario cross = emptyRoom({0.0, 0.0, 0.0});
  cross.obstacles.push_back(disc(0.0, -0.8, kPi / 2, 1.2, 0.0, 0.05));
  World x(cross, WorldConfig(), 1);
  x.step({}, 1.5);
  EXPECT_TRUE(x.collided());
  EXPECT_EQ(x.collision().kind, CollisionInfo::Kind::kObstacle);
  EXPECT_NEAR(x.collision().time_s, (0.8 - 0.25) / 1.2, 0.05);
}

TEST(World, StartingInsideAnObstacleIsACollisionAtTimeZero) {
  Scenario s = emptyRoom({0.0, 0.0, 0.0});
  s.obstacles.push_back(disc(0.3, 0.0, 0.0, 0.0, 0.0));
  World w(s, WorldConfig(), 1);
  EXPECT_TRUE(w.collided());
  EXPECT_EQ(w.collision().time_s, 0.0);
  EXPECT_LT(w.minClearance_m(), 0.0);
}

TEST(World, MinClearanceCountsWallsAndStaticSegments) {
  Scenario s = emptyRoom({3.0, 0.0, 0.0});
  EXPECT_NEAR(World(s, WorldConfig(), 1).minClearance_m(), 1.0 - 0.2, 1e-12);
  s.static_segments.push_back({Vec2(2.5, -1.0), Vec2(2.5, 1.0)});
  World w(s, WorldConfig(), 1);
  EXPECT_EQ(w.walls().size(), 5u);
  EXPECT_NEAR(w.minClearance_m(), 0.5 - 0.2, 1e-12);
  // The LIDAR sees the extra wall.
  const LaserScan2 scan = w.scan();
  const size_t behind = static_cast<size_t>(std::lround((kPi - 1e-9 - scan.angle_min) / scan.angle_increment)) % 720;
  EXPECT_NEAR(scan.ranges[behind], 0.5, 0.05);
}

TEST(World, ScanSeesObstaclesFromTheMountedLaser) {
  Scenario s = emptyRoom({0.0, 0.0, kPi / 2});
  s.obstacles.push_back(disc(0.0, 2.0, 0.0, 0.0, 0.0, 0.3));
  WorldConfig c;
  c.lidar.noise_std_m = 0.0;
  c.lidar.mount = Pose2{0.1, 0.0, kPi};  // 10 cm ahead of the centre, looking backwards
  World w(s, c, 1);
  EXPECT_NEAR(w.laserPose().y, 0.1, 1e-12);
  const LaserScan2 scan = w.scan();
  ASSERT_EQ(scan.ranges.size(), 720u);
  // The disc is straight ahead of the robot, i.e. behind the laser: beam at angle pi (index 0 is -pi).
  EXPECT_NEAR(scan.ranges[0], 2.0 - 0.3 - 0.1, 1e-6);
  // Straight ahead of the laser (robot's back) is the -y wall, 4.1 m away.
  EXPECT_NEAR(scan.ranges[360], 4.1, 1e-6);
}

TEST(World, DeterministicBySeed) {
  const Scenario s = loadDovsScenario(kRoom + "/1-10/7.dovs");
  World a(s, WorldConfig(), 77), b(s, WorldConfig(), 77), c(s, WorldConfig(), 78);
  LaserScan2 sa, sb, sc;
  for (int k = 0; k < 100; ++k) {
    const Twist2 cmd{0.3 + 0.2 * std::sin(0.1 * k), 0.8 * std::cos(0.07 * k)};
    a.step(cmd, 0.2);
    b.step(cmd, 0.2);
    c.step(cmd, 0.2);
    a.scanInto(sa);
    b.scanInto(sb);
    c.scanInto(sc);
    ASSERT_EQ(sa.ranges, sb.ranges) << k;
  }
  EXPECT_EQ(a.robotPose().x, b.robotPose().x);
  EXPECT_EQ(a.robotPose().theta, b.robotPose().theta);
  for (size_t i = 0; i < a.obstacles().size(); ++i)
    EXPECT_EQ(a.obstacles()[i].body.center, b.obstacles()[i].body.center);
  // The seed only drives the sensor noise: same motion, different scans.
  EXPECT_EQ(a.robotPose().x, c.robotPose().x);
  EXPECT_NE(sa.ranges, sc.ranges);
  // reset() replays the same episode.
  const double x_end = a.robotPose().x;
  a.reset(s, 77);
  World fresh(s, WorldConfig(), 77);
  LaserScan2 r1, r2;
  a.scanInto(r1);
  fresh.scanInto(r2);
  EXPECT_EQ(r1.ranges, r2.ranges);
  EXPECT_EQ(a.time_s(), 0.0);
  EXPECT_NE(a.robotPose().x, x_end);
}

}  // namespace
TEST(World, WheelOdometryDriftsFromTheTruthReproduciblyAndLeavesTheScansAlone) {
  Scenario s;
  s.name = "drive";
  s.robot_start = {-2.0, -2.0, 0.3};
  s.goal = Vec2(3.0, 3.0);
  WorldConfig exact, drifting;
  drifting.odometry = OdometryConfig::level("high");
  World a(s, exact, 7), b(s, drifting, 7), c(s, drifting, 7), d(s, drifting, 8);
  for (int k = 0; k < 100; ++k) {  // 20 s on an arc
    for (World* w : {&a, &b, &c, &d}) w->step({0.4, 0.15}, 0.2);
  }
  EXPECT_EQ(a.odomPose().x, a.robotPose().x);   // no drift configured: odom is the truth
  EXPECT_EQ(b.robotPose().x, a.robotPose().x);  // the truth does not depend on the odometry
  const double drift = (b.odomPose().position() - b.robotPose().position()).norm();
  EXPECT_GT(drift, 0.02);
  EXPECT_LT(drift, 2.0);
  EXPECT_EQ(b.odomPose().x, c.odomPose().x);  // same seed, same drift
  EXPECT_NE(b.odomPose().x, d.odomPose().x);
  // The LIDAR's noise has a stream of its own.
  const LaserScan2 sa = a.scan(), sb = b.scan();
  EXPECT_EQ(sa.ranges, sb.ranges);
  EXPECT_THROW(OdometryConfig::level("wobbly"), SimConfigError);
  drifting.odometry.turn_scale_std = -0.1;
  EXPECT_NE(drifting.validate().find("turn_scale_std"), std::string::npos);
}

}  // namespace dqn_dovs::sim

namespace dqn_dovs::sim {
namespace {

// WorldConfig::wall_thickness_m: a free wall end shows the LIDAR its end face, so a wall seen exactly edge-on (a
// jamb beside a robot standing in a doorway) still returns; a joined end (a corner) shows nothing more.
TEST(World, TheLidarSeesTheEndFaceOfAWallItLooksAlong) {
  Scenario s = emptyRoom({0.0, 0.0, 0.0});
  s.static_segments = {{{1.0, 0.0}, {3.0, 0.0}},    // free at (1, 0): straight ahead of the laser, edge-on
                       {{3.0, 0.0}, {3.0, -2.0}}};  // joined to it at (3, 0)
  auto ahead = [&](double thickness) {
    WorldConfig c;
    c.lidar.noise_std_m = 0.0;
    c.wall_thickness_m = thickness;
    World world(s, c, 1);
    const LaserScan2 scan = world.scan();
    // The beam nearest straight ahead.
    const long i = std::lround(-scan.angle_min / scan.angle_increment);
    return static_cast<double>(scan.ranges[static_cast<size_t>(i)]);
  };
  EXPECT_NEAR(ahead(0.1), 1.0, 1e-6) << "the end face at x = 1";
  EXPECT_NEAR(ahead(0.0), 3.0, 1e-6) << "thin walls: the beam runs along the wall to the one it joins";
  WorldConfig bad;
  bad.wall_thickness_m = -0.1;
  EXPECT_NE(bad.validate().find("wall_thickness_m"), std::string::npos);
}

}  // namespace
}  // namespace dqn_dovs::sim
