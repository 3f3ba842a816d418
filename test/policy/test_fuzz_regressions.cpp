// Replays the committed fuzz crash inputs (fuzz/regressions/<target>/) through the same target bodies as the
// libFuzzer binaries (fuzz/targets.h), in the ordinary build, and pins the fixed behaviour with direct checks.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>
#include <vector>

#include "source_paths.h"
#include "targets.h"

namespace fs = std::filesystem;
using namespace dqn_dovs;

namespace {

std::vector<std::uint8_t> readAll(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::vector<std::uint8_t>((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

void replay(const std::string& target, void (*body)(const std::uint8_t*, std::size_t)) {
  const fs::path dir = fs::path(DQN_DOVS_SOURCE_DIR) / "fuzz" / "regressions" / target;
  ASSERT_TRUE(fs::is_directory(dir)) << dir << " is missing";
  std::size_t inputs = 0;
  for (const fs::directory_entry& e : fs::directory_iterator(dir)) {
    if (!e.is_regular_file()) continue;
    const std::vector<std::uint8_t> bytes = readAll(e.path());
    ++inputs;
    try {
      body(bytes.data(), bytes.size());
    } catch (const std::exception& ex) {
      ADD_FAILURE() << e.path() << ": " << ex.what();
    }
  }
  EXPECT_GT(inputs, 0u) << "no regression input in " << dir;
}

}  // namespace

TEST(FuzzRegressions, WeightFile) { replay("weight_file", fuzz::weightFileOne); }
TEST(FuzzRegressions, ScanTracker) { replay("scan_tracker", fuzz::scanTrackerOne); }
TEST(FuzzRegressions, Scenario) { replay("scenario", fuzz::scenarioOne); }

TEST(FuzzRegressions, ScenarioWithAbsurdObstacleSpeedIsRejected) {
  // Obstacle 4 at 2.6e183 m/s: accepted before, and every 0.2 s world step then ran the 100000-sub-step cap.
  const fs::path file = fs::path(DQN_DOVS_SOURCE_DIR) / "fuzz" / "regressions" / "scenario" / "obstacle_speed_1e183";
  try {
    (void)sim::loadDovsScenario(file.string());
    FAIL() << "accepted";
  } catch (const sim::ScenarioError& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.find("scenario file '" + file.string() + "': row 4 (obstacle 4) motion v = 2.6"), 0u) << what;
    EXPECT_NE(what.find("exceeds the limits |v| <= 10 m/s, |w| <= 10 rad/s"), std::string::npos) << what;
  }
}

TEST(FuzzRegressions, WeightFileErrorsEscapeFileBytes) {
  // A normalisation name with a NUL and a newline, and a NaN value: the message must name the entry in full.
  WeightFileContents c = makeRandomWeights(DuelingArchitecture{}, 1, {{std::string("v\0x\n", 4), 0.5f}});
  c.normalization[0].second = std::numeric_limits<float>::quiet_NaN();
  const std::vector<std::uint8_t> bytes = serializeWeightFile(c);
  try {
    (void)QNetwork::fromBytes(bytes, "mem.dqnw");
    FAIL() << "a NaN normalisation value was accepted";
  } catch (const WeightFileError& e) {
    EXPECT_EQ(std::string(e.what()),
              "weight file 'mem.dqnw': field 'normalization entry 'v\\x00x\\x0a'': value is NaN or infinite");
  }
  EXPECT_EQ(printableBytes(std::string("a\\b\x7f\xff", 5)), "a\\\\b\\x7f\\xff");
}

TEST(FuzzRegressions, WeightFileShapesThatOverflowAreRejected) {
  const fs::path dir = fs::path(DQN_DOVS_SOURCE_DIR) / "fuzz" / "regressions" / "weight_file";
  // 2^62 conv weights: 4 * 2^62 bytes wrapped to 0 and the reader asked std::vector for 2^62 floats.
  std::vector<std::uint8_t> bytes = readAll(dir / "weight_bytes_overflow_64_bits");
  bytes.erase(bytes.begin());  // the fuzz mode byte
  try {
    (void)parseWeightFile(bytes, "big.dqnw");
    FAIL() << "accepted";
  } catch (const WeightFileError& e) {
    EXPECT_EQ(e.field(), "layer 0 (grid conv2d) weight");
    EXPECT_NE(std::string(e.what()).find("truncated: needs 4611686018427387904 floats"), std::string::npos) << e.what();
  }
  // Padding 65536 on a 1x1 kernel: 131092 x 131092 outputs overflowed int (undefined behaviour).
  bytes = readAll(dir / "conv_padding_output_overflows_int");
  bytes.erase(bytes.begin());
  try {
    (void)QNetwork::fromBytes(bytes, "pad.dqnw");
    FAIL() << "accepted";
  } catch (const WeightFileError& e) {
    EXPECT_EQ(e.field(), "layer 0 (grid conv2d) shape");
    EXPECT_NE(std::string(e.what()).find("exceeds the 4194304-value limit"), std::string::npos) << e.what();
  }
  LayerRecord l;
  l.type = LayerType::kConv2d;
  l.in_channels = l.out_channels = l.kernel_h = l.kernel_w = 65536;  // 2^64 wrapped to 0
  EXPECT_EQ(l.weightCount(), std::numeric_limits<std::uint64_t>::max());
}

TEST(FuzzRegressions, PredictedSceneBeyondTheTimeGapHasNoObstacles) {
  // One confirmed track, then a prediction far beyond max_time_gap_s: no (non-finite) obstacles.
  TrackerConfig config;
  ObstacleTracker tracker(config);
  for (int k = 0; k < 6; ++k) {
    LaserScan2 scan;
    scan.stamp_s = 0.1 * k;
    scan.angle_min = -kPi;
    scan.angle_increment = kTwoPi / 720.0;
    scan.range_min = 0.05;
    scan.range_max = 12.0;
    scan.ranges.assign(720, std::numeric_limits<float>::infinity());
    const Circle disc{Vec2(2.0 + 0.05 * k, 0.0), 0.2};
    for (std::size_t i = 0; i < scan.ranges.size(); ++i) {
      const double a = scan.angleOf(i);
      const Vec2 d(std::cos(a), std::sin(a));
      const double b = d.dot(disc.center), q = b * b - disc.center.squaredNorm() + disc.radius * disc.radius;
      if (q >= 0.0 && b - std::sqrt(q) > 0.0) scan.ranges[i] = static_cast<float>(b - std::sqrt(q));
    }
    tracker.update(scan, Pose2{});
  }
  ASSERT_EQ(tracker.scene().obstacles.size(), 1u);
  EXPECT_EQ(tracker.predictedScene(0.5 + 0.5 * config.max_time_gap_s).obstacles.size(), 1u);
  const TrackedScene far = tracker.predictedScene(std::numeric_limits<double>::max());
  EXPECT_TRUE(far.obstacles.empty());
  EXPECT_EQ(far.stamp_s, std::numeric_limits<double>::max());
}
