// The kind of a simulator collision by who could have avoided it (passive safety): the simulator node reports it
// with each collision, and the evaluation's yardstick (evaluation/yardstick.h) counts it.
#pragma once

#include "dqn_dovs/sim/world.h"

namespace dqn_dovs {

/// Collisions split by who could have avoided them (passive safety): hitting static geometry (walls, furniture,
/// static obstacles) is never necessary; a robot at rest (speed below kRestSpeedMps) was walked into; a moving
/// robot drove into a moving obstacle.
enum class CollisionKind { kNone = 0, kStatic = 1, kRest = 2, kMoving = 3 };
/// "", "static", "rest", "moving".
const char* collisionKindName(CollisionKind kind);
/// The robot counts as at rest at a contact below this linear speed, m/s.
constexpr double kRestSpeedMps = sim::kRobotRestSpeedMps;
/// The kind of a simulator collision.
CollisionKind classifyCollision(const sim::CollisionInfo& collision);

}  // namespace dqn_dovs
