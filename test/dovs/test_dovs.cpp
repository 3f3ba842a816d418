// Analytic cases of the DOVS: static and moving obstacles, walls, range, grid layout, bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "dovs_bruteforce.h"
#include "dqn_dovs/dovs/dovs.h"

namespace dqn_dovs {
namespace {

MovingObstacle disc(double x, double y, double radius, double heading = 0.0, double speed = 0.0, double turn = 0.0) {
  MovingObstacle o;
  o.center = {x, y};
  o.radius = radius;
  o.heading = heading;
  o.speed = speed;
  o.turn_rate = turn;
  o.is_static = speed == 0.0;
  return o;
}

Observation sceneWith(std::vector<MovingObstacle> obstacles, std::vector<Segment> segments = {}) {
  Observation obs;
  obs.obstacles = std::move(obstacles);
  obs.segments = std::move(segments);
  return obs;
}

int straightRay(const VelocitySpace& d) { return (d.numTrajectories() - 1) / 2; }

TEST(DovsConfig, DefaultsAreValidAndBadFieldsAreNamed) {
  EXPECT_EQ(DovsConfig{}.validate(), "");
  DovsConfig c;
  c.num_trajectories = 64;
  EXPECT_NE(c.validate().find("num_trajectories"), std::string::npos);
  c = DovsConfig{};
  c.safety_factor = 0.9;
  EXPECT_NE(c.validate().find("safety_factor"), std::string::npos);
  c = DovsConfig{};
  c.time_horizon_s = std::nan("");
  EXPECT_NE(c.validate().find("time_horizon_s"), std::string::npos);
  c = DovsConfig{};
  c.grid_size = 1;
  EXPECT_NE(c.validate().find("grid_size"), std::string::npos);
  try {
    DovsBuilder b(RobotLimits{}, c);
    FAIL() << "invalid config accepted";
  } catch (const DovsError& e) {
    EXPECT_NE(std::string(e.what()).find("grid_size"), std::string::npos);
  }
}

TEST(DovsConfig, ParametersAreSetByTheirConfigFileNames) {
  DovsConfig c;
  EXPECT_EQ(setDovsParameter(c, "prediction_growth", "0.25"), "");
  EXPECT_DOUBLE_EQ(c.prediction_growth_mps, 0.25);
  EXPECT_EQ(setDovsParameter(c, "time_horizon", "4"), "");
  EXPECT_DOUBLE_EQ(c.time_horizon_s, 4.0);
  EXPECT_EQ(setDovsParameter(c, "num_trajectories", "33"), "");
  EXPECT_EQ(c.num_trajectories, 33);
  EXPECT_NE(setDovsParameter(c, "num_trajectories", "33.5").find("not an integer"), std::string::npos);
  EXPECT_NE(setDovsParameter(c, "safety_factor", "big").find("'safety_factor'"), std::string::npos);
  EXPECT_NE(setDovsParameter(c, "time_horizon", "inf").find("not a number"), std::string::npos);
  const std::string unknown = setDovsParameter(c, "horizon", "3");
  EXPECT_NE(unknown.find("unknown DOVS parameter 'horizon'"), std::string::npos);
  EXPECT_NE(unknown.find("prediction_growth"), std::string::npos);  // the known names are listed
  EXPECT_EQ(dovsParameterNames().size(), 13u);
  for (const std::string& name : dovsParameterNames()) EXPECT_EQ(setDovsParameter(c, name, "1"), "") << name;
  c = DovsConfig{};
  c.prediction_growth_mps = -0.1;
  EXPECT_NE(c.validate().find("prediction_growth_mps"), std::string::npos);
  c.prediction_growth_mps = 2.5;
  EXPECT_NE(c.validate().find("prediction_growth_mps"), std::string::npos);
  c = DovsConfig{};
  EXPECT_EQ(setDovsParameter(c, "grid_channels", "3"), "");
  EXPECT_EQ(c.grid_channels, 3);
  EXPECT_EQ(c.validate(), "");
  EXPECT_EQ(setDovsParameter(c, "grid_channels", "4"), "");  // parsed here, refused by validate()
  EXPECT_NE(c.validate().find("grid_channels"), std::string::npos);
}

// Enlarged radius of a 0.2 m disc: (0.2 + 0.2) * 1.1 = 0.44 m; t seconds ahead it is 0.44 + g t.
TEST(VelocitySpace, GrowingPredictionReachesTheRobotWhenItOutgrowsTheObstacleSpeed) {
  DovsConfig grown;
  grown.prediction_growth_mps = 0.3;
  // Walking away at 0.1 m/s from 1 m: the disc's near edge comes back at (1 - 0.44) / (0.3 - 0.1) = 2.8 s.
  const Observation away = sceneWith({disc(1.0, 0.0, 0.2, 0.0, 0.1)});
  EXPECT_FALSE(buildDovs(away, RobotLimits{}, DovsConfig{}).stationaryUnsafe());
  EXPECT_TRUE(buildDovs(away, RobotLimits{}, grown).stationaryUnsafe());
  DovsConfig slower = grown;
  slower.prediction_growth_mps = 0.2;  // (1 - 0.44) / 0.1 = 5.6 s, beyond the 3 s horizon
  EXPECT_FALSE(buildDovs(away, RobotLimits{}, slower).stationaryUnsafe());
  // Growth equal to the speed: walking away never comes back; walking in from 2 m arrives at 2.6 s instead of 5.2 s.
  EXPECT_FALSE(buildDovs(sceneWith({disc(1.0, 0.0, 0.2, 0.0, 0.3)}), RobotLimits{}, grown).stationaryUnsafe());
  const Observation toward = sceneWith({disc(2.0, 0.0, 0.2, kPi, 0.3)});
  EXPECT_FALSE(buildDovs(toward, RobotLimits{}, DovsConfig{}).stationaryUnsafe());
  EXPECT_TRUE(buildDovs(toward, RobotLimits{}, grown).stationaryUnsafe());
  // A crossing obstacle blocks a wider band of speeds, and static obstacles do not grow.
  const Observation crossing = sceneWith({disc(1.0, -2.0, 0.2, kPi / 2, 1.0)});
  const VelocitySpace plain = buildDovs(crossing, RobotLimits{}, DovsConfig{});
  const VelocitySpace wide = buildDovs(crossing, RobotLimits{}, grown);
  const IntervalRange a = plain.unsafeIntervals(straightRay(plain));
  const IntervalRange b = wide.unsafeIntervals(straightRay(wide));
  ASSERT_EQ(a.size(), 1u);
  ASSERT_EQ(b.size(), 1u);
  EXPECT_LT(b[0].lo_mps, a[0].lo_mps);
  EXPECT_GE(b[0].hi_mps, a[0].hi_mps);
  const Observation still = sceneWith({disc(1.5, 0.0, 0.2)});
  const VelocitySpace s0 = buildDovs(still, RobotLimits{}, DovsConfig{});
  const VelocitySpace s1 = buildDovs(still, RobotLimits{}, grown);
  EXPECT_EQ(s0.grid(), s1.grid());
}

TEST(VelocitySpace, TrajectoriesSpanTheTriangle) {
  const VelocitySpace d = buildDovs(Observation{}, RobotLimits{}, DovsConfig{});
  ASSERT_EQ(d.numTrajectories(), 65);
  EXPECT_TRUE(d.trajectory(0).pure_rotation);
  EXPECT_TRUE(d.trajectory(64).pure_rotation);
  EXPECT_NEAR(d.trajectory(0).w_top_rps, -kPi, 1e-12);
  EXPECT_NEAR(d.trajectory(64).w_top_rps, kPi, 1e-12);
  const Trajectory& s = d.trajectory(straightRay(d));
  EXPECT_DOUBLE_EQ(s.w_top_rps, 0.0);
  EXPECT_DOUBLE_EQ(s.v_top_mps, 0.7);
  EXPECT_DOUBLE_EQ(s.curvature_1pm, 0.0);
  for (int i = 1; i < 64; ++i) {
    const Trajectory& t = d.trajectory(i);
    EXPECT_TRUE(RobotLimits{}.feasible({t.v_top_mps, t.w_top_rps}, 1e-9));
    EXPECT_NEAR(t.v_top_mps / 0.7 + std::abs(t.w_top_rps) / kPi, 1.0, 1e-9);  // on the triangle edge
    EXPECT_LT(d.trajectory(i - 1).w_top_rps / std::max(1e-9, d.trajectory(i - 1).v_top_mps),
              t.w_top_rps / t.v_top_mps + 1e-9);  // ordered by turn rate
  }
}

TEST(VelocitySpace, EmptySceneIsFreeWhereFeasibleAndGridIsImageOrdered) {
  const VelocitySpace d = buildDovs(Observation{}, RobotLimits{}, DovsConfig{});
  EXPECT_FALSE(d.stationaryUnsafe());
  EXPECT_TRUE(d.isFree({0.3, 0.5}));
  EXPECT_TRUE(d.isFree({0.0, 2.0}));
  EXPECT_FALSE(d.isFree({0.6, 2.0}));  // outside the triangle
  EXPECT_FALSE(d.isFree({std::nan(""), 0.0}));
  ASSERT_EQ(d.gridSize(), 20);
  ASSERT_EQ(d.grid().size(), 400u);
  // Row 0 is the top (v close to v_max): its cell centres are all outside the triangle.
  const Twist2 top_left = d.gridCellVelocity(0, 0);
  EXPECT_NEAR(top_left.v, 0.7 * 19.5 / 20, 1e-12);
  EXPECT_NEAR(top_left.w, -kPi * 19.0 / 20, 1e-12);
  const Twist2 bottom_right = d.gridCellVelocity(19, 19);
  EXPECT_NEAR(bottom_right.v, 0.7 * 0.5 / 20, 1e-12);
  EXPECT_NEAR(bottom_right.w, kPi * 19.0 / 20, 1e-12);
  for (int c = 0; c < 20; ++c) {
    EXPECT_EQ(d.gridCell(0, c), -1.0f) << c;
    EXPECT_EQ(d.gridCell(19, c), 1.0f) << c;
  }
  // Elsewhere +1 exactly where feasible.
  for (int r = 0; r < 20; ++r)
    for (int c = 0; c < 20; ++c)
      EXPECT_EQ(d.gridCell(r, c), RobotLimits{}.feasible(d.gridCellVelocity(r, c)) ? 1.0f : -1.0f);
  EXPECT_EQ(d.grid()[static_cast<size_t>(3 * 20 + 7)], d.gridCell(3, 7));  // row-major
}

TEST(VelocitySpace, StaticObstacleAheadBlocksTheTopOfTheStraightTrajectory) {
  DovsBuilder b(RobotLimits{}, DovsConfig{});
  const VelocitySpace d = b.build(sceneWith({disc(1.0, 0.0, 0.2)}));
  // Enlarged radius (0.2 + 0.2) * 1.1 = 0.44: contact 0.56 m ahead.
  const double v_limit = b.brakingSpeedLimit(0.56);
  EXPECT_NEAR(v_limit, 0.5 * (-0.2 + std::sqrt(0.04 + 4.0 * 0.51)), 1e-12);
  const IntervalRange iv = d.unsafeIntervals(straightRay(d));
  ASSERT_EQ(iv.size(), 1u);
  EXPECT_LE(iv[0].lo_mps, v_limit + 1e-9);  // conservative
  EXPECT_GE(iv[0].lo_mps, v_limit - 0.03);  // but tight
  EXPECT_DOUBLE_EQ(iv[0].hi_mps, 0.7);
  EXPECT_FALSE(d.isFree({0.68, 0.0}));
  EXPECT_TRUE(d.isFree({0.5, 0.0}));
  EXPECT_TRUE(d.isFree({0.3, 1.5}));
  EXPECT_FALSE(d.stationaryUnsafe());
  EXPECT_EQ(d.gridCell(1, 9), -1.0f);  // v = 0.6475, w = -0.157: still reaches it
  EXPECT_EQ(d.gridCell(1, 10), -1.0f);
  EXPECT_EQ(d.gridCell(10, 10), 1.0f);  // slow enough to brake
  EXPECT_EQ(d.numObstaclesInModel(), 1);
}

TEST(VelocitySpace, WallAheadUsesTheBrakingRule) {
  DovsBuilder b(RobotLimits{}, DovsConfig{});
  const VelocitySpace d = b.build(sceneWith({}, {Segment{{0.8, -2.0}, {0.8, 2.0}}}));
  const double v_limit = b.brakingSpeedLimit(0.8 - 0.22);
  const IntervalRange iv = d.unsafeIntervals(straightRay(d));
  ASSERT_EQ(iv.size(), 1u);
  EXPECT_LE(iv[0].lo_mps, v_limit + 1e-9);
  EXPECT_GE(iv[0].lo_mps, v_limit - 0.03);
  EXPECT_TRUE(d.isFree({0.4, 0.0}));
  EXPECT_FALSE(d.isFree({0.69, 0.0}));
}

TEST(VelocitySpace, HeadOnObstacleMakesTheWholeStraightTrajectoryUnsafe) {
  const VelocitySpace d = buildDovs(sceneWith({disc(3.0, 0.0, 0.2, kPi, 1.0)}), RobotLimits{}, DovsConfig{});
  // It reaches the robot's position at (3 - 0.44) / 1 = 2.56 s < 3 s whatever the robot does on this line.
  EXPECT_TRUE(d.stationaryUnsafe());
  const IntervalRange iv = d.unsafeIntervals(straightRay(d));
  ASSERT_EQ(iv.size(), 1u);
  EXPECT_DOUBLE_EQ(iv[0].lo_mps, 0.0);
  EXPECT_DOUBLE_EQ(iv[0].hi_mps, 0.7);
  EXPECT_FALSE(d.isFree({0.0, 1.0}));
  EXPECT_FALSE(d.isFree({0.35, 0.0}));
}

TEST(VelocitySpace, ObstacleMovingAwayFasterThanTheRobotIsHarmless) {
  const VelocitySpace d = buildDovs(sceneWith({disc(1.5, 0.0, 0.2, 0.0, 1.0)}), RobotLimits{}, DovsConfig{});
  EXPECT_FALSE(d.stationaryUnsafe());
  for (int i = 0; i < d.numTrajectories(); ++i) EXPECT_TRUE(d.unsafeIntervals(i).empty()) << i;
  EXPECT_TRUE(d.isFree({0.69, 0.0}));
}

TEST(VelocitySpace, CrossingObstacleBlocksTheSpeedsThatMeetIt) {
  DovsBuilder b(RobotLimits{}, DovsConfig{});
  // Crosses the robot's straight path at x = 1 at t = 2 s.
  const Observation obs = sceneWith({disc(1.0, -2.0, 0.2, kPi / 2, 1.0)});
  const VelocitySpace d = b.build(obs);
  EXPECT_FALSE(d.stationaryUnsafe());
  EXPECT_TRUE(d.isFree({0.1, 0.0}));   // still short of the crossing when it passes
  EXPECT_FALSE(d.isFree({0.5, 0.0}));  // at x = 1 exactly when it does
  const bruteforce::Reference ref(b, obs, 0.002);
  double ref_len = 0.0, dovs_len = 0.0;
  for (double v = 0.0025; v < 0.7; v += 0.005) {
    const bool unsafe = ref.unsafe({v, 0.0});
    if (unsafe) {
      EXPECT_FALSE(d.isFree({v, 0.0})) << "v = " << v;
    }
    ref_len += unsafe;
    dovs_len += !d.isFree({v, 0.0});
  }
  EXPECT_GT(ref_len, 20);
  EXPECT_LE(dovs_len, 1.2 * ref_len);
}

TEST(VelocitySpace, TurningObstacleMatchesBruteForceAlongTrajectories) {
  DovsBuilder b(RobotLimits{}, DovsConfig{});
  const Observation obs = sceneWith({disc(1.5, 1.2, 0.25, -kPi / 2, 0.6, -0.4), disc(0.5, -1.5, 0.3, 1.2, 0.7, 1.5)});
  const VelocitySpace d = b.build(obs);
  const bruteforce::Reference ref(b, obs, 0.002);
  long ref_count = 0, dovs_count = 0;
  for (int i = 1; i + 1 < d.numTrajectories(); ++i) {
    const Trajectory& t = d.trajectory(i);
    for (double f = 0.01; f < 1.0; f += 0.02) {
      const Twist2 tw{f * t.v_top_mps, f * t.w_top_rps};
      const bool unsafe = ref.unsafe(tw);
      ref_count += unsafe;
      // Exact along the trajectories: compare the trajectory's own intervals.
      bool in_dov = false;
      for (const SpeedInterval& iv : d.unsafeIntervals(i)) in_dov = in_dov || (tw.v >= iv.lo_mps && tw.v <= iv.hi_mps);
      dovs_count += in_dov;
      if (unsafe) {
        EXPECT_TRUE(in_dov) << "trajectory " << i << " v " << tw.v;
      }
    }
  }
  EXPECT_GT(ref_count, 100);
  EXPECT_LE(dovs_count, 1.25 * ref_count);
}

TEST(VelocitySpace, ObstaclesOutOfRangeAreIgnored) {
  const VelocitySpace d = buildDovs(sceneWith({disc(4.5, 0.0, 0.2, kPi, 1.2)}, {Segment{{5.0, -1.0}, {5.0, 1.0}}}),
                                    RobotLimits{}, DovsConfig{});
  EXPECT_EQ(d.numObstaclesInModel(), 0);
  EXPECT_FALSE(d.closestObstacle().found);
  for (int i = 0; i < d.numTrajectories(); ++i) EXPECT_TRUE(d.unsafeIntervals(i).empty());
  DovsConfig wide;
  wide.obstacle_range_m = 6.0;
  wide.time_horizon_s = 4.0;  // it reaches the robot after (4.5 - 0.44) / 1.2 = 3.4 s
  const VelocitySpace w = buildDovs(sceneWith({disc(4.5, 0.0, 0.2, kPi, 1.2)}), RobotLimits{}, wide);
  EXPECT_EQ(w.numObstaclesInModel(), 1);
  EXPECT_TRUE(w.stationaryUnsafe());
}

TEST(VelocitySpace, RobotFrameFollowsTheRobotPose) {
  // The same obstacle ahead of a robot turned by 90 degrees at (1, 1).
  Observation obs = sceneWith({disc(1.0, 2.0, 0.2)});
  obs.robot_pose = {1.0, 1.0, kPi / 2};
  const VelocitySpace d = buildDovs(obs, RobotLimits{}, DovsConfig{});
  EXPECT_FALSE(d.isFree({0.68, 0.0}));
  EXPECT_NEAR(d.closestObstacle().bearing_rad, 0.0, 1e-12);
  EXPECT_NEAR(d.closestObstacle().clearance_m, 1.0 - 0.2 - 0.2, 1e-12);
}

TEST(VelocitySpace, InsideTheInflationMovingAwayStaysPossibleButTouchingBlocksEverything) {
  // 0.42 m behind: inside the 0.44 m inflation, not touching (0.4 m).
  const VelocitySpace near = buildDovs(sceneWith({disc(-0.42, 0.0, 0.2)}), RobotLimits{}, DovsConfig{});
  EXPECT_TRUE(near.isFree({0.5, 0.0}));
  const VelocitySpace touching = buildDovs(sceneWith({disc(-0.35, 0.0, 0.2)}), RobotLimits{}, DovsConfig{});
  EXPECT_FALSE(touching.isFree({0.5, 0.0}));
  EXPECT_FALSE(touching.isFree({0.1, 1.0}));
}

TEST(VelocitySpace, IntervalsAreSortedDisjointAndWithinTheTriangle) {
  DovsBuilder b(RobotLimits{}, DovsConfig{});
  std::mt19937_64 rng(5);
  VelocitySpace d;
  for (int k = 0; k < 50; ++k) {
    b.build(bruteforce::randomScene(rng, b, bruteforce::SceneOptions{}), d);
    for (int i = 0; i < d.numTrajectories(); ++i) {
      double prev_hi = -1.0;
      for (const SpeedInterval& iv : d.unsafeIntervals(i)) {
        EXPECT_LE(iv.lo_mps, iv.hi_mps);
        EXPECT_GT(iv.lo_mps, prev_hi);
        EXPECT_GE(iv.lo_mps, 0.0);
        EXPECT_LE(iv.hi_mps, d.trajectory(i).v_top_mps + 1e-12);
        prev_hi = iv.hi_mps;
      }
    }
  }
}

TEST(VelocitySpace, NonFiniteOrNonPositiveInputIsAnErrorNamingTheItem) {
  DovsBuilder b(RobotLimits{}, DovsConfig{});
  auto expectError = [&](const Observation& obs, const std::string& a, const std::string& c) {
    try {
      b.build(obs);
      ADD_FAILURE() << "accepted bad input (" << a << " " << c << ")";
    } catch (const DovsError& e) {
      EXPECT_NE(std::string(e.what()).find(a), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(c), std::string::npos) << e.what();
    }
  };
  const double nan = std::nan(""), inf = std::numeric_limits<double>::infinity();
  expectError(sceneWith({disc(1, 1, 0.2), disc(2, 2, nan)}), "obstacle 1", "radius");
  expectError(sceneWith({disc(2, 2, -0.1)}), "obstacle 0", "radius");
  expectError(sceneWith({disc(2, 2, 0.0)}), "obstacle 0", "radius");
  expectError(sceneWith({disc(inf, 2, 0.2)}), "obstacle 0", "center.x");
  expectError(sceneWith({disc(1, 2, 0.2, 0.0, nan)}), "obstacle 0", "speed");
  expectError(sceneWith({disc(1, 2, 0.2, nan, 1.0)}), "obstacle 0", "heading");
  expectError(sceneWith({disc(1, 2, 0.2, 0.0, 1.0, inf)}), "obstacle 0", "turn_rate");
  expectError(sceneWith({}, {Segment{{0, 0}, {nan, 1}}}), "segment 0", "b");
  Observation bad_pose;
  bad_pose.robot_pose.theta = nan;
  expectError(bad_pose, "robot pose", "theta");
}

}  // namespace
}  // namespace dqn_dovs
