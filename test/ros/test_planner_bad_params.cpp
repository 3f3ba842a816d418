// Starts the real planner_node executable with bad parameters (against the rostest master) and checks that
// it fails fast at start (exit code 1, well before the harness's timeout) with a FATAL message naming the
// culprit: a model path that does not exist, is a directory or is unset, a corrupt model file, parameters out
// of range. The other nodes (dovs_node, obstacle_tracker_node, simulator_node) refuse out-of-range parameters
// the same way. A run with good parameters must keep running (so the harness can tell a refusal from a node
// that never starts).
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <string>

#include "source_paths.h"

namespace {

struct NodeRun {
  int exit_code = -1;  // the node's; 124: still running when `timeout` stopped it
  std::string output;  // stdout and stderr
  double seconds = 0.0;
};

/// The nodes sit next to this test executable (catkin's devel lib folder).
std::string nodeExecutable(const std::string& name) {
  std::array<char, 4096> buf{};
  const ssize_t n = readlink("/proc/self/exe", buf.data(), buf.size() - 1);
  std::string self = n > 0 ? std::string(buf.data(), static_cast<size_t>(n)) : std::string();
  return self.substr(0, self.rfind('/') + 1) + name;
}
std::string plannerExecutable() { return nodeExecutable("planner_node"); }

std::string modelPath() { return std::string(DQN_DOVS_SOURCE_DIR) + "/models/dqn_dovs.dqnw"; }

NodeRun runNode(const std::string& exe, const std::string& name, const std::string& args, double run_s = 15.0) {
  const std::string cmd = "timeout " + std::to_string(run_s) + " " + nodeExecutable(exe) + " __name:=" + name + " " +
                          args + " 2>&1; echo \"EXIT=$?\"";
  NodeRun r;
  const auto t0 = std::chrono::steady_clock::now();
  FILE* pipe = popen(cmd.c_str(), "r");
  if (!pipe) return r;
  std::array<char, 1024> line{};
  while (fgets(line.data(), static_cast<int>(line.size()), pipe)) r.output += line.data();
  pclose(pipe);
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const size_t at = r.output.rfind("EXIT=");
  if (at != std::string::npos) r.exit_code = std::stoi(r.output.substr(at + 5));
  return r;
}

NodeRun runPlanner(const std::string& name, const std::string& args, double run_s = 15.0) {
  return runNode("planner_node", name, args, run_s);
}

/// A refusal to start: exit code 1 (a node that hung would be ended by the harness's timeout, exit code 124), with a
/// FATAL line that names `culprit`.
void expectFatal(const NodeRun& r, const std::string& culprit, const std::string& what) {
  EXPECT_EQ(r.exit_code, 1) << what << " (124: it did not stop by itself):\n" << r.output;
  const size_t fatal = r.output.find("FATAL");
  ASSERT_NE(fatal, std::string::npos) << what << ": no FATAL message:\n" << r.output;
  const size_t line_end = r.output.find('\n', fatal);
  const std::string line = r.output.substr(fatal, line_end == std::string::npos ? std::string::npos : line_end - fatal);
  EXPECT_NE(line.find(culprit), std::string::npos)
      << what << ": the FATAL line does not name '" << culprit << "': " << line;
}

TEST(PlannerBadParams, GoodParametersKeepTheNodeRunning) {
  ASSERT_EQ(access(plannerExecutable().c_str(), X_OK), 0) << "no executable " << plannerExecutable();
  const NodeRun r = runPlanner("planner_good", "_model_path:=" + modelPath(), 3.0);
  EXPECT_EQ(r.exit_code, 124) << "planner_node with good parameters did not keep running:\n" << r.output;
}

TEST(PlannerBadParams, MissingModelFileIsNamed) {
  const std::string missing = "/nonexistent_dir/no_such_model.dqnw";
  const NodeRun r = runPlanner("planner_missing_model", "_model_path:=" + missing);
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.exit_code, 124) << "the node must refuse to start, not hang";
  EXPECT_NE(r.output.find(missing), std::string::npos) << "the message does not name the path:\n" << r.output;
}

TEST(PlannerBadParams, UnsetModelPathIsNamed) {
  const NodeRun r = runPlanner("planner_no_model", "");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.exit_code, 124);
  EXPECT_NE(r.output.find("model_path"), std::string::npos) << r.output;
}

TEST(PlannerBadParams, CorruptModelFileIsNamed) {
  char path[] = "/tmp/dqn_dovs_corrupt_XXXXXX";
  const int fd = mkstemp(path);
  ASSERT_GE(fd, 0);
  const std::string garbage = "this is not a weight file";
  ASSERT_EQ(write(fd, garbage.data(), garbage.size()), static_cast<ssize_t>(garbage.size()));
  close(fd);
  const NodeRun r = runPlanner("planner_corrupt_model", std::string("_model_path:=") + path);
  unlink(path);
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.exit_code, 124);
  EXPECT_NE(r.output.find(path), std::string::npos) << r.output;
}

TEST(PlannerBadParams, OutOfRangeParametersAreNamed) {
  const std::array<std::pair<const char*, const char*>, 4> cases = {{
      {"max_input_age", "_max_input_age:=10.0"},
      {"ramp_rate", "_ramp_rate:=5.0"},
      {"goal_tolerance", "_goal_tolerance:=-1.0"},
      {"v_max", "_robot/v_max:=-0.5"},
  }};
  int k = 0;
  for (const auto& [name, arg] : cases) {
    const NodeRun r = runPlanner("planner_bad_param_" + std::to_string(k++), "_model_path:=" + modelPath() + " " + arg);
    EXPECT_NE(r.exit_code, 0) << arg;
    EXPECT_NE(r.exit_code, 124) << arg;
    EXPECT_NE(r.output.find(name), std::string::npos) << "the message does not name '" << name << "':\n" << r.output;
  }
}

// The same refusals, held to the stricter form: exit code 1, fast, the FATAL line itself naming the culprit.
TEST(PlannerBadParams, WrongModelPathAtStartIsFatalAndNamed) {
  const std::string missing = "/nonexistent_dir/no_such_model.dqnw";
  expectFatal(runPlanner("planner_fatal_missing", "_model_path:=" + missing), missing, "missing model");
  expectFatal(runPlanner("planner_fatal_dir", "_model_path:=/tmp"), "/tmp", "model path is a directory");
  expectFatal(runPlanner("planner_fatal_unset", ""), "model_path", "unset model path");
}

TEST(PlannerBadParams, OutOfRangeParametersAreFatalAndNamed) {
  const std::array<std::pair<const char*, const char*>, 11> cases = {{
      {"max_input_age", "_max_input_age:=10.0"},
      {"ramp_rate", "_ramp_rate:=5.0"},
      {"goal_speed", "_goal_speed:=3.0"},
      {"yaw_tolerance", "_yaw_tolerance:=0.0"},
      {"progress_timeout", "_progress_timeout:=-1.0"},
      {"max_recovery_rounds", "_max_recovery_rounds:=-2"},
      {"backoff_speed", "_backoff_speed:=2.0"},
      {"tf_timeout", "_tf_timeout:=-0.1"},
      {"scan_max_nan_fraction", "_scan_max_nan_fraction:=1.5"},
      {"deadline_fraction", "_deadline_fraction:=0.0"},
      {"a_v", "_robot/a_v:=0.0"},
  }};
  int k = 0;
  for (const auto& [name, arg] : cases) {
    expectFatal(runPlanner("planner_fatal_param_" + std::to_string(k++), "_model_path:=" + modelPath() + " " + arg),
                name, arg);
  }
}

// A model whose state layout is not the one the DOVS parameters give is refused at start: the shipped one-channel
// network with dovs/grid_channels = 3 (docs/dovs.md "Grid channels"), and a channel count that does not exist.
TEST(PlannerBadParams, AModelOfOtherGridChannelsIsFatalAndNamed) {
  expectFatal(runPlanner("planner_fatal_channels", "_model_path:=" + modelPath() + " _dovs/grid_channels:=3"),
              "'state layout: grid channels' is 1 in the file but 3 here", "grid channels of another model");
  expectFatal(runPlanner("planner_fatal_channels_2", "_model_path:=" + modelPath() + " _dovs/grid_channels:=2"),
              "training and evaluation only", "the history channel on the robot");
  expectFatal(runPlanner("planner_fatal_channels_4", "_model_path:=" + modelPath() + " _dovs/grid_channels:=4"),
              "grid_channels", "grid channels out of range");
  // The previous action in the state (docs/dovs.md "The previous action") exists in training and evaluation only.
  expectFatal(runPlanner("planner_fatal_previous_action", "_model_path:=" + modelPath() + " _dovs/previous_action:=1"),
              "training and evaluation only", "the previous action on the robot");
}

// A robot_description on the parameter server: a footprint larger than robot/radius is a refusal (the planner
// would plan for a smaller robot than the real one); a smaller one (the Kobuki's 0.176 m collision cylinder
// under the configured 0.2 m) is a warning that says what to change, and the node runs.
std::string describedRobot(double radius) {
  return "<robot name=\"r\"><link name=\"base_footprint\"><collision><geometry><cylinder radius=\"" +
         std::to_string(radius) +
         "\" length=\"0.3\"/></geometry></collision></link><link name=\"laser\"/>"
         "<joint name=\"j\" type=\"fixed\"><parent link=\"base_footprint\"/><child link=\"laser\"/>"
         "<origin xyz=\"0.1 0 0.4\"/></joint></robot>";
}

TEST(PlannerBadParams, RobotDescriptionLargerThanTheRadiusIsRefusedSmallerIsAWarning) {
  ros::param::set("/robot_description", describedRobot(0.25));
  expectFatal(runPlanner("planner_big_robot", "_model_path:=" + modelPath()), "robot/radius",
              "description larger than robot/radius");
  ros::param::set("/robot_description", describedRobot(0.176));
  const NodeRun r = runPlanner("planner_small_robot", "_model_path:=" + modelPath(), 4.0);
  ros::param::del("/robot_description");
  EXPECT_EQ(r.exit_code, 124) << "a smaller description must not stop the planner:\n" << r.output;
  EXPECT_NE(r.output.find("set robot/radius to 0.176"), std::string::npos) << r.output;
}

TEST(PlannerBadParams, OtherNodesRefuseOutOfRangeParameters) {
  struct Case {
    const char *exe, *culprit;
    std::string args;
  };
  const std::array<Case, 14> cases = {{
      {"dovs_node", "max_input_age", "_max_input_age:=0.0"},
      {"dovs_node", "v_max", "_robot/v_max:=-1.0"},
      // The shield's parameters, read by name (shieldParameterNames): the setter's and the validation's refusals.
      {"dovs_node", "action_shield/escape_window_samples", "_action_shield/escape_window_samples:=2.5"},
      {"dovs_node", "margin", "_static_safety/margin:=-1.0"},
      {"dovs_node", "action_shield/passive_escape", "_action_shield/passive_escape:=maybe"},
      // A people predictor that cannot be read: the parameter and the file are named.
      {"dovs_node", "people_predictor: people predictor '/nonexistent/people.dqnp': cannot be opened",
       "_people_predictor:=/nonexistent/people.dqnp"},
      {"dovs_node", "not a people predictor file",
       "_people_predictor:=" + std::string(DQN_DOVS_SOURCE_DIR) + "/models/dqn_dovs.dqnw"},
      {"obstacle_tracker_node", "tf_timeout", "_tf_timeout:=9.0"},
      // Every tracker parameter is read by its config/tracker.yaml name; a misspelt one is named, not ignored.
      {"obstacle_tracker_node", "reacquire_speed", "_tracker/reacquire_speed:=-1.0"},
      {"obstacle_tracker_node", "tracker/confirm_hitz", "_tracker/confirm_hitz:=2"},
      {"simulator_node", "period", "_period:=0.0"},
      {"simulator_node", "realtime_factor", "_realtime_factor:=-1.0"},
      {"simulator_node", "odometry/level", "_odometry/level:=medium"},
      {"simulator_node", "map_frame", "_map_frame:=odom"},
  }};
  int k = 0;
  for (const Case& c : cases) {
    ASSERT_EQ(access(nodeExecutable(c.exe).c_str(), X_OK), 0) << "no executable " << nodeExecutable(c.exe);
    expectFatal(runNode(c.exe, std::string("bad_param_node_") + std::to_string(k++), c.args), c.culprit,
                std::string(c.exe) + " " + c.args);
  }
}

TEST(PlannerBadParams, MisspeltKeysAreRefusedByEveryNodeWithTheNearestName) {
  // A key no reader of the node names is a typo: without the refusal it would be ignored and its default used.
  struct Case {
    const char *exe, *culprit;
    std::string args;
  };
  const std::string model = "_model_path:=" + modelPath() + " ";
  const std::array<Case, 7> cases = {{
      {"planner_node", "goal_tolerence' (did you mean '/typo_node_0/goal_tolerance'?)", model + "_goal_tolerence:=0.2"},
      {"planner_node", "route/lookahed' (did you mean '/typo_node_1/route/lookahead'?)",
       model + "_route/lookahed:=2.0"},
      {"planner_node", "dovs/safty_factor' (did you mean '/typo_node_2/dovs/safety_factor'?)",
       model + "_dovs/safty_factor:=1.2"},
      {"dovs_node", "map_rang' (did you mean '/typo_node_3/map_range'?)", "_map_rang:=3.0"},
      {"dovs_node", "robot/vmax' (did you mean '/typo_node_4/robot/v_max'?)", "_robot/vmax:=0.5"},
      {"obstacle_tracker_node", "publish_marker' (did you mean '/typo_node_5/publish_markers'?)",
       "_publish_marker:=false"},
      {"simulator_node", "lidar/profil' (did you mean '/typo_node_6/lidar/profile'?)", "_lidar/profil:=hokuyo"},
  }};
  int k = 0;
  for (const Case& c : cases) {
    expectFatal(runNode(c.exe, "typo_node_" + std::to_string(k++), c.args), c.culprit,
                std::string(c.exe) + " " + c.args);
  }
}

TEST(PlannerBadParams, AModelTrainedWithOtherStateParametersIsFatalAndNamed) {
  // The shipped model names the DOVS and robot parameters of its training (its metadata's `state parameters:`): a
  // robot whose dovs/* or robot/* differ builds states the model never saw.
  const std::string model = "_model_path:=" + modelPath() + " ";
  expectFatal(runPlanner("planner_other_safety", model + "_dovs/safety_factor:=1.5"),
              "dovs/safety_factor is 1.5 here, the model was trained with 1.1", "dovs/safety_factor 1.5");
  expectFatal(runPlanner("planner_other_dt", model + "_robot/a_w:=1.5"), "robot/a_w is 1.5 here", "robot/a_w 1.5");
}

TEST(PlannerBadParams, APlannerTheRobotCannotRunIsFatalAndNamed) {
  // The oracle reads the world's truth, the holonomic ORCA drives another robot: neither node takes them.
  expectFatal(runPlanner("planner_oracle", "_model_path:=" + modelPath() + " _planner:=oracle"),
              "planner 'oracle' cannot run on the robot", "planner_node planner oracle");
  expectFatal(runNode("dovs_node", "dovs_holonomic", "_planner:=orca_holonomic"),
              "planner 'orca_holonomic' cannot run on the robot", "dovs_node planner orca_holonomic");
  // Another planner needs no model: planner_node starts without one and keeps running.
  const NodeRun r = runPlanner("planner_s_dovs", "_planner:=s_dovs", 3.0);
  EXPECT_EQ(r.exit_code, 124) << "planner_node with planner s_dovs did not keep running:\n" << r.output;
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_planner_bad_params");
  return RUN_ALL_TESTS();
}
