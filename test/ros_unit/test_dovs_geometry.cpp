// The drawing maths of the rviz DOVS display, on messages built by the same pipeline step dovs_node runs.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <optional>

#include "conversions.h"
#include "dovs_geometry.h"
#include "dqn_dovs/dovs/dovs.h"
#include "pipeline_steps.h"

namespace {

using dqn_dovs::Dovs;
using dqn_dovs_rviz::PlotPoint;
using dqn_dovs_rviz::Polygon;

constexpr double kTol = 1e-9;

// A Dovs message from the real pipeline step: robot at the origin heading +x, the given velocity, goal and
// obstacles (fixed frame = robot frame here).
struct Built {
  Dovs msg;
  dqn_dovs::VelocitySpace space;
};

Built buildMessage(const dqn_dovs::Twist2& current, const std::optional<dqn_dovs::Vec2>& goal,
                   const std::vector<dqn_dovs::MovingObstacle>& obstacles = {},
                   const std::vector<dqn_dovs::Segment>& walls = {}) {
  const dqn_dovs::RobotLimits limits;
  const dqn_dovs::DovsConfig config;
  // The drawing is checked against the validity mask alone (the shield's narrowing is tested in the core).
  const auto unshielded = [] {
    dqn_dovs::ActionShieldConfig c;
    c.enabled = false;
    return c;
  };
  dqn_dovs::DovsBuilder builder(limits, config);
  dqn_dovs::TrackedObstacleArray obstacles_msg = dqn_dovs::movingObstaclesToMsg(obstacles, walls);
  obstacles_msg.header.stamp = ros::Time(10.0);
  obstacles_msg.header.frame_id = "odom";
  Built b;
  dqn_dovs::DovsStep step;
  const std::string error = dqn_dovs::buildDovsStep(obstacles_msg, dqn_dovs::Pose2{}, current, goal, limits,
                                                    dqn_dovs::stateNormalization(limits, config), unshielded(),
                                                    "base_footprint", builder, b.space, step);
  EXPECT_EQ(error, "");
  b.msg = step.msg;
  return b;
}

bool coveredByAny(const std::vector<Polygon>& polygons, const PlotPoint& p) {
  for (const Polygon& poly : polygons) {
    if (dqn_dovs_rviz::convexPolygonContains(poly, p)) return true;
  }
  return false;
}

double totalArea(const std::vector<Polygon>& polygons) {
  double a = 0.0;
  for (const Polygon& p : polygons) a += dqn_dovs_rviz::polygonArea(p);
  return a;
}

bool insideTriangle(const PlotPoint& p, double tol = 1e-12) {
  return p.y() >= -tol && p.y() + std::abs(p.x()) <= 1.0 + tol;
}

double distanceToSegment(const PlotPoint& p, const PlotPoint& a, const PlotPoint& b) {
  const PlotPoint ab = b - a;
  const double t = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
  return (a + t * ab - p).norm();
}

// The message with all intervals replaced by `intervals` on ray `ray` (speeds in m/s).
Dovs withIntervalsOnRay(Dovs msg, size_t ray, const std::vector<std::pair<float, float>>& intervals) {
  const size_t n = msg.trajectory_v_top.size();
  msg.interval_lo.clear();
  msg.interval_hi.clear();
  msg.interval_begin.assign(n + 1, 0);
  for (const auto& [lo, hi] : intervals) {
    msg.interval_lo.push_back(lo);
    msg.interval_hi.push_back(hi);
  }
  for (size_t i = ray + 1; i <= n; ++i) msg.interval_begin[i] = static_cast<uint32_t>(intervals.size());
  return msg;
}

PlotPoint rayTop(const Dovs& msg, size_t i) {
  return dqn_dovs_rviz::toPlot(msg.trajectory_v_top[i], msg.trajectory_w_top[i], msg.v_max, msg.w_max);
}

TEST(DovsGeometry, TriangleAndPlotMapping) {
  const Polygon t = dqn_dovs_rviz::feasibleTriangle();
  ASSERT_EQ(t.size(), 3u);
  EXPECT_TRUE(t[0].isApprox(PlotPoint(-1.0, 0.0)));
  EXPECT_TRUE(t[1].isApprox(PlotPoint(1.0, 0.0)));
  EXPECT_TRUE(t[2].isApprox(PlotPoint(0.0, 1.0)));
  EXPECT_NEAR(dqn_dovs_rviz::polygonArea(t), 1.0, kTol);  // counter-clockwise

  // The triangle's corners are the limits: (v_max, 0) at the top, (0, +-w_max) at the bottom corners.
  EXPECT_TRUE(dqn_dovs_rviz::toPlot(0.7, 0.0, 0.7, M_PI).isApprox(t[2]));
  EXPECT_TRUE(dqn_dovs_rviz::toPlot(0.0, M_PI, 0.7, M_PI).isApprox(t[1]));
  EXPECT_TRUE(dqn_dovs_rviz::toPlot(0.0, -M_PI, 0.7, M_PI).isApprox(t[0]));
  EXPECT_TRUE(dqn_dovs_rviz::toPlot(0.35, 1.0, 0.7, 2.0).isApprox(PlotPoint(0.5, 0.5)));

  // Placement: v along the robot's heading, w toward its right, lifted by layer * scale.
  dqn_dovs_rviz::OverlayPlacement at;
  at.scale_m = 2.0;
  at.offset_m = Eigen::Vector3d(0.1, -1.0, 0.05);
  EXPECT_TRUE(dqn_dovs_rviz::plotToRobot(PlotPoint(0.0, 0.0), at).isApprox(Eigen::Vector3d(0.1, -1.0, 0.05)));
  EXPECT_TRUE(dqn_dovs_rviz::plotToRobot(PlotPoint(0.0, 1.0), at).isApprox(Eigen::Vector3d(2.1, -1.0, 0.05)));
  EXPECT_TRUE(dqn_dovs_rviz::plotToRobot(PlotPoint(1.0, 0.0), at).isApprox(Eigen::Vector3d(0.1, -3.0, 0.05)));
  EXPECT_TRUE(dqn_dovs_rviz::plotToRobot(PlotPoint(-0.5, 0.0), at, 0.01).isApprox(Eigen::Vector3d(0.1, 0.0, 0.07)));
}

TEST(DovsGeometry, WindowInsideTheTriangleIsTheWholeRhombus) {
  const Built b = buildMessage({0.3, 0.4}, dqn_dovs::Vec2(3.0, 0.0));
  const Polygon w = dqn_dovs_rviz::dynamicWindowPolygon(b.msg);
  ASSERT_EQ(w.size(), 4u);
  const double hv = b.msg.dv / b.msg.v_max, hw = b.msg.dw / b.msg.w_max;
  EXPECT_NEAR(dqn_dovs_rviz::polygonArea(w), 2.0 * hv * hw, kTol);
  const PlotPoint c = dqn_dovs_rviz::toPlot(0.3, 0.4, b.msg.v_max, b.msg.w_max);
  EXPECT_TRUE(w[0].isApprox(c + PlotPoint(0.0, -hv)));
  EXPECT_TRUE(w[2].isApprox(c + PlotPoint(0.0, hv)));
}

TEST(DovsGeometry, WindowIsClippedAtZeroSpeed) {
  const Built b = buildMessage({0.04, 0.0}, dqn_dovs::Vec2(3.0, 0.0));
  const Polygon w = dqn_dovs_rviz::dynamicWindowPolygon(b.msg);
  const double hv = b.msg.dv / b.msg.v_max, hw = b.msg.dw / b.msg.w_max;
  const double cy = 0.04 / b.msg.v_max;
  ASSERT_GT(hv, cy);  // the rhombus reaches below v = 0
  const double depth = hv - cy;
  EXPECT_NEAR(dqn_dovs_rviz::polygonArea(w), 2.0 * hv * hw - hw * depth * depth / hv, 1e-12);
  int on_axis = 0;
  for (const PlotPoint& p : w) {
    EXPECT_TRUE(insideTriangle(p)) << p.transpose();
    if (std::abs(p.y()) < 1e-12) ++on_axis;
  }
  EXPECT_EQ(on_axis, 2);
  // The cut at v = 0 is as wide as the rhombus there.
  EXPECT_TRUE(dqn_dovs_rviz::convexPolygonContains(w, PlotPoint(hw * (1.0 - depth / hv) - 1e-6, 0.0)));
  EXPECT_FALSE(dqn_dovs_rviz::convexPolygonContains(w, PlotPoint(0.0, -1e-6), 0.0));
}

TEST(DovsGeometry, WindowIsClippedAtTheTriangleEdge) {
  // Current velocity on the edge v / v_max + w / w_max = 1: a line through the centre of a centrally symmetric
  // rhombus leaves half of it.
  const double v = 0.5, w = M_PI * (1.0 - v / 0.7);
  const Built b = buildMessage({v, w}, dqn_dovs::Vec2(3.0, 0.0));
  ASSERT_NEAR(b.msg.v, v, 1e-9);
  ASSERT_NEAR(b.msg.w, w, 1e-9);
  const Polygon poly = dqn_dovs_rviz::dynamicWindowPolygon(b.msg);
  const double hv = b.msg.dv / b.msg.v_max, hw = b.msg.dw / b.msg.w_max;
  EXPECT_NEAR(dqn_dovs_rviz::polygonArea(poly), hv * hw, 1e-12);
  for (const PlotPoint& p : poly) EXPECT_TRUE(insideTriangle(p)) << p.transpose();

  // Entirely outside (an inconsistent message): nothing to draw.
  Dovs outside = b.msg;
  outside.v = 2.0 * outside.v_max;
  EXPECT_TRUE(dqn_dovs_rviz::dynamicWindowPolygon(outside).empty());
}

TEST(DovsGeometry, GoalLinePassesThroughTheWindowAndItsActions) {
  // Goal ahead-left: the goal line crosses the window, actions 5 and 6 are its ends inside the window.
  const Built b = buildMessage({0.3, 0.3}, dqn_dovs::Vec2(2.0, 0.8));
  ASSERT_EQ(b.msg.goal_line_kind, Dovs::GOAL_ARC);
  ASSERT_TRUE(b.msg.action_valid[5] && b.msg.action_valid[6]);
  const dqn_dovs_rviz::Polyline line = dqn_dovs_rviz::goalLineSegment(b.msg);
  ASSERT_EQ(line.size(), 2u);
  EXPECT_TRUE(line[0].isZero());
  EXPECT_NEAR(line[1].y() + std::abs(line[1].x()), 1.0, 1e-12);  // ends on the triangle edge
  // Along w = k v.
  EXPECT_NEAR(line[1].x() * b.msg.w_max, b.msg.goal_curvature * line[1].y() * b.msg.v_max, 1e-9);
  EXPECT_GT(line[1].x(), 0.0);  // the goal is on the left: turning counter-clockwise

  const Polygon window = dqn_dovs_rviz::dynamicWindowPolygon(b.msg);
  const auto actions = dqn_dovs_rviz::actionPoints(b.msg);
  for (const size_t i : {size_t{5}, size_t{6}, size_t{7}}) {
    if (!actions[i].valid) continue;
    EXPECT_LT(distanceToSegment(actions[i].position, line[0], line[1]), 1e-9) << "action " << i;
    EXPECT_TRUE(dqn_dovs_rviz::convexPolygonContains(window, actions[i].position, 1e-9)) << "action " << i;
  }
  // The segment really crosses the window: its midpoint between actions 5 and 6 is inside.
  EXPECT_TRUE(dqn_dovs_rviz::convexPolygonContains(window, 0.5 * (actions[5].position + actions[6].position), 1e-9));
}

TEST(DovsGeometry, GoalLineTurnInPlaceAndNoGoal) {
  const Built behind = buildMessage({0.0, 0.0}, dqn_dovs::Vec2(-2.0, -0.5));
  ASSERT_EQ(behind.msg.goal_line_kind, Dovs::GOAL_TURN_IN_PLACE);
  const dqn_dovs_rviz::Polyline line = dqn_dovs_rviz::goalLineSegment(behind.msg);
  ASSERT_EQ(line.size(), 2u);
  EXPECT_TRUE(line[0].isZero());
  EXPECT_TRUE(line[1].isApprox(PlotPoint(-1.0, 0.0)));  // goal on the right: clockwise, w < 0

  const Built none = buildMessage({0.2, 0.0}, std::nullopt);
  EXPECT_FALSE(none.msg.has_goal);
  EXPECT_TRUE(dqn_dovs_rviz::goalLineSegment(none.msg).empty());
}

TEST(DovsGeometry, IntervalCoversExactlyItsPartOfTheRayAndTheNeighbouringSectors) {
  const Built b = buildMessage({0.2, 0.0}, dqn_dovs::Vec2(3.0, 0.0));
  const size_t n = b.msg.trajectory_v_top.size();
  ASSERT_GE(n, 5u);
  const size_t ray = n / 2 + 5;
  const double v_top = b.msg.trajectory_v_top[ray];
  const float lo = static_cast<float>(0.3 * v_top), hi = static_cast<float>(0.6 * v_top);
  const Dovs msg = withIntervalsOnRay(b.msg, ray, {{lo, hi}});
  ASSERT_EQ(dqn_dovs_rviz::validateDovsMessage(msg), "");
  const std::vector<Polygon> dov = dqn_dovs_rviz::dovPolygons(msg);
  ASSERT_EQ(dov.size(), 2u);  // one per neighbouring sector

  // Along the ray: covered exactly on [lo, hi].
  const PlotPoint top = rayTop(msg, ray);
  for (int k = 1; k < 200; ++k) {
    const double v = v_top * k / 200.0;
    if (std::abs(v - lo) < 1e-6 || std::abs(v - hi) < 1e-6) continue;
    const bool unsafe = v >= lo && v <= hi;
    EXPECT_EQ(coveredByAny(dov, top * (v / v_top)), unsafe) << "v = " << v;
  }
  // On the bisectors of both neighbouring sectors: covered between the chords at the interval's radii; the next
  // sectors out are untouched.
  const double r0 = lo / v_top * top.norm(), r1 = hi / v_top * top.norm();
  for (const size_t other : {ray - 1, ray + 1}) {
    const PlotPoint bisector = (top.normalized() + rayTop(msg, other).normalized()).normalized();
    const double half = 0.5 * std::acos(top.normalized().dot(rayTop(msg, other).normalized()));
    for (int k = 1; k < 200; ++k) {
      const double rho = k / 200.0;
      if (std::abs(rho - r0 * std::cos(half)) < 1e-6 || std::abs(rho - r1 * std::cos(half)) < 1e-6) continue;
      const bool unsafe = rho >= r0 * std::cos(half) && rho <= r1 * std::cos(half);
      EXPECT_EQ(coveredByAny(dov, rho * bisector), unsafe) << "sector toward ray " << other << ", radius " << rho;
    }
  }
  const PlotPoint beyond = (rayTop(msg, ray + 1).normalized() + rayTop(msg, ray + 2).normalized()).normalized();
  EXPECT_FALSE(coveredByAny(dov, 0.45 * top.norm() * beyond));
  // Each sector piece is the quad between the chords: area sin(angle) (r1^2 - r0^2) / 2.
  double expected = 0.0;
  for (const size_t other : {ray - 1, ray + 1}) {
    const double angle = std::acos(top.normalized().dot(rayTop(msg, other).normalized()));
    expected += 0.5 * std::sin(angle) * (r1 * r1 - r0 * r0);
  }
  EXPECT_NEAR(totalArea(dov), expected, 1e-9);
}

TEST(DovsGeometry, IntervalReachingTheRayEndCoversTheSectorToTheTriangleEdge) {
  const Built b = buildMessage({0.2, 0.0}, dqn_dovs::Vec2(3.0, 0.0));
  const size_t ray = b.msg.trajectory_v_top.size() / 2 - 7;
  const double v_top = b.msg.trajectory_v_top[ray];
  const Dovs msg = withIntervalsOnRay(b.msg, ray, {{static_cast<float>(0.5 * v_top), static_cast<float>(v_top)}});
  const std::vector<Polygon> dov = dqn_dovs_rviz::dovPolygons(msg);
  ASSERT_EQ(dov.size(), 2u);
  for (const Polygon& p : dov) {
    for (const PlotPoint& q : p) EXPECT_TRUE(insideTriangle(q, 1e-12)) << q.transpose();
  }
  // Just inside the triangle edge between this ray and each neighbour: unsafe, as the velocity space says
  // (a neighbour's end stands for the velocities beyond it).
  for (const size_t other : {ray - 1, ray + 1}) {
    const PlotPoint mid = 0.5 * (rayTop(msg, ray) + rayTop(msg, other));
    const PlotPoint near_edge = mid * (1.0 - 1e-6);
    EXPECT_TRUE(coveredByAny(dov, near_edge)) << "toward ray " << other;
  }
}

TEST(DovsGeometry, DovPolygonsAgreeWithTheVelocitySpace) {
  // People crossing from both sides and coming head-on, a person standing close ahead-right, a wall close on
  // the left: a DOV with intervals on most rays.
  std::vector<dqn_dovs::MovingObstacle> obstacles(4);
  obstacles[0].center = dqn_dovs::Vec2(1.5, -1.5);
  obstacles[0].heading = M_PI / 2;
  obstacles[0].speed = 0.6;
  obstacles[1].center = dqn_dovs::Vec2(1.0, 1.5);
  obstacles[1].heading = -M_PI / 2;
  obstacles[1].speed = 0.4;
  obstacles[1].turn_rate = 0.3;
  obstacles[2].center = dqn_dovs::Vec2(2.5, 0.1);
  obstacles[2].heading = M_PI;
  obstacles[2].speed = 0.5;
  obstacles[3].center = dqn_dovs::Vec2(0.6, -0.5);
  obstacles[3].is_static = true;
  const std::vector<dqn_dovs::Segment> walls{{dqn_dovs::Vec2(0.3, 0.8), dqn_dovs::Vec2(3.0, 0.8)}};
  const Built b = buildMessage({0.3, 0.1}, dqn_dovs::Vec2(4.0, 0.0), obstacles, walls);
  const Dovs& msg = b.msg;
  ASSERT_GT(msg.interval_lo.size(), 10u);
  const std::vector<Polygon> dov = dqn_dovs_rviz::dovPolygons(msg);
  for (const Polygon& p : dov) {
    EXPECT_GT(dqn_dovs_rviz::polygonArea(p), 0.0);
    for (const PlotPoint& q : p) EXPECT_TRUE(insideTriangle(q, 1e-12));
  }

  // Boundary radii of every ray (interval ends and the ray end), to skip samples on a boundary: the message's
  // float32 bounds and the straight chords move boundaries by far less than the margin.
  const size_t n = msg.trajectory_v_top.size();
  std::vector<std::vector<double>> boundaries(n);
  std::vector<double> ray_angles(n);
  for (size_t i = 0; i < n; ++i) {
    const PlotPoint top = rayTop(msg, i);
    ray_angles[i] = std::atan2(top.y(), top.x());
    boundaries[i].push_back(top.norm());
    if (msg.trajectory_v_top[i] <= 0.0f) continue;
    for (uint32_t k = msg.interval_begin[i]; k < msg.interval_begin[i + 1]; ++k) {
      boundaries[i].push_back(msg.interval_lo[k] / msg.trajectory_v_top[i] * top.norm());
      boundaries[i].push_back(msg.interval_hi[k] / msg.trajectory_v_top[i] * top.norm());
    }
  }
  const double margin = 2e-3;
  int checked = 0, unsafe = 0, mismatches = 0;
  for (int iy = 0; iy < 160; ++iy) {
    for (int ix = 0; ix < 320; ++ix) {
      const PlotPoint p(-1.0 + (ix + 0.37) / 160.0, (iy + 0.61) / 160.0);
      if (p.y() < margin || p.y() + std::abs(p.x()) > 1.0 - margin) continue;
      const double angle = std::atan2(p.y(), p.x()), rho = p.norm();
      bool near_boundary = false;
      for (size_t i = 0; i < n && !near_boundary; ++i) {
        if (std::abs(angle - ray_angles[i]) < 1e-6) near_boundary = true;
        // Only the two rays around the sample matter.
        const double gap = M_PI / static_cast<double>(n - 1);
        if (std::abs(angle - ray_angles[i]) > gap + 1e-9) continue;
        for (const double r : boundaries[i]) near_boundary = near_boundary || std::abs(rho - r) < margin;
      }
      if (near_boundary) continue;
      const dqn_dovs::Twist2 t{p.y() * msg.v_max, p.x() * msg.w_max};
      const bool expected_unsafe = !b.space.isFree(t);
      if (coveredByAny(dov, p) != expected_unsafe && ++mismatches <= 5) {
        ADD_FAILURE() << "w = " << t.w << ", v = " << t.v << ": drawn " << (expected_unsafe ? "free" : "unsafe")
                      << ", the velocity space says " << (expected_unsafe ? "unsafe" : "free");
      }
      ++checked;
      unsafe += expected_unsafe ? 1 : 0;
    }
  }
  EXPECT_EQ(mismatches, 0) << "of " << checked << " samples";
  EXPECT_GT(checked, 20000);
  EXPECT_GT(unsafe, 1000);
  EXPECT_LT(unsafe, checked - 1000);
}

TEST(DovsGeometry, GridCellsAreTheUnsafeCellsOfTheState) {
  std::vector<dqn_dovs::MovingObstacle> obstacles(1);
  obstacles[0].center = dqn_dovs::Vec2(1.0, 0.2);
  obstacles[0].is_static = true;
  const Built b = buildMessage({0.3, 0.0}, dqn_dovs::Vec2(3.0, 0.0), obstacles);
  const Dovs& msg = b.msg;
  const std::vector<Polygon> cells = dqn_dovs_rviz::gridUnsafeCells(msg);
  const size_t rows = msg.grid_rows, cols = msg.grid_cols;
  ASSERT_EQ(rows, 20u);
  size_t k = 0;
  for (size_t r = 0; r < rows; ++r) {
    for (size_t c = 0; c < cols; ++c) {
      if (msg.state[r * cols + c] > 0.0f) continue;
      ASSERT_LT(k, cells.size());
      const Polygon& cell = cells[k++];
      ASSERT_EQ(cell.size(), 4u);
      EXPECT_NEAR(dqn_dovs_rviz::polygonArea(cell), 2.0 / static_cast<double>(rows * cols), 1e-12);
      const PlotPoint centre = 0.25 * (cell[0] + cell[1] + cell[2] + cell[3]);
      const dqn_dovs::Twist2 t = b.space.gridCellVelocity(static_cast<int>(r), static_cast<int>(c));
      EXPECT_TRUE(centre.isApprox(dqn_dovs_rviz::toPlot(t.v, t.w, msg.v_max, msg.w_max), 1e-12))
          << "cell " << r << ", " << c;
    }
  }
  EXPECT_EQ(k, cells.size());
  // The obstacle ahead makes some feasible cells unsafe, beyond the infeasible ones outside the triangle.
  size_t unsafe_inside = 0;
  for (const Polygon& cell : cells) {
    const PlotPoint centre = 0.25 * (cell[0] + cell[1] + cell[2] + cell[3]);
    unsafe_inside += insideTriangle(centre) ? 1 : 0;
  }
  EXPECT_GT(unsafe_inside, 0u);
}

TEST(DovsGeometry, ActionPointsFollowTheMessage) {
  Built b = buildMessage({0.3, -0.5}, dqn_dovs::Vec2(2.0, -1.0));
  const auto actions = dqn_dovs_rviz::actionPoints(b.msg);
  const Polygon window = dqn_dovs_rviz::dynamicWindowPolygon(b.msg);
  for (size_t i = 0; i < dqn_dovs_rviz::kNumActionPoints; ++i) {
    EXPECT_EQ(actions[i].valid, static_cast<bool>(b.msg.action_valid[i])) << i;
    EXPECT_TRUE(actions[i].position.isApprox(
        dqn_dovs_rviz::toPlot(b.msg.action_v[i], b.msg.action_w[i], b.msg.v_max, b.msg.w_max)));
    if (actions[i].valid) {
      EXPECT_TRUE(dqn_dovs_rviz::convexPolygonContains(window, actions[i].position, 1e-9)) << i;
    }
  }
  // Action 4 (keep) is the current velocity, the window's centre.
  const dqn_dovs_rviz::DovsGeometry g = dqn_dovs_rviz::computeDovsGeometry(b.msg);
  EXPECT_TRUE(g.current.isApprox(actions[4].position));
  // A masked slot may hold NaN: drawn as masked, never as valid.
  b.msg.action_valid[6] = false;
  b.msg.action_v[6] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(dqn_dovs_rviz::validateDovsMessage(b.msg), "");
  EXPECT_FALSE(dqn_dovs_rviz::actionPoints(b.msg)[6].valid);
}

TEST(DovsGeometry, BadMessagesAreRejectedWithTheFieldNamed) {
  const Built b = buildMessage({0.3, 0.0}, dqn_dovs::Vec2(3.0, 0.0));
  ASSERT_EQ(dqn_dovs_rviz::validateDovsMessage(b.msg), "");
  EXPECT_NO_THROW(dqn_dovs_rviz::computeDovsGeometry(b.msg));

  auto expectRejected = [](const Dovs& msg, const std::string& field) {
    const std::string why = dqn_dovs_rviz::validateDovsMessage(msg);
    EXPECT_NE(why.find(field), std::string::npos) << "expected '" << field << "' in: " << why;
    try {
      dqn_dovs_rviz::computeDovsGeometry(msg);
      ADD_FAILURE() << "computeDovsGeometry accepted a message with a bad " << field;
    } catch (const dqn_dovs_rviz::DovsGeometryError& e) {
      EXPECT_EQ(std::string(e.what()), why);
    }
  };
  const double nan = std::numeric_limits<double>::quiet_NaN();
  Dovs m = b.msg;
  m.v_max = nan;
  expectRejected(m, "'v_max'");
  m = b.msg;
  m.w_max = 0.0;
  expectRejected(m, "'w_max'");
  m = b.msg;
  m.dw = std::numeric_limits<double>::infinity();
  expectRejected(m, "'dw'");
  m = b.msg;
  m.action_w[2] = nan;
  expectRejected(m, "'action_w[2]'");
  m = b.msg;
  m.goal_curvature = nan;
  expectRejected(m, "'goal_curvature'");
  m = b.msg;
  m.trajectory_w_top.pop_back();
  expectRejected(m, "trajectory arrays differ");
  m = b.msg;
  m.interval_begin.pop_back();
  expectRejected(m, "interval_begin has");
  m = withIntervalsOnRay(b.msg, 30, {{0.2f, 0.1f}});
  expectRejected(m, "'interval_hi[0]'");
  m = withIntervalsOnRay(b.msg, 30, {{std::numeric_limits<float>::quiet_NaN(), 0.1f}});
  expectRejected(m, "'interval_lo[0]'");
  m = withIntervalsOnRay(b.msg, 30, {{0.1f, 0.2f}});
  m.interval_begin[32] = 0;  // goes down after ray 31
  expectRejected(m, "'interval_begin[32]'");
  m = b.msg;
  m.state.resize(100);
  expectRejected(m, "does not fit in a state of 100");
  m = b.msg;
  m.state[7] = std::numeric_limits<float>::infinity();
  expectRejected(m, "'state[7]'");
}

}  // namespace
