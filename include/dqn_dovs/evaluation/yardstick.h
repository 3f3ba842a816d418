// The yardstick of an episode (README, "Passive safety"; docs/benchmark_worlds.md): who caused a contact, whether the
// robot was at fault, and what the robot costs the people around it (comfort, blocking, delay) and itself (path
// irregularity). The evaluation reports them per episode (EpisodeRecord) and the training reward prices some of them
// (RewardConfig), from these same functions.
#pragma once

#include <vector>

#include "dqn_dovs/common/geometry.h"
#include "dqn_dovs/common/types.h"
#include "dqn_dovs/sim/collision_kind.h"
#include "dqn_dovs/sim/people.h"
#include "dqn_dovs/sim/world.h"

namespace dqn_dovs {

/// Who hit whom, by the motion of both at the contact (as social-navigation evaluators judge it): static geometry
/// (walls, furniture, static discs, a person standing); the robot on a person (the robot closing the gap along the
/// line between their centres at kClosingSpeedMps or more, and faster than the person); or the person on the robot
/// (every other contact with a moving body). "Person" means any moving body: people, and the room's moving discs.
enum class ContactClass { kNone = 0, kStatic = 1, kRobotOnPerson = 2, kPersonOnRobot = 3 };
/// "", "static", "robot_on_person", "person_on_robot".
const char* contactClassName(ContactClass contact);
/// The robot closes a gap at this speed or more (m/s) to count as the one that closed it.
constexpr double kClosingSpeedMps = 0.05;
/// The class of a simulator collision (kNone without one).
ContactClass classifyContact(const sim::CollisionInfo& collision);
/// Hall's intimate and personal distances (m), body to body, of the comfort figures (EpisodeRecord::intimate_s).
constexpr double kIntimateDistance_m = 0.45;
constexpr double kPersonalDistance_m = 1.2;
/// Cost to others (EpisodeRecord::blocking_s): a passage is a place where the narrowest chord through it, wall to
/// wall, is shorter than kPassageWidth_m (a door, a corridor); the robot blocks it when it stands (below
/// kRestSpeedMps) in the chord's middle third while someone within kBlockingReach_m (surface to surface) who reacts to
/// it (an attentive person who has noticed it, or an impassive one) waits or detours: slower than half its preferred
/// speed while not pausing at a stop, or walking more than kDetourAngle_rad off the way to its destination.
constexpr double kPassageWidth_m = 3.2;
constexpr double kBlockingReach_m = 2.0;
constexpr double kDetourAngle_rad = 0.5235987755982988;  // 30 deg
/// The narrowest chord through p between walls: the distance to the nearest wall point plus the distance to the
/// nearest one on the other side (more than 135 deg away as seen from p; infinity when there is none), and where p
/// lies on it (0: at a wall, 0.5: in the middle). In a door it runs jamb to jamb, in a corridor wall to wall.
struct PassageChord {
  double width_m = 0.0;
  double position = 0.0;
};
PassageChord narrowestChord(const Vec2& p, const std::vector<Segment>& walls);
/// Whether a robot standing at p is in the middle third of a passage (narrowestChord shorter than kPassageWidth_m).
bool inPassageMiddle(const Vec2& p, const std::vector<Segment>& walls);
/// Whether person p waits for, or detours around, a robot at `robot` (the blocking rule above).
bool heldUpByRobot(const sim::Person& p, const Circle& robot);
/// The smallest gap between a person's body and the robot's (surface to surface, m); infinity without people.
double nearestPersonGap(const std::vector<sim::Person>& people, const Circle& robot);
/// Whether the robot of `world` (radius robot_radius) blocks a passage now: at rest (below kRestSpeedMps) in a
/// passage's middle third with someone held up by it (heldUpByRobot).
bool blocksPassage(const sim::World& world, double robot_radius);
/// Path irregularity (rad/m): the robot's total turning (the sum of its heading changes, each wrapped to
/// [-pi, pi]) per metre driven; 0 for a path shorter than 1 cm.
double pathIrregularity(const std::vector<Pose2>& path);
/// How far each person has come along its plan (m): the lengths of the legs it has completed plus the part of its
/// current leg done (the leg's length less the distance left), updated once per decision. Two runs of the same
/// people compare by it (EpisodeRecord::delay_s).
class PlanProgress {
 public:
  void reset(const sim::Crowd& crowd);
  void update(const sim::Crowd& crowd);
  /// Metres along its plan, per person.
  const std::vector<double>& metres() const { return metres_; }

 private:
  std::vector<double> done_;         ///< completed legs, m
  std::vector<size_t> destination_;  ///< the destination it walks to
  std::vector<Vec2> leg_start_;      ///< where its current leg began
  std::vector<double> metres_;
};

/// A robot at rest for less than this before a contact (s) stopped too late to count as at rest.
constexpr double kAtFaultRest_s = 0.5;
/// The robot is at fault for a collision (passive safety: it never drives into anything, and is at rest, for long
/// enough, when anything reaches it): any static contact, a contact with the robot moving at kRestSpeedMps or
/// faster, or one with the robot at rest for less than kAtFaultRest_s. False without a collision.
bool robotAtFault(const sim::CollisionInfo& collision);

}  // namespace dqn_dovs
