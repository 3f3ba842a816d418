#include "dqn_dovs/policy/weight_file.h"

#include <array>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <sstream>

namespace dqn_dovs {

namespace {

// Bounds that keep a corrupt header from asking for absurd allocations; far above any real network.
constexpr std::uint32_t kMaxGridSide = 1024;
constexpr std::uint32_t kMaxFeatures = 1024;
constexpr std::uint32_t kMaxNormalizationEntries = 1024;
constexpr std::uint32_t kMaxNameLength = 255;
constexpr std::uint32_t kMaxActions = 64;
constexpr std::uint32_t kMaxLayers = 256;
constexpr std::uint32_t kMaxDim = 65536;
constexpr std::uint32_t kMaxMetadataLength = 1u << 20;
constexpr std::size_t kMagicSize = 8;

std::array<std::uint32_t, 256> makeCrcTable() {
  std::array<std::uint32_t, 256> table{};
  for (std::uint32_t i = 0; i < 256; ++i) {
    std::uint32_t c = i;
    for (int k = 0; k < 8; ++k) c = (c & 1u) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
    table[i] = c;
  }
  return table;
}

std::string layerField(std::size_t index, const LayerRecord* layer, const std::string& what) {
  std::ostringstream os;
  os << "layer " << index;
  if (layer != nullptr) os << " (" << layerStreamName(layer->stream) << " " << layerTypeName(layer->type) << ")";
  os << " " << what;
  return os.str();
}

bool knownStream(std::uint32_t s) { return s <= static_cast<std::uint32_t>(LayerStream::kAttention); }
bool knownType(std::uint32_t t) {
  return t >= static_cast<std::uint32_t>(LayerType::kConv2d) && t <= static_cast<std::uint32_t>(LayerType::kRelu);
}

// Little-endian writer. The host is assumed little-endian for floats too (checked at compile time below).
class ByteWriter {
 public:
  void u32(std::uint32_t v) {
    for (int i = 0; i < 4; ++i) bytes_.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
  }
  void f32s(const std::vector<float>& values) {
    const auto* p = reinterpret_cast<const std::uint8_t*>(values.data());
    bytes_.insert(bytes_.end(), p, p + values.size() * sizeof(float));
  }
  void f32(float v) { f32s(std::vector<float>{v}); }
  void raw(const void* data, std::size_t n) {
    const auto* p = static_cast<const std::uint8_t*>(data);
    bytes_.insert(bytes_.end(), p, p + n);
  }
  void str(const std::string& s) {
    u32(static_cast<std::uint32_t>(s.size()));
    raw(s.data(), s.size());
  }
  std::vector<std::uint8_t>& bytes() { return bytes_; }

 private:
  std::vector<std::uint8_t> bytes_;
};

// Bounds-checked little-endian reader: every read names the field it is for, so a short file says
// which field it ended in.
class ByteReader {
 public:
  ByteReader(const std::vector<std::uint8_t>& bytes, std::size_t end, const std::string& path)
      : bytes_(bytes), end_(end), path_(path) {}

  void need(std::uint64_t n, const std::string& field) const {
    if (n > end_ - pos_) {
      std::ostringstream os;
      os << "truncated: needs " << n << " bytes at offset " << pos_ << " but only " << (end_ - pos_)
         << " remain before the checksum (file size " << bytes_.size() << ")";
      throw WeightFileError(path_, field, os.str());
    }
  }
  std::uint32_t u32(const std::string& field) {
    need(4, field);
    std::uint32_t v = 0;
    for (int i = 0; i < 4; ++i) v |= static_cast<std::uint32_t>(bytes_[pos_ + i]) << (8 * i);
    pos_ += 4;
    return v;
  }
  std::vector<float> f32s(std::uint64_t count, const std::string& field) {
    if (count > (end_ - pos_) / sizeof(float)) {  // count * 4 may not fit 64 bits
      std::ostringstream os;
      os << "truncated: needs " << count << " floats at offset " << pos_ << " but only " << (end_ - pos_)
         << " bytes remain before the checksum (file size " << bytes_.size() << ")";
      throw WeightFileError(path_, field, os.str());
    }
    std::vector<float> out(count);
    if (count > 0) std::memcpy(out.data(), bytes_.data() + pos_, count * sizeof(float));
    pos_ += count * sizeof(float);
    return out;
  }
  std::string str(std::uint64_t length, const std::string& field) {
    need(length, field);
    std::string s(reinterpret_cast<const char*>(bytes_.data() + pos_), length);
    pos_ += length;
    return s;
  }
  void skip(std::size_t n) { pos_ += n; }
  std::size_t pos() const { return pos_; }

 private:
  const std::vector<std::uint8_t>& bytes_;
  std::size_t end_;
  std::size_t pos_ = 0;
  const std::string& path_;
};

static_assert(sizeof(float) == 4, "the weight format stores IEEE-754 binary32 floats");
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ != __ORDER_LITTLE_ENDIAN__
#error "the weight file reader and writer copy floats byte-wise and need a little-endian host"
#endif

std::uint32_t checkedRange(std::uint32_t value, std::uint32_t lo, std::uint32_t hi, const std::string& path,
                           const std::string& field) {
  if (value < lo || value > hi) {
    std::ostringstream os;
    os << "value " << value << " outside the accepted range [" << lo << ", " << hi << "]";
    throw WeightFileError(path, field, os.str());
  }
  return value;
}

}  // namespace

WeightFileError::WeightFileError(const std::string& path, const std::string& field, const std::string& reason)
    : std::runtime_error("weight file '" + path + "': field '" + field + "': " + reason), path_(path), field_(field) {}

const char* layerTypeName(LayerType type) {
  switch (type) {
    case LayerType::kConv2d:
      return "conv2d";
    case LayerType::kLinear:
      return "linear";
    case LayerType::kRelu:
      return "relu";
  }
  return "unknown";
}

const char* layerStreamName(LayerStream stream) {
  switch (stream) {
    case LayerStream::kGrid:
      return "grid";
    case LayerStream::kFeature:
      return "feature";
    case LayerStream::kTrunk:
      return "trunk";
    case LayerStream::kValue:
      return "value";
    case LayerStream::kAdvantage:
      return "advantage";
    case LayerStream::kToken:
      return "token";
    case LayerStream::kAttention:
      return "attention";
  }
  return "unknown";
}

std::uint64_t LayerRecord::weightCount() const {
  switch (type) {
    case LayerType::kConv2d: {
      // Four 32-bit factors can exceed 64 bits (65536^4 wraps to 0): saturate, no file holds that many.
      const std::uint64_t a = std::uint64_t{out_channels} * in_channels, b = std::uint64_t{kernel_h} * kernel_w;
      return (b != 0 && a > std::numeric_limits<std::uint64_t>::max() / b) ? std::numeric_limits<std::uint64_t>::max()
                                                                           : a * b;
    }
    case LayerType::kLinear:
      return std::uint64_t{out_features} * in_features;
    case LayerType::kRelu:
      return 0;
  }
  return 0;
}

std::uint64_t LayerRecord::biasCount() const {
  switch (type) {
    case LayerType::kConv2d:
      return out_channels;
    case LayerType::kLinear:
      return out_features;
    case LayerType::kRelu:
      return 0;
  }
  return 0;
}

std::string printableBytes(const std::string& bytes) {
  static const char* kHex = "0123456789abcdef";
  std::string out;
  out.reserve(bytes.size());
  for (const char ch : bytes) {
    const auto b = static_cast<unsigned char>(ch);
    if (b == '\\') {
      out += "\\\\";
    } else if (b >= 32 && b < 127) {
      out += ch;
    } else {
      out += "\\x";
      out += kHex[b >> 4];
      out += kHex[b & 15];
    }
  }
  return out;
}

std::uint32_t crc32(const std::uint8_t* data, std::size_t size) {
  static const std::array<std::uint32_t, 256> table = makeCrcTable();
  std::uint32_t c = 0xFFFFFFFFu;
  for (std::size_t i = 0; i < size; ++i) c = table[(c ^ data[i]) & 0xFFu] ^ (c >> 8);
  return c ^ 0xFFFFFFFFu;
}

std::uint32_t weightFormatVersionFor(std::uint32_t grid_channels) {
  return grid_channels == 1 ? kWeightFormatVersion : kWeightFormatVersionChannels;
}

std::uint32_t weightFormatVersionFor(const WeightFileContents& c) {
  if (c.route_point_count != 0) return kWeightFormatVersionRoute;
  if (c.wall_ray_count != 0 || c.person_token_count != 0 || c.quantile_count != 1) return kWeightFormatVersionTokens;
  return weightFormatVersionFor(c.grid_channels);
}

std::vector<std::uint8_t> serializeWeightFile(const WeightFileContents& c, const std::string& path) {
  ByteWriter w;
  w.raw(kWeightFileMagic, kMagicSize);
  w.u32(c.format_version);
  w.u32(c.grid_rows);
  w.u32(c.grid_cols);
  if (c.format_version >= kWeightFormatVersionChannels) w.u32(c.grid_channels);
  w.u32(c.feature_count);
  if (c.format_version >= kWeightFormatVersionTokens) {
    for (std::uint32_t v : {c.wall_ray_count, c.person_token_count, c.token_size, c.quantile_count, c.cvar_count})
      w.u32(v);
  }
  if (c.format_version >= kWeightFormatVersionRoute) w.u32(c.route_point_count);
  w.u32(static_cast<std::uint32_t>(c.normalization.size()));
  for (const auto& [name, value] : c.normalization) {
    if (name.size() > kMaxNameLength)
      throw WeightFileError(path, "normalization name", "'" + printableBytes(name) + "' is too long");
    w.str(name);
    w.f32(value);
  }
  w.u32(c.action_count);
  w.u32(static_cast<std::uint32_t>(c.layers.size()));
  for (std::size_t i = 0; i < c.layers.size(); ++i) {
    const LayerRecord& l = c.layers[i];
    w.u32(static_cast<std::uint32_t>(l.stream));
    w.u32(static_cast<std::uint32_t>(l.type));
    if (l.type == LayerType::kConv2d) {
      for (std::uint32_t v :
           {l.in_channels, l.out_channels, l.kernel_h, l.kernel_w, l.stride_h, l.stride_w, l.pad_h, l.pad_w})
        w.u32(v);
    } else if (l.type == LayerType::kLinear) {
      w.u32(l.in_features);
      w.u32(l.out_features);
    }
    if (l.weight.size() != l.weightCount() || l.bias.size() != l.biasCount()) {
      std::ostringstream os;
      os << "tensor lengths " << l.weight.size() << " + " << l.bias.size() << " do not match the declared shape ("
         << l.weightCount() << " + " << l.biasCount() << ")";
      throw WeightFileError(path, layerField(i, &l, "tensors"), os.str());
    }
    w.f32s(l.weight);
    w.f32s(l.bias);
  }
  if (c.metadata.size() > kMaxMetadataLength) throw WeightFileError(path, "metadata", "longer than 1 MiB");
  w.str(c.metadata);
  const std::uint32_t crc = crc32(w.bytes().data(), w.bytes().size());
  w.u32(crc);
  return std::move(w.bytes());
}

void writeWeightFile(const std::string& path, const WeightFileContents& contents) {
  const std::vector<std::uint8_t> bytes = serializeWeightFile(contents, path);
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) throw WeightFileError(path, "file", std::string("cannot open for writing: ") + std::strerror(errno));
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  out.close();
  if (!out) throw WeightFileError(path, "file", "write failed");
}

WeightFileContents parseWeightFile(const std::vector<std::uint8_t>& bytes, const std::string& path) {
  if (bytes.size() < kMagicSize) {
    throw WeightFileError(
        path, "magic", "truncated: file has " + std::to_string(bytes.size()) + " bytes, fewer than the 8-byte magic");
  }
  if (std::memcmp(bytes.data(), kWeightFileMagic, kMagicSize) != 0) {
    std::string found;
    for (std::size_t i = 0; i < kMagicSize; ++i) {
      const char ch = static_cast<char>(bytes[i]);
      found += (ch >= 32 && ch < 127) ? ch : '?';
    }
    throw WeightFileError(path, "magic", "expected \"DQNDOVSW\", found \"" + found + "\" (not a .dqnw weight file)");
  }
  // The last 4 bytes are the checksum; fields are read up to it, so running into it means truncation.
  if (bytes.size() < kMagicSize + 4) {
    throw WeightFileError(path, "format version", "truncated: file ends right after the magic");
  }
  ByteReader r(bytes, bytes.size() - 4, path);
  r.skip(kMagicSize);
  WeightFileContents c;
  // The version is judged before anything else is parsed: another version may lay its fields out differently.
  std::uint32_t version = 0;
  for (std::size_t i = 0; i < 4; ++i) version |= static_cast<std::uint32_t>(bytes[kMagicSize + i]) << (8 * i);
  if (version < kWeightFormatVersion || version > kWeightFormatVersionLatest) {
    throw WeightFileError(path, "format version",
                          "file has version " + std::to_string(version) + ", this reader supports versions " +
                              std::to_string(kWeightFormatVersion) + " to " +
                              std::to_string(kWeightFormatVersionLatest));
  }
  c.format_version = r.u32("format version");
  c.grid_rows = checkedRange(r.u32("state layout: grid rows"), 1, kMaxGridSide, path, "state layout: grid rows");
  c.grid_cols = checkedRange(r.u32("state layout: grid cols"), 1, kMaxGridSide, path, "state layout: grid cols");
  c.grid_channels = 1;
  if (version >= kWeightFormatVersionChannels) {
    c.grid_channels =
        checkedRange(r.u32("state layout: grid channels"), 1, kMaxGridChannels, path, "state layout: grid channels");
  }
  c.feature_count =
      checkedRange(r.u32("state layout: feature count"), 0, kMaxFeatures, path, "state layout: feature count");
  if (version >= kWeightFormatVersionTokens) {
    c.wall_ray_count =
        checkedRange(r.u32("state layout: wall rays"), 0, kMaxWallRayCount, path, "state layout: wall rays");
    c.person_token_count = checkedRange(r.u32("state layout: person tokens"), 0, kMaxPersonTokenCount, path,
                                        "state layout: person tokens");
    c.token_size = checkedRange(r.u32("state layout: token size"), 0, kMaxTokenSize, path, "state layout: token size");
    c.quantile_count = checkedRange(r.u32("quantile count"), 1, kMaxQuantiles, path, "quantile count");
    c.cvar_count = checkedRange(r.u32("cvar count"), 1, c.quantile_count, path, "cvar count");
  }
  if (version >= kWeightFormatVersionRoute) {
    c.route_point_count =
        checkedRange(r.u32("state layout: route points"), 0, kMaxRoutePointCount, path, "state layout: route points");
  }
  const std::uint32_t n_norm =
      checkedRange(r.u32("normalization count"), 0, kMaxNormalizationEntries, path, "normalization count");
  for (std::uint32_t i = 0; i < n_norm; ++i) {
    const std::string field = "normalization entry " + std::to_string(i);
    const std::uint32_t len =
        checkedRange(r.u32(field + " name length"), 1, kMaxNameLength, path, field + " name length");
    std::string name = r.str(len, field + " name");
    const float value = r.f32s(1, field + " value '" + printableBytes(name) + "'")[0];
    c.normalization.emplace_back(std::move(name), value);
  }
  c.action_count = checkedRange(r.u32("action count"), 1, kMaxActions, path, "action count");
  const std::uint32_t n_layers = checkedRange(r.u32("layer count"), 1, kMaxLayers, path, "layer count");
  c.layers.reserve(n_layers);
  for (std::uint32_t i = 0; i < n_layers; ++i) {
    LayerRecord l;
    const std::uint32_t stream = r.u32(layerField(i, nullptr, "stream"));
    if (!knownStream(stream))
      throw WeightFileError(path, layerField(i, nullptr, "stream"), "unknown stream id " + std::to_string(stream));
    const std::uint32_t type = r.u32(layerField(i, nullptr, "type"));
    if (!knownType(type))
      throw WeightFileError(path, layerField(i, nullptr, "type"), "unknown layer type id " + std::to_string(type));
    l.stream = static_cast<LayerStream>(stream);
    l.type = static_cast<LayerType>(type);
    auto dim = [&](const char* name, std::uint32_t lo) {
      const std::string field = layerField(i, &l, name);
      return checkedRange(r.u32(field), lo, kMaxDim, path, field);
    };
    if (l.type == LayerType::kConv2d) {
      l.in_channels = dim("in_channels", 1);
      l.out_channels = dim("out_channels", 1);
      l.kernel_h = dim("kernel_h", 1);
      l.kernel_w = dim("kernel_w", 1);
      l.stride_h = dim("stride_h", 1);
      l.stride_w = dim("stride_w", 1);
      l.pad_h = dim("pad_h", 0);
      l.pad_w = dim("pad_w", 0);
    } else if (l.type == LayerType::kLinear) {
      l.in_features = dim("in_features", 1);
      l.out_features = dim("out_features", 1);
    }
    l.weight = r.f32s(l.weightCount(), layerField(i, &l, "weight"));
    l.bias = r.f32s(l.biasCount(), layerField(i, &l, "bias"));
    c.layers.push_back(std::move(l));
  }
  const std::uint32_t meta_len = checkedRange(r.u32("metadata length"), 0, kMaxMetadataLength, path, "metadata length");
  c.metadata = r.str(meta_len, "metadata");
  if (r.pos() != bytes.size() - 4) {
    std::ostringstream os;
    os << (bytes.size() - 4 - r.pos()) << " unexpected bytes between the metadata (ends at offset " << r.pos()
       << ") and the checksum";
    throw WeightFileError(path, "trailing bytes", os.str());
  }
  std::uint32_t stored = 0;
  for (int i = 0; i < 4; ++i) stored |= static_cast<std::uint32_t>(bytes[bytes.size() - 4 + i]) << (8 * i);
  const std::uint32_t computed = crc32(bytes.data(), bytes.size() - 4);
  if (stored != computed) {
    std::ostringstream os;
    os << std::hex << "CRC-32 stored 0x" << stored << " but the content gives 0x" << computed
       << " (the file is corrupt or was edited)";
    throw WeightFileError(path, "checksum", os.str());
  }
  return c;
}

WeightFileContents readWeightFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw WeightFileError(path, "file", std::string("cannot open: ") + std::strerror(errno));
  std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) throw WeightFileError(path, "file", "read error");
  return parseWeightFile(bytes, path);
}

}  // namespace dqn_dovs
