#include "dqn_dovs/policy/qnetwork.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <sstream>

#include "dqn_dovs/common/random.h"
#include "dqn_dovs/dovs/dovs.h"
#include "dqn_dovs/dovs/state.h"

namespace dqn_dovs {

namespace {

using AlignedFloats = std::vector<float, Eigen::aligned_allocator<float>>;

// Largest activation (or im2col matrix) of one layer, and largest scratch buffer of a loaded network, in floats
// (16 and 64 MiB): far above the real network (a few thousand floats), low enough that every size and offset
// fits an int and that a corrupt shape cannot make each thread allocate gigabytes.
constexpr std::int64_t kMaxActivation = std::int64_t{1} << 22;
constexpr std::int64_t kMaxScratch = std::int64_t{1} << 24;

// Keeps every scratch region on its own cache line.
int roundUp16(int n) { return (n + 15) / 16 * 16; }

std::string layerName(std::size_t index, const LayerRecord& l) {
  std::ostringstream os;
  os << "layer " << index << " (" << layerStreamName(l.stream) << " " << layerTypeName(l.type) << ")";
  return os.str();
}

// Shape bookkeeping of one layer during validation, kept for the allocation pass.
struct PlannedLayer {
  std::size_t index = 0;  // position in the file
  const LayerRecord* record = nullptr;
  int in_c = 0, in_h = 0, in_w = 0;  // conv input (C, H, W); for linear and relu in_c is the vector size
  int out_c = 0, out_h = 0, out_w = 0;
  int inSize() const { return in_c * std::max(in_h, 1) * std::max(in_w, 1); }
  int outSize() const { return out_c * std::max(out_h, 1) * std::max(out_w, 1); }
};

// Uniform floats in [-bound, bound) from a 64-bit generator: the same sequence on every platform,
// unlike std::uniform_real_distribution.
class SplitMix64 {
 public:
  explicit SplitMix64(std::uint64_t seed) : state_(seed) {}
  std::uint64_t next() {
    const std::uint64_t out = sim::mixSeed(state_);  // the SplitMix64 step: the finaliser of state + golden gamma
    state_ += 0x9E3779B97F4A7C15ull;
    return out;
  }
  float uniform(float bound) {
    const double u = static_cast<double>(next() >> 11) * (1.0 / 9007199254740992.0);
    return static_cast<float>((2.0 * u - 1.0) * bound);
  }

 private:
  std::uint64_t state_;
};

}  // namespace

std::string DuelingArchitecture::validate() const {
  if (conv_channels.empty()) return "architecture field 'conv_channels' is empty: the grid stream needs a convolution";
  if (conv_strides.size() != conv_channels.size()) {
    return "architecture field 'conv_strides' has " + std::to_string(conv_strides.size()) +
           " entries, 'conv_channels' has " + std::to_string(conv_channels.size()) + ": they must match";
  }
  for (std::uint32_t c : conv_channels)
    if (c == 0) return "architecture field 'conv_channels' contains 0";
  for (std::uint32_t s : conv_strides)
    if (s == 0) return "architecture field 'conv_strides' contains 0";
  if (conv_kernel == 0 || conv_kernel % 2 == 0) {
    return "architecture field 'conv_kernel' = " + std::to_string(conv_kernel) + ": must be odd and positive";
  }
  if (feature_hidden == 0) return "architecture field 'feature_hidden' must be positive";
  if (grid_channels == 0 || grid_channels > kMaxGridChannels) {
    return "architecture field 'grid_channels' = " + std::to_string(grid_channels) + ": must be in [1, " +
           std::to_string(kMaxGridChannels) + "]";
  }
  for (std::uint32_t h : trunk_hidden)
    if (h == 0) return "architecture field 'trunk_hidden' contains 0";
  if (feature_count != QNetwork::kFeatureCount && feature_count != QNetwork::kFeatureCountWithPreviousChoice) {
    return "architecture field 'feature_count' = " + std::to_string(feature_count) + ": must be " +
           std::to_string(QNetwork::kFeatureCount) + " or " +
           std::to_string(QNetwork::kFeatureCountWithPreviousChoice) + " (with the previous choice)";
  }
  if (wall_rays > static_cast<std::uint32_t>(kMaxWallRays))
    return "architecture field 'wall_rays' = " + std::to_string(wall_rays) + ": must be in [0, " +
           std::to_string(kMaxWallRays) + "]";
  if (person_tokens > static_cast<std::uint32_t>(kMaxPersonTokens))
    return "architecture field 'person_tokens' = " + std::to_string(person_tokens) + ": must be in [0, " +
           std::to_string(kMaxPersonTokens) + "]";
  if (route_points > static_cast<std::uint32_t>(kMaxRoutePoints))
    return "architecture field 'route_points' = " + std::to_string(route_points) + ": must be in [0, " +
           std::to_string(kMaxRoutePoints) + "]";
  if (person_tokens > 0 && token_hidden.empty()) return "architecture field 'token_hidden' is empty";
  for (std::uint32_t h : token_hidden)
    if (h == 0) return "architecture field 'token_hidden' contains 0";
  for (std::uint32_t h : attention_hidden)
    if (h == 0) return "architecture field 'attention_hidden' contains 0";
  if (quantiles < 1 || quantiles > kMaxQuantiles)
    return "architecture field 'quantiles' = " + std::to_string(quantiles) + ": must be in [1, " +
           std::to_string(kMaxQuantiles) + "]";
  if (cvar_count < 1 || cvar_count > quantiles)
    return "architecture field 'cvar_count' = " + std::to_string(cvar_count) + ": must be in [1, quantiles]";
  return {};
}

WeightFileContents makeRandomWeights(const DuelingArchitecture& arch, std::uint64_t seed,
                                     std::vector<std::pair<std::string, float>> normalization, std::string metadata) {
  const std::string problem = arch.validate();
  if (!problem.empty()) throw std::runtime_error("makeRandomWeights: " + problem);
  SplitMix64 rng(seed);
  WeightFileContents c;
  c.grid_rows = QNetwork::kGridRows;
  c.grid_cols = QNetwork::kGridCols;
  c.grid_channels = arch.grid_channels;
  c.feature_count = arch.feature_count;
  c.wall_ray_count = arch.wall_rays;
  c.person_token_count = arch.person_tokens;
  c.route_point_count = arch.route_points;
  c.token_size = arch.person_tokens > 0 ? static_cast<std::uint32_t>(kPersonTokenSize) : 0u;
  c.quantile_count = arch.quantiles;
  c.cvar_count = arch.cvar_count;
  c.format_version = weightFormatVersionFor(c);
  c.action_count = QNetwork::kActionCount;
  c.normalization = std::move(normalization);
  c.metadata = std::move(metadata);

  auto fill = [&rng](LayerRecord& l, std::uint64_t fan_in) {
    const float bound = 1.0f / std::sqrt(static_cast<float>(fan_in));
    l.weight.resize(l.weightCount());
    l.bias.resize(l.biasCount());
    for (float& w : l.weight) w = rng.uniform(bound);
    for (float& b : l.bias) b = rng.uniform(bound);
  };
  auto relu = [&c](LayerStream s) {
    LayerRecord l;
    l.stream = s;
    l.type = LayerType::kRelu;
    c.layers.push_back(l);
  };
  auto linear = [&](LayerStream s, std::uint32_t in, std::uint32_t out) {
    LayerRecord l;
    l.stream = s;
    l.type = LayerType::kLinear;
    l.in_features = in;
    l.out_features = out;
    fill(l, in);
    c.layers.push_back(std::move(l));
  };

  std::uint32_t channels = arch.grid_channels, h = QNetwork::kGridRows, w = QNetwork::kGridCols;
  const std::uint32_t k = arch.conv_kernel, pad = k / 2;
  for (std::size_t i = 0; i < arch.conv_channels.size(); ++i) {
    LayerRecord l;
    l.stream = LayerStream::kGrid;
    l.type = LayerType::kConv2d;
    l.in_channels = channels;
    l.out_channels = arch.conv_channels[i];
    l.kernel_h = l.kernel_w = k;
    l.stride_h = l.stride_w = arch.conv_strides[i];
    l.pad_h = l.pad_w = pad;
    fill(l, std::uint64_t{channels} * k * k);
    c.layers.push_back(std::move(l));
    relu(LayerStream::kGrid);
    channels = arch.conv_channels[i];
    h = (h + 2 * pad - k) / arch.conv_strides[i] + 1;
    w = (w + 2 * pad - k) / arch.conv_strides[i] + 1;
  }
  linear(LayerStream::kFeature, arch.feature_count + arch.wall_rays + kRoutePointInputs * arch.route_points,
         arch.feature_hidden);
  relu(LayerStream::kFeature);
  const std::uint32_t embedding = arch.person_tokens > 0 ? arch.token_hidden.back() : 0u;
  std::uint32_t width = channels * h * w + arch.feature_hidden + embedding;
  for (std::uint32_t hidden : arch.trunk_hidden) {
    linear(LayerStream::kTrunk, width, hidden);
    relu(LayerStream::kTrunk);
    width = hidden;
  }
  linear(LayerStream::kValue, width, arch.quantiles);
  linear(LayerStream::kAdvantage, width, QNetwork::kActionCount * arch.quantiles);
  if (arch.person_tokens > 0) {
    std::uint32_t in = kPersonTokenSize;
    for (std::uint32_t hidden : arch.token_hidden) {
      linear(LayerStream::kToken, in, hidden);
      relu(LayerStream::kToken);
      in = hidden;
    }
    in = 2 * embedding;
    for (std::uint32_t hidden : arch.attention_hidden) {
      linear(LayerStream::kAttention, in, hidden);
      relu(LayerStream::kAttention);
      in = hidden;
    }
    linear(LayerStream::kAttention, in, 1);
  }
  return c;
}

QNetwork QNetwork::load(const std::string& path) { return fromContents(readWeightFile(path), path); }

QNetwork QNetwork::fromBytes(const std::vector<std::uint8_t>& bytes, const std::string& source) {
  return fromContents(parseWeightFile(bytes, source), source);
}

QNetwork QNetwork::fromContents(const WeightFileContents& c, const std::string& source) {
  auto fail = [&source](const std::string& field, const std::string& reason) {
    throw WeightFileError(source, field, reason);
  };
  auto expectEqual = [&](const std::string& field, std::uint32_t found, int expected) {
    if (found != static_cast<std::uint32_t>(expected)) {
      fail(field,
           "file has " + std::to_string(found) + ", this planner's network input needs " + std::to_string(expected));
    }
  };
  if (c.format_version < kWeightFormatVersion || c.format_version > kWeightFormatVersionLatest) {
    fail("format version", "version " + std::to_string(c.format_version) + " is not supported (reader versions " +
                               std::to_string(kWeightFormatVersion) + " to " +
                               std::to_string(kWeightFormatVersionLatest) + ")");
  }
  if (c.format_version < kWeightFormatVersionRoute && c.route_point_count != 0)
    fail("format version", "version " + std::to_string(c.format_version) + " has no route points (version 4 does)");
  if (c.route_point_count > static_cast<std::uint32_t>(kMaxRoutePoints))
    fail("state layout: route points", "file has " + std::to_string(c.route_point_count) +
                                           ", the planner's states have at most " + std::to_string(kMaxRoutePoints));
  if (c.format_version < kWeightFormatVersionTokens &&
      (c.wall_ray_count != 0 || c.person_token_count != 0 || c.token_size != 0 || c.quantile_count != 1 ||
       c.cvar_count != 1)) {
    fail("format version", "version " + std::to_string(c.format_version) +
                               " has no wall rays, person tokens or quantiles (version 3 does)");
  }
  if (c.wall_ray_count > static_cast<std::uint32_t>(kMaxWallRays))
    fail("state layout: wall rays", "file has " + std::to_string(c.wall_ray_count) +
                                        ", the planner's states have at "
                                        "most " +
                                        std::to_string(kMaxWallRays));
  if (c.person_token_count > static_cast<std::uint32_t>(kMaxPersonTokens))
    fail("state layout: person tokens", "file has " + std::to_string(c.person_token_count) +
                                            ", the planner's states have at most " + std::to_string(kMaxPersonTokens));
  if (c.token_size != (c.person_token_count > 0 ? static_cast<std::uint32_t>(kPersonTokenSize) : 0u))
    fail("state layout: token size",
         "file has " + std::to_string(c.token_size) + ", the planner's person tokens " +
             (c.person_token_count > 0 ? "have " + std::to_string(kPersonTokenSize) + " floats"
                                       : std::string("are absent (0)")));
  if (c.quantile_count < 1 || c.quantile_count > kMaxQuantiles)
    fail("quantile count",
         "file has " + std::to_string(c.quantile_count) + ", must be in [1, " + std::to_string(kMaxQuantiles) + "]");
  if (c.cvar_count < 1 || c.cvar_count > c.quantile_count)
    fail("cvar count", "file has " + std::to_string(c.cvar_count) +
                           ", must be in [1, quantile count = " + std::to_string(c.quantile_count) + "]");
  if (c.format_version == kWeightFormatVersion && c.grid_channels != 1) {
    fail("state layout: grid channels",
         "a version 1 file has one grid channel, not " + std::to_string(c.grid_channels));
  }
  if (c.grid_channels < 1 || c.grid_channels > static_cast<std::uint32_t>(kMaxStateGridChannels)) {
    fail("state layout: grid channels",
         "file has " + std::to_string(c.grid_channels) + ": the planner's states " + kGridChannelsRule);
  }
  expectEqual("state layout: grid rows", c.grid_rows, kGridRows);
  expectEqual("state layout: grid cols", c.grid_cols, kGridCols);
  if (c.feature_count != static_cast<std::uint32_t>(kFeatureCount) &&
      c.feature_count != static_cast<std::uint32_t>(kFeatureCountWithPreviousChoice)) {
    fail("state layout: feature count", "file has " + std::to_string(c.feature_count) +
                                            ", this planner's network input needs " + std::to_string(kFeatureCount) +
                                            " (or " + std::to_string(kFeatureCountWithPreviousChoice) +
                                            " with the previous choice)");
  }
  expectEqual("action count", c.action_count, kActionCount);

  if (c.normalization.empty()) fail("normalization count", "the file carries no normalisation constants");
  std::set<std::string> names;
  for (const auto& [name, value] : c.normalization) {
    if (name.empty()) fail("normalization name", "empty name");
    if (!names.insert(name).second) fail("normalization entry '" + printableBytes(name) + "'", "name appears twice");
    if (!std::isfinite(value)) fail("normalization entry '" + printableBytes(name) + "'", "value is NaN or infinite");
  }

  // Pass 1: group the layers into streams and infer every shape.
  std::array<std::vector<PlannedLayer>, 7> streams;
  int last_stream = -1;
  for (std::size_t i = 0; i < c.layers.size(); ++i) {
    const LayerRecord& l = c.layers[i];
    const int s = static_cast<int>(l.stream);
    if (s < last_stream) {
      fail(layerName(i, l) + " stream",
           "layers must be grouped by stream in the order grid, feature, trunk, value, advantage, token, attention");
    }
    last_stream = s;
    if (l.weight.size() != l.weightCount() || l.bias.size() != l.biasCount()) {
      fail(layerName(i, l) + " sizes", "tensor lengths do not match the declared shape");
    }
    for (std::size_t j = 0; j < l.weight.size(); ++j) {
      if (!std::isfinite(l.weight[j]))
        fail(layerName(i, l) + " weight", "element " + std::to_string(j) + " is NaN or infinite");
    }
    for (std::size_t j = 0; j < l.bias.size(); ++j) {
      if (!std::isfinite(l.bias[j]))
        fail(layerName(i, l) + " bias", "element " + std::to_string(j) + " is NaN or infinite");
    }
    PlannedLayer p;
    p.index = i;
    p.record = &l;
    streams[s].push_back(p);
  }

  int concat_grid = 0, concat_feature = 0, trunk_out = 0;
  int max_col = 0;
  auto shapeError = [&](const PlannedLayer& p, const std::string& what, long found, long expected) {
    std::ostringstream os;
    os << what << " is " << found << " but the previous layer gives " << expected;
    fail(layerName(p.index, *p.record) + " shape", os.str());
  };
  // Vector streams (everything but the grid): linear and relu only.
  auto planVector = [&](std::vector<PlannedLayer>& layers, int in_size, const char* stream_name) {
    int size = in_size;
    for (PlannedLayer& p : layers) {
      const LayerRecord& l = *p.record;
      p.in_c = size;
      if (l.type == LayerType::kConv2d) {
        fail(layerName(p.index, l) + " type",
             std::string("the ") + stream_name + " stream takes linear and relu layers only");
      } else if (l.type == LayerType::kLinear) {
        if (static_cast<int>(l.in_features) != size) shapeError(p, "in_features", l.in_features, size);
        size = static_cast<int>(l.out_features);
      }
      p.out_c = size;
    }
    return size;
  };
  auto requireWeighted = [&](const std::vector<PlannedLayer>& layers, LayerType type, const char* stream_name) {
    for (const PlannedLayer& p : layers)
      if (p.record->type == type) return;
    fail(std::string(stream_name) + " stream", std::string("has no ") + layerTypeName(type) + " layer");
  };

  {  // grid stream
    requireWeighted(streams[0], LayerType::kConv2d, "grid");
    int ch = static_cast<int>(c.grid_channels), h = kGridRows, w = kGridCols;
    for (PlannedLayer& p : streams[0]) {
      const LayerRecord& l = *p.record;
      p.in_c = ch;
      p.in_h = h;
      p.in_w = w;
      if (l.type == LayerType::kLinear) {
        fail(layerName(p.index, l) + " type", "the grid stream takes conv2d and relu layers only");
      } else if (l.type == LayerType::kConv2d) {
        if (static_cast<int>(l.in_channels) != ch) shapeError(p, "in_channels", l.in_channels, ch);
        const long padded_h = h + 2L * l.pad_h, padded_w = w + 2L * l.pad_w;
        if (l.kernel_h > padded_h || l.kernel_w > padded_w) {
          std::ostringstream os;
          os << "kernel " << l.kernel_h << "x" << l.kernel_w << " is larger than the padded input " << padded_h << "x"
             << padded_w;
          fail(layerName(p.index, l) + " shape", os.str());
        }
        // Sizes in 64 bits, bounded before they become ints: padding alone can make an output far larger than
        // the file (a 1x1 kernel with 65536 padding is 131092 x 131092 pixels per channel).
        const std::int64_t out_h = (padded_h - l.kernel_h) / l.stride_h + 1;
        const std::int64_t out_w = (padded_w - l.kernel_w) / l.stride_w + 1;
        const std::int64_t pixels = out_h * out_w;
        const std::int64_t taps = std::int64_t{l.in_channels} * l.kernel_h * l.kernel_w;
        if (std::int64_t{l.out_channels} * pixels > kMaxActivation || taps > kMaxActivation / pixels) {
          std::ostringstream os;
          os << "output " << l.out_channels << " x " << out_h << " x " << out_w << " with " << taps
             << " kernel taps per pixel exceeds the " << kMaxActivation << "-value limit of one activation";
          fail(layerName(p.index, l) + " shape", os.str());
        }
        ch = static_cast<int>(l.out_channels);
        h = static_cast<int>(out_h);
        w = static_cast<int>(out_w);
        max_col = std::max(max_col, static_cast<int>(taps * pixels));
      }
      p.out_c = ch;
      p.out_h = h;
      p.out_w = w;
    }
    concat_grid = ch * h * w;
  }
  requireWeighted(streams[1], LayerType::kLinear, "feature");
  const int feature_count = static_cast<int>(c.feature_count);
  const int wall_rays = static_cast<int>(c.wall_ray_count);
  const int route_points = static_cast<int>(c.route_point_count);
  const int flat_inputs = feature_count + wall_rays + kRoutePointInputs * route_points;
  concat_feature = planVector(streams[1], flat_inputs, "feature");
  const int tokens = static_cast<int>(c.person_token_count), token_size = static_cast<int>(c.token_size);
  int embedding = 0;
  if (tokens > 0) {
    requireWeighted(streams[5], LayerType::kLinear, "token");
    embedding = planVector(streams[5], token_size, "token");
    requireWeighted(streams[6], LayerType::kLinear, "attention");
    if (const int a = planVector(streams[6], 2 * embedding, "attention"); a != 1)
      fail("attention stream", "ends with " + std::to_string(a) + " outputs, the attention score needs 1");
  } else if (!streams[5].empty() || !streams[6].empty()) {
    fail("token stream", "the file has token or attention layers but no person tokens");
  }
  trunk_out = planVector(streams[2], concat_grid + concat_feature + embedding, "trunk");
  const int quantiles = static_cast<int>(c.quantile_count);
  requireWeighted(streams[3], LayerType::kLinear, "value");
  if (const int v = planVector(streams[3], trunk_out, "value"); v != quantiles) {
    fail("value stream", "ends with " + std::to_string(v) + " outputs, the value head needs one per quantile (" +
                             std::to_string(quantiles) + ")");
  }
  requireWeighted(streams[4], LayerType::kLinear, "advantage");
  if (const int a = planVector(streams[4], trunk_out, "advantage"); a != kActionCount * quantiles) {
    fail("advantage stream", "ends with " + std::to_string(a) +
                                 " outputs, the advantage head needs one per action and quantile (" +
                                 std::to_string(kActionCount * quantiles) + ")");
  }

  // Pass 2: lay the activations out in one scratch buffer and turn layers into ops.
  QNetwork net;
  net.source_ = source;
  net.metadata_ = c.metadata;
  net.normalization_ = c.normalization;
  int cursor = 0;
  auto alloc = [&cursor, &fail](int n) {
    const int at = cursor;
    if (std::int64_t{cursor} + roundUp16(n) > kMaxScratch) {
      fail("layers", "the activations need more than the " + std::to_string(kMaxScratch) + "-float scratch limit");
    }
    cursor += roundUp16(n);
    return at;
  };
  net.grid_channels_ = static_cast<int>(c.grid_channels);
  const int grid_size = net.grid_channels_ * kGridRows * kGridCols;
  net.feature_count_ = feature_count;
  net.wall_rays_ = wall_rays;
  net.route_points_ = route_points;
  net.person_tokens_ = tokens;
  net.token_size_ = token_size;
  net.quantiles_ = quantiles;
  net.cvar_count_ = static_cast<int>(c.cvar_count);
  net.token_embedding_ = embedding;
  const int state_offset = alloc(net.stateSize());
  net.state_offset_ = state_offset;
  const int concat_offset = alloc(concat_grid + concat_feature + embedding);
  const int col_offset = alloc(max_col);

  // Runs one stream starting from region (offset, size); `final_offset` >= 0 makes its last weighted layer
  // write there (the concatenation). Returns the offset of the stream's output.
  auto emit = [&](const std::vector<PlannedLayer>& layers, int offset, int size, int final_offset,
                  std::vector<Op>& target) {
    std::size_t last_weighted = layers.size();
    for (std::size_t i = 0; i < layers.size(); ++i)
      if (layers[i].record->type != LayerType::kRelu) last_weighted = i;
    bool own_region = false;  // false while the current region is shared with another stream
    for (std::size_t i = 0; i < layers.size(); ++i) {
      const PlannedLayer& p = layers[i];
      const LayerRecord& l = *p.record;
      Op op;
      op.in_offset = offset;
      op.in_size = size;
      op.out_size = p.outSize();
      std::ostringstream desc;
      desc << layerStreamName(l.stream) << " " << layerTypeName(l.type);
      if (l.type == LayerType::kRelu) {
        op.kind = OpKind::kRelu;
        op.out_offset = own_region ? offset : alloc(size);
        desc << " (" << size << ")";
      } else {
        op.param = static_cast<int>(net.weights_.size());
        op.out_offset = (i == last_weighted && final_offset >= 0) ? final_offset : alloc(op.out_size);
        if (l.type == LayerType::kConv2d) {
          op.kind = OpKind::kConv;
          op.in_channels = p.in_c;
          op.in_h = p.in_h;
          op.in_w = p.in_w;
          op.out_h = p.out_h;
          op.out_w = p.out_w;
          op.kernel_h = static_cast<int>(l.kernel_h);
          op.kernel_w = static_cast<int>(l.kernel_w);
          op.stride_h = static_cast<int>(l.stride_h);
          op.stride_w = static_cast<int>(l.stride_w);
          op.pad_h = static_cast<int>(l.pad_h);
          op.pad_w = static_cast<int>(l.pad_w);
          op.col_offset = col_offset;
          const int k = p.in_c * op.kernel_h * op.kernel_w;
          net.weights_.push_back(Eigen::Map<const RowMatrix>(l.weight.data(), l.out_channels, k));
          desc << " " << p.in_c << "->" << l.out_channels << " kernel " << l.kernel_h << "x" << l.kernel_w << " stride "
               << l.stride_h << "x" << l.stride_w << " pad " << l.pad_h << "x" << l.pad_w << " (" << p.in_h << "x"
               << p.in_w << " -> " << p.out_h << "x" << p.out_w << ")";
        } else {
          op.kind = OpKind::kLinear;
          net.weights_.push_back(Eigen::Map<const RowMatrix>(l.weight.data(), l.out_features, l.in_features));
          desc << " " << l.in_features << "->" << l.out_features;
        }
        net.biases_.push_back(
            Eigen::Map<const Eigen::VectorXf>(l.bias.data(), static_cast<Eigen::Index>(l.bias.size())));
      }
      own_region = true;
      offset = op.out_offset;
      size = op.out_size;
      target.push_back(op);
      net.layer_descriptions_.push_back(desc.str());
    }
    return offset;
  };
  emit(streams[0], state_offset, grid_size, concat_offset, net.ops_);
  emit(streams[1], state_offset + grid_size, flat_inputs, concat_offset + concat_grid, net.ops_);
  if (tokens > 0) {
    net.token_in_offset_ = alloc(token_size);
    net.token_out_offset_ = emit(streams[5], net.token_in_offset_, token_size, -1, net.token_ops_);
    net.embeddings_offset_ = alloc(tokens * embedding);
    net.attention_in_offset_ = alloc(2 * embedding);
    net.attention_out_offset_ = emit(streams[6], net.attention_in_offset_, 2 * embedding, -1, net.attention_ops_);
    net.pooled_offset_ = concat_offset + concat_grid + concat_feature;
  }
  const int trunk_offset = emit(streams[2], concat_offset, concat_grid + concat_feature + embedding, -1, net.post_ops_);
  // Both heads read the trunk output; emit() never writes in place into a region it did not create.
  net.value_offset_ = emit(streams[3], trunk_offset, trunk_out, -1, net.post_ops_);
  net.advantage_offset_ = emit(streams[4], trunk_offset, trunk_out, -1, net.post_ops_);
  net.scratch_size_ = cursor;
  return net;
}

void QNetwork::runOp(const Op& op, float* scratch) const {
  const float* in = scratch + op.in_offset;
  float* out = scratch + op.out_offset;
  switch (op.kind) {
    case OpKind::kRelu: {
      Eigen::Map<Eigen::VectorXf>(out, op.out_size) = Eigen::Map<const Eigen::VectorXf>(in, op.in_size).cwiseMax(0.0f);
      return;
    }
    case OpKind::kLinear: {
      Eigen::Map<Eigen::VectorXf> y(out, op.out_size);
      y.noalias() = weights_[op.param] * Eigen::Map<const Eigen::VectorXf>(in, op.in_size);
      y += biases_[op.param];
      return;
    }
    case OpKind::kConv: {
      // im2col: row (ci, ky, kx) holds, for every output pixel, the input value under that kernel tap
      // (0 in the padding), so the convolution becomes one matrix product with the [out, in*kh*kw] weights.
      const int pixels = op.out_h * op.out_w;
      float* col = scratch + op.col_offset;
      int row = 0;
      for (int ci = 0; ci < op.in_channels; ++ci) {
        const float* plane = in + ci * op.in_h * op.in_w;
        for (int ky = 0; ky < op.kernel_h; ++ky) {
          for (int kx = 0; kx < op.kernel_w; ++kx, ++row) {
            float* dst = col + row * pixels;
            for (int oy = 0; oy < op.out_h; ++oy) {
              const int iy = oy * op.stride_h - op.pad_h + ky;
              float* dst_row = dst + oy * op.out_w;
              if (iy < 0 || iy >= op.in_h) {
                std::fill(dst_row, dst_row + op.out_w, 0.0f);
                continue;
              }
              const float* src = plane + iy * op.in_w;
              for (int ox = 0; ox < op.out_w; ++ox) {
                const int ix = ox * op.stride_w - op.pad_w + kx;
                dst_row[ox] = (ix >= 0 && ix < op.in_w) ? src[ix] : 0.0f;
              }
            }
          }
        }
      }
      const RowMatrix& w = weights_[op.param];
      Eigen::Map<RowMatrix> y(out, w.rows(), pixels);
      y.noalias() = w * Eigen::Map<const RowMatrix>(col, w.cols(), pixels);
      y.colwise() += biases_[op.param];
      return;
    }
  }
}

const float* QNetwork::forward(const Eigen::Ref<const Eigen::VectorXf>& state) const {
  const int state_size = stateSize(), grid_size = grid_channels_ * kGridRows * kGridCols;
  if (state.size() != state_size) {
    throw QNetworkInputError(
        "Q-network state has " + std::to_string(state.size()) + " elements, expected " + std::to_string(state_size) +
        " (" + std::to_string(grid_channels_) + " x 20 x 20 grid + " + std::to_string(feature_count_) + " features" +
        (wall_rays_ > 0 ? " + " + std::to_string(wall_rays_) + " wall rays" : std::string()) +
        (route_points_ > 0 ? " + " + std::to_string(route_points_) + " route points" : std::string()) +
        (person_tokens_ > 0 ? " + " + std::to_string(person_tokens_) + " person tokens" : std::string()) + ")");
  }
  for (int i = 0; i < state_size; ++i) {
    if (!std::isfinite(state[i])) {
      const int after_grid = i - grid_size, after_features = after_grid - feature_count_,
                after_rays = after_features - wall_rays_, after_route = after_rays - kRoutePointInputs * route_points_;
      const std::string where = i < grid_size        ? std::string("grid")
                                : after_features < 0 ? "feature " + std::to_string(after_grid)
                                : after_rays < 0     ? "wall ray " + std::to_string(after_features)
                                : after_route < 0
                                    ? "route point " + std::to_string(after_rays / kRoutePointInputs)
                                    : "person token " + std::to_string(after_route / std::max(token_size_, 1));
      throw QNetworkInputError("Q-network state element " + std::to_string(i) + " is " +
                               (std::isnan(state[i]) ? "NaN" : "infinite") + " (" + where + ")");
    }
  }
  // One buffer per thread, shared by every network evaluated on it; it only grows.
  thread_local AlignedFloats scratch;
  if (static_cast<int>(scratch.size()) < scratch_size_) scratch.resize(scratch_size_);
  float* s = scratch.data();
  std::copy(state.data(), state.data() + state_size, s + state_offset_);
  for (const Op& op : ops_) runOp(op, s);
  if (person_tokens_ > 0) {
    // Each present token through the encoder, then a softmax over the attention scores of the present ones; the
    // pooled encoding is 0 when no token is present.
    const int e = token_embedding_;
    const float* tokens = s + state_offset_ + grid_size + flatInputs();
    float* embeddings = s + embeddings_offset_;
    float* pooled = s + pooled_offset_;
    int present = 0;
    for (int k = 0; k < person_tokens_; ++k) {
      const float* t = tokens + k * token_size_;
      if (!(t[0] > 0.5f)) continue;
      std::copy(t, t + token_size_, s + token_in_offset_);
      for (const Op& op : token_ops_) runOp(op, s);
      std::copy(s + token_out_offset_, s + token_out_offset_ + e, embeddings + present * e);
      ++present;
    }
    std::fill(pooled, pooled + e, 0.0f);
    if (present > 0) {
      float* attention_in = s + attention_in_offset_;
      Eigen::Map<Eigen::VectorXf> mean(attention_in + e, e);
      mean.setZero();
      for (int k = 0; k < present; ++k) mean += Eigen::Map<const Eigen::VectorXf>(embeddings + k * e, e);
      mean /= static_cast<float>(present);
      std::array<float, kMaxPersonTokens> score{};
      float top = -std::numeric_limits<float>::infinity();
      for (int k = 0; k < present; ++k) {
        std::copy(embeddings + k * e, embeddings + (k + 1) * e, attention_in);
        for (const Op& op : attention_ops_) runOp(op, s);
        score[static_cast<size_t>(k)] = s[attention_out_offset_];
        top = std::max(top, score[static_cast<size_t>(k)]);
      }
      float total = 0.0f;
      for (int k = 0; k < present; ++k)
        total += (score[static_cast<size_t>(k)] = std::exp(score[static_cast<size_t>(k)] - top));
      Eigen::Map<Eigen::VectorXf> out(pooled, e);
      for (int k = 0; k < present; ++k)
        out += (score[static_cast<size_t>(k)] / total) * Eigen::Map<const Eigen::VectorXf>(embeddings + k * e, e);
    }
  }
  for (const Op& op : post_ops_) runOp(op, s);
  return s;
}

const float* QNetwork::zValues(const Eigen::Ref<const Eigen::VectorXf>& state) const {
  const float* s = forward(state);
  const float* value = s + value_offset_;
  const float* adv = s + advantage_offset_;
  const int n = quantiles_;
  thread_local std::vector<float> z;  // grows once per thread, like the scratch
  if (static_cast<int>(z.size()) < kActionCount * n) z.resize(static_cast<size_t>(kActionCount * n));
  for (int j = 0; j < n; ++j) {
    float mean = 0.0f;
    for (int a = 0; a < kActionCount; ++a) mean += adv[a * n + j];
    mean /= static_cast<float>(kActionCount);
    for (int a = 0; a < kActionCount; ++a) {
      const float q = value[j] + adv[a * n + j] - mean;
      if (!std::isfinite(q)) {
        throw QNetworkInputError("Q-network output for action " + std::to_string(a) +
                                 " is not finite (state values far outside the training range?)");
      }
      z[static_cast<size_t>(a * n + j)] = q;
    }
  }
  return z.data();
}

std::vector<float> QNetwork::quantileValues(const Eigen::Ref<const Eigen::VectorXf>& state) const {
  const float* z = zValues(state);
  return std::vector<float>(z, z + kActionCount * quantiles_);
}

QNetwork::QValues QNetwork::qValues(const Eigen::Ref<const Eigen::VectorXf>& state) const {
  const float* z = zValues(state);
  QValues q;
  for (int a = 0; a < kActionCount; ++a) {
    float sum = 0.0f;
    for (int j = 0; j < quantiles_; ++j) sum += z[a * quantiles_ + j];
    q[static_cast<size_t>(a)] = quantiles_ == 1 ? sum : sum / static_cast<float>(quantiles_);
  }
  return q;
}

QNetwork::QValues QNetwork::actionValues(const Eigen::Ref<const Eigen::VectorXf>& state) const {
  if (cvar_count_ == quantiles_) return qValues(state);
  float* z = const_cast<float*>(zValues(state));  // this thread's buffer: sorted in place
  QValues out;
  for (int a = 0; a < kActionCount; ++a) {
    float* first = z + a * quantiles_;
    std::sort(first, first + quantiles_);
    float sum = 0.0f;
    for (int j = 0; j < cvar_count_; ++j) sum += first[j];
    out[static_cast<size_t>(a)] = sum / static_cast<float>(cvar_count_);
  }
  return out;
}

int QNetwork::maskedArgmax(const QValues& q, const ActionMask& mask) {
  int best = -1;
  for (int a = 0; a < kActionCount; ++a) {
    if (!mask[a] || std::isnan(q[a])) continue;
    if (best < 0 || q[a] > q[best]) best = a;
  }
  return best;
}

int QNetwork::selectAction(const Eigen::Ref<const Eigen::VectorXf>& state, const ActionMask& mask) const {
  if (std::none_of(mask.begin(), mask.end(), [](bool b) { return b; })) return -1;
  return maskedArgmax(actionValues(state), mask);
}

std::string QNetwork::normalizationMismatch(const std::vector<std::pair<std::string, float>>& expected,
                                            float rel_tol) const {
  std::ostringstream os;
  for (const auto& [name, value] : expected) {
    const auto it = std::find_if(normalization_.begin(), normalization_.end(),
                                 [&name = name](const auto& e) { return e.first == name; });
    if (it == normalization_.end()) {
      os << "'" << name << "' is expected but missing from the file; ";
      continue;
    }
    const float scale = std::max({1.0f, std::abs(value), std::abs(it->second)});
    if (!(std::abs(it->second - value) <= rel_tol * scale)) {
      os << "'" << name << "' is " << it->second << " in the file but " << value << " here; ";
    }
  }
  for (const auto& [name, value] : normalization_) {
    const bool known =
        std::any_of(expected.begin(), expected.end(), [&name = name](const auto& e) { return e.first == name; });
    if (!known) os << "'" << printableBytes(name) << "' (= " << value << ") is in the file but not expected; ";
  }
  std::string out = os.str();
  if (!out.empty()) out = "normalisation of '" + source_ + "' differs: " + out.substr(0, out.size() - 2);
  return out;
}

std::string QNetwork::gridChannelsMismatch(int expected) const {
  if (expected == grid_channels_) return {};
  return "state layout of '" + source_ + "' differs: 'state layout: grid channels' is " +
         std::to_string(grid_channels_) + " in the file but " + std::to_string(expected) +
         " here (check dovs/grid_channels of dovs_node)";
}

std::string QNetwork::previousActionMismatch(bool expected) const {
  const int want = expected ? kFeatureCountWithPreviousChoice : kFeatureCount;
  if (want == feature_count_) return {};
  return "state layout of '" + source_ + "' differs: 'state layout: feature count' is " +
         std::to_string(feature_count_) + " in the file but " + std::to_string(want) +
         " here (check dovs/previous_action: 1 adds the previous choice, in training and evaluation only)";
}

std::string QNetwork::tokenLayoutMismatch(int wall_rays, int person_tokens, int route_points) const {
  if (route_points != route_points_)
    return "state layout of '" + source_ + "' differs: 'state layout: route points' is " +
           std::to_string(route_points_) + " in the file but " + std::to_string(route_points) +
           " here (check dovs/route_points)";
  if (wall_rays != wall_rays_)
    return "state layout of '" + source_ + "' differs: 'state layout: wall rays' is " + std::to_string(wall_rays_) +
           " in the file but " + std::to_string(wall_rays) + " here (check dovs/wall_rays)";
  if (person_tokens != person_tokens_)
    return "state layout of '" + source_ + "' differs: 'state layout: person tokens' is " +
           std::to_string(person_tokens_) + " in the file but " + std::to_string(person_tokens) +
           " here (check dovs/person_tokens)";
  return {};
}

std::string QNetwork::describe() const {
  std::ostringstream os;
  os << "Q-network '" << source_ << "': state " << grid_channels_ << "x" << kGridRows << "x" << kGridCols << " grid + "
     << feature_count_ << " features + " << wall_rays_ << " wall rays + " << route_points_ << " route points + "
     << person_tokens_ << " person tokens, " << kActionCount << " actions, " << quantiles_
     << " quantiles (choice: mean of the lowest " << cvar_count_ << ")\n";
  for (std::size_t i = 0; i < layer_descriptions_.size(); ++i)
    os << "  " << i << ": " << layer_descriptions_[i] << "\n";
  return os.str();
}

}  // namespace dqn_dovs
