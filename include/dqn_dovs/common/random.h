// Seeded random numbers for the simulator. The standard library's distributions are implementation-defined,
// so the same seed could give different episodes on different compilers; these draws are defined bit for bit
// on top of std::mt19937_64 (whose output sequence the standard fixes), which keeps scenarios and sensor
// noise reproducible everywhere.
#pragma once

#include <cmath>
#include <cstdint>
#include <random>

namespace dqn_dovs::sim {

/// SplitMix64 finaliser: turns related seeds (0, 1, 2, ...) into unrelated ones, and derives independent
/// sub-stream seeds (world -> lidar noise) from one user seed.
inline uint64_t mixSeed(uint64_t x) {
  x += 0x9E3779B97F4A7C15ULL;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ULL;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBULL;
  return x ^ (x >> 31);
}

/// A reproducible random stream: uniform doubles, integers and standard normals.
class Rng {
 public:
  explicit Rng(uint64_t seed = 0) { reseed(seed); }

  void reseed(uint64_t seed) {
    engine_.seed(mixSeed(seed));
    has_spare_normal_ = false;
  }

  /// Uniform in [0, 1) with 53 random bits.
  double uniform01() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }

  /// Uniform in [lo, hi); returns lo when hi <= lo.
  double uniform(double lo, double hi) { return hi > lo ? lo + (hi - lo) * uniform01() : lo; }

  /// Uniform integer in [lo, hi] (inclusive), without modulo bias; returns lo when hi <= lo.
  int64_t uniformInt(int64_t lo, int64_t hi) {
    if (hi <= lo) return lo;
    const uint64_t span = static_cast<uint64_t>(hi - lo) + 1ULL;
    if (span == 0) return static_cast<int64_t>(engine_());  // the full 64-bit range
    const uint64_t limit = UINT64_MAX - UINT64_MAX % span;
    uint64_t x = engine_();
    while (x >= limit) x = engine_();
    return lo + static_cast<int64_t>(x % span);
  }

  /// True with probability p.
  bool bernoulli(double p) { return uniform01() < p; }

  /// Standard normal (Marsaglia polar method; the second value of each pair is kept for the next call).
  double normal() {
    if (has_spare_normal_) {
      has_spare_normal_ = false;
      return spare_normal_;
    }
    double u = 0.0, v = 0.0, s = 0.0;
    do {
      u = 2.0 * uniform01() - 1.0;
      v = 2.0 * uniform01() - 1.0;
      s = u * u + v * v;
    } while (s >= 1.0 || s == 0.0);
    const double f = std::sqrt(-2.0 * std::log(s) / s);
    spare_normal_ = v * f;
    has_spare_normal_ = true;
    return u * f;
  }

 private:
  std::mt19937_64 engine_;
  double spare_normal_ = 0.0;
  bool has_spare_normal_ = false;
};

}  // namespace dqn_dovs::sim
