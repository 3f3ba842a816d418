// QNetwork: loading .dqnw files (every corruption is a named error), inference against a plain
// reference implementation, masked action choice.
#include <gtest/gtest.h>
#include <unistd.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <thread>

#include "dqn_dovs/dovs/state.h"
#include "dqn_dovs/policy/qnetwork.h"
#include "dqn_dovs/policy/weight_file.h"

namespace dqn_dovs {
namespace {

const std::vector<std::pair<std::string, float>> kNormalization = {
    {"v_max", 0.7f}, {"w_max", 3.14159265f}, {"distance_scale", 8.0f}};

std::string tempPath(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / ("dqn_dovs_test_qnetwork_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  return (dir / name).string();
}

void writeBytes(const std::string& path, const std::vector<std::uint8_t>& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}

WeightFileContents defaultContents(std::uint64_t seed = 7) {
  WeightFileContents c = makeRandomWeights(DuelingArchitecture{}, seed, kNormalization, "unit test");
  // Fresh biases are tiny; larger ones make a missed bias add visible.
  std::mt19937 rng(static_cast<unsigned>(seed));
  std::normal_distribution<float> noise(0.0f, 0.3f);
  for (LayerRecord& l : c.layers)
    for (float& b : l.bias) b += noise(rng);
  return c;
}

Eigen::VectorXf randomState(std::mt19937& rng, int grid_channels = 1, int features = 8) {
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  const int grid = grid_channels * 400;
  Eigen::VectorXf s(grid + features);
  for (int i = 0; i < grid; ++i) s[i] = u(rng) < 0.4f ? -1.0f : 1.0f;
  for (int i = grid; i < grid + features; ++i) s[i] = u(rng);
  return s;
}

// Straightforward double-precision forward pass over the records, written from the format spec:
// independent of the im2col/GEMM code under test.
std::array<double, 8> referenceQ(const WeightFileContents& c, const Eigen::VectorXf& state) {
  const int grid_values = static_cast<int>(c.grid_channels) * 400;
  std::vector<double> grid(state.data(), state.data() + grid_values);
  int ch = static_cast<int>(c.grid_channels), h = 20, w = 20;
  std::vector<double> feat(state.data() + grid_values, state.data() + grid_values + c.feature_count);
  std::vector<double> trunk, value, adv;
  auto linear = [](const LayerRecord& l, const std::vector<double>& x) {
    std::vector<double> y(l.out_features);
    for (std::uint32_t o = 0; o < l.out_features; ++o) {
      double acc = l.bias[o];
      for (std::uint32_t i = 0; i < l.in_features; ++i) acc += double(l.weight[o * l.in_features + i]) * x[i];
      y[o] = acc;
    }
    return y;
  };
  auto relu = [](std::vector<double>& x) {
    for (double& v : x) v = std::max(v, 0.0);
  };
  bool trunk_started = false;
  for (const LayerRecord& l : c.layers) {
    if (l.stream >= LayerStream::kTrunk && !trunk_started) {
      trunk = grid;
      trunk.insert(trunk.end(), feat.begin(), feat.end());
      trunk_started = true;
    }
    std::vector<double>* x = l.stream == LayerStream::kGrid      ? &grid
                             : l.stream == LayerStream::kFeature ? &feat
                             : l.stream == LayerStream::kTrunk   ? &trunk
                             : l.stream == LayerStream::kValue   ? &value
                                                                 : &adv;
    if ((l.stream == LayerStream::kValue || l.stream == LayerStream::kAdvantage) && x->empty()) *x = trunk;
    if (l.type == LayerType::kRelu) {
      relu(*x);
    } else if (l.type == LayerType::kLinear) {
      *x = linear(l, *x);
    } else {
      const int oh = (h + 2 * int(l.pad_h) - int(l.kernel_h)) / int(l.stride_h) + 1;
      const int ow = (w + 2 * int(l.pad_w) - int(l.kernel_w)) / int(l.stride_w) + 1;
      std::vector<double> y(std::size_t(l.out_channels) * oh * ow);
      for (std::uint32_t co = 0; co < l.out_channels; ++co)
        for (int oy = 0; oy < oh; ++oy)
          for (int ox = 0; ox < ow; ++ox) {
            double acc = l.bias[co];
            for (int ci = 0; ci < ch; ++ci)
              for (std::uint32_t ky = 0; ky < l.kernel_h; ++ky)
                for (std::uint32_t kx = 0; kx < l.kernel_w; ++kx) {
                  const int iy = oy * int(l.stride_h) - int(l.pad_h) + int(ky);
                  const int ix = ox * int(l.stride_w) - int(l.pad_w) + int(kx);
                  if (iy < 0 || iy >= h || ix < 0 || ix >= w) continue;
                  acc += double(l.weight[((co * ch + ci) * l.kernel_h + ky) * l.kernel_w + kx]) *
                         (*x)[(ci * h + iy) * w + ix];
                }
            y[(co * oh + oy) * ow + ox] = acc;
          }
      *x = y;
      ch = int(l.out_channels);
      h = oh;
      w = ow;
    }
  }
  double mean = 0.0;
  for (double a : adv) mean += a / 8.0;
  std::array<double, 8> q{};
  for (int a = 0; a < 8; ++a) q[a] = value[0] + adv[a] - mean;
  return q;
}

// Expects loading `contents` (serialised with a valid checksum) to fail with a message naming the
// file and containing `field_part`.
void expectLoadError(const WeightFileContents& contents, const std::string& name, const std::string& field_part) {
  const std::string path = tempPath(name);
  writeWeightFile(path, contents);
  try {
    QNetwork::load(path);
    ADD_FAILURE() << name << ": loading succeeded, expected an error on '" << field_part << "'";
  } catch (const WeightFileError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find(path), std::string::npos) << msg;
    EXPECT_NE(e.field().find(field_part), std::string::npos)
        << name << ": field '" << e.field() << "', message: " << msg;
  }
}

std::string loadErrorField(const std::vector<std::uint8_t>& bytes, const std::string& name,
                           std::string* message = nullptr) {
  const std::string path = tempPath(name);
  writeBytes(path, bytes);
  try {
    QNetwork::load(path);
  } catch (const WeightFileError& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    if (message) *message = e.what();
    return e.field();
  }
  ADD_FAILURE() << name << ": loading succeeded, expected an error";
  return {};
}

// The field of the WeightFileError that QNetwork::fromContents throws for `c`, or "(accepted)".
std::string contentsErrorField(const WeightFileContents& c, const std::string& source) {
  try {
    QNetwork::fromContents(c, source);
  } catch (const WeightFileError& e) {
    return e.field();
  }
  return "(accepted)";
}

TEST(QNetwork, MatchesReferenceForwardPass) {
  const WeightFileContents c = defaultContents();
  const std::string path = tempPath("good.dqnw");
  writeWeightFile(path, c);
  const QNetwork net = QNetwork::load(path);
  EXPECT_EQ(net.metadata(), "unit test");
  EXPECT_EQ(net.normalization(), kNormalization);
  std::mt19937 rng(1);
  double max_diff = 0.0, spread = 0.0;
  for (int n = 0; n < 50; ++n) {
    const Eigen::VectorXf s = randomState(rng);
    const auto q = net.qValues(s);
    const auto ref = referenceQ(c, s);
    for (int a = 0; a < 8; ++a) {
      max_diff = std::max(max_diff, std::abs(double(q[a]) - ref[a]));
      spread = std::max(spread, std::abs(ref[a] - ref[0]));
    }
  }
  EXPECT_LT(max_diff, 1e-4);
  EXPECT_GT(spread, 1e-3) << "degenerate network: every action has the same Q";
}

TEST(QNetwork, OtherArchitecturesRunToo) {
  DuelingArchitecture arch;
  arch.conv_channels = {4, 6};
  arch.conv_strides = {2, 1};
  arch.conv_kernel = 5;
  arch.feature_hidden = 16;
  arch.trunk_hidden = {};
  ASSERT_EQ(arch.validate(), "");
  const WeightFileContents c = makeRandomWeights(arch, 3, kNormalization);
  const QNetwork net = QNetwork::fromContents(c, "<small>");
  std::mt19937 rng(2);
  const Eigen::VectorXf s = randomState(rng);
  const auto q = net.qValues(s);
  const auto ref = referenceQ(c, s);
  for (int a = 0; a < 8; ++a) EXPECT_NEAR(q[a], ref[a], 1e-4);
  arch.conv_kernel = 4;
  EXPECT_NE(arch.validate().find("conv_kernel"), std::string::npos);
}

TEST(QNetwork, GridChannelsAreAVersionTwoFileAndTheStateGrows) {
  DuelingArchitecture arch;
  arch.grid_channels = 3;
  WeightFileContents c = makeRandomWeights(arch, 5, kNormalization);
  EXPECT_EQ(c.format_version, 2u);
  EXPECT_EQ(c.grid_channels, 3u);
  // The header gains one u32 (the channel count) and the first convolution 2 x 8 x 9 weights.
  const std::vector<std::uint8_t> bytes = serializeWeightFile(c);
  const std::vector<std::uint8_t> one =
      serializeWeightFile(makeRandomWeights(DuelingArchitecture{}, 5, kNormalization));
  EXPECT_EQ(bytes.size(), one.size() + 4 + 2 * 8 * 9 * 4);
  EXPECT_EQ(weightFormatVersionFor(1), 1u);  // one channel: the file every earlier reader wrote and reads
  const WeightFileContents back = parseWeightFile(bytes, "<v2>");
  EXPECT_EQ(back.format_version, 2u);
  EXPECT_EQ(back.grid_channels, 3u);
  const QNetwork net = QNetwork::fromContents(back, "<v2>");
  EXPECT_EQ(net.gridChannels(), 3);
  EXPECT_EQ(net.stateSize(), 1208);
  std::mt19937 rng(9);
  for (int n = 0; n < 10; ++n) {
    const Eigen::VectorXf s = randomState(rng, 3);
    const auto q = net.qValues(s);
    const auto ref = referenceQ(back, s);
    for (int a = 0; a < 8; ++a) EXPECT_NEAR(q[a], ref[a], 1e-4);
  }
  // The extra channels are read: changing only the third channel changes the Q-values.
  Eigen::VectorXf s = randomState(rng, 3);
  const auto q0 = net.qValues(s);
  for (int i = 800; i < 1200; ++i) s[i] = -s[i];
  const auto q1 = net.qValues(s);
  double moved = 0.0;
  for (int a = 0; a < 8; ++a) moved = std::max(moved, std::abs(double(q1[a]) - q0[a]));
  EXPECT_GT(moved, 1e-4);
  // A one-channel state for it, and the other way round, are named errors.
  try {
    net.qValues(randomState(rng, 1));
    ADD_FAILURE() << "a 408-float state was accepted by a 3-channel network";
  } catch (const QNetworkInputError& e) {
    EXPECT_NE(std::string(e.what()).find("expected 1208 (3 x 20 x 20 grid"), std::string::npos) << e.what();
  }
  EXPECT_EQ(net.gridChannelsMismatch(3), "");
  const std::string why = net.gridChannelsMismatch(1);
  EXPECT_NE(why.find("'state layout: grid channels' is 3 in the file but 1 here"), std::string::npos) << why;
  EXPECT_NE(why.find("dovs/grid_channels"), std::string::npos) << why;

  // Channel counts the planner cannot build, a version 1 file claiming channels, and a first convolution reading
  // another count are refused, naming the field.
  WeightFileContents four = back;
  four.grid_channels = 4;
  expectLoadError(four, "four.dqnw", "state layout: grid channels");
  WeightFileContents v1 = back;
  v1.format_version = 1;
  EXPECT_EQ(contentsErrorField(v1, "<v1 with channels>"), "state layout: grid channels");
  WeightFileContents zero = back;
  zero.grid_channels = 0;
  EXPECT_EQ(loadErrorField(serializeWeightFile(zero), "zero.dqnw"), "state layout: grid channels");
  WeightFileContents conv_one = back;
  conv_one.grid_channels = 1;
  conv_one.format_version = 1;
  // A first convolution reading 3 channels of a one-channel grid.
  EXPECT_NE(contentsErrorField(conv_one, "<conv reads 3>").find("shape"), std::string::npos);
}

// The previous choice (docs/dovs.md "The previous action"): 9 more feature inputs, told by the file's feature count.
TEST(QNetwork, ThePreviousChoiceIsSeventeenFeatureInputs) {
  DuelingArchitecture arch;
  arch.feature_count = QNetwork::kFeatureCountWithPreviousChoice;
  ASSERT_EQ(arch.validate(), "");
  const WeightFileContents c = makeRandomWeights(arch, 6, kNormalization);
  EXPECT_EQ(c.format_version, 1u);  // the header's feature count carries the layout
  EXPECT_EQ(c.feature_count, 17u);
  const QNetwork net = QNetwork::fromContents(parseWeightFile(serializeWeightFile(c), "<17>"), "<17>");
  EXPECT_EQ(net.featureCount(), 17);
  EXPECT_EQ(net.stateSize(), 417);
  std::mt19937 rng(12);
  for (int n = 0; n < 10; ++n) {
    const Eigen::VectorXf s = randomState(rng, 1, 17);
    const auto q = net.qValues(s);
    const auto ref = referenceQ(c, s);
    for (int a = 0; a < 8; ++a) EXPECT_NEAR(q[a], ref[a], 1e-4);
  }
  // The last input is read: moving the one-hot from one slot to another changes the Q-values.
  Eigen::VectorXf s = randomState(rng, 1, 17);
  s.tail(9).setZero();
  s[408] = 1.0f;
  const auto q0 = net.qValues(s);
  s[408] = 0.0f;
  s[416] = 1.0f;
  const auto q1 = net.qValues(s);
  double moved = 0.0;
  for (int a = 0; a < 8; ++a) moved = std::max(moved, std::abs(double(q1[a]) - q0[a]));
  EXPECT_GT(moved, 1e-4);
  try {
    net.qValues(randomState(rng));
    ADD_FAILURE() << "a 408-float state was accepted by a network of 17 feature inputs";
  } catch (const QNetworkInputError& e) {
    EXPECT_NE(std::string(e.what()).find("expected 417 (1 x 20 x 20 grid + 17 features)"), std::string::npos)
        << e.what();
  }
  EXPECT_EQ(net.previousActionMismatch(true), "");
  const std::string why = net.previousActionMismatch(false);
  EXPECT_NE(why.find("'state layout: feature count' is 17 in the file but 8 here"), std::string::npos) << why;
  EXPECT_NE(why.find("dovs/previous_action"), std::string::npos) << why;
  const QNetwork plain = QNetwork::fromContents(makeRandomWeights(DuelingArchitecture{}, 6, kNormalization), "<8>");
  EXPECT_EQ(plain.previousActionMismatch(false), "");
  EXPECT_NE(plain.previousActionMismatch(true).find("is 8 in the file but 17 here"), std::string::npos);
  // Other feature counts: the architecture and the file are refused, naming the field.
  arch.feature_count = 9;
  EXPECT_NE(arch.validate().find("feature_count"), std::string::npos);
  WeightFileContents nine = c;
  nine.feature_count = 9;
  expectLoadError(nine, "nine.dqnw", "state layout: feature count");
  // A file claiming 17 features whose feature layer reads 8 is a shape error.
  WeightFileContents narrow = makeRandomWeights(DuelingArchitecture{}, 6, kNormalization);
  narrow.feature_count = 17;
  EXPECT_NE(contentsErrorField(narrow, "<17 claimed, 8 read>").find("feature"), std::string::npos);
}

TEST(QNetwork, RejectsBadStates) {
  const QNetwork net = QNetwork::fromContents(defaultContents(), "<memory>");
  std::mt19937 rng(3);
  Eigen::VectorXf s = randomState(rng);
  s[405] = std::numeric_limits<float>::quiet_NaN();
  try {
    net.qValues(s);
    ADD_FAILURE() << "NaN state accepted";
  } catch (const QNetworkInputError& e) {
    EXPECT_NE(std::string(e.what()).find("element 405 is NaN"), std::string::npos) << e.what();
  }
  s[405] = 0.0f;
  s[12] = std::numeric_limits<float>::infinity();
  EXPECT_THROW(net.qValues(s), QNetworkInputError);
  QNetwork::ActionMask all{};
  all.fill(true);
  EXPECT_THROW(net.selectAction(s, all), QNetworkInputError);
  EXPECT_THROW(net.qValues(Eigen::VectorXf::Zero(407)), QNetworkInputError);
  // Finite but absurd inputs overflow to inf inside the network: reported, not returned.
  s.setConstant(3e38f);
  EXPECT_THROW(net.qValues(s), QNetworkInputError);
}

TEST(QNetwork, MaskedActionChoice) {
  const QNetwork net = QNetwork::fromContents(defaultContents(11), "<memory>");
  std::mt19937 rng(4);
  std::bernoulli_distribution valid(0.4);
  QNetwork::ActionMask none{};
  EXPECT_EQ(net.selectAction(randomState(rng), none), -1);
  int picked_non_greedy = 0;
  for (int n = 0; n < 300; ++n) {
    const Eigen::VectorXf s = randomState(rng);
    QNetwork::ActionMask mask;
    for (bool& m : mask) m = valid(rng);
    const int a = net.selectAction(s, mask);
    const auto q = net.qValues(s);
    if (std::none_of(mask.begin(), mask.end(), [](bool b) { return b; })) {
      EXPECT_EQ(a, -1);
      continue;
    }
    ASSERT_GE(a, 0);
    ASSERT_LT(a, 8);
    EXPECT_TRUE(mask[a]) << "picked invalid action " << a;
    for (int b = 0; b < 8; ++b) {
      if (mask[b]) {
        EXPECT_GE(q[a], q[b]);
      }
    }
    const int greedy = int(std::max_element(q.begin(), q.end()) - q.begin());
    if (greedy != a) ++picked_non_greedy;
  }
  EXPECT_GT(picked_non_greedy, 0) << "the mask never changed the choice: test proves nothing";
  // Ties go to the lowest valid index; NaN is never chosen.
  const QNetwork::QValues q = {1, 5, 5, 2, 0, 0, 0, std::numeric_limits<float>::quiet_NaN()};
  EXPECT_EQ(QNetwork::maskedArgmax(q, {true, true, true, true, true, true, true, true}), 1);
  EXPECT_EQ(QNetwork::maskedArgmax(q, {false, false, false, false, false, false, false, true}), -1);
  EXPECT_EQ(QNetwork::maskedArgmax(q, {true, false, false, false, false, false, false, true}), 0);
}

TEST(QNetwork, ThreadsGetTheSameAnswers) {
  const QNetwork net = QNetwork::fromContents(defaultContents(), "<memory>");
  std::mt19937 rng(5);
  std::vector<Eigen::VectorXf> states;
  for (int i = 0; i < 40; ++i) states.push_back(randomState(rng));
  std::vector<QNetwork::QValues> expected;
  for (const auto& s : states) expected.push_back(net.qValues(s));
  std::vector<int> mismatches(3, 0);
  std::vector<std::thread> threads;
  for (int t = 0; t < 3; ++t) {
    threads.emplace_back([&, t] {
      for (int rep = 0; rep < 20; ++rep)
        for (std::size_t i = 0; i < states.size(); ++i)
          if (net.qValues(states[i]) != expected[i]) ++mismatches[t];
    });
  }
  for (auto& th : threads) th.join();
  for (int m : mismatches) EXPECT_EQ(m, 0);
}

TEST(QNetwork, NormalizationMismatchNamesEveryDifference) {
  const QNetwork net = QNetwork::fromContents(defaultContents(), "net.dqnw");
  EXPECT_EQ(net.normalizationMismatch(kNormalization), "");
  auto reordered = kNormalization;
  std::swap(reordered[0], reordered[2]);
  EXPECT_EQ(net.normalizationMismatch(reordered), "");
  auto other = kNormalization;
  other[0].second = 0.5f;
  other.pop_back();
  other.emplace_back("goal_angle_scale", 3.14f);
  const std::string msg = net.normalizationMismatch(other);
  EXPECT_NE(msg.find("'v_max' is 0.7 in the file but 0.5"), std::string::npos) << msg;
  EXPECT_NE(msg.find("'goal_angle_scale' is expected but missing"), std::string::npos) << msg;
  EXPECT_NE(msg.find("'distance_scale' (= 8) is in the file but not expected"), std::string::npos) << msg;
  EXPECT_NE(msg.find("net.dqnw"), std::string::npos) << msg;
}

TEST(WeightFile, RoundTripsThroughBytes) {
  const WeightFileContents c = defaultContents();
  const auto bytes = serializeWeightFile(c);
  const WeightFileContents back = parseWeightFile(bytes, "<bytes>");
  EXPECT_EQ(back.normalization, c.normalization);
  EXPECT_EQ(back.metadata, c.metadata);
  ASSERT_EQ(back.layers.size(), c.layers.size());
  for (std::size_t i = 0; i < c.layers.size(); ++i) {
    EXPECT_EQ(back.layers[i].weight, c.layers[i].weight);
    EXPECT_EQ(back.layers[i].bias, c.layers[i].bias);
    EXPECT_EQ(back.layers[i].stream, c.layers[i].stream);
  }
  // zlib's CRC-32 of "123456789" is the standard check value.
  const std::string check = "123456789";
  EXPECT_EQ(crc32(reinterpret_cast<const std::uint8_t*>(check.data()), check.size()), 0xCBF43926u);
}

TEST(WeightFile, MissingFile) {
  try {
    QNetwork::load("/nonexistent/dir/net.dqnw");
    ADD_FAILURE() << "missing file loaded";
  } catch (const WeightFileError& e) {
    EXPECT_EQ(e.field(), "file");
    EXPECT_NE(std::string(e.what()).find("/nonexistent/dir/net.dqnw"), std::string::npos);
  }
}

TEST(WeightFile, TruncatedAtManyOffsets) {
  const auto bytes = serializeWeightFile(defaultContents());
  // Inside the magic, the header, the normalisation block, the first layer, a late layer, the metadata.
  for (std::size_t cut : {std::size_t{0}, std::size_t{5}, std::size_t{10}, std::size_t{17}, std::size_t{30},
                          std::size_t{60}, std::size_t{200}, bytes.size() / 2, bytes.size() - 20, bytes.size() - 1}) {
    std::vector<std::uint8_t> part(bytes.begin(), bytes.begin() + static_cast<long>(cut));
    std::string message;
    const std::string field = loadErrorField(part, "truncated_" + std::to_string(cut) + ".dqnw", &message);
    EXPECT_FALSE(field.empty());
    EXPECT_NE(message.find("truncated"), std::string::npos) << "cut at " << cut << ": " << message;
  }
}

TEST(WeightFile, BadMagicVersionChecksumTrailing) {
  auto bytes = serializeWeightFile(defaultContents());
  auto bad_magic = bytes;
  bad_magic[0] = 'X';
  EXPECT_EQ(loadErrorField(bad_magic, "magic.dqnw"), "magic");

  WeightFileContents v5 = defaultContents();
  v5.format_version = kWeightFormatVersionLatest + 1;
  std::string message;
  EXPECT_EQ(loadErrorField(serializeWeightFile(v5), "version.dqnw", &message), "format version");
  EXPECT_NE(message.find("version 5"), std::string::npos) << message;

  auto flipped = bytes;
  flipped[bytes.size() / 2] ^= 0x40;
  EXPECT_EQ(loadErrorField(flipped, "checksum.dqnw"), "checksum");
  auto bad_crc = bytes;
  bad_crc.back() ^= 0x01;
  EXPECT_EQ(loadErrorField(bad_crc, "crc.dqnw"), "checksum");

  auto longer = bytes;
  longer.insert(longer.end() - 4, {0, 0, 0, 0});
  EXPECT_EQ(loadErrorField(longer, "trailing.dqnw"), "trailing bytes");
}

TEST(WeightFile, MismatchedStateLayoutAndActions) {
  WeightFileContents c = defaultContents();
  c.grid_rows = 16;
  expectLoadError(c, "rows.dqnw", "state layout: grid rows");
  c = defaultContents();
  c.grid_cols = 21;
  expectLoadError(c, "cols.dqnw", "state layout: grid cols");
  c = defaultContents();
  c.feature_count = 7;
  expectLoadError(c, "features.dqnw", "state layout: feature count");
  c = defaultContents();
  c.action_count = 6;
  expectLoadError(c, "actions.dqnw", "action count");
}

TEST(WeightFile, VersionThreeLayoutsAreCheckedFieldByField) {
  DuelingArchitecture arch;
  arch.wall_rays = 8;
  arch.person_tokens = 6;
  arch.quantiles = 16;
  arch.cvar_count = 4;
  const std::vector<std::pair<std::string, float>> norm = {{"v_max", 0.7f}};
  const WeightFileContents good = makeRandomWeights(arch, 5, norm);
  EXPECT_EQ(good.format_version, kWeightFormatVersionTokens);
  const QNetwork net = QNetwork::fromBytes(serializeWeightFile(good), "tokens.dqnw");
  EXPECT_EQ(net.stateSize(), 408 + 8 + 6 * kPersonTokenSize);
  EXPECT_EQ(net.quantileCount(), 16);
  EXPECT_EQ(net.cvarCount(), 4);
  EXPECT_TRUE(net.tokenLayoutMismatch(8, 6, 0).empty());
  EXPECT_NE(net.tokenLayoutMismatch(0, 6, 0).find("'state layout: wall rays' is 8 in the file but 0"),
            std::string::npos);
  EXPECT_NE(net.tokenLayoutMismatch(8, 0, 0).find("dovs/person_tokens"), std::string::npos);
  EXPECT_NE(net.tokenLayoutMismatch(8, 6, 4).find("dovs/route_points"), std::string::npos);
  // The action value is the mean of the 4 lowest of each action's 16 quantiles; Q is the mean of all 16.
  Eigen::VectorXf s = Eigen::VectorXf::Constant(net.stateSize(), 0.3f);
  const std::vector<float> z = net.quantileValues(s);
  const auto q = net.qValues(s), cvar = net.actionValues(s);
  for (int a = 0; a < QNetwork::kActionCount; ++a) {
    std::vector<float> mine(z.begin() + a * 16, z.begin() + (a + 1) * 16);
    std::sort(mine.begin(), mine.end());
    EXPECT_NEAR(cvar[static_cast<size_t>(a)], (mine[0] + mine[1] + mine[2] + mine[3]) / 4.0f, 1e-5f);
    float mean = 0.0f;
    for (float v : mine) mean += v / 16.0f;
    EXPECT_NEAR(q[static_cast<size_t>(a)], mean, 1e-5f);
  }
  // A token may be absent: the state's first token entry 0 drops it, and then nothing else of it matters.
  Eigen::VectorXf absent = s;
  for (int k = 0; k < 6; ++k) absent[416 + k * kPersonTokenSize] = 0.0f;
  Eigen::VectorXf noisy = absent;
  for (int i = 417; i < noisy.size(); ++i)
    if ((i - 416) % kPersonTokenSize != 0) noisy[i] = -1.7f;
  EXPECT_EQ(net.qValues(absent), net.qValues(noisy));

  WeightFileContents c = good;
  c.token_size = 13;
  expectLoadError(c, "token_size.dqnw", "state layout: token size");
  c = good;
  c.person_token_count = 17;
  std::string message;
  EXPECT_EQ(loadErrorField(serializeWeightFile(c), "many_tokens.dqnw", &message), "state layout: person tokens");
  c = good;
  c.cvar_count = 17;
  EXPECT_EQ(loadErrorField(serializeWeightFile(c), "cvar.dqnw", &message), "cvar count");
  c = good;
  c.quantile_count = 8;  // the heads still end with 16 and 128 outputs
  expectLoadError(c, "quantiles.dqnw", "value stream");
  c = good;
  c.person_token_count = 0;  // token layers without tokens
  c.token_size = 0;
  expectLoadError(c, "no_tokens.dqnw", "token stream");
  c = good;
  c.format_version = kWeightFormatVersionChannels;  // written without fields 5a-5e: the layers do not fit
  EXPECT_FALSE(loadErrorField(serializeWeightFile(c), "v2.dqnw", &message).empty());
}

TEST(WeightFile, VersionFourAddsTheRoutePoints) {
  DuelingArchitecture arch;
  arch.wall_rays = 8;
  arch.route_points = 6;
  arch.person_tokens = 4;
  const std::vector<std::pair<std::string, float>> norm = {{"v_max", 0.7f}};
  const WeightFileContents good = makeRandomWeights(arch, 7, norm);
  EXPECT_EQ(good.format_version, kWeightFormatVersionRoute);
  const std::vector<std::uint8_t> bytes = serializeWeightFile(good);
  EXPECT_EQ(parseWeightFile(bytes, "route.dqnw").route_point_count, 6u);
  const QNetwork net = QNetwork::fromBytes(bytes, "route.dqnw");
  EXPECT_EQ(net.routePoints(), 6);
  EXPECT_EQ(net.flatInputs(), 8 + 8 + 12);
  EXPECT_EQ(net.stateSize(), 400 + 8 + 8 + 12 + 4 * kPersonTokenSize);
  EXPECT_TRUE(net.tokenLayoutMismatch(8, 4, 6).empty());
  EXPECT_NE(net.tokenLayoutMismatch(8, 4, 0).find("'state layout: route points' is 6 in the file but 0"),
            std::string::npos);
  // The route points feed the feature stream: changing one changes Q; the person tokens start after them.
  Eigen::VectorXf s = Eigen::VectorXf::Constant(net.stateSize(), 0.2f);
  Eigen::VectorXf moved = s;
  moved[416 + 11] = -0.9f;
  EXPECT_NE(net.qValues(s), net.qValues(moved));
  Eigen::VectorXf absent = s;
  for (int k = 0; k < 4; ++k) absent[428 + k * kPersonTokenSize] = 0.0f;
  Eigen::VectorXf noisy = absent;
  for (int k = 0; k < 4; ++k)
    for (int i = 1; i < kPersonTokenSize; ++i) noisy[428 + k * kPersonTokenSize + i] = -1.3f;
  EXPECT_EQ(net.qValues(absent), net.qValues(noisy));
  s[420] = std::numeric_limits<float>::quiet_NaN();
  try {
    (void)net.qValues(s);
    ADD_FAILURE() << "a NaN route point was accepted";
  } catch (const QNetworkInputError& e) {
    EXPECT_NE(std::string(e.what()).find("route point 2"), std::string::npos) << e.what();
  }

  std::string message;
  WeightFileContents c = good;
  c.route_point_count = 17;
  EXPECT_EQ(loadErrorField(serializeWeightFile(c), "many_route.dqnw", &message), "state layout: route points");
  c = good;
  c.route_point_count = 5;  // the feature stream still reads 6 points
  EXPECT_FALSE(loadErrorField(serializeWeightFile(c), "five.dqnw", &message).empty());
  c = good;
  c.format_version = kWeightFormatVersionTokens;  // written without field 5f: the layers do not fit
  EXPECT_FALSE(loadErrorField(serializeWeightFile(c), "v3.dqnw", &message).empty());
  // A network without route points keeps version 3 and its bytes.
  arch.route_points = 0;
  EXPECT_EQ(makeRandomWeights(arch, 7, norm).format_version, kWeightFormatVersionTokens);
}

TEST(WeightFile, WrongLayerShapes) {
  auto find = [](WeightFileContents& c, LayerStream s, LayerType t) -> LayerRecord& {
    for (LayerRecord& l : c.layers)
      if (l.stream == s && l.type == t) return l;
    throw std::runtime_error("layer not found");
  };
  {  // the second convolution claims 4 input channels, the first gives 8
    WeightFileContents c = defaultContents();
    LayerRecord& conv = c.layers[2];
    ASSERT_EQ(conv.type, LayerType::kConv2d);
    conv.in_channels = 4;
    conv.weight.resize(conv.weightCount());
    expectLoadError(c, "conv_in.dqnw", "layer 2 (grid conv2d) shape");
  }
  {  // trunk input must be 400 + 64
    WeightFileContents c = defaultContents();
    LayerRecord& l = find(c, LayerStream::kTrunk, LayerType::kLinear);
    l.in_features = 460;
    l.weight.resize(l.weightCount());
    expectLoadError(c, "trunk_in.dqnw", "trunk linear) shape");
  }
  {  // advantage head with 7 outputs
    WeightFileContents c = defaultContents();
    LayerRecord& l = find(c, LayerStream::kAdvantage, LayerType::kLinear);
    l.out_features = 7;
    l.weight.resize(l.weightCount());
    l.bias.resize(7);
    expectLoadError(c, "adv_out.dqnw", "advantage stream");
  }
  {  // value head with 2 outputs
    WeightFileContents c = defaultContents();
    LayerRecord& l = find(c, LayerStream::kValue, LayerType::kLinear);
    l.out_features = 2;
    l.weight.resize(l.weightCount());
    l.bias.resize(2);
    expectLoadError(c, "value_out.dqnw", "value stream");
  }
  {  // a linear layer in the grid stream
    WeightFileContents c = defaultContents();
    LayerRecord l = find(c, LayerStream::kFeature, LayerType::kLinear);
    l.stream = LayerStream::kGrid;
    c.layers.insert(c.layers.begin(), l);
    expectLoadError(c, "grid_linear.dqnw", "layer 0 (grid linear) type");
  }
  {  // streams out of order
    WeightFileContents c = defaultContents();
    std::swap(c.layers[0], c.layers[6]);
    expectLoadError(c, "order.dqnw", "stream");
  }
  {  // no value head at all
    WeightFileContents c = defaultContents();
    c.layers.erase(std::remove_if(c.layers.begin(), c.layers.end(),
                                  [](const LayerRecord& l) { return l.stream == LayerStream::kValue; }),
                   c.layers.end());
    expectLoadError(c, "no_value.dqnw", "value stream");
  }
  {  // a kernel larger than the grid
    WeightFileContents c = defaultContents();
    LayerRecord& conv = c.layers[4];
    conv.kernel_h = conv.kernel_w = 11;  // input is 10 x 10
    conv.pad_h = conv.pad_w = 0;
    conv.weight.resize(conv.weightCount());
    expectLoadError(c, "kernel.dqnw", "layer 4 (grid conv2d) shape");
  }
  {  // an unknown layer type id, patched into valid bytes (with a recomputed checksum)
    auto bytes = serializeWeightFile(defaultContents());
    WeightFileContents c = defaultContents();
    // offset of layer 0's type: magic 8 + 5 u32 + normalisation entries + action count + layer count + stream
    std::size_t off = 8 + 5 * 4;
    for (const auto& [name, value] : c.normalization) off += 4 + name.size() + 4;
    off += 4 + 4 + 4;
    bytes[off] = 9;
    const std::uint32_t crc = crc32(bytes.data(), bytes.size() - 4);
    for (int i = 0; i < 4; ++i) bytes[bytes.size() - 4 + i] = static_cast<std::uint8_t>(crc >> (8 * i));
    EXPECT_EQ(loadErrorField(bytes, "type.dqnw"), "layer 0 type");
  }
  // A writer never produces tensors that disagree with their declared shape.
  WeightFileContents c = defaultContents();
  c.layers[0].weight.pop_back();
  EXPECT_THROW(serializeWeightFile(c), WeightFileError);
}

TEST(WeightFile, NonFiniteValues) {
  WeightFileContents c = defaultContents();
  c.layers[8].weight[123] = std::numeric_limits<float>::quiet_NaN();
  expectLoadError(c, "nan_weight.dqnw", "layer 8 (trunk linear) weight");
  c = defaultContents();
  c.layers[0].bias[3] = std::numeric_limits<float>::infinity();
  expectLoadError(c, "inf_bias.dqnw", "layer 0 (grid conv2d) bias");
  c = defaultContents();
  c.normalization[1].second = std::numeric_limits<float>::quiet_NaN();
  expectLoadError(c, "nan_norm.dqnw", "normalization entry 'w_max'");
  c = defaultContents();
  c.normalization.clear();
  expectLoadError(c, "no_norm.dqnw", "normalization count");
  c = defaultContents();
  c.normalization.push_back(c.normalization[0]);
  expectLoadError(c, "dup_norm.dqnw", "normalization entry 'v_max'");
}

}  // namespace
}  // namespace dqn_dovs
