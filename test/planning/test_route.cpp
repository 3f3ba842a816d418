// Route planning on occupancy grids: the distance transform, routes through doors and around corners with the
// robot's clearance, the reasons when there is none, unknown cells, the subgoal and progress along a route, the
// blocked-route check and planning with extra obstacle points, a map loaded from test/data, the grid of known walls
// and furniture, and RouteGuide (the route following planner_node and the evaluation share).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "dqn_dovs/maps/occupancy_map.h"
#include "dqn_dovs/planning/route.h"
#include "dqn_dovs/planning/route_map.h"
#include "source_paths.h"

namespace dqn_dovs {
namespace {

constexpr double kRadius = 0.18;
constexpr int8_t kOccupied = 100;
constexpr int8_t kUnknown = -1;

/// A free grid of width_m x height_m with the origin at (0, 0) and a wall one cell thick along its border.
RouteGrid room(double width_m, double height_m, double resolution_m = 0.05) {
  RouteGrid g;
  g.resolution_m = resolution_m;
  g.width = static_cast<int>(std::lround(width_m / resolution_m));
  g.height = static_cast<int>(std::lround(height_m / resolution_m));
  g.cells.assign(size_t(g.width) * g.height, 0);
  for (int j = 0; j < g.height; ++j) {
    for (int i = 0; i < g.width; ++i) {
      if (i == 0 || j == 0 || i == g.width - 1 || j == g.height - 1) g.cells[size_t(j) * g.width + i] = kOccupied;
    }
  }
  return g;
}

/// Sets every cell whose centre lies in [x0, x1) x [y0, y1) (origin at (0, 0)) to `value`.
void fill(RouteGrid& g, double x0, double y0, double x1, double y1, int8_t value) {
  for (int j = 0; j < g.height; ++j) {
    for (int i = 0; i < g.width; ++i) {
      const double x = (i + 0.5) * g.resolution_m, y = (j + 0.5) * g.resolution_m;
      if (x >= x0 && x < x1 && y >= y0 && y < y1) g.cells[size_t(j) * g.width + i] = value;
    }
  }
}

/// Brute force: distance from p to the closest occupied cell centre minus half a cell (the planner's clearance).
double bruteClearance(const RouteGrid& g, const Vec2& p) {
  double best = std::numeric_limits<double>::infinity();
  for (int j = 0; j < g.height; ++j) {
    for (int i = 0; i < g.width; ++i) {
      if (g.cells[size_t(j) * g.width + i] < 65) continue;
      const Vec2 c((i + 0.5) * g.resolution_m, (j + 0.5) * g.resolution_m);
      best = std::min(best, (p - c).norm());
    }
  }
  return best - 0.5 * g.resolution_m;
}

/// Smallest brute-force clearance along the segment a -> b, sampled every quarter cell.
double segmentClearance(const RouteGrid& g, const Vec2& a, const Vec2& b) {
  const int n = std::max(1, static_cast<int>(std::ceil((b - a).norm() / (0.25 * g.resolution_m))));
  double best = std::numeric_limits<double>::infinity();
  for (int k = 0; k <= n; ++k) best = std::min(best, bruteClearance(g, a + (b - a) * (double(k) / n)));
  return best;
}

RouteConfig config() {
  RouteConfig c;
  c.robot_radius_m = kRadius;
  return c;
}

/// Two 5 m x 5 m rooms side by side, the wall between them (x in [4.95, 5.05)) with a door at y in [3.5, 3.5 + w).
RouteGrid twoRooms(double door_width_m) {
  RouteGrid g = room(10.0, 5.0);
  fill(g, 4.95, 0.0, 5.05, 3.5, kOccupied);
  fill(g, 4.95, 3.5 + door_width_m, 5.05, 5.0, kOccupied);
  return g;
}

TEST(Route, DistanceTransformIsExact) {
  RouteGrid g;
  g.resolution_m = 0.1;
  g.width = 37;
  g.height = 23;
  g.cells.assign(size_t(g.width) * g.height, 0);
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> pick(0, 99);
  for (int8_t& c : g.cells) c = pick(rng) < 3 ? kOccupied : 0;
  const RoutePlanner planner(g, config());
  for (int j = 0; j < g.height; ++j) {
    for (int i = 0; i < g.width; ++i) {
      const Vec2 centre((i + 0.5) * g.resolution_m, (j + 0.5) * g.resolution_m);
      ASSERT_NEAR(planner.clearance(centre), bruteClearance(g, centre), 1e-5) << "cell " << i << ", " << j;
    }
  }
  EXPECT_EQ(planner.clearance(Vec2(-1.0, 0.0)), -1.0);
}

TEST(Route, StraightRouteInAnEmptyRoom) {
  const RoutePlanner planner(room(5.0, 5.0), config());
  const Route r = planner.plan(Vec2(1.0, 2.5), Vec2(4.0, 2.52));
  ASSERT_TRUE(r.found) << r.why;
  ASSERT_EQ(r.points.size(), 2u);
  EXPECT_NEAR((r.points.front() - Vec2(1.0, 2.5)).norm(), 0.0, 1e-12);
  EXPECT_NEAR((r.points.back() - Vec2(4.0, 2.52)).norm(), 0.0, 1e-12);
  EXPECT_NEAR(r.length_m, (Vec2(4.0, 2.52) - Vec2(1.0, 2.5)).norm(), 1e-9);
  EXPECT_EQ(r.arc_m.size(), r.points.size());
  EXPECT_DOUBLE_EQ(r.start_moved_m, 0.0);
}

TEST(Route, DoorwayRouteDetoursThroughTheDoorWithClearance) {
  const RouteGrid g = twoRooms(1.0);
  const RoutePlanner planner(g, config());
  const Vec2 start(2.0, 1.0), goal(8.0, 1.0);
  const Route r = planner.plan(start, goal);
  ASSERT_TRUE(r.found) << r.why;
  // Shortest possible: both legs to the door's lower jamb (5, 3.5); around the jambs at the robot's radius, with
  // the wall's thickness, about 8.1 m.
  const double lower_bound = 2.0 * (Vec2(5.0, 3.5) - start).norm();
  EXPECT_GT(r.length_m, lower_bound);
  EXPECT_LT(r.length_m, 1.1 * 8.1);
  EXPECT_LE(r.points.size(), 8u) << "the route is simplified, not a staircase";
  for (const Vec2& p : r.points) EXPECT_GE(bruteClearance(g, p), kRadius - 1e-9) << p.transpose();
  // Between the points, up to the grid's resolution.
  for (size_t k = 1; k < r.points.size(); ++k) {
    EXPECT_GE(segmentClearance(g, r.points[k - 1], r.points[k]), kRadius - g.resolution_m) << "segment " << k;
  }
  double crossing_y = -1.0;
  for (size_t k = 1; k < r.points.size(); ++k) {
    const Vec2 a = r.points[k - 1], b = r.points[k];
    if ((a.x() - 5.0) * (b.x() - 5.0) <= 0.0 && a.x() != b.x())
      crossing_y = a.y() + (b.y() - a.y()) * (5.0 - a.x()) / (b.x() - a.x());
  }
  EXPECT_GT(crossing_y, 3.5 + kRadius - 0.05);
  EXPECT_LT(crossing_y, 4.5 - kRadius + 0.05);
}

TEST(Route, NoRouteWhenTheDoorIsNarrowerThanTheRobot) {
  const RoutePlanner planner(twoRooms(0.3), config());
  const Route r = planner.plan(Vec2(2.0, 1.0), Vec2(8.0, 1.0));
  EXPECT_FALSE(r.found);
  EXPECT_TRUE(r.points.empty());
  EXPECT_EQ(r.why,
            "no route: start (2.00, 1.00) and goal (8.00, 1.00) are not connected (obstacles inflated by the robot "
            "radius 0.18 m)");
  // The same door lets a thinner robot through.
  RouteConfig thin = config();
  thin.robot_radius_m = 0.08;
  EXPECT_TRUE(RoutePlanner(twoRooms(0.3), thin).plan(Vec2(2.0, 1.0), Vec2(8.0, 1.0)).found);
}

TEST(Route, GoalInsideAWallOrOutsideTheMapIsRefusedWithTheReason) {
  const RoutePlanner planner(twoRooms(1.0), config());
  Route r = planner.plan(Vec2(2.0, 1.0), Vec2(5.0, 1.0));
  EXPECT_FALSE(r.found);
  EXPECT_EQ(r.why, "goal (5.00, 1.00) is inside an obstacle inflated by the robot radius 0.18 m");
  // Free, but closer to the wall than the radius.
  r = planner.plan(Vec2(2.0, 1.0), Vec2(5.15, 1.0));
  EXPECT_EQ(r.why, "goal (5.15, 1.00) is inside an obstacle inflated by the robot radius 0.18 m");
  r = planner.plan(Vec2(2.0, 1.0), Vec2(12.0, 1.0));
  EXPECT_FALSE(r.found);
  EXPECT_NE(r.why.find("goal (12.00, 1.00) is outside the map (200 x 100 cells"), std::string::npos) << r.why;
  r = planner.plan(Vec2(std::nan(""), 1.0), Vec2(8.0, 1.0));
  EXPECT_NE(r.why.find("start (nan, 1.00) is not finite"), std::string::npos) << r.why;
}

TEST(Route, StartInsideTheInflatedZoneStillPlans) {
  const RoutePlanner planner(room(5.0, 5.0), config());
  const Vec2 start(0.15, 2.5);  // 0.1 m from the wall's face
  ASSERT_TRUE(planner.lethal(start));
  const Route r = planner.plan(start, Vec2(4.0, 2.5));
  ASSERT_TRUE(r.found) << r.why;
  EXPECT_GT(r.start_moved_m, 0.0);
  EXPECT_LE(r.start_moved_m, planner.config().start_search_radius_m);
  EXPECT_EQ(r.points.front(), start);
  EXPECT_FALSE(planner.lethal(r.points[1]));
  // Nowhere free within the search radius: refused, with the reason.
  RouteConfig narrow = config();
  narrow.start_search_radius_m = 0.02;
  const Route refused = RoutePlanner(room(5.0, 5.0), narrow).plan(start, Vec2(4.0, 2.5));
  EXPECT_FALSE(refused.found);
  EXPECT_EQ(refused.why,
            "start (0.15, 2.50) is inside an obstacle inflated by the robot radius 0.18 m and no free cell lies "
            "within start_search_radius_m 0.02 m");
}

TEST(Route, UnknownCellsAreCrossedOnlyWhenAllowed) {
  RouteGrid g = room(6.0, 4.0);
  fill(g, 2.8, 0.0, 3.2, 4.0, kUnknown);  // unknown from wall to wall
  fill(g, 0.0, 0.0, 6.0, 0.05, kOccupied);
  fill(g, 0.0, 3.95, 6.0, 4.0, kOccupied);
  const Vec2 start(1.0, 2.0), goal(5.0, 2.0);
  const Route allowed = RoutePlanner(g, config()).plan(start, goal);
  ASSERT_TRUE(allowed.found) << allowed.why;
  EXPECT_NEAR(allowed.length_m, 4.0, 1e-9);
  RouteConfig strict = config();
  strict.allow_unknown = false;
  const RoutePlanner planner(g, strict);
  const Route refused = planner.plan(start, goal);
  EXPECT_FALSE(refused.found);
  EXPECT_NE(refused.why.find("not connected"), std::string::npos) << refused.why;
  EXPECT_NE(refused.why.find("unknown cells not crossed"), std::string::npos) << refused.why;
  EXPECT_EQ(planner.plan(start, Vec2(3.0, 2.0)).why,
            "goal (3.00, 2.00) is in an unknown cell and unknown cells may not be crossed (allow_unknown)");
}

TEST(Route, UnknownCellsCostMoreThanFreeOnes) {
  // A wall with a gap at its bottom, and unknown cells over the gap's straight line: with a high penalty the
  // route goes around the unknown patch through the free part of the gap.
  RouteGrid g = room(6.0, 4.0);
  fill(g, 2.95, 1.5, 3.05, 4.0, kOccupied);
  fill(g, 1.5, 0.95, 4.5, 1.5, kUnknown);
  RouteConfig c = config();
  c.unknown_penalty = 10.0;
  const Route r = RoutePlanner(g, c).plan(Vec2(1.0, 1.2), Vec2(5.0, 1.2));
  ASSERT_TRUE(r.found) << r.why;
  for (size_t k = 1; k < r.points.size(); ++k) {
    const Vec2 mid = 0.5 * (r.points[k - 1] + r.points[k]);
    EXPECT_FALSE(mid.x() > 1.5 && mid.x() < 4.5 && mid.y() > 0.95 && mid.y() < 1.5) << mid.transpose();
  }
}

TEST(Route, RefusesGridsBeyondTheCapAndInconsistentInput) {
  RouteGrid wide;
  wide.width = 4097;
  wide.height = 1;
  wide.cells.assign(4097, 0);
  try {
    RoutePlanner planner(wide);
    FAIL() << "a 4097-cell-wide grid was accepted";
  } catch (const RouteError& e) {
    EXPECT_EQ(std::string(e.what()),
              "route grid: size 4097 x 1 cells exceeds the cap of 4096 x 4096 (max_cells_per_side)");
  }
  RouteGrid short_cells = room(1.0, 1.0);
  short_cells.cells.pop_back();
  EXPECT_THROW(RoutePlanner{short_cells}, RouteError);
  RouteConfig c;
  c.robot_radius_m = -0.1;
  try {
    RoutePlanner planner(room(1.0, 1.0), c);
    FAIL() << "a negative radius was accepted";
  } catch (const RouteError& e) {
    EXPECT_NE(std::string(e.what()).find("'robot_radius_m' = -0.1"), std::string::npos) << e.what();
  }
}

/// A U: along the bottom corridor, around the end of the wall at y in [1.45, 1.55), back along the top one.
RouteGrid uTurn() {
  RouteGrid g = room(6.0, 3.0);
  fill(g, 0.0, 1.45, 4.5, 1.55, kOccupied);
  return g;
}

TEST(RouteFollowerTest, SubgoalNeverJumpsBackOnAUTurn) {
  const RoutePlanner planner(uTurn(), config());
  const Route r = planner.plan(Vec2(0.5, 0.75), Vec2(0.5, 2.25));
  ASSERT_TRUE(r.found) << r.why;
  ASSERT_GT(r.length_m, 9.0);
  RouteFollower follower;
  double last_remaining = r.length_m, last_projection = 0.0;
  for (double arc = 0.0; arc <= r.length_m - 0.5; arc += 0.1) {
    const RouteProgress p = planner.subgoal(r, routePointAt(r, arc), 1.0, follower);
    EXPECT_LE(p.remaining_m, last_remaining + 1e-9) << "at arc " << arc;
    EXPECT_GE(p.projection_arc_m, last_projection - 1e-9) << "at arc " << arc;
    EXPECT_LT(p.off_route_m, 1e-6) << "at arc " << arc;
    last_remaining = p.remaining_m;
    last_projection = p.projection_arc_m;
  }
  // On the way back, the robot is pushed toward the first corridor: it is closer to the first leg of the route than
  // to the second, but the projection stays on the second leg.
  const Vec2 pushed(1.0, 1.2);
  const RouteProgress p = planner.subgoal(r, pushed, 1.0, follower);
  EXPECT_LE(p.remaining_m, last_remaining + 1e-9);
  EXPECT_GT(p.off_route_m, 0.5);
  // Without the follower's memory the same point projects onto the first leg.
  RouteFollower fresh;
  EXPECT_GT(planner.subgoal(r, pushed, 1.0, fresh).remaining_m, r.length_m - 2.0);
}

TEST(RouteFollowerTest, SubgoalStaysInLineOfSightAroundACorner) {
  // An L-shaped corridor, 1 m wide: east along the bottom, then north.
  RouteGrid g = room(5.0, 5.0);
  fill(g, 0.0, 1.05, 3.55, 5.0, kOccupied);
  fill(g, 4.55, 0.0, 5.0, 5.0, kOccupied);
  const RoutePlanner planner(g, config());
  const Route r = planner.plan(Vec2(0.6, 0.55), Vec2(4.05, 4.4));
  ASSERT_TRUE(r.found) << r.why;
  RouteFollower follower;
  RouteProgress p;
  Vec2 robot = r.points.front();
  for (double arc = 0.0; robot.x() < 2.5; arc += 0.1) {
    robot = routePointAt(r, arc);
    p = planner.subgoal(r, robot, 3.0, follower);
  }
  const Vec2 naive = routePointAt(r, p.projection_arc_m + 3.0);
  ASSERT_LT(segmentClearance(g, robot, naive), 0.0) << "the lookahead point itself is behind the corner";
  EXPECT_GE(segmentClearance(g, robot, p.subgoal), kRadius - g.resolution_m) << p.subgoal.transpose();
  EXPECT_TRUE(planner.lineOfSight(robot, p.subgoal));
  EXPECT_FALSE(p.final_goal);
  // Pulled back, but still ahead: at least to the corridor's bend.
  EXPECT_GT((p.subgoal - robot).norm(), 0.8);
}

TEST(RouteFollowerTest, RemainingLengthDecreasesAsTheRobotAdvances) {
  const RoutePlanner planner(twoRooms(1.0), config());
  const Route r = planner.plan(Vec2(2.0, 1.0), Vec2(8.0, 1.0));
  ASSERT_TRUE(r.found) << r.why;
  RouteFollower follower;
  double last = std::numeric_limits<double>::infinity();
  const double lookahead = 2.0;
  for (double arc = 0.0; arc < r.length_m; arc += 0.25) {
    // Slightly beside the route, as a real robot would be.
    const Vec2 robot = routePointAt(r, arc) + Vec2(0.0, 0.04);
    const RouteProgress p = planner.subgoal(r, robot, lookahead, follower);
    EXPECT_LT(p.remaining_m, last) << "at arc " << arc;
    EXPECT_NEAR(p.remaining_m, r.length_m - arc, 0.1) << "at arc " << arc;
    EXPECT_LT(p.off_route_m, 0.05);
    EXPECT_EQ(p.final_goal, p.remaining_m < lookahead) << "at arc " << arc;
    if (p.final_goal) {
      EXPECT_EQ(p.subgoal, r.points.back());
    }
    last = p.remaining_m;
  }
}

TEST(RouteBlockedTest, PointAheadOnTheRouteBlocksBehindOrAsideDoesNot) {
  const RoutePlanner planner(room(5.0, 5.0), config());
  const Route r = planner.plan(Vec2(1.0, 2.5), Vec2(4.0, 2.5));
  ASSERT_TRUE(r.found) << r.why;
  RouteFollower follower;
  planner.subgoal(r, Vec2(2.0, 2.5), 1.0, follower);
  EXPECT_TRUE(routeBlocked(r, follower, {Vec2(3.0, 2.55)}, kRadius, 2.0));
  EXPECT_FALSE(routeBlocked(r, follower, {Vec2(1.5, 2.5)}, kRadius, 2.0)) << "behind";
  EXPECT_FALSE(routeBlocked(r, follower, {Vec2(3.0, 3.0)}, kRadius, 2.0)) << "aside";
  EXPECT_FALSE(routeBlocked(r, follower, {Vec2(3.0, 2.5)}, kRadius, 0.5)) << "farther ahead than asked";
  EXPECT_TRUE(routeBlocked(r, follower, {Vec2(0.5, 0.5), Vec2(3.0, 2.5)}, kRadius, 2.0)) << "one of several";
}

TEST(Route, ExtraObstaclePointsAreAvoided) {
  const RouteGrid g = room(5.0, 5.0);
  const RoutePlanner planner(g, config());
  std::vector<Vec2> points;
  for (double y = 2.0; y <= 3.0; y += 0.05) points.emplace_back(2.5, y);
  const Vec2 start(1.0, 2.5), goal(4.0, 2.5);
  const Route r = planner.plan(start, goal, points);
  ASSERT_TRUE(r.found) << r.why;
  EXPECT_GT(r.length_m, 3.2);
  for (size_t k = 1; k < r.points.size(); ++k) {
    for (const Vec2& q : points) {
      const Vec2 a = r.points[k - 1], b = r.points[k];
      const double t = std::clamp((q - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0);
      EXPECT_GE((a + t * (b - a) - q).norm(), kRadius - g.resolution_m) << "segment " << k;
    }
  }
  // The planner's own grid is unchanged.
  EXPECT_NEAR(planner.plan(start, goal).length_m, 3.0, 1e-9);
  EXPECT_EQ(planner.plan(start, Vec2(2.5, 2.5), points).why,
            "goal (2.50, 2.50) is inside an extra obstacle point inflated by the robot radius 0.18 m");
}

TEST(Route, PlansOnAMapLoadedFromTestData) {
  const OccupancyMap map = loadOccupancyMap(std::string(DQN_DOVS_TEST_DATA_DIR) + "/route_rooms.yaml");
  const RouteGrid grid = routeGridFromMap(map);
  ASSERT_EQ(grid.width, 80);
  ASSERT_EQ(grid.height, 40);
  ASSERT_EQ(grid.cells.size(), map.cells.size());
  const RoutePlanner planner(grid, config());
  // The wall between the rooms is grid column 40, map x in [3.0, 3.1) with the origin at (-1, -0.5).
  EXPECT_TRUE(planner.lethal(Vec2(3.05, 1.0)));
  EXPECT_FALSE(planner.lethal(Vec2(4.05, 1.0)));
  const Vec2 start(0.5, 0.5), goal(5.5, 0.5);
  const Route r = planner.plan(start, goal);
  ASSERT_TRUE(r.found) << r.why;
  // Up to the door (map y in [2.0, 3.0)) and down again.
  EXPECT_GT(r.length_m, 2.0 * (Vec2(3.05, 2.0) - start).norm());
  EXPECT_LT(r.length_m, 7.0);
  double highest = -1.0;
  for (const Vec2& p : r.points) highest = std::max(highest, p.y());
  EXPECT_GT(highest, 2.0);
  for (const Vec2& p : r.points) EXPECT_FALSE(planner.lethal(p) && p != start) << p.transpose();
}

TEST(Route, SubgoalOfARouteNotFoundIsTheRobot) {
  const RoutePlanner planner(twoRooms(0.3), config());
  const Route r = planner.plan(Vec2(2.0, 1.0), Vec2(8.0, 1.0));
  ASSERT_FALSE(r.found);
  RouteFollower follower;
  const RouteProgress p = planner.subgoal(r, Vec2(2.0, 1.0), 2.0, follower);
  EXPECT_EQ(p.subgoal, Vec2(2.0, 1.0));
  EXPECT_TRUE(p.final_goal);
  EXPECT_FALSE(routeBlocked(r, follower, {Vec2(2.0, 1.0)}, kRadius, 2.0));
}

TEST(RouteGridFromGeometryTest, WallsAndDiscsBecomeOccupiedCellsARouteGoesAround) {
  // Two 5 x 5 m rooms as segments, the wall between them at x = 5 with a 1 m door at y in [3.5, 4.5], a chair.
  const std::vector<Segment> walls = {{Vec2(0, 0), Vec2(10, 0)},  {Vec2(10, 0), Vec2(10, 5)},
                                      {Vec2(10, 5), Vec2(0, 5)},  {Vec2(0, 5), Vec2(0, 0)},
                                      {Vec2(5, 0), Vec2(5, 3.5)}, {Vec2(5, 4.5), Vec2(5, 5)}};
  const std::vector<Circle> chairs = {{Vec2(7.0, 2.0), 0.25}};
  const RouteGrid g = routeGridFromGeometry(walls, chairs, Vec2(-0.1, -0.1), Vec2(10.1, 5.1), 0.05);
  EXPECT_EQ(g.width, 204);
  EXPECT_EQ(g.height, 104);
  EXPECT_DOUBLE_EQ(g.origin.x, -0.1);
  auto at = [&](const Vec2& p) {
    const int i = static_cast<int>(std::floor((p.x() - g.origin.x) / g.resolution_m));
    const int j = static_cast<int>(std::floor((p.y() - g.origin.y) / g.resolution_m));
    return g.cells[size_t(j) * g.width + i];
  };
  EXPECT_EQ(at(Vec2(5.01, 2.0)), kOccupied) << "a wall";
  EXPECT_EQ(at(Vec2(4.99, 2.0)), kOccupied) << "a wall between two cell centres marks both";
  EXPECT_EQ(at(Vec2(5.0, 4.0)), 0) << "the door";
  EXPECT_EQ(at(Vec2(7.0, 2.0)), kOccupied) << "the chair";
  EXPECT_EQ(at(Vec2(7.0, 2.4)), 0);
  // A diagonal wall leaves no gap a route could slip through.
  const RouteGrid d = routeGridFromGeometry({{Vec2(0, 0), Vec2(3, 2.9)}}, {}, Vec2(-0.5, -0.5), Vec2(3.5, 3.5), 0.05);
  const RoutePlanner across(d, config());
  const Route blocked = across.plan(Vec2(0.5, 2.5), Vec2(2.5, 0.5));
  ASSERT_TRUE(blocked.found) << blocked.why;
  EXPECT_GT(blocked.length_m, 4.0) << "round the diagonal wall's ends, not through it";
  // Through the door, around the chair.
  const RoutePlanner planner(g, config());
  const Route r = planner.plan(Vec2(2.0, 1.0), Vec2(8.0, 1.0));
  ASSERT_TRUE(r.found) << r.why;
  double highest = 0.0;
  for (const Vec2& p : r.points) highest = std::max(highest, p.y());
  EXPECT_GT(highest, 3.5);
  for (size_t k = 1; k < r.points.size(); ++k) {
    EXPECT_GT(pointSegmentDistance(Vec2(7.0, 2.0), {r.points[k - 1], r.points[k]}), 0.25 + kRadius - 0.05);
  }
}

TEST(RouteGridFromGeometryTest, BadInputIsNamed) {
  const auto message = [](const std::vector<Segment>& s, const Vec2& lo, const Vec2& hi, double res) {
    try {
      routeGridFromGeometry(s, {}, lo, hi, res);
    } catch (const RouteError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(message({}, Vec2(0, 0), Vec2(1, 1), 0.0).find("resolution"), std::string::npos);
  EXPECT_NE(message({}, Vec2(1, 0), Vec2(0, 1), 0.05).find("is not finite or empty"), std::string::npos);
  EXPECT_NE(message({}, Vec2(0, 0), Vec2(1e4, 1), 0.05).find("more than 4096 cells"), std::string::npos);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(message({{Vec2(nan, 0), Vec2(1, 1)}}, Vec2(0, 0), Vec2(1, 1), 0.05).find("a segment is not finite"),
            std::string::npos);
}

TEST(RouteGridFromGeometryTest, AKnownWorldsGridCoversItsWallsStartAndGoal) {
  // A corridor's two walls, a chair in it, a goal beyond the walls' ends and a start below them.
  const std::vector<Segment> walls = {{Vec2(0, 0), Vec2(6, 0)}, {Vec2(0, 2), Vec2(6, 2)}};
  const std::vector<Circle> chairs = {{Vec2(3.0, 1.0), 0.3}};
  const RouteGrid g = knownWorldGrid(walls, chairs, {Vec2(1.0, -1.0), Vec2(8.0, 1.0)}, 0.05);
  auto at = [&](const Vec2& p) {
    const int i = static_cast<int>(std::floor((p.x() - g.origin.x) / g.resolution_m));
    const int j = static_cast<int>(std::floor((p.y() - g.origin.y) / g.resolution_m));
    EXPECT_TRUE(i >= 0 && j >= 0 && i < g.width && j < g.height) << "(" << p.x() << ", " << p.y() << ") off the grid";
    return g.cells[size_t(j) * g.width + i];
  };
  // The box of the walls, the start and the goal, two cells more on every side.
  EXPECT_NEAR(g.origin.x, -0.1, 1e-9);
  EXPECT_NEAR(g.origin.y, -1.1, 1e-9);
  EXPECT_NEAR(g.origin.x + g.width * g.resolution_m, 8.1, 0.05 + 1e-9);
  EXPECT_NEAR(g.origin.y + g.height * g.resolution_m, 2.1, 0.05 + 1e-9);
  EXPECT_EQ(at(Vec2(1.0, -1.0)), 0) << "the start";
  EXPECT_EQ(at(Vec2(8.0, 1.0)), 0) << "the goal";
  EXPECT_EQ(at(Vec2(2.0, 0.0)), kOccupied) << "a wall";
  EXPECT_EQ(at(Vec2(3.0, 1.0)), kOccupied) << "the chair";
  EXPECT_EQ(at(Vec2(1.0, 1.0)), 0);
  // It is routeGridFromGeometry over that box: the evaluation's episodes and simulator_node's map agree.
  const RouteGrid same = routeGridFromGeometry(walls, chairs, Vec2(-0.1, -1.1), Vec2(8.1, 2.1), 0.05);
  EXPECT_EQ(g.cells, same.cells);
  EXPECT_EQ(g.width, same.width);
  try {
    knownWorldGrid({}, chairs, {}, 0.05);
    ADD_FAILURE() << "nothing to cover was accepted";
  } catch (const RouteError& e) {
    EXPECT_NE(std::string(e.what()).find("no walls and no point to cover"), std::string::npos) << e.what();
  }
}

TEST(RouteGuideTest, GivesTheSubgoalOfThePrimitivesAndTheGoalItselfAtTheEnd) {
  const RoutePlanner planner(twoRooms(1.0), config());
  const Vec2 start(2.0, 1.0), goal(8.0, 1.0);
  RouteGuide guide;
  EXPECT_EQ(guide.config().lookahead_m, 3.0) << "planner_node's route/lookahead";
  // Without a route: the goal itself.
  RouteGuidance g = guide.update(&planner, start, goal, 0.0);
  EXPECT_FALSE(g.on_route);
  EXPECT_EQ(g.local_goal, goal);
  EXPECT_TRUE(g.final_goal);
  EXPECT_DOUBLE_EQ(g.remaining_m, (goal - start).norm());
  ASSERT_EQ(guide.plan(planner, start, goal, 0.0), "");
  ASSERT_TRUE(guide.hasRoute());
  ASSERT_TRUE(guide.planned());
  const Route route = guide.route();
  EXPECT_EQ(route.points.back(), goal);
  // Step by step along the route, beside it as a real robot: what RoutePlanner::subgoal gives with its own follower.
  RouteFollower follower;
  bool finals = false;
  for (double arc = 0.0; arc < route.length_m; arc += 0.2) {
    const Vec2 robot = routePointAt(route, arc) + Vec2(0.03, -0.02);
    g = guide.update(&planner, robot, goal, arc);
    const RouteProgress p = planner.subgoal(route, robot, 3.0, follower);
    ASSERT_TRUE(g.on_route);
    EXPECT_EQ(g.final_goal, p.final_goal) << "at arc " << arc;
    EXPECT_EQ(g.local_goal, p.final_goal ? goal : p.subgoal) << "at arc " << arc;
    EXPECT_EQ(g.remaining_m, p.remaining_m);
    EXPECT_EQ(g.off_route_m, p.off_route_m);
    EXPECT_EQ(g.replan, RouteReplan::kNone);
    EXPECT_NEAR(guide.distanceToGo(robot, goal), p.off_route_m + p.remaining_m, 1e-9);
    finals = finals || g.final_goal;
  }
  EXPECT_TRUE(finals);
  // A route given as is (another global planner's): followRoute, never planned again even far off it.
  const Route given = routeFromPoints({start, Vec2(5.0, 4.0), goal});
  guide.follow(given);
  EXPECT_FALSE(guide.planned());
  RouteFollower given_follower;
  for (const Vec2& robot : {Vec2(2.5, 1.5), Vec2(4.0, 3.0), Vec2(3.0, 0.5)}) {
    g = guide.update(&planner, robot, goal, 0.0);
    const RouteProgress p = followRoute(given, robot, 3.0, given_follower);
    EXPECT_EQ(g.local_goal, p.final_goal ? goal : p.subgoal);
    EXPECT_EQ(g.replan, RouteReplan::kNone);
  }
  guide.clear();
  EXPECT_FALSE(guide.hasRoute());
}

TEST(RouteGuideTest, PlansAgainOffTheRouteAfterARoundAndWhenBlockedTwice) {
  const RoutePlanner planner(room(10.0, 5.0), config());
  const Vec2 start(1.0, 2.5), goal(9.0, 2.5);
  RouteGuideConfig c;
  c.replan_off_route_m = 1.0;
  RouteGuide guide(c);
  ASSERT_EQ(guide.plan(planner, start, goal, 0.0), "");
  std::vector<Vec2> seen;
  int scans = 0;
  const auto scan = [&]() {
    ++scans;
    return seen;
  };
  // On the route, nothing seen: no replan; the scan is read once per blocked_check_period_s.
  RouteGuidance g = guide.update(&planner, Vec2(2.0, 2.5), goal, 10.0, 0, scan);
  EXPECT_EQ(g.replan, RouteReplan::kNone);
  g = guide.update(&planner, Vec2(2.1, 2.5), goal, 10.5, 0, scan);
  EXPECT_EQ(scans, 1);
  // A panel across the way: blocked at the second check a period later, then planned round it.
  for (double y = 1.5; y <= 3.5; y += 0.05) seen.emplace_back(4.0, y);
  g = guide.update(&planner, Vec2(2.2, 2.5), goal, 11.0, 0, scan);
  EXPECT_EQ(g.replan, RouteReplan::kNone) << "seen once: a person walking across is gone by the next check";
  g = guide.update(&planner, Vec2(2.3, 2.5), goal, 12.0, 0, scan);
  EXPECT_EQ(g.replan, RouteReplan::kBlocked);
  EXPECT_TRUE(g.replanned) << g.replan_error;
  EXPECT_EQ(routeReplanName(g.replan), std::string("blocked"));
  EXPECT_GT(guide.route().length_m, 7.0);
  for (size_t k = 1; k < guide.route().points.size(); ++k) {
    EXPECT_GT(pointSegmentDistance(Vec2(4.0, 2.5), {guide.route().points[k - 1], guide.route().points[k]}), 0.9);
  }
  // The panel gone from sight, it is remembered: off the route, the new plan still goes round it.
  seen.clear();
  g = guide.update(&planner, Vec2(2.3, 0.8), goal, 13.0, 0, scan);
  EXPECT_EQ(g.replan, RouteReplan::kOffRoute);
  ASSERT_TRUE(g.replanned) << g.replan_error;
  for (size_t k = 1; k < guide.route().points.size(); ++k) {
    EXPECT_GT(pointSegmentDistance(Vec2(4.0, 2.5), {guide.route().points[k - 1], guide.route().points[k]}), 0.9);
  }
  // A recovery round ends: planned again.
  g = guide.update(&planner, guide.route().points.front(), goal, 13.2, 1, scan);
  EXPECT_EQ(g.replan, RouteReplan::kAfterRound);
  g = guide.update(&planner, guide.route().points.front(), goal, 13.4, 1, scan);
  EXPECT_EQ(g.replan, RouteReplan::kNone) << "the same round counts once";
  // Past obstacle_memory_s the panel is forgotten: the straight route again.
  g = guide.update(&planner, Vec2(2.0, 2.5), goal, 200.0, 1, scan);
  EXPECT_EQ(g.replan, RouteReplan::kOffRoute);
  EXPECT_NEAR(guide.route().length_m, 7.0, 1e-9);
  // A plan that fails keeps the route and says why.
  const Route kept = guide.route();
  g = guide.update(&planner, Vec2(2.0, 1.0), Vec2(20.0, 2.5), 201.0, 1, scan);
  EXPECT_EQ(g.replan, RouteReplan::kOffRoute);
  EXPECT_FALSE(g.replanned);
  EXPECT_EQ(g.replan_error.rfind("no route: goal (20.00, 2.50) is outside the map", 0), 0u) << g.replan_error;
  EXPECT_EQ(guide.route().points, kept.points);
  // Without the planner (a map of another frame) it only follows.
  g = guide.update(nullptr, Vec2(2.0, 4.5), goal, 202.0, 2, scan);
  EXPECT_EQ(g.replan, RouteReplan::kNone);
  EXPECT_TRUE(g.on_route);
}

TEST(RouteGuideTest, BadSettingsAreNamed) {
  RouteGuideConfig c;
  EXPECT_EQ(c.validate(), "");
  c.lookahead_m = 0.0;
  EXPECT_EQ(c.validate(), "route parameter 'lookahead_m' = 0: must be > 0 m");
  c = RouteGuideConfig();
  c.blocked_clearance_fraction = 1.5;
  EXPECT_NE(c.validate().find("blocked_clearance_fraction"), std::string::npos);
  c = RouteGuideConfig();
  c.obstacle_memory_s = -1.0;
  EXPECT_THROW(RouteGuide{c}, RouteError);
  RouteGuide guide;
  EXPECT_THROW(guide.setConfig(c), RouteError);
  EXPECT_EQ(guide.config().obstacle_memory_s, RouteGuideConfig().obstacle_memory_s) << "the settings in force stay";
}

}  // namespace
}  // namespace dqn_dovs
