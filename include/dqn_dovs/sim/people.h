// Simulated people: a body disc for contact and two leg discs for the LIDAR, walking between destinations.
//
// Each person walks to its current destination at its preferred speed, waits there for a while, then takes the
// next destination of its list (and starts over at the end). Motion models:
//   - constant: the person keeps its start velocity (what the paper's discs do);
//   - social_force: the social force model of Helbing and Molnar (1995): a drive toward the destination at the
//     preferred speed with relaxation time tau, repulsion from other people through their elliptical potential
//     (stretched along the other's motion, with the anisotropy that weighs what is ahead) and from walls, and a
//     pull toward the centroid of the person's group;
//   - orca: reciprocal avoidance among people (ORCA, common/orca_lp.h): each person takes the velocity closest to
//     its preferred one that keeps half of the avoidance of every other person within orca_neighbor_dist_m over
//     orca_time_horizon_s (all of it for a robot it sees), and walls as hard constraints.
// The robot is invisible to people unless PeopleConfig::see_robot, in which case they repel from it like from a
// person. Legs: two discs beside the body's centre line whose fore-aft offsets swing in opposite phase with a
// stride that grows with the walking speed, scaled to the scan height (legs pivot at the hip); the phase advances
// with the distance walked, so a standing person's legs are side by side.
// Nobody walks through a wall: a move that would cross one keeps only its component along it.
// Traffic in buildings (docs/simulator.md, "Traffic in buildings"): a TrafficRule makes people keep to one side of
// a way bounded by walls on both sides (a corridor), and at each Door people pass one at a time, the others waiting
// beside the door, off its line, on their own side.
// Deterministic: the same people, walls, configuration and robot motion give the same trajectories.
#pragma once

#include <limits>
#include <string>
#include <vector>

#include "dqn_dovs/common/geometry.h"
#include "dqn_dovs/common/types.h"

namespace dqn_dovs::sim {

/// How people move.
enum class PeopleModel { kConstant, kSocialForce, kOrca };

/// "constant", "social_force", "orca"; parsePeopleModel throws SimConfigError naming an unknown name.
const char* peopleModelName(PeopleModel model);
PeopleModel parsePeopleModel(const std::string& name);
std::vector<std::string> peopleModelNames();

/// How a person treats the robot (docs/simulator.md, "People who notice the robot"). Each person draws one at spawn
/// from PeopleConfig::mix.
///   oblivious: the robot is invisible to it (walks into it as if it were not there);
///   impassive: walks around the robot as around a still obstacle, sideways only: never slows down or times its way
///              for it;
///   attentive: notices the robot inside its field of view (PeopleConfig::notice_fov_rad ahead, notice_range_m)
///              after a reaction delay of its own, then gives way to it as to another person, with a strength of its
///              own; it keeps giving way while the robot stays within notice_range_m.
enum class PersonBehavior { kOblivious = 0, kImpassive = 1, kAttentive = 2 };
/// "oblivious", "impassive", "attentive".
const char* personBehaviorName(PersonBehavior behavior);

/// Shares of the behaviours among the people of an episode, e.g. "attentive=0.6,impassive=0.2,oblivious=0.2" (the
/// shares are normalised; a name left out has share 0), or the name of a preset: "headline" (headline()).
struct PeopleMix {
  double attentive = 0.0;
  double impassive = 0.0;
  double oblivious = 1.0;
  /// Parses the text form; throws SimConfigError naming the entry and the reason (unknown behaviour, a name given
  /// twice, a share that is negative or not a number, all shares 0).
  static PeopleMix parse(const std::string& text);
  /// Every person attentive (what `people see the robot` means).
  static PeopleMix allAttentive() { return {1.0, 0.0, 0.0}; }
  /// The benchmark's headline mix, attentive=0.7,impassive=0.2,oblivious=0.1: about three in ten people in a public
  /// place are busy with something else (a phone, music), most of whom still walk around what is in their way, and
  /// a few never see the robot at all (docs/simulator.md, "The headline mix", gives the sources).
  static PeopleMix headline() { return {0.7, 0.2, 0.1}; }
  /// The text form with normalised shares, e.g. "attentive=0.6,impassive=0.2,oblivious=0.2" (zero shares left out).
  std::string str() const;
  /// Whether anyone reacts to the robot (then the people's future depends on what the robot does).
  bool anyReacts() const { return attentive > 0.0 || impassive > 0.0; }
  /// Empty when consistent, otherwise a message naming the share and why.
  std::string validate() const;
  /// The behaviour a draw u in [0, 1) picks: attentive first, then impassive, then oblivious.
  PersonBehavior pick(double u) const;
};

/// Which side of a way people keep to.
enum class TrafficSide { kNone = 0, kRight = 1, kLeft = 2 };
/// "none", "right", "left"; parseTrafficSide throws SimConfigError naming an unknown name.
const char* trafficSideName(TrafficSide side);
TrafficSide parseTrafficSide(const std::string& name);

/// The keep-to-a-side rule of a world: between two walls (both within TrafficRule::kLaneReach_m of a person,
/// across its way) each person steers toward a lane on its `side`, its centre a fraction of the way's width from
/// the wall on that side (never nearer the wall than its radius + 0.15 m, never past the way's middle), so that two
/// people walking opposite ways pass each other each on its own side. `strength` in [0, 1] scales how hard it
/// steers there (0: not at all; 1: up to about 27 deg off its way). Without walls on both sides (an open room) the
/// rule does nothing. Near its destination (within 1.5 m) a person lets the rule fade, so that every stop is
/// reached.
struct TrafficRule {
  TrafficSide side = TrafficSide::kNone;
  double strength = 0.0;
  static constexpr double kLaneReach_m = 2.5;   ///< walls farther than this across a person's way do not count
  static constexpr double kLaneFraction = 0.3;  ///< the lane's centre: this fraction of the width from the wall
  bool active() const { return side != TrafficSide::kNone && strength > 0.0; }
  bool operator==(const TrafficRule& o) const { return side == o.side && strength == o.strength; }
  /// Empty when consistent, otherwise a message naming the field and why.
  std::string validate() const;
};

/// A door people pass one at a time (docs/simulator.md, "Traffic in buildings"): its centre, the unit direction
/// across it (normal to its wall) and its width (m). Someone walking through it (its next waypoint is the door's
/// centre, or its last one was and it has not yet crossed) within kApproach_m of the centre either holds the door
/// (the one inside it, else the nearest, with the time waited counting as nearness: kPatience_mps; ties to the
/// lower index; the holder's group goes with it) or waits beside the door on its own side of the wall, to the side
/// of its TrafficRule (right when none; the other side, or farther back, when a wall is in the way), off the
/// door's line, so that whoever comes out has a free way. The holder keeps the door until it is out of it on the
/// other side, or for at most kHold_s (so that nobody waits forever).
struct Door {
  Vec2 center = Vec2::Zero();
  Vec2 across = Vec2(1.0, 0.0);  ///< unit, normal to the door's wall
  double width_m = 1.0;
  static constexpr double kApproach_m = 2.5;
  static constexpr double kHold_s = 10.0;
  static constexpr double kPatience_mps = 0.5;
  bool operator==(const Door& o) const { return center == o.center && across == o.across && width_m == o.width_m; }
  /// Empty when consistent (finite, across of unit length, width > 0), otherwise a message saying why.
  std::string validate() const;
};

/// One person's initial state and plan.
struct PersonSpec {
  Vec2 position = Vec2::Zero();
  double heading_rad = 0.0;
  double body_radius_m = 0.25;       ///< contact disc, 0.2..0.3 m for adults
  double preferred_speed_mps = 1.0;  ///< walking speed when unhindered, 0.5..1.3 m/s
  /// Places to walk to in turn (cycled); empty: walk straight along heading_rad at the preferred speed.
  std::vector<Vec2> destinations;
  /// Per destination (empty: none): a waypoint on the way (a door, a junction's centre), not a stop. Nobody waits
  /// there, and it is passed as soon as the next destination can be walked to in a straight line clear of every
  /// wall by the body's radius (people go through a door; they do not queue for its centre point).
  std::vector<bool> pass_through;
  /// Pause at each destination, s.
  double wait_s = 0.0;
  /// People with the same group id >= 0 walk together (the social force model pulls them to their centroid).
  int group = -1;
};

/// Parameters of the people models and their legs.
struct PeopleConfig {
  PeopleModel model = PeopleModel::kSocialForce;
  /// Whether people see the robot and give way to it (false: the robot is invisible, the hardest case). true makes
  /// every person attentive, whatever `mix` says.
  bool see_robot = false;
  /// How people treat the robot: each person draws a behaviour from these shares at spawn (Crowd's seed).
  PeopleMix mix;
  /// Attentive people: the field of view in which they notice the robot (centred on their heading; pi: 180 deg
  /// ahead), how far (surface to surface), their reaction delay (uniform in [min, max] per person, s) and the
  /// strength with which they give way (uniform in [min, max] per person, a factor on the repulsion between people).
  double notice_fov_rad = 3.141592653589793;
  double notice_range_m = 4.0;
  double reaction_min_s = 0.3;
  double reaction_max_s = 0.6;
  double yield_strength_min = 0.6;
  double yield_strength_max = 1.0;
  /// The behaviours in force: all attentive with see_robot, else mix.
  PeopleMix effectiveMix() const { return see_robot ? PeopleMix::allAttentive() : mix; }
  double relaxation_time_s = 0.5;      ///< tau: how fast a person returns to its preferred velocity
  double person_repulsion_mps2 = 7.0;  ///< A: repulsion between people when their bodies touch (V0 / sigma)
  double person_range_m = 0.3;         ///< B: its decay length (sigma)
  double step_time_s = 0.5;            ///< how far ahead the other's motion shapes the repulsion's ellipse
  double anisotropy = 0.35;            ///< lambda in [0, 1]: weight of what is behind (1: as ahead)
  double wall_repulsion_mps2 = 10.0;   ///< repulsion from walls
  double wall_range_m = 0.1;           ///< its decay length
  double group_attraction_mps2 = 1.0;  ///< pull toward the group's centroid per metre beyond group_radius_m
  double group_radius_m = 0.6;         ///< a group member closer than this to the centroid feels no pull
  double max_speed_factor = 1.3;       ///< speed limit as a multiple of the preferred speed
  double arrival_radius_m = 0.3;       ///< a destination closer than this is reached
  /// A person who has come no closer to its destination (by 0.1 m) for stall_time_s is stalled. Within
  /// stall_radius_m of a stop it counts the stop as reached (someone else stands there: a group's shared stop, a
  /// crowded spot; people settle for near enough instead of pushing forever); anywhere else (two people meeting in
  /// a door or a narrow corridor, or short of a waypoint) it stops driving for give_way_s, so that the other can
  /// pass, then tries again.
  double stall_time_s = 4.0;
  double stall_radius_m = 1.5;
  double give_way_s = 2.0;
  double leg_radius_m = 0.06;     ///< leg disc radius at the scan height
  double hip_half_width_m = 0.1;  ///< lateral offset of each leg from the centre line
  /// Height of the LIDAR's scan plane (m): legs pivot at the hip, so the lower the scan the closer the legs.
  double scan_height_m = 0.3;
  double hip_height_m = 0.9;          ///< height of the hip joint (m)
  double physics_step_s = 0.05;       ///< longest integration step
  double orca_time_horizon_s = 2.0;   ///< orca: horizon of the velocity obstacles of people (and the robot), s
  double orca_wall_horizon_s = 1.0;   ///< orca: horizon of the velocity obstacles of walls, s
  double orca_neighbor_dist_m = 4.0;  ///< orca: people farther than this (surface to surface) are ignored, m

  /// Empty when consistent, otherwise a message naming the field and why.
  std::string validate() const;
};

/// One person's state.
struct Person {
  PersonSpec spec;
  Vec2 position = Vec2::Zero();
  Vec2 velocity = Vec2::Zero();
  double heading_rad = 0.0;
  size_t destination = 0;                                      ///< index into spec.destinations
  double waiting_s = 0.0;                                      ///< pause left at the current destination, s
  double gait_phase_rad = 0.0;                                 ///< advances with the distance walked
  double closest_m = std::numeric_limits<double>::infinity();  ///< nearest it has come to its destination
  double stalled_s = 0.0;  ///< time since it last came 0.1 m closer to it (PeopleConfig::stall_time_s)
  PersonBehavior behavior = PersonBehavior::kOblivious;  ///< drawn at spawn from PeopleConfig::mix
  double reaction_s = 0.0;                               ///< attentive: its reaction delay, s
  double yield_strength = 1.0;                           ///< attentive: its strength of giving way
  double seen_s = 0.0;                                   ///< attentive: how long the robot has been in view, s
  bool noticed = false;                                  ///< attentive: it gives way to the robot now
  bool door_waiting = false;  ///< waits for a door (Door) at door_spot instead of walking to its destination
  Vec2 door_spot = Vec2::Zero();
  double door_waited_s = 0.0;  ///< how long it has waited for the door it is bound for, s
};

/// The people of one episode.
class Crowd {
 public:
  Crowd() = default;
  /// Throws SimConfigError when config.validate() fails or a spec is not finite or has a non-positive radius or
  /// speed. Each person's behaviour (and an attentive one's reaction delay and strength) is drawn from config.mix
  /// with `seed` (a stream of its own: the same seed, the same behaviours, whatever else the seed drives).
  /// `rule` and `doors`: the world's traffic (Scenario::traffic, Scenario::doors); throws SimConfigError when one
  /// fails its validate().
  Crowd(const std::vector<PersonSpec>& people, const PeopleConfig& config, uint64_t seed = 0,
        const TrafficRule& rule = {}, const std::vector<Door>& doors = {});

  /// Advances every person by dt_s (split into steps of at most config.physics_step_s). `walls` repel and
  /// block people (social force); `robot` and `robot_velocity` matter to impassive and attentive people only.
  void step(double dt_s, const std::vector<Segment>& walls, const Circle& robot, const Vec2& robot_velocity);

  const std::vector<Person>& people() const { return people_; }
  const PeopleConfig& config() const { return config_; }
  const TrafficRule& trafficRule() const { return rule_; }
  const std::vector<Door>& doors() const { return doors_; }
  /// The person holding door k (index into people()), or -1 when it is free.
  int doorHolder(size_t k) const { return door_state_.at(k).holder; }
  /// The body discs (contact).
  std::vector<Circle> bodies() const;
  /// The two leg discs of every person, left then right (what a LIDAR at leg height sees).
  std::vector<Circle> legs() const;
  /// Appends what a LIDAR sees of every person to `out`: the legs, or the bodies when !legs (no allocation once
  /// `out` has room).
  void appendSeen(std::vector<Circle>& out, bool legs) const;
  /// The bodies as moving obstacles (velocity as speed and heading of motion; turn rate 0).
  std::vector<MovingObstacle> asObstacles() const;
  /// The leg discs of one person.
  static void legsOf(const Person& p, const PeopleConfig& config, Circle& left, Circle& right);

 private:
  void substep(double dt, const std::vector<Segment>& walls, const Circle& robot, const Vec2& robot_velocity);
  Vec2 drive(const Person& p, const std::vector<Segment>& walls) const;
  /// The rule's lateral steering of a desired velocity `v` (dist: to the target).
  Vec2 keepToSide(const Person& p, const Vec2& v, double dist, const std::vector<Segment>& walls) const;
  /// Who holds each door and who waits where, after this step of dt.
  void updateDoors(double dt, const std::vector<Segment>& walls);
  /// Attentive people: whether each has noticed the robot, after this step of dt.
  void notice(double dt, const Circle& robot);
  /// The orca model's velocity for person i over a step of dt.
  Vec2 orcaVelocity(size_t i, double dt, const std::vector<Segment>& walls, const Circle& robot,
                    const Vec2& robot_velocity) const;

  struct DoorState {
    int holder = -1;
    int from_side = 0;  ///< the side (sign across the door) the holder came from
    double held_s = 0.0;
  };

  std::vector<Person> people_;
  PeopleConfig config_;
  TrafficRule rule_;
  std::vector<Door> doors_;
  std::vector<DoorState> door_state_;
};

}  // namespace dqn_dovs::sim
