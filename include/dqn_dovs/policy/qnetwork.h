// The DQN-DOVS Q-network on the robot: Eigen inference of the two-stream dueling network stored in a
// `.dqnw` weight file (docs/weight_format.md), with masked action choice.
// Numerically the same function as python/dqn_dovs_py/model.py's DuelingQNet (parity-tested to 1e-4).
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "dqn_dovs/policy/weight_file.h"

namespace dqn_dovs {

/// A state the network cannot evaluate (wrong size, NaN/inf), or Q-values that came out non-finite.
/// The planner reacts by decelerating.
class QNetworkInputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Shape of the two-stream dueling network; the same hyper-parameters, names and defaults as the
/// constructor of python/dqn_dovs_py/model.py's DuelingQNet. Used to generate networks in C++ (tests,
/// benchmarks); a loaded network takes its shapes from the file.
struct DuelingArchitecture {
  /// Output channels of each 3x3 convolution of the grid stream, in order.
  std::vector<std::uint32_t> conv_channels = {8, 16, 16};
  /// Stride of each convolution (same length as conv_channels); padding is conv_kernel / 2.
  std::vector<std::uint32_t> conv_strides = {1, 2, 2};
  /// Square kernel side of every convolution, odd.
  std::uint32_t conv_kernel = 3;
  /// Width of the single hidden layer of the feature stream.
  std::uint32_t feature_hidden = 64;
  /// Widths of the trunk's hidden layers after the concatenation, in order.
  std::vector<std::uint32_t> trunk_hidden = {256, 128};
  /// Channels of the grid image the first convolution reads (1: the DOVS grid; 2 or 3: docs/dovs.md "Grid
  /// channels"). A file with more than one is written as format version 2.
  std::uint32_t grid_channels = 1;
  /// Inputs of the feature stream: 8 (the features) or 17 (with the previous choice, docs/dovs.md "The previous
  /// action"; QNetwork::kFeatureCountWithPreviousChoice).
  std::uint32_t feature_count = 8;
  /// Wall rays and person tokens in the state (docs/dovs.md "Person tokens"); with tokens, the token encoder's
  /// hidden widths (its last is the encoding's width) and the attention score's hidden widths. A file with any of
  /// them, or with quantiles > 1, is written as format version 3.
  std::uint32_t wall_rays = 0;
  std::uint32_t person_tokens = 0;
  /// Route points in the state after the wall rays (docs/dovs.md "The route ahead"), 2 feature-stream inputs each.
  /// A file with any is written as format version 4.
  std::uint32_t route_points = 0;
  std::vector<std::uint32_t> token_hidden = {64, 64};
  std::vector<std::uint32_t> attention_hidden = {64};
  /// Quantiles of each action's return (1: the plain dueling head) and how many of the lowest the choice averages.
  std::uint32_t quantiles = 1;
  std::uint32_t cvar_count = 1;

  /// Empty when consistent, otherwise a message naming the offending field and why.
  std::string validate() const;
};

/// Layer records of `arch` for the standard state (arch.grid_channels x 20 x 20 grid, arch.feature_count features, 8
/// actions), weights
/// drawn like PyTorch's default initialisation (uniform in +-1/sqrt(fan_in)) from a fixed-seed generator.
WeightFileContents makeRandomWeights(const DuelingArchitecture& arch, std::uint64_t seed,
                                     std::vector<std::pair<std::string, float>> normalization,
                                     std::string metadata = "random weights");

class QNetwork {
 public:
  static constexpr int kGridRows = 20;
  static constexpr int kGridCols = 20;
  static constexpr int kFeatureCount = 8;
  /// Feature inputs of a network whose state carries the previous choice after the 8 features (9 more inputs;
  /// DovsConfig::previous_action, docs/dovs.md "The previous action"): the file's `state layout: feature count`.
  static constexpr int kFeatureCountWithPreviousChoice = kFeatureCount + 9;
  /// State size of a network on the one-channel grid (the paper's state); stateSize() is this network's.
  static constexpr int kStateSize = kGridRows * kGridCols + kFeatureCount;  ///< 408
  static constexpr int kActionCount = 8;

  using QValues = std::array<float, kActionCount>;
  using ActionMask = std::array<bool, kActionCount>;

  /// Reads `path` and builds the network. Throws WeightFileError naming the file and the field on any
  /// problem: missing file, magic, version, truncation, checksum, state layout, action count, layer
  /// shapes that do not chain, NaN/inf weights or normalisation values.
  static QNetwork load(const std::string& path);

  /// Builds the network from a complete weight file image in memory (parseWeightFile + fromContents), with
  /// the same checks and WeightFileError messages as load(); `source` names the bytes in the errors.
  static QNetwork fromBytes(const std::vector<std::uint8_t>& bytes, const std::string& source);

  /// Builds the network from parsed contents; `source` names them in error messages (a path).
  static QNetwork fromContents(const WeightFileContents& contents, const std::string& source);

  /// Channels of the grid image this network reads (the file's `state layout: grid channels`; 1 for version 1).
  int gridChannels() const { return grid_channels_; }
  /// Inputs after the grid (the file's `state layout: feature count`): kFeatureCount, or
  /// kFeatureCountWithPreviousChoice when the state carries the previous choice.
  int featureCount() const { return feature_count_; }
  /// Wall rays after the features (version 3's `state layout: wall rays`, 0 before).
  int wallRays() const { return wall_rays_; }
  /// Route points after the wall rays (version 4's `state layout: route points`, 0 before), 2 floats each.
  int routePoints() const { return route_points_; }
  /// Person tokens after the wall rays and the route points (version 3's `state layout: person tokens`, 0 before), each
  /// kPersonTokenSize (dovs/state.h) floats.
  int personTokens() const { return person_tokens_; }
  /// Quantiles of each action's return (1: a plain Q-network) and how many of the lowest ones the action choice
  /// averages (version 3's `quantile count`, `cvar count`).
  int quantileCount() const { return quantiles_; }
  int cvarCount() const { return cvar_count_; }
  /// Floats in one state: gridChannels() x 20 x 20 grid values (channel-major, each row-major), then featureCount(),
  /// then wallRays(), then routePoints() x 2, then personTokens() tokens.
  int stateSize() const { return grid_channels_ * kGridRows * kGridCols + flatInputs() + person_tokens_ * token_size_; }
  /// The feature stream's inputs: featureCount() + wallRays() + 2 x routePoints().
  int flatInputs() const { return feature_count_ + wall_rays_ + 2 * route_points_; }

  /// Q-values of one state (stateSize() floats: the grid channels row-major, then the features).
  /// Throws QNetworkInputError on a wrong size or a NaN/inf element (naming the index), and when the
  /// result is not finite. Thread-safe: scratch memory is per thread, allocated on a thread's first call
  /// (and when a larger network is evaluated), so steady-state calls do not allocate.
  QValues qValues(const Eigen::Ref<const Eigen::VectorXf>& state) const;

  /// What the action choice maximises: with quantileCount() = N > 1 each action's CVaR, the mean of its cvarCount()
  /// lowest quantiles (sorted ascending); the Q-values otherwise. Throws like qValues.
  QValues actionValues(const Eigen::Ref<const Eigen::VectorXf>& state) const;

  /// Every quantile, action-major (action a's quantile j at a * quantileCount() + j): Z = V + A - mean over actions.
  /// Throws like qValues.
  std::vector<float> quantileValues(const Eigen::Ref<const Eigen::VectorXf>& state) const;

  /// The valid action with the highest action value (actionValues; the Q-value of a plain network) (lowest index on
  /// ties), or -1 when no action is valid, in which case the network is not evaluated and the caller decelerates.
  /// Throws like qValues.
  int selectAction(const Eigen::Ref<const Eigen::VectorXf>& state, const ActionMask& mask) const;

  /// Masked argmax on precomputed Q-values: -1 when the mask is all false; NaN values are never chosen.
  static int maskedArgmax(const QValues& q, const ActionMask& mask);

  /// The normalisation constants the network was trained with, in file order.
  const std::vector<std::pair<std::string, float>>& normalization() const { return normalization_; }

  /// Empty when the file's normalisation has exactly the names of `expected` (any order) with values
  /// equal within `rel_tol` (relative, absolute near 0); otherwise a message naming every mismatch.
  /// The planner calls it with its own state normaliser's constants before trusting the network.
  std::string normalizationMismatch(const std::vector<std::pair<std::string, float>>& expected,
                                    float rel_tol = 1e-6f) const;

  /// Empty when the network reads `expected` grid channels, otherwise a message naming the file's
  /// `state layout: grid channels` and the DOVS parameter that sets the states' (dovs/grid_channels).
  std::string gridChannelsMismatch(int expected) const;

  /// Empty when the network reads the previous choice exactly when `expected` says the states carry it, otherwise a
  /// message naming the file's `state layout: feature count` and the DOVS parameter (dovs/previous_action).
  std::string previousActionMismatch(bool expected) const;

  /// Empty when the network reads exactly `wall_rays` wall rays, `person_tokens` person tokens and `route_points`
  /// route points, otherwise a message naming the file's state layout field and the DOVS parameter (dovs/wall_rays,
  /// dovs/person_tokens, dovs/route_points).
  std::string tokenLayoutMismatch(int wall_rays, int person_tokens, int route_points) const;
  /// Free-text provenance (training command, date, config, seed, source commit, init from).
  std::string metadata() const { return metadata_; }

  /// Where the network was loaded from.
  const std::string& source() const { return source_; }

  /// One line per layer with its shape, for logs.
  std::string describe() const;

 private:
  enum class OpKind { kConv, kLinear, kRelu };
  /// One step of the forward pass on the flat per-thread scratch buffer (offsets in floats).
  struct Op {
    OpKind kind = OpKind::kRelu;
    int in_offset = 0;
    int in_size = 0;
    int out_offset = 0;
    int out_size = 0;
    int param = -1;  ///< index into weights_/biases_ (conv, linear)
    // conv geometry
    int in_channels = 0, in_h = 0, in_w = 0, out_h = 0, out_w = 0;
    int kernel_h = 0, kernel_w = 0, stride_h = 0, stride_w = 0, pad_h = 0, pad_w = 0;
    int col_offset = 0;  ///< im2col matrix, (in_channels * kernel_h * kernel_w) x (out_h * out_w)
  };
  using RowMatrix = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

  QNetwork() = default;
  void runOp(const Op& op, float* scratch) const;
  /// Runs the network on `state` (checked) and returns the thread's scratch with the heads' outputs in place.
  const float* forward(const Eigen::Ref<const Eigen::VectorXf>& state) const;
  /// forward, then every quantile action-major in a per-thread buffer (valid until the thread's next call).
  const float* zValues(const Eigen::Ref<const Eigen::VectorXf>& state) const;

  std::vector<Op> ops_;            // grid and feature streams (into the concatenation)
  std::vector<Op> post_ops_;       // trunk, value and advantage heads
  std::vector<Op> token_ops_;      // the token encoder, run on each present token
  std::vector<Op> attention_ops_;  // the attention score, run on each present token's [encoding, mean encoding]
  int wall_rays_ = 0;
  int route_points_ = 0;
  int person_tokens_ = 0;
  int token_size_ = 0;
  int quantiles_ = 1;
  int cvar_count_ = 1;
  int token_embedding_ = 0;      // width of the token encoder's output (E)
  int token_in_offset_ = 0;      // where one token is copied for the encoder
  int token_out_offset_ = 0;     // the encoder's output
  int embeddings_offset_ = 0;    // every token's encoding, person_tokens_ x E
  int attention_in_offset_ = 0;  // [encoding, mean encoding], 2E
  int attention_out_offset_ = 0;
  int pooled_offset_ = 0;  // the pooled encoding, inside the concatenation
  int state_offset_ = 0;
  std::vector<RowMatrix> weights_;
  std::vector<Eigen::VectorXf> biases_;
  int scratch_size_ = 0;
  int grid_channels_ = 1;
  int feature_count_ = kFeatureCount;
  int value_offset_ = 0;
  int advantage_offset_ = 0;
  std::vector<std::string> layer_descriptions_;
  std::vector<std::pair<std::string, float>> normalization_;
  std::string metadata_;
  std::string source_;
};

}  // namespace dqn_dovs
