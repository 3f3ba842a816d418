#!/usr/bin/env bash
# Builds the core-only gtest suite with AddressSanitizer + UndefinedBehaviorSanitizer (DQN_DOVS_SANITIZE=ON,
# -fno-sanitize-recover=all: the first report fails the test) in build_asan/ and runs it with ctest.
# Ends with "N passed, N failed" (one per gtest executable) and the build and run times.
set -uo pipefail
cd "$(dirname "$0")/.."
# shellcheck source=scripts/env.sh
. scripts/env.sh
jobs=${JOBS:-2}
ba=build_asan
mkdir -p "$ba"
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1:strict_string_checks=1:detect_stack_use_after_return=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
tests=()
for f in $(core_test_sources); do tests+=("$(basename "$f" .cpp)"); done
t0=$(date +%s)
echo "[asan] building the core gtests (${#tests[@]}) in $ba/ with -fsanitize=address,undefined"
if [ ! -f "$ba/CMakeCache.txt" ]; then
  # shellcheck disable=SC2046
  cmake -S . -B "$ba" -G Ninja $(ccache_args) -DDQN_DOVS_CORE_ONLY=ON -DDQN_DOVS_SANITIZE=ON -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -g" >"$ba/cmake.log" 2>&1 || {
    echo "[asan] FAILED: cmake configure (log $ba/cmake.log)"; tail -15 "$ba/cmake.log"; rm -f "$ba/CMakeCache.txt"
    echo; echo "0 passed, 1 failed"; exit 1; }
fi
if ! cmake --build "$ba" -j "$jobs" --target "${tests[@]}" >"$ba/build.log" 2>&1; then
  echo "[asan] FAILED: build (log $ba/build.log):"; grep -E "error" "$ba/build.log" | head -20
  echo; echo "0 passed, 1 failed"; exit 1
fi
t1=$(date +%s)
echo "[asan] built in $((t1 - t0)) s; running ctest"
(cd "$ba" && ctest --output-on-failure -j "$jobs" --timeout 1200) >"$ba/ctest.log" 2>&1
t2=$(date +%s)
total=$(sed -nE 's/.*tests passed, ([0-9]+) tests failed out of ([0-9]+).*/\2/p' "$ba/ctest.log" | tail -n 1)
nfail=$(sed -nE 's/.*tests passed, ([0-9]+) tests failed out of ([0-9]+).*/\1/p' "$ba/ctest.log" | tail -n 1)
if [ -z "$total" ]; then
  echo "[asan] FAILED: could not read the ctest summary (log $ba/ctest.log)"; tail -20 "$ba/ctest.log"
  echo; echo "0 passed, 1 failed"; exit 1
fi
if [ "$nfail" -gt 0 ]; then
  echo "[asan] failures (log $ba/ctest.log):"
  grep -E "\(Failed\)|\(Subprocess aborted\)|\(SEGFAULT\)|\(Timeout\)|\*\*\*Exception" "$ba/ctest.log" | head -20
  grep -E "ERROR: AddressSanitizer|runtime error:|ERROR: LeakSanitizer|SUMMARY:" "$ba/ctest.log" | head -20
fi
echo "[asan] ran in $((t2 - t1)) s; total $((t2 - t0)) s"
echo
echo "$((total - nfail)) passed, $nfail failed"
[ "$nfail" -eq 0 ] && [ "$total" -gt 0 ]
