// libFuzzer target: the .dovs scenario loader (sim::parseDovsScenario), then a few steps of the simulated world.
// Body and invariants: targets.h. Run: make fuzz (or scripts/fuzz.sh scenario SECONDS).
#include <cstdio>
#include <cstdlib>

#include "targets.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    dqn_dovs::fuzz::scenarioOne(data, size);
  } catch (const dqn_dovs::fuzz::InvariantViolation& e) {
    std::fprintf(stderr, "fuzz_scenario: %s\n", e.what());
    std::abort();
  }
  return 0;
}
