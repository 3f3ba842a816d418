// Writes small valid seed inputs for the fuzz targets: fuzz_make_seeds OUT_DIR SCENARIO.dovs...
//   OUT_DIR/weight_file/  tiny networks in the .dqnw format (mode byte + file image; see targets.h)
//   OUT_DIR/scan_tracker/ simulated scans of each scenario, encoded for scanTrackerOne
//   OUT_DIR/scenario/     the scenario files themselves
//   OUT_DIR/dovs_msg/     serialised dqn_dovs/Dovs messages built by dovs_node's step on each scenario
#include <ros/serialization.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <string>
#include <vector>

#include "dqn_dovs/Dovs.h"
#include "dqn_dovs/dovs/actions.h"
#include "dqn_dovs/dovs/dovs.h"
#include "dqn_dovs/dovs/state.h"
#include "dqn_dovs/policy/action_shield.h"
#include "dqn_dovs/policy/qnetwork.h"
#include "dqn_dovs/policy/weight_file.h"
#include "dqn_dovs/sim/scenario.h"
#include "dqn_dovs/sim/world.h"

namespace fs = std::filesystem;
using namespace dqn_dovs;

namespace {

void writeFile(const fs::path& path, const std::vector<std::uint8_t>& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  if (!out) throw std::runtime_error("cannot write seed '" + path.string() + "'");
}

// Inverse of fuzz::ByteStream::number / numberF for values inside [lo, hi] (the "u16 in range" mode) and inf.
struct Encoder {
  std::vector<std::uint8_t> bytes;
  void u8(std::uint8_t v) { bytes.push_back(v); }
  void number(double v, double lo, double hi) {
    if (std::isinf(v)) {
      u8(v > 0 ? 1 : 17);
      return;
    }
    const double t = std::min(1.0, std::max(0.0, (v - lo) / (hi - lo)));
    const auto q = static_cast<std::uint16_t>(std::lround(t * 65535.0));
    u8(6);
    u8(static_cast<std::uint8_t>(q & 0xFF));
    u8(static_cast<std::uint8_t>(q >> 8));
  }
};

std::vector<std::uint8_t> encodeScans(const sim::Scenario& scenario, int scans) {
  sim::World world(scenario, sim::WorldConfig{}, 7);
  Encoder e;
  const Pose2 p0 = world.laserPose();
  e.number(p0.x, -5.0, 5.0);
  e.number(p0.y, -5.0, 5.0);
  e.number(p0.theta, -4.0, 4.0);
  e.number(0.0, -100.0, 100.0);
  e.u8(static_cast<std::uint8_t>(scans - 1));
  for (int k = 0; k < scans; ++k) {
    world.step(Twist2{0.2, 0.1}, 0.1);
    const LaserScan2 scan = world.scan();
    e.u8(2 | 4);  // stamp delta, the simulated LIDAR's geometry, absolute pose
    e.number(0.1, -0.05, 0.3);
    // Greedy piecewise-linear runs of at most 64 beams (the reader's run format).
    const auto& r = scan.ranges;
    for (std::size_t i = 0; i < r.size();) {
      std::size_t run = 1;
      double slope = 0.0;
      if (std::isfinite(r[i]) && i + 1 < r.size() && std::isfinite(r[i + 1])) {
        slope = std::max(-0.1, std::min(0.1, static_cast<double>(r[i + 1] - r[i])));
        while (run < 64 && i + run < r.size() && std::isfinite(r[i + run]) &&
               std::abs(r[i] + slope * static_cast<double>(run) - r[i + run]) < 0.004)
          ++run;
      } else if (!std::isfinite(r[i])) {
        while (run < 64 && i + run < r.size() && !std::isfinite(r[i + run])) ++run;
      }
      e.u8(static_cast<std::uint8_t>(run - 1));
      e.number(r[i], -1.0, 12.0);
      e.number(slope, -0.1, 0.1);
      i += run;
    }
    const Pose2 p = world.laserPose();
    e.number(p.x, -50.0, 50.0);
    e.number(p.y, -50.0, 50.0);
    e.number(p.theta, -7.0, 7.0);
  }
  return e.bytes;
}

// A Dovs message as dovs_node fills it (same fields and units, built from the core directly so that the seeds
// do not depend on the node code under test).
std::vector<std::uint8_t> dovsMessage(const sim::Scenario& scenario, bool with_goal) {
  sim::World world(scenario, sim::WorldConfig{}, 3);
  world.step(Twist2{0.3, 0.0}, 0.2);
  const RobotLimits limits;
  const DovsConfig config;
  DovsBuilder builder(limits, config);
  Observation obs;
  obs.robot_pose = world.robotPose();
  obs.robot_twist = world.robotTwist();
  obs.goal = with_goal ? world.goal() : obs.robot_pose.position();
  obs.obstacles = world.groundTruthObstacles();
  obs.segments = world.walls();
  const VelocitySpace dovs = builder.build(obs);
  const ActionSet actions = computeActions(obs.robot_twist, obs.robot_pose.toLocal(obs.goal), limits);
  const StateNormalization norm = stateNormalization(limits, config);
  Dovs m;
  m.header.frame_id = "base_footprint";
  m.has_goal = with_goal;
  m.v_max = limits.v_max;
  m.w_max = limits.w_max;
  m.dv = limits.a_v * limits.dt;
  m.dw = limits.a_w * limits.dt;
  m.v = obs.robot_twist.v;
  m.w = obs.robot_twist.w;
  m.goal_line_kind = with_goal ? Dovs::GOAL_ARC : Dovs::GOAL_NONE;
  m.goal_curvature = actions.goal_line.curvature_1pm;
  m.goal_turn_sign = actions.goal_line.turn_sign;
  for (std::size_t i = 0; i < m.action_v.size(); ++i) {
    m.action_v[i] = actions.velocities[i].v;
    m.action_w[i] = actions.velocities[i].w;
    m.action_valid[i] = actions.valid[i] && (with_goal || i < 5);
  }
  // Boxed in, the message carries the shield's escape (as dovs_node sends it).
  const ShieldedMask shielded = shieldActions(actions, dovs, obs, ActionShieldConfig{});
  m.escape = shielded.has_escape;
  m.escape_v = shielded.has_escape ? shielded.escape.v : 0.0;
  m.escape_w = shielded.has_escape ? shielded.escape.w : 0.0;
  m.escape_tier = static_cast<std::uint8_t>(shielded.has_escape ? shielded.escape_tier : EscapeTier::kFree);
  // The static geometry near the robot, for the planner's last check (the scenario's room walls).
  const StaticScene statics(obs, limits, StaticSafetyConfig{});
  m.static_frame = "odom";
  m.static_segments = statics.flatSegments(obs.robot_pose);
  m.static_discs = statics.flatDiscs(obs.robot_pose);
  for (int i = 0; i < dovs.numTrajectories(); ++i) {
    const Trajectory& t = dovs.trajectory(i);
    m.trajectory_curvature.push_back(static_cast<float>(t.curvature_1pm));
    m.trajectory_pure_rotation.push_back(t.pure_rotation);
    m.trajectory_v_top.push_back(static_cast<float>(t.v_top_mps));
    m.trajectory_w_top.push_back(static_cast<float>(t.w_top_rps));
    m.interval_begin.push_back(static_cast<std::uint32_t>(m.interval_lo.size()));
    for (const SpeedInterval& s : dovs.unsafeIntervals(i)) {
      m.interval_lo.push_back(static_cast<float>(s.lo_mps));
      m.interval_hi.push_back(static_cast<float>(s.hi_mps));
    }
  }
  m.interval_begin.push_back(static_cast<std::uint32_t>(m.interval_lo.size()));
  m.grid_rows = m.grid_cols = static_cast<std::uint16_t>(dovs.gridSize());
  const StateVector state = buildState(dovs, obs, norm);
  m.state.assign(state.data(), state.data() + state.size());
  for (const auto& field : norm.fields()) m.state_normalization.push_back(field.second);
  std::vector<std::uint8_t> bytes(ros::serialization::serializationLength(m));
  ros::serialization::OStream stream(bytes.data(), static_cast<std::uint32_t>(bytes.size()));
  ros::serialization::serialize(stream, m);
  return bytes;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::cerr << "usage: fuzz_make_seeds OUT_DIR SCENARIO.dovs...\n";
    return 2;
  }
  try {
    const fs::path out = argv[1];
    for (const char* d : {"weight_file", "scan_tracker", "scenario", "dovs_msg"}) fs::create_directories(out / d);

    DuelingArchitecture tiny;
    tiny.conv_channels = {2, 3};
    tiny.conv_strides = {2, 2};
    tiny.feature_hidden = 4;
    tiny.trunk_hidden = {6};
    for (std::uint64_t seed : {1, 2}) {
      WeightFileContents c = makeRandomWeights(tiny, seed, {{"v_max", 0.7f}, {"w_max", 3.14159f}}, "fuzz seed");
      std::vector<std::uint8_t> bytes = serializeWeightFile(c);
      bytes.insert(bytes.begin(), static_cast<std::uint8_t>(seed == 1 ? 1 : 0));
      writeFile(out / "weight_file" / ("tiny" + std::to_string(seed) + ".bin"), bytes);
    }
    {  // format version 2: a grid of 3 channels (the dynamic window and the goal line)
      DuelingArchitecture wide = tiny;
      wide.grid_channels = 3;
      std::vector<std::uint8_t> bytes =
          serializeWeightFile(makeRandomWeights(wide, 3, {{"v_max", 0.7f}, {"w_max", 3.14159f}}, "fuzz seed"));
      bytes.insert(bytes.begin(), std::uint8_t{1});
      writeFile(out / "weight_file" / "tiny3_channels.bin", bytes);
    }
    for (int i = 2; i < argc; ++i) {
      const std::string path = argv[i];
      const sim::Scenario s = sim::loadDovsScenario(path);
      const std::string stem = std::to_string(i - 1);
      std::ifstream in(path, std::ios::binary);
      writeFile(out / "scenario" / (stem + ".dovs"),
                std::vector<std::uint8_t>((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>()));
      writeFile(out / "scan_tracker" / (stem + ".bin"), encodeScans(s, 6));
      writeFile(out / "dovs_msg" / (stem + "_goal.bin"), dovsMessage(s, true));
      writeFile(out / "dovs_msg" / (stem + "_nogoal.bin"), dovsMessage(s, false));
    }
  } catch (const std::exception& e) {
    std::cerr << "fuzz_make_seeds: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
