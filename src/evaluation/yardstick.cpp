#include "dqn_dovs/evaluation/yardstick.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace dqn_dovs {

const char* contactClassName(ContactClass contact) {
  switch (contact) {
    case ContactClass::kNone:
      return "";
    case ContactClass::kStatic:
      return "static";
    case ContactClass::kRobotOnPerson:
      return "robot_on_person";
    case ContactClass::kPersonOnRobot:
      return "person_on_robot";
  }
  return "?";
}

ContactClass classifyContact(const sim::CollisionInfo& collision) {
  if (collision.kind == sim::CollisionInfo::Kind::kNone) return ContactClass::kNone;
  if (collision.static_contact) return ContactClass::kStatic;
  const double robot_closing = collision.robot_velocity.dot(collision.normal);
  const double other_closing = -collision.other_velocity.dot(collision.normal);
  return robot_closing >= kClosingSpeedMps && robot_closing > other_closing ? ContactClass::kRobotOnPerson
                                                                            : ContactClass::kPersonOnRobot;
}

bool robotAtFault(const sim::CollisionInfo& collision) {
  if (collision.kind == sim::CollisionInfo::Kind::kNone) return false;
  if (collision.static_contact || collision.robot_speed_mps >= kRestSpeedMps) return true;
  return collision.robot_rest_s < kAtFaultRest_s;
}

PassageChord narrowestChord(const Vec2& p, const std::vector<Segment>& walls) {
  // The nearest wall point, then the nearest one on the other side (more than 135 deg away as seen from p).
  constexpr double kOpposite = -0.70710678118654752;
  double first = std::numeric_limits<double>::infinity();
  Vec2 toward = Vec2::Zero();
  for (const Segment& w : walls) {
    const Vec2 d = closestPointOnSegment(p, w) - p;
    if (d.norm() < first) {
      first = d.norm();
      toward = d;
    }
  }
  if (!std::isfinite(first) || first < 1e-9) return {first < 1e-9 ? 0.0 : first, 0.0};
  toward /= first;
  double second = std::numeric_limits<double>::infinity();
  for (const Segment& w : walls) {
    const Vec2 d = closestPointOnSegment(p, w) - p;
    if (d.norm() > 1e-9 && d.dot(toward) / d.norm() <= kOpposite) second = std::min(second, d.norm());
  }
  if (!std::isfinite(second)) return {second, 0.0};
  return {first + second, first / (first + second)};
}

bool inPassageMiddle(const Vec2& p, const std::vector<Segment>& walls) {
  const PassageChord c = narrowestChord(p, walls);
  return c.width_m < kPassageWidth_m && c.position >= 1.0 / 3.0;
}

bool heldUpByRobot(const sim::Person& p, const Circle& robot) {
  const bool reacts =
      (p.behavior == sim::PersonBehavior::kAttentive && p.noticed) || p.behavior == sim::PersonBehavior::kImpassive;
  if (!reacts || (p.position - robot.center).norm() - p.spec.body_radius_m - robot.radius > kBlockingReach_m)
    return false;
  if (p.waiting_s > 0.0 || p.spec.destinations.empty()) return false;  // pausing at a stop, or walking nowhere
  const Vec2 way = p.spec.destinations[p.destination] - p.position;
  if (way.norm() < 0.3) return false;  // arriving
  const double speed = p.velocity.norm();
  if (speed < 0.5 * p.spec.preferred_speed_mps) return true;
  return std::acos(std::clamp(p.velocity.dot(way) / (speed * way.norm()), -1.0, 1.0)) > kDetourAngle_rad;
}

double nearestPersonGap(const std::vector<sim::Person>& people, const Circle& robot) {
  double nearest = std::numeric_limits<double>::infinity();
  for (const sim::Person& p : people) {
    nearest = std::min(nearest, (p.position - robot.center).norm() - p.spec.body_radius_m - robot.radius);
  }
  return nearest;
}

bool blocksPassage(const sim::World& world, double robot_radius) {
  const std::vector<sim::Person>& people = world.crowd().people();
  if (people.empty() || std::abs(world.robotTwist().v) >= kRestSpeedMps) return false;
  const Circle robot{world.robotPose().position(), robot_radius};
  if (!inPassageMiddle(robot.center, world.walls())) return false;
  return std::any_of(people.begin(), people.end(), [&](const sim::Person& p) { return heldUpByRobot(p, robot); });
}

double pathIrregularity(const std::vector<Pose2>& path) {
  double turned = 0.0, length = 0.0;
  for (size_t i = 1; i < path.size(); ++i) {
    turned += std::abs(angleDiff(path[i].theta, path[i - 1].theta));
    length += (path[i].position() - path[i - 1].position()).norm();
  }
  return length < 0.01 ? 0.0 : turned / length;
}

void PlanProgress::reset(const sim::Crowd& crowd) {
  const size_t n = crowd.people().size();
  done_.assign(n, 0.0);
  metres_.assign(n, 0.0);
  destination_.clear();
  leg_start_.clear();
  for (const sim::Person& p : crowd.people()) {
    destination_.push_back(p.destination);
    leg_start_.push_back(p.position);
  }
}

void PlanProgress::update(const sim::Crowd& crowd) {
  for (size_t i = 0; i < crowd.people().size() && i < metres_.size(); ++i) {
    const sim::Person& p = crowd.people()[i];
    if (p.spec.destinations.empty()) {  // walking straight on: the distance along its heading
      const Vec2 along(std::cos(p.spec.heading_rad), std::sin(p.spec.heading_rad));
      metres_[i] = (p.position - leg_start_[i]).dot(along);
      continue;
    }
    if (p.destination != destination_[i]) {  // a leg completed (or more, when several waypoints passed at once)
      const Vec2& reached = p.spec.destinations[destination_[i]];
      done_[i] += (reached - leg_start_[i]).norm();
      leg_start_[i] = reached;
      destination_[i] = p.destination;
    }
    const Vec2& to = p.spec.destinations[p.destination];
    metres_[i] = done_[i] + (to - leg_start_[i]).norm() - (to - p.position).norm();
  }
}

}  // namespace dqn_dovs
