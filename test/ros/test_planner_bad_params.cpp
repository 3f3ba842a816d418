// Starts the real planner_node executable with bad parameters (against the rostest master) and checks that
// it exits non-zero at start with a message naming the culprit: a model path that does not exist, no model,
// a corrupt model file, parameters out of range. A run with good parameters must keep running (so the
// harness can tell a refusal from a node that never starts).
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <fstream>
#include <string>

namespace {

struct NodeRun {
  int exit_code = -1;  // the node's; 124: still running when `timeout` stopped it
  std::string output;  // stdout and stderr
};

/// planner_node sits next to this test executable (catkin's devel lib folder).
std::string plannerExecutable() {
  std::array<char, 4096> buf{};
  const ssize_t n = readlink("/proc/self/exe", buf.data(), buf.size() - 1);
  std::string self = n > 0 ? std::string(buf.data(), static_cast<size_t>(n)) : std::string();
  return self.substr(0, self.rfind('/') + 1) + "planner_node";
}

std::string modelPath() { return std::string(DQN_DOVS_SOURCE_DIR) + "/models/dqn_dovs.dqnw"; }

NodeRun runPlanner(const std::string& name, const std::string& args, double run_s = 15.0) {
  const std::string cmd = "timeout " + std::to_string(run_s) + " " + plannerExecutable() + " __name:=" + name + " " +
                          args + " 2>&1; echo \"EXIT=$?\"";
  NodeRun r;
  FILE* pipe = popen(cmd.c_str(), "r");
  if (!pipe) return r;
  std::array<char, 1024> line{};
  while (fgets(line.data(), static_cast<int>(line.size()), pipe)) r.output += line.data();
  pclose(pipe);
  const size_t at = r.output.rfind("EXIT=");
  if (at != std::string::npos) r.exit_code = std::stoi(r.output.substr(at + 5));
  return r;
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

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_planner_bad_params");
  return RUN_ALL_TESTS();
}
