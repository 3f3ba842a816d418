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
bin=build/dqn_dovs/devel/lib/dqn_dovs
echo "[check] gtests without a ROS master"
for src in $(core_test_sources) test/ros_unit/test_*.cpp; do
  name=$(basename "$src" .cpp)
  exe="$bin/$name"
  if [ ! -x "$exe" ]; then
    echo "[check] $name: not built ($exe)"; failed=$((failed + 1)); continue
  fi
  if "$exe" >"log/check.$name.txt" 2>&1; then
    passed=$((passed + 1))
  else
    echo "[check] $name FAILED (log/check.$name.txt):"; grep -E "FAILED|Failure" "log/check.$name.txt" | head -10
    failed=$((failed + 1))
  fi
done
echo "[check] gtests: $passed executables passed, $failed failed"

echo "[check] Python tests (pytest, without the training smoke run and the sweep)"
PYTHONPATH="$root/python${PYTHONPATH:+:$PYTHONPATH}" DQN_DOVS_BIN_DIR="$root/install/lib/dqn_dovs" \
  DQN_DOVS_REQUIRE_CORE=1 MPLBACKEND=Agg \
  .venv/bin/python -m pytest -q -p no:cacheprovider --deselect test/python/test_train_smoke.py \
  --deselect test/python/test_sweep.py test/python \
  >log/check.pytest.txt 2>&1
py_status=$?
tail -n 3 log/check.pytest.txt
py_passed=$(grep -oE "[0-9]+ passed" log/check.pytest.txt | tail -n 1 | grep -oE "[0-9]+" || echo 0)
py_failed=$(grep -oE "[0-9]+ (failed|error)" log/check.pytest.txt | grep -oE "[0-9]+" | paste -sd+ - | bc 2>/dev/null || echo 0)
[ -n "$py_failed" ] || py_failed=0
if [ "$py_status" -ne 0 ] && [ "$py_failed" -eq 0 ]; then py_failed=1; fi
passed=$((passed + py_passed)); failed=$((failed + py_failed))
echo
echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ] && [ "$passed" -gt 0 ]
