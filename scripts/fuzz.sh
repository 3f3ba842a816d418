#!/usr/bin/env bash
# Builds the libFuzzer targets of fuzz/ in build_fuzz/ (clang, ASan + UBSan, core-only) and runs them.
#   scripts/fuzz.sh [TARGET...]        targets: weight_file scan_tracker scenario dovs_msg (default: all)
#   FUZZ_SECONDS=N                     fuzzing time per target (default 600; make test uses 40)
# Per target, two tests: the replay of fuzz/regressions/TARGET/ (every committed crash input once) and a
# fuzzing run of FUZZ_SECONDS from build_fuzz/corpus/TARGET (kept between runs) and freshly made seeds. A
# crash (sanitizer report, broken invariant, uncaught exception, timeout, out of memory) fails the run; its
# input is written to build_fuzz/crashes/TARGET/ and the path printed. Ends with "N passed, N failed".
# Needs the generated message headers of `make build` (build/dqn_dovs/devel/include) for dovs_msg.
set -uo pipefail
cd "$(dirname "$0")/.."
# shellcheck source=scripts/env.sh
. scripts/env.sh
seconds=${FUZZ_SECONDS:-600}
jobs=${JOBS:-2}
all_targets=(weight_file scan_tracker scenario dovs_msg)
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=("${all_targets[@]}")
for t in "${targets[@]}"; do
  [[ " ${all_targets[*]} " == *" $t "* ]] || { echo "[fuzz] unknown target '$t' (known: ${all_targets[*]})" >&2; exit 2; }
done
bf=build_fuzz
mkdir -p "$bf/logs"
passed=0
failed=0

echo "[fuzz] building ${targets[*]} in $bf/ (clang++, -fsanitize=fuzzer,address,undefined)"
if [ ! -f "$bf/build.ninja" ]; then
  # shellcheck disable=SC2046
  cmake -S . -B "$bf" -G Ninja $(ccache_args) -DCMAKE_CXX_COMPILER=clang++ -DDQN_DOVS_CORE_ONLY=ON -DDQN_DOVS_FUZZ=ON \
    -DCMAKE_BUILD_TYPE=RelWithDebInfo "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -g" >"$bf/logs/cmake.txt" 2>&1 || {
    echo "[fuzz] FAILED: cmake configure of $bf (log $bf/logs/cmake.txt):"; tail -15 "$bf/logs/cmake.txt"
    rm -f "$bf/build.ninja"; echo; echo "0 passed, $((2 * ${#targets[@]})) failed"; exit 1; }
fi
if ! cmake --build "$bf" -j "$jobs" >"$bf/logs/build.txt" 2>&1; then
  echo "[fuzz] FAILED: build of the fuzz targets (log $bf/logs/build.txt):"; grep -E "error|Error" "$bf/logs/build.txt" | head -20
  echo; echo "0 passed, $((2 * ${#targets[@]})) failed"; exit 1
fi

# Seeds: tiny networks, simulated scans, Dovs messages and a few of the package's own scenario files.
scenarios=()
for s in 1-1/1 1-5/2 1-12/3; do
  f=data/scenarios/room/$s.dovs
  [ -f "$f" ] && scenarios+=("$f")
done
[ ${#scenarios[@]} -gt 0 ] || echo "[fuzz] note: data/scenarios/room not found: seeds without scenarios"
if ! "$bf/fuzz/fuzz_make_seeds" "$bf/seeds" "${scenarios[@]}" >"$bf/logs/seeds.txt" 2>&1; then
  echo "[fuzz] FAILED: making the seeds:"; cat "$bf/logs/seeds.txt"
  echo; echo "0 passed, $((2 * ${#targets[@]})) failed"; exit 1
fi

for t in "${targets[@]}"; do
  bin=$bf/fuzz/fuzz_$t
  dict=()
  [ -f "fuzz/$t.dict" ] && dict=("-dict=fuzz/$t.dict")
  # 1. Regressions: every committed input once.
  shopt -s nullglob
  regressions=(fuzz/regressions/$t/*)
  shopt -u nullglob
  if [ ${#regressions[@]} -gt 0 ]; then
    log=$bf/logs/$t.regressions.txt
    if "$bin" -timeout=60 -rss_limit_mb=2048 "${regressions[@]}" >"$log" 2>&1; then
      echo "[fuzz] $t: ${#regressions[@]} regression inputs replayed, ok"
      passed=$((passed + 1))
    else
      bad=$(grep -E "^Running: " "$log" | tail -n 1 | sed 's/^Running: //')
      echo "[fuzz] $t: FAILED: regression input $bad crashes again (log $log):"
      grep -E "invariant violated|ERROR:|SUMMARY:|runtime error|terminate called|what\(\)" "$log" | head -8
      failed=$((failed + 1))
    fi
  fi
  # 2. Fuzzing.
  mkdir -p "$bf/corpus/$t" "$bf/crashes/$t"
  log=$bf/logs/$t.fuzz.txt
  start=$(date +%s)
  "$bin" -max_total_time="$seconds" -timeout=30 -rss_limit_mb=2048 -print_final_stats=1 \
    -artifact_prefix="$bf/crashes/$t/" "${dict[@]}" "$bf/corpus/$t" "$bf/seeds/$t" >"$log" 2>&1
  rc=$?
  elapsed=$(($(date +%s) - start))
  execs=$(sed -nE 's/^stat::number_of_executed_units: *([0-9]+).*/\1/p' "$log" | tail -n 1)
  if [ $rc -eq 0 ]; then
    echo "[fuzz] $t: ok, ${execs:-?} executions in ${elapsed} s, no crash (corpus $(ls "$bf/corpus/$t" | wc -l) inputs)"
    passed=$((passed + 1))
  else
    crash=$(sed -nE 's/.*Test unit written to (.*)$/\1/p' "$log" | tail -n 1)
    echo "[fuzz] $t: FAILED after ${elapsed} s (${execs:-?} executions): crash input ${crash:-<none written>} (log $log):"
    grep -E "invariant violated|ERROR:|SUMMARY:|runtime error|terminate called|what\(\)" "$log" | head -8
    echo "[fuzz]   reproduce: $bin ${crash:-}"
    failed=$((failed + 1))
  fi
done
echo
echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ] && [ "$passed" -gt 0 ]
