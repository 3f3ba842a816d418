// Observation assembly shared by dovs_node, the bag replay and the Episode (perception/observation.h): the map's walls
// near the robot, and the moving tracks on the arcs of their learned prediction.
#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <vector>

#include "dqn_dovs/perception/observation.h"
#include "dqn_dovs/perception/people_predictor.h"
#include "source_paths.h"

namespace dqn_dovs {
namespace {

TEST(Observation, MapWallsNearTheRobotJoinInTheFixedFrame) {
  // The map's origin lies 1 m along +x of the fixed frame, turned by 90 degrees.
  const Pose2 map_in_fixed{1.0, 0.0, M_PI / 2};
  const std::vector<Segment> walls = {Segment{Vec2(0.0, 0.0), Vec2(2.0, 0.0)},     // -> (1, 0)-(1, 2) fixed
                                      Segment{Vec2(0.0, -8.0), Vec2(2.0, -8.0)}};  // -> x = 9: far away
  std::vector<Segment> segments = {Segment{Vec2(-1.0, -1.0), Vec2(-1.0, 1.0)}};    // the scan's own
  appendMapWalls(walls, map_in_fixed, Vec2(0.0, 0.0), 4.0, segments);
  ASSERT_EQ(segments.size(), 2u);
  EXPECT_NEAR(segments[1].a.x(), 1.0, 1e-12);
  EXPECT_NEAR(segments[1].a.y(), 0.0, 1e-12);
  EXPECT_NEAR(segments[1].b.x(), 1.0, 1e-12);
  EXPECT_NEAR(segments[1].b.y(), 2.0, 1e-12);
  appendMapWalls(walls, map_in_fixed, Vec2(0.0, 0.0), 0.5, segments);  // nothing within 0.5 m
  EXPECT_EQ(segments.size(), 2u);
}

TEST(Observation, OnlyTheTracksFromFirstOnTakeTheirPredictedArcs) {
  auto predictor = std::make_shared<const PeoplePredictor>(
      PeoplePredictor::load(std::string(DQN_DOVS_SOURCE_DIR) + "/models/people_predictor_tracks.dqnp"));
  // A disc (index 0) and two people walking along +x, then turning towards +y.
  std::vector<MovingObstacle> obstacles(3);
  for (size_t k = 0; k < obstacles.size(); ++k) {
    obstacles[k].center = Vec2(1.0 + k, 2.0 * k);
    obstacles[k].radius = 0.25;
    obstacles[k].speed = 1.0;
  }
  const std::vector<MovingObstacle> start = obstacles;
  PredictedArcs arcs(predictor), reference(predictor);
  std::vector<MovingObstacle> people;
  for (int step = 0; step < 10; ++step) {
    const double t = 0.2 * step;
    for (size_t k = 0; k < obstacles.size(); ++k) {
      const double turn = step > 5 ? 0.04 * (step - 5) * (step - 5) : 0.0;
      obstacles[k].center = start[k].center + Vec2(t, turn);
      obstacles[k].heading = step > 5 ? 0.3 : 0.0;
      obstacles[k].turn_rate = 0.0;
    }
    people.assign(obstacles.begin() + 1, obstacles.end());
    predictArcs(arcs, obstacles, 1, {11, 12}, t, {});
    reference.apply(people, {11, 12}, t, {});  // the people alone, as their own list
  }
  // The disc keeps its constant (v, w); the people take exactly the arcs of the people predicted on their own, and
  // at least one of them is not its constant velocity any more.
  EXPECT_EQ(obstacles[0].turn_rate, 0.0);
  EXPECT_EQ(obstacles[0].speed, 1.0);
  bool bent = false;
  for (size_t k = 1; k < obstacles.size(); ++k) {
    EXPECT_EQ(obstacles[k].turn_rate, people[k - 1].turn_rate) << k;
    EXPECT_EQ(obstacles[k].speed, people[k - 1].speed) << k;
    EXPECT_EQ(obstacles[k].heading, people[k - 1].heading) << k;
    bent |= obstacles[k].turn_rate != 0.0;
  }
  EXPECT_TRUE(bent) << "the prediction left every person on a straight line";
}

}  // namespace
}  // namespace dqn_dovs
