#include "dqn_dovs/sim/collision_kind.h"

namespace dqn_dovs {

const char* collisionKindName(CollisionKind kind) {
  switch (kind) {
    case CollisionKind::kNone:
      return "";
    case CollisionKind::kStatic:
      return "static";
    case CollisionKind::kRest:
      return "rest";
    case CollisionKind::kMoving:
      return "moving";
  }
  return "";
}

CollisionKind classifyCollision(const sim::CollisionInfo& collision) {
  if (collision.kind == sim::CollisionInfo::Kind::kNone) return CollisionKind::kNone;
  if (collision.static_contact) return CollisionKind::kStatic;
  return collision.robot_speed_mps < kRestSpeedMps ? CollisionKind::kRest : CollisionKind::kMoving;
}

}  // namespace dqn_dovs
