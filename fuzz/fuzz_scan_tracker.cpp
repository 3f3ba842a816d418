// libFuzzer target: sequences of arbitrary laser scans and laser poses through ObstacleTracker::update.
// Body and invariants: targets.h. Run: make fuzz (or scripts/fuzz.sh scan_tracker SECONDS).
#include <cstdio>
#include <cstdlib>

#include "targets.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    dqn_dovs::fuzz::scanTrackerOne(data, size);
  } catch (const dqn_dovs::fuzz::InvariantViolation& e) {
    std::fprintf(stderr, "fuzz_scan_tracker: %s\n", e.what());
    std::abort();
  }
  return 0;
}
