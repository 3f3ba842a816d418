// Shared pieces of the fuzz targets (fuzz/fuzz_*.cpp) and their regression replay
// (test/policy/test_fuzz_regressions.cpp): a reader that turns arbitrary bytes into numbers (with a bias towards the
// values that break code: NaN, inf, 0, huge, negative) and the invariant check that makes a fuzz target fail.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>

namespace dqn_dovs::fuzz {

/// A broken invariant: the code under test returned something its contract rules out. The fuzz entry points
/// print it and abort (a crash for libFuzzer); the regression gtests see it as an unexpected exception.
class InvariantViolation : public std::logic_error {
 public:
  using std::logic_error::logic_error;
};

inline void require(bool condition, const std::string& what) {
  if (!condition) throw InvariantViolation("invariant violated: " + what);
}

/// Consumes the fuzz input front to back; once it is exhausted every read returns 0 (deterministic).
class ByteStream {
 public:
  ByteStream(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}

  std::size_t remaining() const { return size_ - pos_; }
  bool empty() const { return pos_ >= size_; }

  std::uint8_t u8() { return empty() ? 0 : data_[pos_++]; }
  std::uint16_t u16() { return static_cast<std::uint16_t>(u8() | (u8() << 8)); }
  std::uint32_t u32() {
    std::uint32_t v = 0;
    for (int i = 0; i < 4; ++i) v |= static_cast<std::uint32_t>(u8()) << (8 * i);
    return v;
  }
  std::uint64_t u64() {
    std::uint64_t v = 0;
    for (int i = 0; i < 8; ++i) v |= static_cast<std::uint64_t>(u8()) << (8 * i);
    return v;
  }
  double rawDouble() {
    const std::uint64_t bits = u64();
    double d;
    std::memcpy(&d, &bits, sizeof d);
    return d;
  }
  float rawFloat() {
    const std::uint32_t bits = u32();
    float f;
    std::memcpy(&f, &bits, sizeof f);
    return f;
  }
  /// A double that is usually "reasonable": one mode byte picks a special value (NaN, +-inf, 0, -0, denormal,
  /// +-max), a raw IEEE pattern, or lo + (hi - lo) * u16 / 65535 (most of the time).
  double number(double lo, double hi) {
    const std::uint8_t mode = u8();
    switch (mode % 16) {
      case 0:
        return std::numeric_limits<double>::quiet_NaN();
      case 1:
        return (mode & 16) ? -std::numeric_limits<double>::infinity() : std::numeric_limits<double>::infinity();
      case 2:
        return (mode & 16) ? -0.0 : 0.0;
      case 3:
        return (mode & 16) ? -std::numeric_limits<double>::max() : std::numeric_limits<double>::max();
      case 4:
        return std::numeric_limits<double>::denorm_min();
      case 5:
        return rawDouble();
      default:
        return lo + (hi - lo) * static_cast<double>(u16()) / 65535.0;
    }
  }
  float numberF(double lo, double hi) {
    const std::uint8_t mode = u8();
    switch (mode % 16) {
      case 0:
        return std::numeric_limits<float>::quiet_NaN();
      case 1:
        return (mode & 16) ? -std::numeric_limits<float>::infinity() : std::numeric_limits<float>::infinity();
      case 2:
        return (mode & 16) ? -0.0f : 0.0f;
      case 3:
        return (mode & 16) ? -std::numeric_limits<float>::max() : std::numeric_limits<float>::max();
      case 4:
        return rawFloat();
      default:
        return static_cast<float>(lo + (hi - lo) * static_cast<double>(u16()) / 65535.0);
    }
  }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t pos_ = 0;
};

inline bool finite(double v) { return std::isfinite(v); }

}  // namespace dqn_dovs::fuzz
