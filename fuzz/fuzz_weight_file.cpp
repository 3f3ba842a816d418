// libFuzzer target: the .dqnw weight-file parser and QNetwork::fromBytes, then inference on the loaded network.
// Body and invariants: targets.h. Run: make fuzz (or scripts/fuzz.sh weight_file SECONDS).
#include <cstdio>
#include <cstdlib>

#include "targets.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    dqn_dovs::fuzz::weightFileOne(data, size);
  } catch (const dqn_dovs::fuzz::InvariantViolation& e) {
    std::fprintf(stderr, "fuzz_weight_file: %s\n", e.what());
    std::abort();
  }
  return 0;
}
