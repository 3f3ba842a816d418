// People: legs and gait, walking to destinations with waits, the social force model (avoidance, walls, groups,
// seeing the robot), doors passed on the way, stops settled for when occupied, the constant model, determinism
// and bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

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
  // Three people on each side, every one bound for the other room and back.
  auto crowd = [](bool waypoints) {
    std::vector<PersonSpec> people;
    for (int i = 0; i < 3; ++i) {
      people.push_back(throughTheDoor({-2.5, -1.5 + 1.5 * i}, {2.5, 1.5 - 1.5 * i}, waypoints));
      people.push_back(throughTheDoor({2.5, -1.2 + 1.5 * i}, {-2.5, 1.2 - 1.5 * i}, waypoints));
    }
    return Crowd(people, PeopleConfig{});
  };
  Crowd passing = crowd(true), queuing = crowd(false);
  const int passed = stopsReached(passing, kDoorWalls, 60.0), queued = stopsReached(queuing, kDoorWalls, 60.0);
  // 2 x 5 m at ~1 m/s and two 1 s waits: about 12 s per round trip; through a door shared both ways, at least
  // one round trip each in a minute. With the door's centre a stop to reach (the crowd jams around it) far fewer.
  EXPECT_GE(passed, 12) << "queued: " << queued;
  EXPECT_LT(queued, passed / 2) << "passed: " << passed;
  for (const Person& p : passing.people()) {
    for (const Segment& w : kDoorWalls) EXPECT_GT(pointSegmentDistance(p.position, w), 0.5 * p.spec.body_radius_m);
  }
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
}

}  // namespace
}  // namespace dqn_dovs::sim
