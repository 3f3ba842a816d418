// The `.dqnw` weight file of the Q-network (docs/weight_format.md): its in-memory form, a strict reader
// and a writer. The Python exporter (python/dqn_dovs_py/export.py) writes the same bytes.
// The reader checks the container (magic, version, sizes, truncation, checksum); whether the layers form
// a network the planner can run is checked by QNetwork (qnetwork.h).
#pragma once

#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace dqn_dovs {

/// Eight bytes at offset 0 of every weight file.
inline constexpr char kWeightFileMagic[9] = "DQNDOVSW";
/// The format version of a network on the paper's one-channel grid (every file written before grid channels
/// existed). Writers use it whenever grid_channels is 1, so such a file's bytes do not change.
inline constexpr std::uint32_t kWeightFormatVersion = 1;
/// Version 2 adds one field, `state layout: grid channels`, after the grid's columns (docs/weight_format.md):
/// the grid is a C x rows x cols image (the DOVS grid, then the dynamic window and the goal line).
inline constexpr std::uint32_t kWeightFormatVersionChannels = 2;
/// Version 3 adds, after the feature count, the wall rays, the person tokens (count and size) and the quantile head
/// (quantile count, CVaR count) (docs/weight_format.md), and two streams: the token encoder and the attention score.
inline constexpr std::uint32_t kWeightFormatVersionTokens = 3;
/// Version 4 adds, after the cvar count, the route points (docs/weight_format.md): x, y of that many points along
/// the route ahead follow the wall rays in the state and join the feature stream's input.
inline constexpr std::uint32_t kWeightFormatVersionRoute = 4;
/// The newest version the readers read.
inline constexpr std::uint32_t kWeightFormatVersionLatest = kWeightFormatVersionRoute;
/// Largest wall ray count, person token count, token size and quantile count a file may declare.
inline constexpr std::uint32_t kMaxWallRayCount = 32;
inline constexpr std::uint32_t kMaxPersonTokenCount = 16;
inline constexpr std::uint32_t kMaxRoutePointCount = 16;
inline constexpr std::uint32_t kMaxTokenSize = 256;
inline constexpr std::uint32_t kMaxQuantiles = 256;
/// Largest grid channel count a file may declare.
inline constexpr std::uint32_t kMaxGridChannels = 16;

/// A weight file that cannot be used. The message names the file, the field and the reason;
/// path() and field() give them separately for callers that want to react to one field.
class WeightFileError : public std::runtime_error {
 public:
  WeightFileError(const std::string& path, const std::string& field, const std::string& reason);
  const std::string& path() const { return path_; }
  const std::string& field() const { return field_; }

 private:
  std::string path_;
  std::string field_;
};

/// Layer type ids as stored in the file.
enum class LayerType : std::uint32_t { kConv2d = 1, kLinear = 2, kRelu = 3 };

/// Which part of the two-stream dueling network a layer belongs to. The topology is fixed by the
/// format: grid and feature streams run side by side, their outputs are concatenated (grid first,
/// flattened channel-major), the trunk follows, then the value and advantage heads.
/// Version 3 adds the token encoder (run on each person token) and the attention score (run on each token's encoding
/// beside the mean encoding); their pooled encoding joins the concatenation after the feature stream's output.
enum class LayerStream : std::uint32_t {
  kGrid = 0,
  kFeature = 1,
  kTrunk = 2,
  kValue = 3,
  kAdvantage = 4,
  kToken = 5,
  kAttention = 6
};

/// Human-readable names used in error messages and descriptions.
const char* layerTypeName(LayerType type);
const char* layerStreamName(LayerStream stream);

/// One layer record. Only the fields of its type are meaningful (and written).
struct LayerRecord {
  LayerStream stream = LayerStream::kGrid;
  LayerType type = LayerType::kRelu;
  // conv2d (dilation 1, one group)
  std::uint32_t in_channels = 0;
  std::uint32_t out_channels = 0;
  std::uint32_t kernel_h = 0;
  std::uint32_t kernel_w = 0;
  std::uint32_t stride_h = 1;
  std::uint32_t stride_w = 1;
  std::uint32_t pad_h = 0;
  std::uint32_t pad_w = 0;
  // linear
  std::uint32_t in_features = 0;
  std::uint32_t out_features = 0;
  /// conv2d: [out_channels][in_channels][kernel_h][kernel_w]; linear: [out_features][in_features];
  /// row-major, exactly PyTorch's contiguous layout. Empty for relu.
  std::vector<float> weight;
  /// [out_channels] or [out_features]. Empty for relu.
  std::vector<float> bias;

  /// Number of weight elements the declared shape needs (0 for relu; UINT64_MAX when it does not fit 64 bits).
  std::uint64_t weightCount() const;
  /// Number of bias elements the declared shape needs (0 for relu).
  std::uint64_t biasCount() const;
};

/// Everything a weight file holds, in file order.
struct WeightFileContents {
  std::uint32_t format_version = kWeightFormatVersion;
  std::uint32_t grid_rows = 20;  ///< rows of the velocity grid (v axis)
  std::uint32_t grid_cols = 20;  ///< columns of the velocity grid (w axis)
  /// Channels of the grid image (versions 2 and 3; a version 1 file has 1). The state holds
  /// grid_channels x grid_rows x grid_cols grid values, channel-major, then the features.
  std::uint32_t grid_channels = 1;
  std::uint32_t feature_count = 8;  ///< normalised scalar features after the grid
  /// Version 3 only (0, 0, 0, 1, 1 in older files): wall rays after the features; person tokens after them and the
  /// floats of each; the quantiles of each action's return (1: the plain Q-value); how many of the lowest quantiles
  /// the action choice averages (CVaR; = quantile_count: the mean, i.e. Q).
  std::uint32_t wall_ray_count = 0;
  std::uint32_t person_token_count = 0;
  std::uint32_t token_size = 0;
  std::uint32_t quantile_count = 1;
  std::uint32_t cvar_count = 1;
  /// Version 4 only (0 in older files): route points after the wall rays, 2 floats each.
  std::uint32_t route_point_count = 0;
  /// The state normalisation the network was trained with, as named constants (file order kept).
  std::vector<std::pair<std::string, float>> normalization;
  std::uint32_t action_count = 8;
  std::vector<LayerRecord> layers;
  /// Free text: training command, date, provenance (config, seed, source commit, init from).
  std::string metadata;
};

/// Bytes from a file as they may appear in an error message: printable ASCII is kept, every other byte
/// (NUL, newline, control characters, non-ASCII) becomes \xNN and a backslash becomes \\, so a message
/// is never cut short at a NUL or broken across log lines by what a corrupt file holds.
std::string printableBytes(const std::string& bytes);

/// CRC-32 (IEEE 802.3, reflected, polynomial 0xEDB88320, init and final xor 0xFFFFFFFF), the same
/// value as Python's zlib.crc32.
std::uint32_t crc32(const std::uint8_t* data, std::size_t size);

/// The version a writer puts in a file for `grid_channels`: 1 for one channel, 2 otherwise.
std::uint32_t weightFormatVersionFor(std::uint32_t grid_channels);
/// The version a writer puts in a file of `contents`: 3 with wall rays, person tokens or quantiles, otherwise
/// weightFormatVersionFor(grid_channels), so older networks keep their bytes.
std::uint32_t weightFormatVersionFor(const WeightFileContents& contents);

/// Serialises `contents` with its checksum. Writes the header fields as given (even a foreign version or
/// layout, which lets tests produce such files), but throws WeightFileError when a tensor's length does
/// not match its declared shape or a string is too long, since the result could not be parsed back.
std::vector<std::uint8_t> serializeWeightFile(const WeightFileContents& contents,
                                              const std::string& path_for_errors = "<memory>");

/// serializeWeightFile + write to `path`; throws WeightFileError when the file cannot be written.
void writeWeightFile(const std::string& path, const WeightFileContents& contents);

/// Parses a complete file image. Checks, in order: magic, version, every field's bounds and the
/// remaining length (truncation), the checksum, trailing bytes. Throws WeightFileError naming
/// `path_for_errors` and the field. Values (NaN, shapes that do not chain) are not judged here.
WeightFileContents parseWeightFile(const std::vector<std::uint8_t>& bytes, const std::string& path_for_errors);

/// Reads and parses `path`; a missing or unreadable file is a WeightFileError on field "file".
WeightFileContents readWeightFile(const std::string& path);

}  // namespace dqn_dovs
