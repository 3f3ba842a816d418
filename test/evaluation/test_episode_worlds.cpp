// Episodes in every world family, with the tracker and with perfect information: the DOVS takes the walls of any
// shape (corridors, doors, furniture) and far goals, the state stays finite and within its clip, and the episode
// ends with an outcome.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>

#include "dqn_dovs/dovs/actions.h"
#include "dqn_dovs/dovs/state.h"
#include "dqn_dovs/evaluation/episode.h"
#include "dqn_dovs/sim/worlds.h"

namespace dqn_dovs {
namespace {

TEST(EpisodeWorlds, EveryFamilyGivesFiniteStatesWallsAndAnOutcome) {
  for (const std::string& family : sim::worldFamilyNames()) {
    for (const bool perfect : {false, true}) {
      sim::WorldFamilyConfig w;
      w.family = sim::parseWorldFamily(family);
      w.people = 8;
      const sim::Scenario scenario = sim::generateWorld(w, 21);
      EpisodeConfig config;
      config.perfect_info = perfect;
      config.tracker.pair_legs = family != "room";
      config.reward.max_steps = 60;
      Episode episode(config);
      episode.reset(scenario, 4);
      int steps = 0, with_walls = 0;
      while (!episode.done()) {
        const Eigen::VectorXf& state = episode.state();
        ASSERT_EQ(state.size(), kStateSize);
        for (int i = 0; i < state.size(); ++i) {
          ASSERT_TRUE(std::isfinite(state[i])) << family << " step " << steps << " entry " << i;
          ASSERT_LE(std::abs(state[i]), episode.normalization().clip + 1e-6f);
        }
        with_walls += episode.observation().segments.empty() ? 0 : 1;
        int action = kActionKeep;
        for (int a = 0; a < kNumActions; ++a) {
          if (episode.actions().valid[static_cast<size_t>(a)]) action = a;  // the last valid: the goal line
        }
        episode.stepAction(episode.actions().valid[static_cast<size_t>(action)] ? action : kActionKeep);
        ++steps;
      }
      EXPECT_NE(episode.outcome(), Outcome::kRunning);
      EXPECT_LE(steps, 60);
      if (family != "room" && family != "crowd" && steps > 3) {
        EXPECT_GT(with_walls, 0) << family << " sees no wall";
      }
    }
  }
  // A goal beyond the distance scale saturates its feature instead of leaving the clip (without a route: with one
  // the corridor's goal reaches the state as subgoals a lookahead ahead first).
  sim::WorldFamilyConfig corridor;
  corridor.family = sim::WorldFamily::kCorridor;
  corridor.people = 0;
  EpisodeConfig straight;
  straight.route.enabled = false;
  Episode episode(straight);
  episode.reset(sim::generateWorld(corridor, 2), 1);
  const double distance = (episode.observation().goal - episode.observation().robot_pose.position()).norm();
  ASSERT_GT(distance, episode.normalization().goal_distance_scale_m);
  EXPECT_FLOAT_EQ(episode.state()[kStateGridCells + kFeatureGoalDistance], episode.normalization().clip);
}

// The previous action in the state (DovsConfig::previous_action, docs/dovs.md "The previous action"): each state ends
// with a one-hot of what the step before it ran, whichever way the step was asked for; none after a reset.
TEST(EpisodeWorlds, EachStateCarriesWhatThePreviousStepRan) {
  sim::WorldFamilyConfig w;
  w.family = sim::WorldFamily::kCrowd;
  w.people = 6;
  const sim::Scenario scenario = sim::generateWorld(w, 5);
  EpisodeConfig config;
  config.tracker.pair_legs = true;
  config.dovs.previous_action = 1;
  Episode episode(config);
  auto slot = [&episode]() {
    const Eigen::VectorXf tail = episode.state().tail(kPreviousChoiceInputs);
    if (tail.isZero()) return -1;
    EXPECT_FLOAT_EQ(tail.sum(), 1.0f);
    int k = 0;
    tail.maxCoeff(&k);
    return k;
  };
  for (int round = 0; round < 2; ++round) {
    episode.reset(scenario, 3);
    ASSERT_EQ(episode.state().size(), 417);
    EXPECT_EQ(slot(), -1);  // the first decision has no previous choice
    ASSERT_TRUE(episode.actions().valid[kActionKeep]);
    episode.stepAction(kActionKeep);
    EXPECT_EQ(slot(), kActionKeep);
    episode.step(Twist2{0.1, 0.0});  // a command that is no action: the shield's escape, another planner's
    EXPECT_EQ(slot(), kPreviousChoiceOther);
    PlannerDecision d;
    for (int a = 0; a < kNumActions; ++a) {
      if (episode.actions().valid[static_cast<size_t>(a)]) d.action = a;
    }
    ASSERT_GE(d.action, 0);
    d.command = episode.actions().velocities[static_cast<size_t>(d.action)];
    episode.stepDecision(d);
    EXPECT_EQ(slot(), d.action);
    d.action = -1;  // a planner's own velocity
    episode.stepDecision(d);
    EXPECT_EQ(slot(), kPreviousChoiceOther);
  }
}

}  // namespace
}  // namespace dqn_dovs

namespace dqn_dovs {
namespace {

// EpisodeConfig::tracker_map: the tracker is given the world's walls and furniture, placed in the drifting odom
// frame by the truth. A clutter of chairs, tables and shelves with nobody in it, the robot standing still under
// high odometry drift: without the map some chair or piece of furniture is a track; with it none is, and the pieces
// of it come out as segments.
/// A clutter of chairs, tables and shelves with nobody in it.
sim::Scenario emptyClutter() {
  sim::WorldFamilyConfig w;
  w.family = sim::WorldFamily::kClutter;
  w.people = 0;
  return sim::generateWorld(w, 7);
}

TEST(EpisodeWorlds, WithTheMapTheFurnitureIsNeverATrack) {
  const sim::Scenario scenario = emptyClutter();
  size_t chairs = 0;
  for (const MovingObstacle& o : scenario.obstacles) chairs += o.is_static ? 1 : 0;
  ASSERT_GT(chairs, 0u) << "the clutter has chairs";
  auto tracks = [&](bool with_map) {
    EpisodeConfig config;
    config.tracker_map = with_map;
    config.tracker.pair_legs = true;
    config.world.odometry = sim::OdometryConfig::level("high");
    config.reward.max_steps = 30;
    Episode episode(config);
    episode.reset(scenario, 3);
    size_t seen = 0, segments = 0;
    while (!episode.done()) {
      seen += episode.trackedScene().obstacles.size();
      segments += episode.trackedScene().segments.size();
      episode.step(Twist2{});
    }
    return std::make_pair(seen, segments);
  };
  const auto [without_tracks, without_segments] = tracks(false);
  const auto [with_tracks, with_segments] = tracks(true);
  EXPECT_GT(without_tracks, 0u);
  EXPECT_EQ(with_tracks, 0u);
  EXPECT_GT(with_segments, without_segments);

  EpisodeConfig both;
  both.tracker_map = true;
  both.perfect_info = true;
  EXPECT_NE(both.validate().find("tracker_map"), std::string::npos);
}

// EpisodeConfig::dovs_map: the map's walls and furniture outlines within map_range_m join the scan's segments, in the
// drifting odom frame (placed by the truth), as dovs_node adds them with use_map.
TEST(EpisodeWorlds, WithTheMapTheVelocitySpaceKnowsTheWallsNearTheRobot) {
  const sim::Scenario scenario = emptyClutter();
  EpisodeConfig config;
  config.dovs_map = true;
  config.map_range_m = 3.0;
  config.world.odometry = sim::OdometryConfig::level("high");
  config.reward.max_steps = 25;
  Episode episode(config);
  episode.reset(scenario, 3);
  EpisodeConfig scan_only = config;
  scan_only.dovs_map = false;
  Episode plain(scan_only);
  plain.reset(scenario, 3);
  while (!episode.done()) {
    const Observation& o = episode.observation();
    const Pose2 world_from_odom = episode.world().robotPose().compose(episode.world().odomPose().inverse());
    const size_t scanned = episode.trackedScene().segments.size();
    ASSERT_GE(o.segments.size(), scanned);
    size_t walls_near = 0;
    for (const Segment& wall : episode.world().walls()) {
      walls_near += pointSegmentDistance(episode.world().robotPose().position(), wall) <= 3.0 ? 1 : 0;
    }
    size_t walls_given = 0;
    for (size_t k = scanned; k < o.segments.size(); ++k) {
      const Segment& s = o.segments[k];
      EXPECT_LE(pointSegmentDistance(o.robot_pose.position(), s), 3.0 + 1e-9);
      const Segment in_world{world_from_odom.toWorld(s.a), world_from_odom.toWorld(s.b)};
      for (const Segment& wall : episode.world().walls()) {
        if ((wall.a - in_world.a).norm() < 1e-6 && (wall.b - in_world.b).norm() < 1e-6) ++walls_given;
      }
    }
    EXPECT_EQ(walls_given, walls_near) << "every wall within the range, where the world has it";
    EXPECT_EQ(plain.observation().segments.size(), plain.trackedScene().segments.size());
    episode.step(Twist2{0.2, 0.3});
    plain.step(Twist2{0.2, 0.3});
  }
  EpisodeConfig both;
  both.dovs_map = true;
  both.perfect_info = true;
  EXPECT_NE(both.validate().find("dovs_map"), std::string::npos);
}

// EpisodeConfig::track_truth (a diagnostic of what the tracker costs): the tracks the planners see take the true
// motion, or the whole true state, of the body each follows, in the drifting odom frame; tracks that follow
// nothing stay as the tracker gives them, and the tracker itself is untouched.
TEST(EpisodeWorlds, TracksGivenTheTruthTakeItFromTheBodyTheyFollow) {
  sim::WorldFamilyConfig w;
  w.family = sim::WorldFamily::kCrowd;
  w.people = 8;
  const sim::Scenario scenario = sim::generateWorld(w, 5);
  auto make = [&](TrackTruth what) {
    EpisodeConfig config;
    config.tracker.pair_legs = true;
    config.world.odometry = sim::OdometryConfig::level("high");
    config.reward.max_steps = 40;
    config.track_truth = what;
    auto episode = std::make_unique<Episode>(config);
    episode->reset(scenario, 9);
    return episode;
  };
  auto plain = make(TrackTruth::kNone), motion = make(TrackTruth::kMotion), state = make(TrackTruth::kState);
  size_t tracks = 0, given_state = 0, given_motion = 0, motion_changed = 0;
  while (!plain->done()) {
    const std::vector<MovingObstacle>& seen = plain->observation().obstacles;
    const TrackedScene& scene = plain->trackedScene();
    ASSERT_EQ(seen.size(), scene.obstacles.size());
    ASSERT_EQ(motion->observation().obstacles.size(), seen.size());
    ASSERT_EQ(state->observation().obstacles.size(), seen.size());
    const sim::World& world = plain->world();
    const Pose2 odom_from_world = world.odomPose().compose(world.robotPose().inverse());
    std::vector<MovingObstacle> truth = world.groundTruthObstacles();
    for (MovingObstacle& b : truth) b.center = odom_from_world.toWorld(b.center);
    for (size_t k = 0; k < seen.size(); ++k) {
      ++tracks;
      // The tracker is the same in the three episodes: only what the planners see differs.
      ASSERT_EQ(motion->trackedScene().obstacles[k].center, scene.obstacles[k].center);
      ASSERT_EQ(state->trackedScene().obstacles[k].center, scene.obstacles[k].center);
      const MovingObstacle& m = motion->observation().obstacles[k];
      const MovingObstacle& s = state->observation().obstacles[k];
      EXPECT_EQ(m.center, seen[k].center) << "motion keeps the track's centre";
      EXPECT_EQ(m.radius, seen[k].radius);
      if (s.center != seen[k].center) {
        // Given a body's state: it is one of the bodies within the match distance of the track.
        bool found = false;
        for (const MovingObstacle& b : truth) {
          if ((b.center - s.center).norm() < 1e-9 && (b.center - seen[k].center).norm() < kTrackTruthMatch_m) {
            found = true;
            EXPECT_EQ(s.radius, b.radius);
            EXPECT_EQ(s.speed, b.speed);
          }
        }
        EXPECT_TRUE(found) << "track " << k << " took a state that is no body's within reach";
        ++given_state;
        // The same track in the motion episode took that body's motion.
        EXPECT_EQ(m.speed, s.speed);
        EXPECT_EQ(m.turn_rate, s.turn_rate);
        ++given_motion;
        motion_changed += m.speed != seen[k].speed ? 1 : 0;
      } else {
        EXPECT_EQ(s.speed, seen[k].speed) << "a track that follows no body stays as it is";
        EXPECT_EQ(m.speed, seen[k].speed);
      }
    }
    plain->step(Twist2{0.2, 0.1});
    motion->step(Twist2{0.2, 0.1});
    state->step(Twist2{0.2, 0.1});
  }
  EXPECT_GT(tracks, 50u);
  EXPECT_GT(given_state, tracks / 2) << "most tracks follow a person";
  EXPECT_GT(motion_changed, given_motion / 2) << "the truth's speed is not the tracker's";

  EpisodeConfig both;
  both.track_truth = TrackTruth::kMotion;
  both.perfect_info = true;
  EXPECT_NE(both.validate().find("track_truth"), std::string::npos);
  EXPECT_EQ(parseTrackTruth("state"), TrackTruth::kState);
  EXPECT_THROW(parseTrackTruth("velocity"), std::invalid_argument);
}

}  // namespace
}  // namespace dqn_dovs
