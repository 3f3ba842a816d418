// The text scenario format (version 2): every family's worlds round-trip exactly, maps become walls, v1 files
// still load through the same entry point, and malformed files are named with the line and the reason.
#include <gtest/gtest.h>

#include <fstream>
#include <iterator>
#include <string>

#include "dqn_dovs/sim/scenario.h"
#include "dqn_dovs/sim/worlds.h"
#include "sim_test_helpers.h"

namespace dqn_dovs::sim {
namespace {

void write(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
}

std::string errorOf(const std::string& text) {
  try {
    parseScenarioText(text, "s.scenario");
  } catch (const ScenarioError& e) {
    return e.what();
  }
  return "";
}

TEST(ScenarioText, EveryFamilyRoundTripsExactly) {
  test::TempDir dir;
  for (const std::string& family : worldFamilyNames()) {
    WorldFamilyConfig c;
    c.family = parseWorldFamily(family);
    c.people = 6;
    const Scenario a = generateWorld(c, 3);
    const std::string path = dir.file(family + ".scenario");
    saveScenarioText(a, path);
    const Scenario b = loadScenarioFile(path);
    EXPECT_EQ(b.name, a.name);
    EXPECT_EQ(b.room_half_size_m, a.room_half_size_m);
    EXPECT_EQ(b.robot_start.x, a.robot_start.x);
    EXPECT_EQ(b.robot_start.theta, a.robot_start.theta);
    EXPECT_EQ(b.goal, a.goal);
    ASSERT_EQ(b.obstacles.size(), a.obstacles.size()) << family;
    for (size_t i = 0; i < a.obstacles.size(); ++i) {
      EXPECT_EQ(b.obstacles[i].center, a.obstacles[i].center);
      EXPECT_EQ(b.obstacles[i].speed, a.obstacles[i].speed);
      EXPECT_EQ(b.obstacles[i].radius, a.obstacles[i].radius);
      EXPECT_EQ(b.obstacles[i].is_static, a.obstacles[i].is_static);
    }
    ASSERT_EQ(b.static_segments.size(), a.static_segments.size()) << family;
    for (size_t i = 0; i < a.static_segments.size(); ++i) EXPECT_EQ(b.static_segments[i].b, a.static_segments[i].b);
    EXPECT_EQ(b.traffic, a.traffic) << family;
    EXPECT_EQ(b.doors, a.doors) << family;
    ASSERT_EQ(b.people.size(), a.people.size()) << family;
    for (size_t i = 0; i < a.people.size(); ++i) {
      EXPECT_EQ(b.people[i].position, a.people[i].position);
      EXPECT_EQ(b.people[i].preferred_speed_mps, a.people[i].preferred_speed_mps);
      EXPECT_EQ(b.people[i].group, a.people[i].group);
      EXPECT_EQ(b.people[i].destinations, a.people[i].destinations);
      EXPECT_EQ(b.people[i].pass_through, a.people[i].pass_through);
    }
  }
}

TEST(ScenarioText, PolygonsMapsAndVersionOneFiles) {
  test::TempDir dir;
  // A 2 x 1 cell map with one occupied cell: its four edges become walls.
  write(dir.file("m.yaml"), "image: m.pgm\nresolution: 0.5\norigin: [1.0, 1.0, 0.0]\n");
  write(dir.file("m.pgm"), std::string("P5\n2 1\n255\n") + char(0) + char(254));
  const std::string text =
      "dqn_dovs scenario 2\n# a room with a table and a map\nname table room\nroom 5\nrobot -3 0 0.5\ngoal 3 0\n"
      "obstacle 0 2 1.0 0.5 0.1 0.2\nobstacle 0 -2 0 0 0 0.3 static\npolygon -1 -1 1 -1 0 1\nmap m.yaml\n"
      "person 2 2 3.14 0.25 1.1 0.5 -1 -2 2 2 -2\n";
  write(dir.file("t.scenario"), text);
  const Scenario s = loadScenarioFile(dir.path() + "/t.scenario");
  EXPECT_EQ(s.name, "table room");
  EXPECT_EQ(s.room_half_size_m, 5.0);
  ASSERT_EQ(s.obstacles.size(), 2u);
  EXPECT_FALSE(s.obstacles[0].is_static);
  EXPECT_TRUE(s.obstacles[1].is_static);
  EXPECT_EQ(s.static_segments.size(), 3u + 4u);  // the triangle, then the map cell
  EXPECT_EQ(s.static_segments[3].a, Vec2(1.0, 1.0));
  ASSERT_EQ(s.people.size(), 1u);
  EXPECT_EQ(s.people[0].destinations.size(), 2u);
  // A file without traffic or doors has none, and is written again without them.
  EXPECT_FALSE(s.traffic.active());
  EXPECT_TRUE(s.doors.empty());
  saveScenarioText(s, dir.file("again.scenario"));
  std::ifstream again(dir.file("again.scenario"));
  const std::string written((std::istreambuf_iterator<char>(again)), std::istreambuf_iterator<char>());
  EXPECT_EQ(written.find("traffic"), std::string::npos);
  EXPECT_EQ(written.find("door"), std::string::npos);
  // Traffic and doors are read.
  const Scenario t = parseScenarioText(
      "dqn_dovs scenario 2\nrobot 0 0 0\ngoal 1 1\ntraffic left 0.5\ndoor 0 0.5 0 2 1.1\n", "t.scenario");
  EXPECT_EQ(t.traffic, (TrafficRule{TrafficSide::kLeft, 0.5}));
  ASSERT_EQ(t.doors.size(), 1u);
  EXPECT_EQ(t.doors[0], (Door{Vec2(0.0, 0.5), Vec2(0.0, 1.0), 1.1}));  // across made a unit vector
  // A .dovs file goes through the same entry point.
  Scenario v1;
  v1.robot_start = {0.5, 0.5, 0.0};
  v1.goal = Vec2(-2.0, 1.0);
  saveDovsScenario(v1, dir.file("v1.dovs"));
  EXPECT_EQ(loadScenarioFile(dir.path() + "/v1.dovs").goal, Vec2(-2.0, 1.0));
}

TEST(ScenarioText, MalformedFilesAreNamedWithTheLine) {
  const std::string head = "dqn_dovs scenario 2\nrobot 0 0 0\ngoal 1 1\n";
  EXPECT_NE(errorOf("robot 0 0 0\n").find("the first line is not 'dqn_dovs scenario 2'"), std::string::npos);
  EXPECT_NE(errorOf(head + "tree 1 2\n").find("line 4: unknown item 'tree'"), std::string::npos);
  EXPECT_NE(errorOf(head + "wall 0 0 1\n").find("line 4: 'wall' takes 4 numbers, got 3"), std::string::npos);
  EXPECT_NE(errorOf(head + "wall 0 0 1 x\n").find("'x' is not a finite number"), std::string::npos);
  EXPECT_NE(errorOf(head + "wall 0 0 1 nan\n").find("'nan' is not a finite number"), std::string::npos);
  EXPECT_NE(errorOf(head + "wall 0 0 1 static\n").find("'static' is not a finite number"), std::string::npos);
  EXPECT_NE(errorOf(head + "obstacle 9 0 0 0 0 0.2\n").find("line 4: an obstacle (9, 0) is not inside the room"),
            std::string::npos);
  EXPECT_NE(errorOf(head + "obstacle 1 0 0 0 0 -0.2\n").find("radius must be > 0"), std::string::npos);
  EXPECT_NE(errorOf(head + "person 1 0 0 0.25 1 0 0.5\n").find("integer group"), std::string::npos);
  EXPECT_NE(errorOf(head + "person 1 0 0 0.25 1 0 -1 2 2 via\n").find("'via' must be followed by"), std::string::npos);
  EXPECT_NE(errorOf(head + "person 1 0 0 0.25 via 1 0 -1 2 2\n").find("each may follow 'via'"), std::string::npos);
  EXPECT_NE(errorOf(head + "map nowhere.yaml\n").find("line 4: map 'nowhere.yaml': cannot open"), std::string::npos);
  EXPECT_NE(errorOf("dqn_dovs scenario 2\nrobot 0 0 0\n").find("needs a 'robot' and a 'goal'"), std::string::npos);
  EXPECT_NE(errorOf(head + "traffic middle 1\n").find("line 4: traffic side 'middle'"), std::string::npos);
  EXPECT_NE(errorOf(head + "traffic right 2\n").find("strength 2: must be in [0, 1]"), std::string::npos);
  EXPECT_NE(errorOf(head + "door 0 0 1 0\n").find("'door' takes 5 numbers"), std::string::npos);
  EXPECT_NE(errorOf(head + "door 0 0 0 0 1\n").find("a unit direction across"), std::string::npos);
  EXPECT_THROW(loadScenarioFile("/nonexistent.scenario"), ScenarioError);
}

}  // namespace
}  // namespace dqn_dovs::sim
