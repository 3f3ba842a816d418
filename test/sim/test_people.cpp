// People: legs and gait, walking to destinations with waits, the social force model (avoidance, walls, groups,
// seeing the robot), doors passed on the way, stops settled for when occupied, the constant model, determinism
// and bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include "dqn_dovs/common/random.h"
#include "dqn_dovs/sim/errors.h"
#include "dqn_dovs/sim/people.h"

namespace dqn_dovs::sim {
namespace {

const Circle kFarRobot{Vec2(100.0, 100.0), 0.2};

PersonSpec walker(Vec2 from, Vec2 to, double speed = 1.0) {
  PersonSpec s;
  s.position = from;
  s.heading_rad = std::atan2((to - from).y(), (to - from).x());
  s.preferred_speed_mps = speed;
  s.destinations = {to};
  return s;
}

/// Fore-aft and lateral offsets of a person's two legs from its centre, in its own frame.
void legOffsets(const Person& p, const PeopleConfig& c, Vec2& left, Vec2& right) {
  Circle l, r;
  Crowd::legsOf(p, c, l, r);
  const Pose2 body{p.position.x(), p.position.y(), p.heading_rad};
  left = body.toLocal(l.center);
  right = body.toLocal(r.center);
}

TEST(People, LegsStandSideBySideAndSwingInOppositePhaseWhenWalking) {
  PeopleConfig c;
  Person p;
  p.position = Vec2(1.0, 2.0);
  p.heading_rad = 0.7;
  p.gait_phase_rad = 1.2;
  Vec2 l, r;
  legOffsets(p, c, l, r);  // standing: no swing whatever the phase
  EXPECT_NEAR(l.x(), 0.0, 1e-12);
  EXPECT_NEAR(r.x(), 0.0, 1e-12);
  EXPECT_NEAR(l.y(), c.hip_half_width_m, 1e-12);
  EXPECT_NEAR(r.y(), -c.hip_half_width_m, 1e-12);
  double amplitude_slow = 0.0, amplitude_fast = 0.0;
  for (double speed : {0.5, 1.3}) {
    Crowd crowd({walker({0, 0}, {100, 0}, speed)}, c);
    double largest = 0.0;
    for (int k = 0; k < 60; ++k) {
      crowd.step(0.05, {}, kFarRobot, Vec2::Zero());
      legOffsets(crowd.people()[0], c, l, r);
      EXPECT_NEAR(l.x(), -r.x(), 1e-9);  // opposite phase
      largest = std::max(largest, std::abs(l.x()));
    }
    (speed < 1.0 ? amplitude_slow : amplitude_fast) = largest;
  }
  // Half a step (0.3 + 0.3 v m) at the scan height (0.3 m of a 0.9 m leg: two thirds of it).
  EXPECT_NEAR(amplitude_slow, 0.5 * (0.3 + 0.3 * 0.5) * 2.0 / 3.0, 0.01);
  EXPECT_NEAR(amplitude_fast, 0.5 * (0.3 + 0.3 * 1.3) * 2.0 / 3.0, 0.01);  // longer strides when faster
  c.scan_height_m = 0.9;  // a scan at hip height sees the legs side by side
  Crowd hips({walker({0, 0}, {100, 0}, 1.0)}, c);
  for (int k = 0; k < 20; ++k) hips.step(0.05, {}, kFarRobot, Vec2::Zero());
  legOffsets(hips.people()[0], c, l, r);
  EXPECT_NEAR(l.x(), 0.0, 1e-12);
}

TEST(People, WalkToEachDestinationWaitThereAndGoOn) {
  PersonSpec s = walker({0, 0}, {3, 0});
  s.destinations.push_back({3, 3});
  s.wait_s = 1.0;
  Crowd crowd({s}, PeopleConfig{});
  double reached_first = -1.0, left_first = -1.0, reached_second = -1.0;
  for (int k = 1; k <= 400; ++k) {
    crowd.step(0.05, {}, kFarRobot, Vec2::Zero());
    const Person& p = crowd.people()[0];
    const double t = 0.05 * k;
    if (reached_first < 0 && p.destination == 1) reached_first = t;
    if (reached_first > 0 && left_first < 0 && p.waiting_s == 0.0) left_first = t;
    if (reached_first > 0 && reached_second < 0 && p.destination == 0) reached_second = t;
  }
  // 3 m at ~1 m/s (slowing down over the last half metre), a 1 s wait, then another 3 m.
  EXPECT_GT(reached_first, 2.5);
  EXPECT_LT(reached_first, 4.5);
  EXPECT_NEAR(left_first - reached_first, 1.0, 0.06);
  EXPECT_GT(reached_second, left_first + 2.5);
  EXPECT_LT(reached_second, left_first + 5.0);
}

TEST(People, SocialForceLetsTwoPeoplePassHeadOnWhereConstantOnesCollide) {
  auto closest = [](PeopleModel model) {
    PeopleConfig c;
    c.model = model;
    PersonSpec a = walker({-4, 0.05}, {4, 0.05}), b = walker({4, -0.05}, {-4, -0.05});
    Crowd crowd({a, b}, c);
    double d = std::numeric_limits<double>::infinity();
    for (int k = 0; k < 200; ++k) {
      crowd.step(0.05, {}, kFarRobot, Vec2::Zero());
      d = std::min(d, (crowd.people()[0].position - crowd.people()[1].position).norm());
    }
    return d;
  };
  EXPECT_GT(closest(PeopleModel::kSocialForce), 0.5 * 0.95);  // two 0.25 m bodies never overlap
  EXPECT_GT(closest(PeopleModel::kOrca), 0.5 - 0.01);
  EXPECT_LT(closest(PeopleModel::kConstant), 0.2);
}

TEST(People, NobodyWalksThroughAWall) {
  // A wall between everyone and their destinations; people start close to it and push toward it for 20 s.
  const std::vector<Segment> walls = {{Vec2(-5, 0), Vec2(5, 0)}};
  for (PeopleModel model : {PeopleModel::kSocialForce, PeopleModel::kConstant, PeopleModel::kOrca}) {
    PeopleConfig c;
    c.model = model;
    std::vector<PersonSpec> people;
    for (int i = 0; i < 8; ++i) people.push_back(walker({-3.5 + i, -0.4 - 0.1 * i}, {-3.5 + i, 3.0}, 1.3));
    Crowd crowd(people, c);
    for (int k = 0; k < 400; ++k) {
      crowd.step(0.05, walls, kFarRobot, Vec2::Zero());
      for (const Person& p : crowd.people()) ASSERT_LT(p.position.y(), 0.0) << peopleModelName(model) << " step " << k;
    }
  }
}

TEST(People, GroupsWalkTogetherAndAVisibleRobotIsGivenWay) {
  PersonSpec a = walker({0, -1.5}, {10, -1.5}), b = walker({0, 1.5}, {10, 1.5});
  a.group = b.group = 4;
  PeopleConfig c;
  Crowd together({a, b}, c);
  a.group = b.group = -1;
  Crowd apart({a, b}, c);
  for (int k = 0; k < 100; ++k) {
    together.step(0.05, {}, kFarRobot, Vec2::Zero());
    apart.step(0.05, {}, kFarRobot, Vec2::Zero());
  }
  const auto gap = [](const Crowd& cr) { return (cr.people()[0].position - cr.people()[1].position).norm(); };
  EXPECT_LT(gap(together), 2.0);
  EXPECT_NEAR(gap(apart), 3.0, 0.05);

  // A robot standing in a person's way: walked into when invisible, given way to when seen.
  const Circle robot{Vec2(3.0, 0.0), 0.2};
  auto closest = [&](bool see) {
    PeopleConfig cfg;
    cfg.see_robot = see;
    Crowd crowd({walker({0, 0.02}, {6, 0.02})}, cfg);
    double d = std::numeric_limits<double>::infinity();
    for (int k = 0; k < 150; ++k) {
      crowd.step(0.05, {}, robot, Vec2::Zero());
      d = std::min(d, (crowd.people()[0].position - robot.center).norm());
    }
    return d;
  };
  EXPECT_LT(closest(false), 0.1);
  EXPECT_GT(closest(true), 0.25 + 0.2 - 0.02);
}

// One person walking at a robot that stands 3 m ahead on its line; the mix decides how it treats the robot.
struct Approach {
  double closest_m = std::numeric_limits<double>::infinity();    ///< centre to centre
  double slowest_mps = std::numeric_limits<double>::infinity();  ///< its lowest speed on the way to the robot
  double noticed_at_s = -1.0;                                    ///< when it started giving way (attentive), s
  Person person;
};
Approach approach(const std::string& mix, double reaction_s = 0.45) {
  PeopleConfig cfg;
  cfg.mix = PeopleMix::parse(mix);
  cfg.reaction_min_s = cfg.reaction_max_s = reaction_s;
  const Circle robot{Vec2(3.0, 0.0), 0.2};
  Crowd crowd({walker({0, 0.02}, {6, 0.02})}, cfg, 7);
  Approach a;
  for (int k = 0; k < 150; ++k) {
    crowd.step(0.05, {}, robot, Vec2::Zero());
    const Person& p = crowd.people()[0];
    a.closest_m = std::min(a.closest_m, (p.position - robot.center).norm());
    // Once up to speed (1.5 s: three relaxation times), until it is level with the robot.
    if (k >= 30 && p.position.x() < robot.center.x()) a.slowest_mps = std::min(a.slowest_mps, p.velocity.norm());
    if (p.noticed && a.noticed_at_s < 0.0) a.noticed_at_s = 0.05 * (k + 1);
  }
  a.person = crowd.people()[0];
  return a;
}

TEST(PeopleBehaviors, TheMixDecidesHowTheRobotIsTreated) {
  const Approach oblivious = approach("oblivious=1"), impassive = approach("impassive=1"),
                 attentive = approach("attentive=1");
  EXPECT_EQ(oblivious.person.behavior, PersonBehavior::kOblivious);
  EXPECT_EQ(impassive.person.behavior, PersonBehavior::kImpassive);
  EXPECT_EQ(attentive.person.behavior, PersonBehavior::kAttentive);
  // Oblivious: walks through the robot's place.
  EXPECT_LT(oblivious.closest_m, 0.1);
  // Impassive: walks around it, but never slower for it (at its walking speed of 1 m/s throughout).
  EXPECT_GT(impassive.closest_m, 0.25 + 0.2 - 0.05);
  EXPECT_GT(impassive.slowest_mps, oblivious.slowest_mps - 0.05);
  // An attentive one slows down for it.
  EXPECT_LT(attentive.slowest_mps, oblivious.slowest_mps - 0.1);
  // Attentive: gives way.
  EXPECT_GT(attentive.closest_m, 0.25 + 0.2 - 0.02);
}

TEST(PeopleBehaviors, AnAttentivePersonGivesWayAfterItsDelayAndNotBefore) {
  // The robot is in view from the start: it notices after its reaction delay, to the step.
  for (double delay : {0.3, 0.6}) {
    const Approach a = approach("attentive=1", delay);
    EXPECT_NEAR(a.noticed_at_s, delay, 0.05 + 1e-9) << "delay " << delay;
  }
  // Before the delay it walks exactly as an oblivious person: the same positions.
  PeopleConfig seeing, blind;
  seeing.mix = PeopleMix::allAttentive();
  seeing.reaction_min_s = seeing.reaction_max_s = 1.0;
  const Circle robot{Vec2(1.8, 0.0), 0.2};
  Crowd a({walker({0, 0.02}, {6, 0.02})}, seeing, 3), b({walker({0, 0.02}, {6, 0.02})}, blind, 3);
  for (int k = 0; k < 19; ++k) {  // 0.95 s
    a.step(0.05, {}, robot, Vec2::Zero());
    b.step(0.05, {}, robot, Vec2::Zero());
  }
  EXPECT_FALSE(a.people()[0].noticed);
  EXPECT_EQ(a.people()[0].position, b.people()[0].position);
  a.step(0.1, {}, robot, Vec2::Zero());
  EXPECT_TRUE(a.people()[0].noticed);
  // A robot behind it (outside the 180 deg ahead) is not noticed, however long.
  Crowd c({walker({0, 0.02}, {6, 0.02})}, seeing, 3);
  const Circle behind{Vec2(-1.0, 0.0), 0.2};
  for (int k = 0; k < 60; ++k) c.step(0.05, {}, behind, Vec2::Zero());
  EXPECT_FALSE(c.people()[0].noticed);
}

TEST(PeopleBehaviors, DrawnFromTheMixBySeedAndReproducible) {
  std::vector<PersonSpec> people;
  for (int i = 0; i < 400; ++i) people.push_back(walker({0.0, 0.1 * i}, {5.0, 0.1 * i}));
  PeopleConfig cfg;
  cfg.mix = PeopleMix::parse("attentive=0.6,impassive=0.2,oblivious=0.2");
  const Crowd a(people, cfg, 11), b(people, cfg, 11), c(people, cfg, 12);
  int counts[3] = {0, 0, 0};
  bool differs = false;
  for (size_t i = 0; i < people.size(); ++i) {
    const Person& p = a.people()[i];
    EXPECT_EQ(p.behavior, b.people()[i].behavior);
    EXPECT_EQ(p.reaction_s, b.people()[i].reaction_s);
    differs |= p.behavior != c.people()[i].behavior;
    ++counts[static_cast<int>(p.behavior)];
    EXPECT_GE(p.reaction_s, cfg.reaction_min_s);
    EXPECT_LE(p.reaction_s, cfg.reaction_max_s);
    EXPECT_GE(p.yield_strength, cfg.yield_strength_min);
    EXPECT_LE(p.yield_strength, cfg.yield_strength_max);
  }
  EXPECT_TRUE(differs);
  // 400 draws: each share within 4 standard deviations.
  EXPECT_NEAR(counts[static_cast<int>(PersonBehavior::kAttentive)], 240, 40);
  EXPECT_NEAR(counts[static_cast<int>(PersonBehavior::kImpassive)], 80, 32);
  EXPECT_NEAR(counts[static_cast<int>(PersonBehavior::kOblivious)], 80, 32);
  // see_robot: everybody attentive, whatever the mix.
  cfg.see_robot = true;
  const Crowd seeing(people, cfg, 11);
  for (const Person& p : seeing.people()) EXPECT_EQ(p.behavior, PersonBehavior::kAttentive);
}

TEST(PeopleBehaviors, TheMixTextIsReadOrRefusedWithItsReason) {
  const PeopleMix m = PeopleMix::parse("attentive=3,oblivious=1");
  EXPECT_DOUBLE_EQ(m.attentive, 0.75);
  EXPECT_DOUBLE_EQ(m.impassive, 0.0);
  EXPECT_DOUBLE_EQ(m.oblivious, 0.25);
  EXPECT_EQ(m.str(), "attentive=0.75,oblivious=0.25");
  EXPECT_TRUE(m.anyReacts());
  EXPECT_FALSE(PeopleMix().anyReacts());
  EXPECT_EQ(PeopleMix::parse(m.str()).str(), m.str());
  // The preset names the benchmark's headline mix.
  EXPECT_EQ(PeopleMix::parse("headline").str(), "attentive=0.7,impassive=0.2,oblivious=0.1");
  auto refused = [](const std::string& text, const std::string& reason) {
    try {
      PeopleMix::parse(text);
      ADD_FAILURE() << "'" << text << "' was accepted";
    } catch (const SimConfigError& e) {
      EXPECT_NE(std::string(e.what()).find(reason), std::string::npos) << e.what();
    }
  };
  refused("curious=1", "'curious' is not one of oblivious, impassive, attentive");
  refused("attentive=0.5,attentive=0.5", "'attentive' is given twice");
  refused("attentive=-1", "must be a number >= 0");
  refused("attentive=nan", "must be a number >= 0");
  refused("attentive", "is not BEHAVIOUR=SHARE");
  refused("attentive=0,oblivious=0", "every share is 0");
  refused("", "is empty");
  PeopleConfig cfg;
  cfg.reaction_max_s = 0.1;  // below reaction_min_s
  EXPECT_NE(cfg.validate().find("reaction_min_s"), std::string::npos);
  cfg = PeopleConfig();
  cfg.notice_fov_rad = 0.0;
  EXPECT_NE(cfg.validate().find("notice_fov_rad"), std::string::npos);
}

TEST(People, SameInputSameTrajectories) {
  std::vector<PersonSpec> people;
  for (int i = 0; i < 6; ++i)
    people.push_back(walker({-3.0 + i, -2.0 + 0.5 * i}, {3.0 - i, 2.0 - 0.3 * i}, 0.6 + 0.1 * i));
  const std::vector<Segment> walls = {{Vec2(-4, -3), Vec2(4, -3)}, {Vec2(-4, 3), Vec2(4, 3)}};
  Crowd a(people, PeopleConfig{}), b(people, PeopleConfig{});
  for (int k = 0; k < 100; ++k) {
    a.step(0.1, walls, kFarRobot, Vec2::Zero());
    b.step(0.1, walls, kFarRobot, Vec2::Zero());
  }
  for (size_t i = 0; i < people.size(); ++i) {
    EXPECT_EQ(a.people()[i].position, b.people()[i].position);
    EXPECT_EQ(a.people()[i].gait_phase_rad, b.people()[i].gait_phase_rad);
  }
  EXPECT_EQ(a.legs().size(), 12u);
  EXPECT_EQ(a.asObstacles().size(), 6u);
}

/// Two rooms split by a wall along x = 0 with a 1 m door at |y| < 0.5.
const std::vector<Segment> kDoorWalls = {{Vec2(0, -4), Vec2(0, -0.5)}, {Vec2(0, 0.5), Vec2(0, 4)}};
/// That door, for people who pass it one at a time.
const Door kDoor{Vec2::Zero(), Vec2(1.0, 0.0), 1.0};

/// A person who walks from `from` through the door (a waypoint) to a stop `to` in the other room and back.
PersonSpec throughTheDoor(Vec2 from, Vec2 to, bool door_is_waypoint) {
  PersonSpec s = walker(from, Vec2::Zero());
  s.body_radius_m = 0.25;
  s.destinations = {Vec2::Zero(), to, Vec2::Zero(), from};
  if (door_is_waypoint) s.pass_through = {true, false, true, false};
  s.wait_s = 1.0;
  return s;
}

/// Stops (not waypoints) reached by everyone in `seconds`.
int stopsReached(Crowd& crowd, const std::vector<Segment>& walls, double seconds) {
  int stops = 0;
  std::vector<size_t> destination(crowd.people().size(), 0);
  for (int k = 0; k < static_cast<int>(seconds / 0.05); ++k) {
    crowd.step(0.05, walls, kFarRobot, Vec2::Zero());
    for (size_t i = 0; i < crowd.people().size(); ++i) {
      const Person& p = crowd.people()[i];
      if (p.destination == destination[i]) continue;
      if (destination[i] % 2 == 1) ++stops;  // 1 and 3 are the stops
      destination[i] = p.destination;
    }
  }
  return stops;
}

TEST(People, PeopleGoThroughADoorFromBothSidesInsteadOfQueuingForItsCentre) {
  // Three people on each side, every one bound for the other room and back; they pass the door one at a time.
  auto crowd = [](bool waypoints, bool door) {
    std::vector<PersonSpec> people;
    for (int i = 0; i < 3; ++i) {
      people.push_back(throughTheDoor({-2.5, -1.5 + 1.5 * i}, {2.5, 1.5 - 1.5 * i}, waypoints));
      people.push_back(throughTheDoor({2.5, -1.2 + 1.5 * i}, {-2.5, 1.2 - 1.5 * i}, waypoints));
    }
    return Crowd(people, PeopleConfig{}, 0, TrafficRule{TrafficSide::kRight, 1.0},
                 door ? std::vector<Door>{kDoor} : std::vector<Door>{});
  };
  Crowd passing = crowd(true, true), queuing = crowd(false, true), free_for_all = crowd(true, false);
  const int passed = stopsReached(passing, kDoorWalls, 60.0), queued = stopsReached(queuing, kDoorWalls, 60.0);
  std::printf("[ six people, two ways ] stops in 60 s: %d one at a time, %d without the door's rule\n", passed,
              stopsReached(free_for_all, kDoorWalls, 60.0));
  // 2 x 5 m at ~1 m/s and two 1 s waits: about 12 s per round trip; through a door shared both ways, at least
  // one round trip each in a minute (the ones waiting stand beside the door, off its line, and do not jam it). With
  // the door's centre a stop to reach (the crowd jams around it) far fewer.
  EXPECT_GE(passed, 12) << "queued: " << queued;
  EXPECT_LT(queued, passed / 2) << "passed: " << passed;
  for (const Person& p : passing.people()) {
    for (const Segment& w : kDoorWalls) EXPECT_GT(pointSegmentDistance(p.position, w), 0.5 * p.spec.body_radius_m);
  }
}

/// Two people meeting in the 1 m door of kDoorWalls, one from each side (docs/experiments/2026-12-07-door-yield.md):
/// start x in [1, 3] m from the wall, y in [-2, 2], a stop 1.5-3 m into the other room, the door a waypoint, speed
/// 0.8-1.3 m/s, radius 0.2-0.3 m, 30 s of 0.05 s steps; each then walks back through the door to where it started
/// (throughTheDoor), so that they may meet again.
struct DoorMeeting {
  bool overlap = false;       ///< the two bodies overlapped at some step
  bool both_through = false;  ///< each reached its stop in the other room
  bool wall_crossed = false;
  double closest_gap_m = std::numeric_limits<double>::infinity();  ///< surface to surface
};
DoorMeeting meetInTheDoor(uint64_t seed, const std::vector<Door>& doors, PeopleModel model) {
  Rng rng(seed);
  std::vector<PersonSpec> people;
  for (double side : {-1.0, 1.0}) {
    const Vec2 from(side * rng.uniform(1.0, 3.0), rng.uniform(-2.0, 2.0));
    const Vec2 stop(-side * rng.uniform(1.5, 3.0), rng.uniform(-2.0, 2.0));
    PersonSpec s = throughTheDoor(from, stop, true);
    s.preferred_speed_mps = rng.uniform(0.8, 1.3);
    s.body_radius_m = rng.uniform(0.2, 0.3);
    s.wait_s = 1.0;
    people.push_back(s);
  }
  PeopleConfig config;
  config.model = model;
  Crowd crowd(people, config, seed, TrafficRule{TrafficSide::kRight, 1.0}, doors);
  DoorMeeting m;
  bool through[2] = {false, false};
  for (int k = 0; k < 600; ++k) {
    const Vec2 before[2] = {crowd.people()[0].position, crowd.people()[1].position};
    crowd.step(0.05, kDoorWalls, kFarRobot, Vec2::Zero());
    const Person &a = crowd.people()[0], &b = crowd.people()[1];
    const double gap = (a.position - b.position).norm() - a.spec.body_radius_m - b.spec.body_radius_m;
    m.closest_gap_m = std::min(m.closest_gap_m, gap);
    m.overlap |= gap < 0.0;
    for (int i = 0; i < 2; ++i) {
      const Person& p = crowd.people()[static_cast<size_t>(i)];
      through[i] |= (p.position - p.spec.destinations[1]).norm() < config.arrival_radius_m + 0.05;
      for (const Segment& w : kDoorWalls) m.wall_crossed |= segmentsCross(before[i], p.position, w);
    }
  }
  m.both_through = through[0] && through[1];
  return m;
}

TEST(Traffic, TwoPeopleMeetingInADoorPassOneAtATimeWithoutTouching) {
  for (PeopleModel model : {PeopleModel::kSocialForce, PeopleModel::kOrca}) {
    int overlaps = 0, stuck = 0, crossed = 0, overlaps_without = 0, stuck_without = 0;
    double closest = std::numeric_limits<double>::infinity();
    for (uint64_t seed = 1; seed <= 100; ++seed) {
      const DoorMeeting m = meetInTheDoor(seed, {kDoor}, model);
      overlaps += m.overlap;
      stuck += !m.both_through;
      crossed += m.wall_crossed;
      closest = std::min(closest, m.closest_gap_m);
      const DoorMeeting without = meetInTheDoor(seed, {}, model);
      overlaps_without += without.overlap;
      stuck_without += !without.both_through;
      EXPECT_FALSE(m.overlap) << peopleModelName(model) << " seed " << seed << " gap " << m.closest_gap_m;
      EXPECT_TRUE(m.both_through) << peopleModelName(model) << " seed " << seed;
    }
    EXPECT_EQ(crossed, 0) << peopleModelName(model);
    std::printf(
        "[ door meetings, %s ] of 100 pairs, with the door / without: overlapping %d / %d (closest gap with "
        "it %.3f m), not both through in 30 s %d / %d\n",
        peopleModelName(model), overlaps, overlaps_without, closest, stuck, stuck_without);
    if (model == PeopleModel::kSocialForce) {
      EXPECT_GT(stuck_without, 5);  // without the door's rule they push at each other in the door and give way
    }
  }
}

TEST(Traffic, TheOneWaitingStandsBesideTheDoorOffItsLineAndGoesWhenItIsFree) {
  // One walks at the door from 0.6 m away (nearer: it holds the door), one from 2.2 m on the other side (waits).
  PersonSpec near = throughTheDoor({-0.6, 0.0}, {2.5, 0.0}, true), far = throughTheDoor({2.2, 0.3}, {-2.5, 0.3}, true);
  Crowd crowd({near, far}, PeopleConfig{}, 0, TrafficRule{TrafficSide::kRight, 1.0}, {kDoor});
  crowd.step(0.05, kDoorWalls, kFarRobot, Vec2::Zero());
  EXPECT_EQ(crowd.doorHolder(0), 0);
  ASSERT_TRUE(crowd.people()[1].door_waiting);
  const Vec2 spot = crowd.people()[1].door_spot;
  // On its own side (x > 0), off the door's line (|y| beyond the opening by its radius), to its right: facing the
  // door (-x), its right is +y.
  EXPECT_GT(spot.x(), 0.0);
  EXPECT_GT(spot.y(), 0.5 + far.body_radius_m);
  double far_through = -1.0;
  for (int k = 1; k <= 400 && far_through < 0.0; ++k) {
    crowd.step(0.05, kDoorWalls, kFarRobot, Vec2::Zero());
    const Person& p = crowd.people()[1];
    if (crowd.doorHolder(0) == 0) {
      // While the other holds the door it keeps out of the door's line.
      EXPECT_TRUE(std::abs(p.position.y()) > 0.5 + 0.5 * p.spec.body_radius_m || p.position.x() > 1.2)
          << "step " << k << " at " << p.position.transpose();
    }
    if (p.position.x() < -0.5) far_through = 0.05 * k;
  }
  EXPECT_GT(far_through, 0.0) << "it never went";
  // A left-hand rule puts the waiting place on the other side.
  Crowd left({near, far}, PeopleConfig{}, 0, TrafficRule{TrafficSide::kLeft, 1.0}, {kDoor});
  left.step(0.05, kDoorWalls, kFarRobot, Vec2::Zero());
  EXPECT_LT(left.people()[1].door_spot.y(), -0.5 - far.body_radius_m);
}

TEST(Traffic, AHolderThatCannotGetThroughLetsTheOthersGo) {
  // The nearer one is bound for the door but its plan never takes it through (a stop on the far side it is pushed
  // back from by a wall across the way, 0.6 m beyond the door): after Door::kHold_s the other gets the door.
  std::vector<Segment> walls = kDoorWalls;
  walls.push_back({Vec2(0.6, -1.0), Vec2(0.6, 1.0)});  // blocks the east side just beyond the door
  PersonSpec blocked = throughTheDoor({-0.8, 0.0}, {2.5, 0.0}, true);
  PersonSpec other = throughTheDoor({-2.0, 1.5}, {-3.0, -1.5}, true);  // a west-room plan: never at the door
  other.destinations = {Vec2(-2.0, -1.5), Vec2(-2.0, 1.5)};
  other.pass_through.clear();
  PersonSpec waiting = throughTheDoor({2.0, -2.0}, {-2.5, 0.0}, true);
  Crowd crowd({blocked, other, waiting}, PeopleConfig{}, 0, TrafficRule{}, {kDoor});
  bool held_by_waiting = false;
  for (int k = 0; k < 600 && !held_by_waiting; ++k) {
    crowd.step(0.05, walls, kFarRobot, Vec2::Zero());
    held_by_waiting = crowd.doorHolder(0) == 2;
  }
  EXPECT_TRUE(held_by_waiting);
}

/// A 2.5 m corridor along x (walls at y = +-1.25, 16 m long).
const std::vector<Segment> kCorridor = {{Vec2(-8, -1.25), Vec2(8, -1.25)}, {Vec2(-8, 1.25), Vec2(8, 1.25)}};

/// Two people walking the corridor opposite ways from random lateral places: how many of `cases` pass each on its
/// right (the one walking +x below the other when they are level), and whether any overlapped or left it.
struct Passing {
  int right = 0, left = 0, overlaps = 0, out = 0;
};
Passing passInTheCorridor(const TrafficRule& rule, PeopleModel model, int cases) {
  Passing r;
  PeopleConfig config;
  config.model = model;
  for (int c = 1; c <= cases; ++c) {
    Rng rng(static_cast<uint64_t>(c));
    const double ya = rng.uniform(-0.8, 0.8), yb = rng.uniform(-0.8, 0.8);
    PersonSpec a = walker({-7.0, ya}, {7.0, ya}, rng.uniform(0.8, 1.3)),
               b = walker({7.0, yb}, {-7.0, yb}, rng.uniform(0.8, 1.3));
    a.body_radius_m = rng.uniform(0.2, 0.3);
    b.body_radius_m = rng.uniform(0.2, 0.3);
    Crowd crowd({a, b}, config, static_cast<uint64_t>(c), rule, {});
    bool overlapped = false, outside = false;
    for (int k = 0; k < 400; ++k) {
      crowd.step(0.05, kCorridor, kFarRobot, Vec2::Zero());
      const Person &p = crowd.people()[0], &q = crowd.people()[1];
      overlapped |= (p.position - q.position).norm() < p.spec.body_radius_m + q.spec.body_radius_m;
      for (const Person& x : crowd.people()) outside |= std::abs(x.position.y()) > 1.25 - 0.5 * x.spec.body_radius_m;
      if (p.position.x() >= q.position.x()) {
        (p.position.y() < q.position.y() ? r.right : r.left) += 1;
        break;
      }
    }
    r.overlaps += overlapped;
    r.out += outside;
  }
  return r;
}

TEST(Traffic, TwoPeopleWalkingOppositeWaysInACorridorPassEachOnItsRight) {
  for (PeopleModel model : {PeopleModel::kSocialForce, PeopleModel::kOrca}) {
    const Passing right = passInTheCorridor({TrafficSide::kRight, 1.0}, model, 50),
                  left = passInTheCorridor({TrafficSide::kLeft, 1.0}, model, 50),
                  off = passInTheCorridor({}, model, 50),
                  weak = passInTheCorridor({TrafficSide::kRight, 0.0}, model, 50);
    const char* name = peopleModelName(model);
    std::printf("[ corridor passing, %s ] on the right of 50: rule right %d, rule left %d, no rule %d\n", name,
                right.right, left.right, off.right);
    EXPECT_EQ(right.right, 50) << name;
    EXPECT_EQ(left.left, 50) << name;  // the side matters
    // Without the rule (or with strength 0) they pass whichever way they happen to start.
    EXPECT_GT(off.right, 5) << name;
    EXPECT_GT(off.left, 5) << name;
    EXPECT_EQ(weak.right, off.right) << name;
    for (const Passing& p : {right, left, off}) {
      EXPECT_EQ(p.right + p.left, 50) << name;  // they always met and passed
      EXPECT_EQ(p.overlaps, 0) << name;
      EXPECT_EQ(p.out, 0) << name;  // nobody pushed into a wall
    }
  }
}

TEST(Traffic, AloneInACorridorAPersonKeepsToItsLaneClearOfTheWall) {
  // Walking the corridor's middle with the rule, it settles on the lane on its right: 0.3 of the width from the
  // wall, clear of it, and it keeps walking at its speed (never stalls against the wall).
  Crowd crowd({walker({-7.0, 0.0}, {7.0, 0.0}, 1.0)}, PeopleConfig{}, 0, TrafficRule{TrafficSide::kRight, 1.0}, {});
  for (int k = 0; k < 160; ++k) crowd.step(0.05, kCorridor, kFarRobot, Vec2::Zero());
  const Person& p = crowd.people()[0];
  EXPECT_NEAR(p.position.y(), -1.25 + 0.3 * 2.5, 0.15);
  EXPECT_GT(p.velocity.x(), 0.9);
  // Near its stop the rule fades, so the stop (on the corridor's centre line) is reached.
  for (int k = 0; k < 200; ++k) crowd.step(0.05, kCorridor, kFarRobot, Vec2::Zero());
  EXPECT_LT((crowd.people()[0].position - Vec2(7.0, 0.0)).norm(), PeopleConfig{}.arrival_radius_m + 0.1);
}

TEST(Traffic, SameInputSameTrajectoriesWithDoorsAndTheRule) {
  std::vector<PersonSpec> people;
  for (int i = 0; i < 3; ++i) {
    people.push_back(throughTheDoor({-2.5, -1.5 + 1.5 * i}, {2.5, 1.5 - 1.5 * i}, true));
    people.push_back(throughTheDoor({2.5, -1.2 + 1.5 * i}, {-2.5, 1.2 - 1.5 * i}, true));
  }
  const TrafficRule rule{TrafficSide::kRight, 1.0};
  Crowd a(people, PeopleConfig{}, 4, rule, {kDoor}), b(people, PeopleConfig{}, 4, rule, {kDoor}),
      c(people, PeopleConfig{}, 4, TrafficRule{}, {});
  bool differs = false;
  for (int k = 0; k < 300; ++k) {
    a.step(0.05, kDoorWalls, kFarRobot, Vec2::Zero());
    b.step(0.05, kDoorWalls, kFarRobot, Vec2::Zero());
    c.step(0.05, kDoorWalls, kFarRobot, Vec2::Zero());
    ASSERT_EQ(a.doorHolder(0), b.doorHolder(0));
  }
  for (size_t i = 0; i < people.size(); ++i) {
    EXPECT_EQ(a.people()[i].position, b.people()[i].position);
    differs |= a.people()[i].position != c.people()[i].position;
  }
  EXPECT_TRUE(differs);  // the door and the rule change what people do
}

TEST(People, SomeonePushedOffTheWayThroughADoorGoesBackToIt) {
  // Already past the door in its plan (its stop is in the west room) but standing in the east room: straight at
  // the stop is into the wall, so it goes back to the door first.
  PersonSpec s = walker({1.0, 2.0}, {-2.5, 2.0});
  s.destinations = {Vec2(-2.5, 2.0), Vec2::Zero()};
  s.pass_through = {false, true};
  Crowd crowd({s}, PeopleConfig{});
  double reached = -1.0;
  for (int k = 1; k <= 400 && reached < 0; ++k) {
    crowd.step(0.05, kDoorWalls, kFarRobot, Vec2::Zero());
    if ((crowd.people()[0].position - Vec2(-2.5, 2.0)).norm() < PeopleConfig{}.arrival_radius_m) reached = 0.05 * k;
  }
  EXPECT_GT(reached, 0.0) << "stuck at " << crowd.people()[0].position.transpose();
}

TEST(People, AStopThatCannotBeReachedIsSettledForFromNearEnough) {
  // The stop lies 0.2 m behind a wall's face (as when someone else stands on it): a body of 0.25 m comes no nearer
  // than 0.45 m, outside arrival_radius_m.
  const std::vector<Segment> walls = {{Vec2(-2, 0), Vec2(2, 0)}};
  PersonSpec s = walker({0, 3}, {0, -0.2});
  s.destinations.push_back({-1.5, 3});
  const PeopleConfig config;
  Crowd crowd({s}, config);
  double moved_on = -1.0;
  for (int k = 1; k <= 400 && moved_on < 0; ++k) {
    crowd.step(0.05, walls, kFarRobot, Vec2::Zero());
    if (crowd.people()[0].destination == 1) moved_on = 0.05 * k;
  }
  ASSERT_GT(moved_on, 0.0) << "still pushing toward the stop";
  EXPECT_GT(moved_on, config.stall_time_s);
  EXPECT_LT(moved_on, 3.0 + config.stall_time_s + 2.0);  // ~3 s of walking, then stalled
}

TEST(People, BadInputIsNamed) {
  PeopleConfig c;
  c.relaxation_time_s = 0.0;
  EXPECT_NE(c.validate().find("relaxation_time_s"), std::string::npos);
  c = PeopleConfig();
  c.anisotropy = 1.5;
  EXPECT_NE(c.validate().find("anisotropy"), std::string::npos);
  PersonSpec s = walker({0, 0}, {1, 0});
  s.body_radius_m = -0.2;
  try {
    Crowd({walker({0, 0}, {1, 0}), s}, PeopleConfig{});
    FAIL() << "no error for a negative radius";
  } catch (const SimConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("person 1"), std::string::npos) << e.what();
  }
  EXPECT_THROW(parsePeopleModel("teleport"), SimConfigError);
  EXPECT_EQ(parsePeopleModel("social_force"), PeopleModel::kSocialForce);
  EXPECT_EQ(parsePeopleModel("orca"), PeopleModel::kOrca);
  Crowd crowd({walker({0, 0}, {1, 0})}, PeopleConfig{});
  EXPECT_THROW(crowd.step(std::nan(""), {}, kFarRobot, Vec2::Zero()), SimConfigError);
  PersonSpec flagged = walker({0, 0}, {1, 0});
  flagged.pass_through = {true, false};  // two flags for one destination
  try {
    Crowd({flagged}, PeopleConfig{});
    FAIL() << "no error for mismatched pass-through flags";
  } catch (const SimConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("2 pass-through flags for 1 destinations"), std::string::npos) << e.what();
  }
  c = PeopleConfig();
  c.stall_time_s = 0.0;
  EXPECT_NE(c.validate().find("stall_time_s"), std::string::npos);
  EXPECT_THROW(Crowd({}, PeopleConfig{}, 0, TrafficRule{TrafficSide::kRight, 1.5}), SimConfigError);
  EXPECT_THROW(Crowd({}, PeopleConfig{}, 0, TrafficRule{}, {Door{Vec2::Zero(), Vec2(2.0, 0.0), 1.0}}), SimConfigError);
  EXPECT_THROW(Crowd({}, PeopleConfig{}, 0, TrafficRule{}, {Door{Vec2::Zero(), Vec2(1.0, 0.0), 0.0}}), SimConfigError);
  EXPECT_EQ(parseTrafficSide("left"), TrafficSide::kLeft);
  EXPECT_THROW(parseTrafficSide("middle"), SimConfigError);
}

}  // namespace
}  // namespace dqn_dovs::sim
