#!/usr/bin/env bash
# The edit loop's check (make check, after make build): every gtest that needs no ROS master (test/<component>/,
# test/ros_unit/) and the Python tests except the training smoke run and the sweep. A few minutes on 2 cores; make
# test stays the full suite (rostests, the training smoke run, the sweep, fuzzing, ASan).
# Ends with one line "N passed, N failed" (gtest executables and Python tests); exits non-zero on any failure.
set -uo pipefail
cd "$(dirname "$0")/.."
root="$(pwd)"
# shellcheck source=scripts/env.sh
. scripts/env.sh
[ -f install/setup.sh ] || { echo "check: install/setup.sh missing; run 'make build' first" >&2; exit 2; }
# The rviz plugin test finds the package (pluginlib) through the sourced environment.
# shellcheck disable=SC1091
set +u; . install/setup.sh; set -u
mkdir -p log

passed=0; failed=0
rm -f log/check.gtests.counts
bin=build/dqn_dovs/devel/lib/dqn_dovs
t0=$(date +%s)
# The gtests in the background, beside the Python tests: the two halves take about as long.
(
  p=0; f=0
  for src in $(core_test_sources) test/ros_unit/test_*.cpp; do
    name=$(basename "$src" .cpp)
    exe="$bin/$name"
    if [ ! -x "$exe" ]; then
      echo "[check] $name: not built ($exe)"; f=$((f + 1)); continue
    fi
    if "$exe" >"log/check.$name.txt" 2>&1; then
      p=$((p + 1))
    else
      echo "[check] $name FAILED (log/check.$name.txt):"; grep -E "FAILED|Failure" "log/check.$name.txt" | head -10
      f=$((f + 1))
    fi
  done
  echo "[check] gtests: $p executables passed, $f failed ($(( $(date +%s) - t0 )) s)"
  echo "$p $f" >log/check.gtests.counts
) >log/check.gtests.txt 2>&1 &
gtests=$!
trap 'kill $gtests 2>/dev/null' EXIT

echo "[check] Python tests (pytest, without the training smoke run and the sweep)"
PYTHONPATH="$root/python${PYTHONPATH:+:$PYTHONPATH}" DQN_DOVS_BIN_DIR="$root/install/lib/dqn_dovs" \
  DQN_DOVS_REQUIRE_CORE=1 MPLBACKEND=Agg \
  .venv/bin/python -m pytest -q -p no:cacheprovider --deselect test/python/test_train_smoke.py \
  --deselect test/python/test_sweep.py test/python \
  >log/check.pytest.txt 2>&1
py_status=$?
tail -n 3 log/check.pytest.txt
echo "[check] Python tests: $(( $(date +%s) - t0 )) s"
wait $gtests
trap - EXIT
echo "[check] gtests without a ROS master"
cat log/check.gtests.txt
read -r g_pass g_fail <log/check.gtests.counts 2>/dev/null || { g_pass=0; g_fail=1; }
passed=$((passed + g_pass)); failed=$((failed + g_fail))
py_passed=$(grep -oE "[0-9]+ passed" log/check.pytest.txt | tail -n 1 | grep -oE "[0-9]+" || echo 0)
py_failed=$(grep -oE "[0-9]+ (failed|error)" log/check.pytest.txt | grep -oE "[0-9]+" | paste -sd+ - | bc 2>/dev/null || echo 0)
[ -n "$py_failed" ] || py_failed=0
if [ "$py_status" -ne 0 ] && [ "$py_failed" -eq 0 ]; then py_failed=1; fi
passed=$((passed + py_passed)); failed=$((failed + py_failed))
echo
echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ] && [ "$passed" -gt 0 ]
