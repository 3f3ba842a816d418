// ORCA's geometry and linear program (van den Berg et al. 2011): velocity obstacles of discs and wall segments,
// the half-planes ORCA derives from them, and the randomised incremental LP that picks the velocity closest to a
// preferred one. Shared by the ORCA planners (planning/orca.h) and the simulator's people (sim/people.h).
#pragma once

#include <cstddef>
#include <random>
#include <vector>

#include "dqn_dovs/common/geometry.h"

namespace dqn_dovs {

/// One ORCA constraint: the half-plane of velocities on the left of the directed line through `point` along the
/// unit vector `direction` (cross(direction, v - point) >= 0).
struct OrcaLine {
  Vec2 point = Vec2::Zero();
  Vec2 direction = Vec2::UnitX();

  /// Signed distance of v into the allowed side (negative: violated by that much).
  double margin(const Vec2& v) const;
};

/// The velocity obstacle of an obstacle, seen from a robot at the origin: the velocities v such that the robot
/// moving from the origin at v comes within `combined_radius_m` of the segment [a, b] (relative positions; a = b
/// for a disc) at some time in (0, horizon_s]. Computes the half-plane that ORCA derives from it: the point of the
/// velocity obstacle's boundary closest to `relative_velocity`, and the boundary normal pointing out of the
/// obstacle. When the robot already overlaps (distance < combined radius), the boundary is that of the
/// velocity obstacle for time `collision_time_step_s` cut at the current overlap (leave it within one step).
struct VelocityObstacleProjection {
  Vec2 boundary_point = Vec2::Zero();  ///< closest boundary point to the relative velocity
  Vec2 normal = Vec2::UnitX();         ///< unit, points out of the velocity obstacle
  bool inside = false;                 ///< relative velocity was inside the velocity obstacle
  bool overlapping = false;            ///< the robot already overlaps the obstacle
};

/// See VelocityObstacleProjection. Requires horizon_s > 0, combined_radius_m > 0, collision_time_step_s > 0.
VelocityObstacleProjection projectOnVelocityObstacle(const Vec2& a, const Vec2& b, double combined_radius_m,
                                                     double horizon_s, const Vec2& relative_velocity,
                                                     double collision_time_step_s);

/// ORCA half-plane of the robot (position p, velocity v, radius r) against a disc obstacle moving at constant
/// velocity. `responsibility` is the robot's share of the avoidance: 1 (the default) when the obstacle does not
/// react, so the line passes through the velocity obstacle's boundary point shifted by the obstacle's velocity;
/// 1/2 between two agents that both run ORCA (reciprocal avoidance).
OrcaLine orcaLineForDisc(const Vec2& robot_position, const Vec2& robot_velocity, double robot_radius_m,
                         const Vec2& obstacle_center, const Vec2& obstacle_velocity, double obstacle_radius_m,
                         double horizon_s, double collision_time_step_s, double responsibility = 1.0);

/// ORCA half-plane of the robot against a static wall segment (walls are obstacle lines: hard constraints).
OrcaLine orcaLineForSegment(const Vec2& robot_position, const Vec2& robot_velocity, double robot_radius_m,
                            const Segment& wall, double horizon_s, double collision_time_step_s);

/// Result of the ORCA linear program.
struct OrcaLpResult {
  Vec2 velocity = Vec2::Zero();
  bool feasible = true;        ///< false: no velocity met every line; `velocity` minimises the largest violation of
                               ///< the soft lines while keeping the hard ones where possible
  double max_violation = 0.0;  ///< largest violation of any line by `velocity` (0 when feasible)
};

/// The ORCA linear program: the velocity within `max_speed` of the origin closest to `preferred` that satisfies
/// every line. The first `num_hard` lines (walls) are hard; the rest (discs) soft. Solved by the randomised
/// incremental 2-D algorithm (1-D LP on each violated line); when infeasible, the 3-D program minimising the
/// largest violation of the soft lines, subject to the hard ones, solved by projection on each violated line.
/// `rng` (may be null: the given order) shuffles the constraint order within the hard and the soft lines.
OrcaLpResult solveOrcaLp(const std::vector<OrcaLine>& lines, size_t num_hard, double max_speed, const Vec2& preferred,
                         std::mt19937_64* rng = nullptr);

}  // namespace dqn_dovs
