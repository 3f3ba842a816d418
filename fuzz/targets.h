// Bodies of the ROS-free fuzz targets: each takes one fuzz input, runs it through a core entry point that
// reads untrusted data, and checks the contract of that entry point. A documented rejection (the loader's
// exception type, a rejected scan) is fine; anything else (a crash, a sanitizer report, another exception
// type, a result that breaks an invariant) is a failure. Used by fuzz/fuzz_<target>.cpp (libFuzzer) and
// by test/policy/test_fuzz_regressions.cpp (replays fuzz/regressions/<target>/ in the ordinary gtest build).
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <set>
#include <string>
#include <vector>

#include "dqn_dovs/perception/tracker.h"
#include "dqn_dovs/policy/qnetwork.h"
#include "dqn_dovs/policy/weight_file.h"
#include "dqn_dovs/sim/scenario.h"
#include "dqn_dovs/sim/world.h"
#include "fuzz_common.h"

namespace dqn_dovs::fuzz {

// ----------------------------------------------------------------------------------------------------------
// (a) weight file: byte 0 is a mode byte, the rest is the file image. Mode bit 0 set: the last 4 bytes are
// replaced by the correct CRC-32 first, so that mutations reach the layer checks of QNetwork::fromContents
// instead of stopping at the checksum. Bytes after a fixed-size prefix drive a few evaluations.
// ----------------------------------------------------------------------------------------------------------
inline const char* kWeightSource = "<fuzz input>";

inline void checkWeightFileError(const WeightFileError& e) {
  require(e.path() == kWeightSource, "WeightFileError names the source, got '" + e.path() + "'");
  require(!e.field().empty(), "WeightFileError names a field");
  const std::string what = e.what();
  require(what.find("weight file '<fuzz input>': field '" + e.field() + "': ") == 0,
          "WeightFileError message names file and field: " + what);
  require(what.size() > 40, "WeightFileError gives a reason: " + what);
}

inline void checkNetwork(const QNetwork& net, ByteStream& in) {
  require(!net.normalization().empty(), "a loaded network has normalisation constants");
  for (const auto& [name, value] : net.normalization()) {
    require(!name.empty() && std::isfinite(value), "normalisation entry '" + name + "' is named and finite");
  }
  require(net.source() == kWeightSource, "network source is the given name");
  require(!net.describe().empty(), "describe() says something");
  for (int k = 0; k < 3; ++k) {
    require(net.stateSize() == net.gridChannels() * 400 + net.featureCount(),
            "stateSize() is the grid channels' cells + the features");
    Eigen::VectorXf state(net.stateSize());
    bool finite_state = true;
    for (int i = 0; i < net.stateSize(); ++i) {
      state[i] = k == 0 ? 0.0f : (k == 1 ? (i % 3 == 0 ? -1.0f : 1.0f) : in.numberF(-2.0, 2.0));
      finite_state = finite_state && std::isfinite(state[i]);
    }
    QNetwork::ActionMask mask;
    const std::uint8_t bits = k == 0 ? 0xFF : in.u8();
    for (int a = 0; a < QNetwork::kActionCount; ++a) mask[a] = (bits >> a) & 1;
    try {
      const QNetwork::QValues q = net.qValues(state);
      require(finite_state, "qValues accepted a state with NaN/inf");
      for (float v : q) require(std::isfinite(v), "qValues returned a non-finite value without throwing");
      const int a = net.selectAction(state, mask);
      if (bits == 0) {
        require(a == -1, "selectAction with every action masked returns -1");
      } else {
        require(a >= 0 && a < QNetwork::kActionCount && mask[a], "selectAction returns a valid, unmasked action");
        for (int b = 0; b < QNetwork::kActionCount; ++b)
          require(!mask[b] || q[b] <= q[a], "selectAction returns the best unmasked action");
      }
    } catch (const QNetworkInputError& e) {
      // Documented: a non-finite state, or Q-values that came out non-finite (huge finite weights).
      require(std::string(e.what()).find("Q-network") == 0,
              std::string("QNetworkInputError names the network: ") + e.what());
    }
  }
}

inline void weightFileOne(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return;
  const std::uint8_t mode = data[0];
  std::vector<std::uint8_t> bytes(data + 1, data + size);
  if ((mode & 1) && bytes.size() >= 12) {
    const std::uint32_t crc = crc32(bytes.data(), bytes.size() - 4);
    for (int i = 0; i < 4; ++i) bytes[bytes.size() - 4 + i] = static_cast<std::uint8_t>(crc >> (8 * i));
  }
  WeightFileContents contents;
  try {
    contents = parseWeightFile(bytes, kWeightSource);
  } catch (const WeightFileError& e) {
    checkWeightFileError(e);
    // The network loader must reject it the same way.
    try {
      (void)QNetwork::fromBytes(bytes, kWeightSource);
      require(false, "QNetwork::fromBytes accepted bytes that parseWeightFile rejects");
    } catch (const WeightFileError& e2) {
      require(std::string(e.what()) == e2.what(), "fromBytes and parseWeightFile give the same error");
    }
    return;
  }
  // Parsed: the container is canonical, so writing it back gives the same bytes.
  require(serializeWeightFile(contents, kWeightSource) == bytes, "parse -> serialize reproduces the file");
  for (const LayerRecord& l : contents.layers) {
    require(l.weight.size() == l.weightCount() && l.bias.size() == l.biasCount(), "tensor sizes match shapes");
  }
  ByteStream in(data, size);
  try {
    const QNetwork net = QNetwork::fromBytes(bytes, kWeightSource);
    checkNetwork(net, in);
  } catch (const WeightFileError& e) {
    checkWeightFileError(e);
  }
}

// ----------------------------------------------------------------------------------------------------------
// (b) scans into the obstacle tracker: a sequence of up to 12 scans (stamps that go forward, repeat, jump or
// go back; any angles, range limits, beam counts; ranges with NaN/inf/negative values) seen from arbitrary
// laser poses. update() never throws and every reported track is finite and well-formed.
// ----------------------------------------------------------------------------------------------------------
inline void checkScene(const TrackedScene& scene, const TrackerConfig& config, const std::string& when) {
  std::set<int> ids;
  for (const TrackedObstacle& o : scene.obstacles) {
    const std::string who = when + ": track " + std::to_string(o.id);
    require(o.id >= 0 && ids.insert(o.id).second, who + " has a unique non-negative id");
    require(o.center.allFinite(), who + " centre is finite");
    require(std::isfinite(o.radius) && o.radius > 0.0, who + " radius is finite and positive");
    require(std::isfinite(o.heading) && std::isfinite(o.speed) && std::isfinite(o.turn_rate),
            who + " motion is finite");
    require(std::abs(o.turn_rate) <= config.max_turn_rate_rps + 1e-9, who + " turn rate within the clamp");
    require(o.covariance.allFinite(), who + " covariance is finite");
    require(std::isfinite(o.age_s) && o.age_s >= 0.0, who + " age is finite and non-negative");
    require(o.hits >= 2, who + " is reported with at least 2 hits");
  }
  for (const Segment& s : scene.segments) require(s.a.allFinite() && s.b.allFinite(), when + ": segment is finite");
}

inline void scanTrackerOne(const std::uint8_t* data, std::size_t size) {
  ByteStream in(data, size);
  TrackerConfig config;
  ObstacleTracker tracker(config);
  Pose2 pose{in.number(-5.0, 5.0), in.number(-5.0, 5.0), in.number(-4.0, 4.0)};
  double stamp = in.number(-100.0, 100.0);
  const int scans = 1 + in.u8() % 12;
  for (int k = 0; k < scans && !in.empty(); ++k) {
    const std::uint8_t mode = in.u8();
    LaserScan2 scan;
    stamp = (mode & 1) ? in.number(-100.0, 100.0) : stamp + in.number(-0.05, 0.3);
    scan.stamp_s = stamp;
    const bool sim_geometry = mode & 2;  // the 720-beam full turn of the simulated LIDAR, else fuzzed
    scan.angle_min = sim_geometry ? -kPi : in.number(-4.0, 4.0);
    scan.angle_increment = sim_geometry ? kTwoPi / 720.0 : in.number(-0.05, 0.05);
    scan.range_min = sim_geometry ? 0.05 : in.number(0.0, 1.0);
    scan.range_max = sim_geometry ? 12.0 : in.number(0.0, 40.0);
    const std::size_t beams = sim_geometry ? 720 : in.u16() % 1500;
    scan.ranges.assign(beams, std::numeric_limits<float>::infinity());
    // Piecewise-linear runs of beams, so that walls and arcs are reachable.
    for (std::size_t i = 0; i < beams && !in.empty();) {
      const std::size_t run = 1 + in.u8() % 64;
      const float base = in.numberF(-1.0, 12.0);
      const float slope = in.numberF(-0.1, 0.1);
      for (std::size_t j = 0; j < run && i < beams; ++j, ++i) scan.ranges[i] = base + slope * static_cast<float>(j);
    }
    if (mode & 4) {
      pose = Pose2{in.number(-50.0, 50.0), in.number(-50.0, 50.0), in.number(-7.0, 7.0)};
    } else {
      pose = Pose2{pose.x + in.number(-0.1, 0.1), pose.y + in.number(-0.1, 0.1), pose.theta + in.number(-0.1, 0.1)};
    }
    const std::string problem = checkScan(scan);
    const std::size_t tracks_before = tracker.trackCount();
    const TrackedScene scene_before = tracker.scene();
    const TrackerResult r = tracker.update(scan, pose);
    const std::string when = "scan " + std::to_string(k);
    if (!problem.empty() || !pose.isFinite()) {
      require(r.status == TrackerStatus::kRejected, when + ": an unusable scan or pose is rejected");
    }
    if (r.status == TrackerStatus::kRejected) {
      require(!r.message.empty(), when + ": a rejection says why");
      require(tracker.trackCount() == tracks_before, when + ": a rejected scan leaves the tracks untouched");
      require(r.scene.obstacles.size() == scene_before.obstacles.size(),
              when + ": a rejection reports the previous scene");
    } else {
      require(r.scene.stamp_s == scan.stamp_s, when + ": the scene has the scan's stamp");
      require(r.ignored_beams <= scan.ranges.size(), when + ": ignored beams <= beams");
      if (r.status == TrackerStatus::kReset) require(!r.message.empty(), when + ": a reset says why");
    }
    checkScene(r.scene, config, when);
    checkScene(tracker.predictedScene(stamp + 0.35), config, when + " predicted");
    require(tracker.trackCount() <= 10000, when + ": track count stays bounded");
  }
}

// ----------------------------------------------------------------------------------------------------------
// (c) `.dovs` scenario: the whole input is the file. A rejection is a ScenarioError naming the file; an
// accepted scenario holds only finite values strictly inside the room and can be simulated.
// ----------------------------------------------------------------------------------------------------------
inline void scenarioOne(const std::uint8_t* data, std::size_t size) {
  const std::string path = "fuzz/1-0/input.dovs";
  sim::Scenario s;
  try {
    s = sim::parseDovsScenario(data, size, path);
  } catch (const sim::ScenarioError& e) {
    const std::string what = e.what();
    require(what.find("scenario file '" + path + "': ") == 0 && what.size() > path.size() + 20,
            "ScenarioError names the file and the reason: " + what);
    return;
  }
  require(size > 0 && size % 40 == 0, "only whole 40-byte rows are accepted");
  require(s.obstacles.size() == size / 40 - 1, "one obstacle per row after the robot row");
  require(s.name == "1-0/input", "scenario named after folder and file, got '" + s.name + "'");
  const double half = s.room_half_size_m;
  auto inside = [half](const Vec2& p) { return p.allFinite() && std::abs(p.x()) < half && std::abs(p.y()) < half; };
  require(inside(s.robot_start.position()) && std::isfinite(s.robot_start.theta), "robot start inside the room");
  require(inside(s.goal), "goal inside the room");
  for (const MovingObstacle& o : s.obstacles) {
    require(inside(o.center), "obstacle inside the room");
    require(o.radius == sim::kDefaultObstacleRadius, "obstacle has the default radius");
    require(std::isfinite(o.heading) && std::abs(o.heading) <= kPi + 1e-12, "heading normalised");
    require(std::isfinite(o.speed) && o.speed >= 0.0 && std::isfinite(o.turn_rate), "speed >= 0, finite motion");
    require(o.is_static == (o.speed == 0.0 && o.turn_rate == 0.0), "static iff v = w = 0");
  }
  // Simulate a little: the world accepts every scenario the loader accepts and stays finite.
  sim::applyDynamicFraction(s, 0.85);
  sim::World world(s, sim::WorldConfig{}, 1);
  for (int k = 0; k < 4; ++k) {
    world.step(Twist2{0.3, 0.2}, 0.2);
    require(world.robotPose().isFinite(), "robot pose stays finite");
    for (const sim::SimObstacle& o : world.obstacles()) {
      require(o.body.center.allFinite() && std::isfinite(o.body.heading), "obstacle state stays finite");
    }
  }
  const LaserScan2 scan = world.scan();
  for (float r : scan.ranges) require(!std::isnan(r), "simulated scan has no NaN range");
}

}  // namespace dqn_dovs::fuzz
