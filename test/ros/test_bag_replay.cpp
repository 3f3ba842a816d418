// Bag regression: test/data/replay.bag (a simulated run recorded by scripts/record_test_bag.sh) replayed
// offline through the tracker, the DOVS and the planner's network with the nodes' own steps and the shipped
// parameters (loaded by the .test into this node's namespace, read with the nodes' loaders). The same bag
// must give the same tracks and decisions on every run, equal to the stored expectations within tolerances.
// With ~regenerate true (scripts/regenerate_bag_expectations.sh) the expectations are rewritten instead.
#include <gtest/gtest.h>
#include <ros/ros.h>

#include <algorithm>
#include <string>

#include "bag_replay.h"
#include "dovs_node.h"
#include "obstacle_tracker_node.h"
#include "ros_params.h"
#include "source_paths.h"

namespace {

using dqn_dovs::ReplayResult;

std::string dataPath(const std::string& name) { return std::string(DQN_DOVS_SOURCE_DIR) + "/test/data/" + name; }

dqn_dovs::ReplayConfig loadConfig() {
  ros::NodeHandle pnh("~");
  dqn_dovs::ReplayConfig c;
  const ros::NodeHandle tracker_ns(pnh, "obstacle_tracker"), dovs_ns(pnh, "dovs"), planner_ns(pnh, "planner");
  c.tracker = dqn_dovs::loadTrackerConfig(tracker_ns);
  c.dovs = dqn_dovs::loadDovsConfig(dovs_ns);
  c.shield = dqn_dovs::loadActionShieldConfig(dovs_ns);
  c.limits = dqn_dovs::loadRobotLimits(dovs_ns);
  c.fixed_frame = dqn_dovs::param<std::string>(dovs_ns, "fixed_frame", "odom");
  c.base_frame = dqn_dovs::param<std::string>(dovs_ns, "base_frame", "base_footprint");
  c.max_input_age_s = dqn_dovs::param<double>(dovs_ns, "max_input_age", 0.5);
  c.model_path = dqn_dovs::param<std::string>(planner_ns, "model_path", "");
  c.people_predictor = dqn_dovs::param<std::string>(dovs_ns, "people_predictor", "");
  // The goal the velocity space was built for: planner/local_goal where the planner followed a route.
  c.goal_topic = pnh.param<std::string>("goal_topic", c.goal_topic);
  c.tracker_map = dqn_dovs::param<bool>(tracker_ns, "use_map", false);
  c.tracker_map_unknown_is_occupied = dqn_dovs::param<bool>(tracker_ns, "map_unknown_is_occupied", false);
  c.dovs_map = dqn_dovs::param<bool>(dovs_ns, "use_map", false);
  c.dovs_map_range_m = dqn_dovs::param<double>(dovs_ns, "map_range", 4.0);
  c.dovs_map_unknown_is_occupied = dqn_dovs::param<bool>(dovs_ns, "map_unknown_is_occupied", false);
  return c;
}

TEST(BagReplay, SameDecisionsEveryRunAndAsStored) {
  ros::NodeHandle pnh("~");
  const std::string bag = pnh.param<std::string>("bag", dataPath("replay.bag"));
  const std::string tracks_csv = pnh.param<std::string>("expected_tracks", dataPath("replay_expected_tracks.csv"));
  const std::string decisions_csv =
      pnh.param<std::string>("expected_decisions", dataPath("replay_expected_decisions.csv"));
  const dqn_dovs::ReplayConfig config = loadConfig();
  ASSERT_FALSE(config.model_path.empty()) << "~planner/model_path is not set";

  const ReplayResult first = dqn_dovs::replayBag(bag, config);
  // The bag is a real run: tracks, decisions, and a robot that moves.
  ASSERT_GT(first.scans.size(), 100u) << "too few usable scans in " << bag;
  EXPECT_EQ(first.scans_dropped, 0);
  ASSERT_GT(first.decisions.size(), 100u) << "too few decisions in " << bag;
  EXPECT_GT(first.tracks.size(), 50u) << "the tracker confirmed almost nothing";
  const double top_speed =
      std::max_element(first.decisions.begin(), first.decisions.end(), [](const auto& a, const auto& b) {
        return a.v < b.v;
      })->v;
  EXPECT_GT(top_speed, 0.2) << "the recorded robot hardly moved";
  if (config.tracker_map) {
    EXPECT_GT(first.scans_with_map, static_cast<int>(first.scans.size() * 9 / 10))
        << "the tracker had the bag's map for only " << first.scans_with_map << " of " << first.scans.size()
        << " scans";
  }
  if (config.dovs_map) {
    EXPECT_GT(first.steps_with_map_walls, static_cast<int>(first.decisions.size() * 9 / 10))
        << "the velocity space had the map's walls for only " << first.steps_with_map_walls << " steps";
  }

  if (pnh.param("regenerate", false)) {
    dqn_dovs::writeReplayCsv(first, tracks_csv, decisions_csv);
    ROS_INFO("bag replay: wrote %zu scans, %zu track rows, %zu decisions to %s and %s", first.scans.size(),
             first.tracks.size(), first.decisions.size(), tracks_csv.c_str(), decisions_csv.c_str());
    return;
  }

  // Determinism: a second replay is identical, to the last bit.
  const ReplayResult second = dqn_dovs::replayBag(bag, config);
  const std::vector<std::string> run_diffs =
      dqn_dovs::compareReplay(first, second, dqn_dovs::ReplayTolerance{0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0, 0.0});
  EXPECT_TRUE(run_diffs.empty()) << "two replays of the same bag differ, first: " << run_diffs.front();

  const ReplayResult expected = dqn_dovs::readReplayCsv(tracks_csv, decisions_csv);
  const std::vector<std::string> diffs = dqn_dovs::compareReplay(expected, first);
  std::string listing;
  for (size_t i = 0; i < std::min<size_t>(diffs.size(), 20); ++i) listing += "\n  " + diffs[i];
  EXPECT_TRUE(diffs.empty()) << diffs.size() << " differences from the stored expectations (first 20):" << listing
                             << "\nIf the change is intended, run scripts/regenerate_bag_expectations.sh";
}

// Corrupt input fails with a message naming the file, never a crash.
TEST(BagReplay, MissingBagIsNamed) {
  const dqn_dovs::ReplayConfig config = loadConfig();
  try {
    dqn_dovs::replayBag("/nonexistent_dir/no.bag", config);
    FAIL() << "replaying a missing bag must throw";
  } catch (const dqn_dovs::ReplayError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent_dir/no.bag"), std::string::npos) << e.what();
  }
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_bag_replay");
  return RUN_ALL_TESTS();
}
