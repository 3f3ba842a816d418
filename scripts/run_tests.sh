#!/usr/bin/env bash
# Runs every test (core gtests, rostests, Python tests, C++ formatting, fuzz targets, core gtests under ASan) and
# ends with one line "N passed, N failed".
# Two lanes at once: the sanitizer lane (fuzz targets, then the ASan build and run; niced, it needs nothing of the
# rest) in the background, and colcon test (ctest with DQN_DOVS_TEST_JOBS tests at a time, default 3: most
# rostests wait on the clock; the soak first) then the Python tests and the formatting in the foreground. Each
# phase's time is printed.
# Exits non-zero when any test fails or errors, or when no test ran.
set -uo pipefail
cd "$(dirname "$0")/.."
root="$(pwd)"
# shellcheck source=scripts/env.sh
. scripts/env.sh
# shellcheck disable=SC1091
set +u; . install/setup.sh; set -u
export ROS_HOME="$root/log/ros_home"
export ROS_LOG_DIR="$ROS_HOME/log"
mkdir -p "$ROS_LOG_DIR"

rm -rf build/dqn_dovs/test_results
t_start=$(date +%s)
took() { echo "$(( $(date +%s) - $1 )) s"; }
fz_seconds=${DQN_DOVS_FUZZ_SECONDS:-40}
test_jobs=${DQN_DOVS_TEST_JOBS:-3}

# Sanitizer lane (background): fuzz targets (scripts/fuzz.sh: the committed crash inputs once, then a bounded fuzzing
# run per target), then the core gtests under AddressSanitizer + UBSan (scripts/test_asan.sh, build_asan/).
rm -f log/fuzz.last.txt log/asan.last.txt log/lane.times
(
  t=$(date +%s)
  FUZZ_SECONDS=$fz_seconds nice -n 10 bash scripts/fuzz.sh >log/fuzz.last.txt 2>&1
  echo "fuzz $(took "$t")" >>log/lane.times
  t=$(date +%s)
  nice -n 10 bash scripts/test_asan.sh >log/asan.last.txt 2>&1
  echo "asan $(took "$t")" >>log/lane.times
) &
lane=$!
trap 'kill $lane 2>/dev/null' EXIT

t=$(date +%s)
echo "[test] C++ gtests and rostests (colcon test, $test_jobs at a time)"
colcon test --base-paths . --build-base build --install-base install --merge-install \
  --event-handlers console_direct- console_start_end- --ctest-args -j "$test_jobs" --output-on-failure \
  >log/test.last.txt 2>&1
summary=$(colcon test-result --test-result-base build/dqn_dovs/test_results --all --verbose 2>&1 | tee log/test-result.last.txt | tail -n 1)
failed_lines=$(grep -E "^build/.*: [0-9]+ tests?, [0-9]+ errors?, [1-9][0-9]* failures?|^build/.*: [0-9]+ tests?, [1-9][0-9]* errors?" log/test-result.last.txt || true)
read -r c_tests c_err c_fail c_skip < <(echo "$summary" | sed -E 's/Summary: ([0-9]+) tests?, ([0-9]+) errors?, ([0-9]+) failures?, ([0-9]+) skipped.*/\1 \2 \3 \4/')
if ! [[ "$c_tests" =~ ^[0-9]+$ ]]; then
  echo "[test] could not read colcon test results: $summary" >&2; c_tests=0; c_err=1; c_fail=0; c_skip=0
fi
if [ "$c_err" -gt 0 ] || [ "$c_fail" -gt 0 ]; then
  echo "[test] C++/ROS test failures:"; echo "$failed_lines"
  grep -B2 -A20 -E "\[  FAILED  \]|FAILURE|Failure|failures=\"[1-9]" log/test-result.last.txt | head -120
fi
echo "[test] C++/ROS: $c_tests tests, $c_fail failures, $c_err errors, $c_skip skipped ($(took "$t"))"

echo "[test] Python tests (pytest)"
t=$(date +%s)
py_pass=0; py_fail=0; py_skip=0
if ls test/python/test_*.py >/dev/null 2>&1; then
  PYTHONPATH="$root/python${PYTHONPATH:+:$PYTHONPATH}" DQN_DOVS_BIN_DIR="$root/install/lib/dqn_dovs" \
    DQN_DOVS_REQUIRE_CORE="${DQN_DOVS_REQUIRE_CORE:-1}" MPLBACKEND=Agg \
    .venv/bin/python -m pytest -q -p no:cacheprovider --junitxml=log/pytest.xml test/python >log/pytest.last.txt 2>&1
  tail -n 30 log/pytest.last.txt
  # The counts are the attributes of the JUnit report's first <testsuite> element.
  suite=$(grep -oE '<testsuite [^>]*>' log/pytest.xml 2>/dev/null | head -n 1)
  count() { local v; v=$(echo "$suite" | grep -oE " $1=\"[0-9]+\"" | grep -oE "[0-9]+"); echo "${v:-0}"; }
  py_total=$(count tests); py_err=$(count errors); py_fail0=$(count failures); py_skip=$(count skipped)
  [ -n "$suite" ] || { echo "[test] no pytest report (log/pytest.xml)" >&2; py_err=1; }
  py_fail=$((py_fail0 + py_err)); py_skip=$py_skip; py_pass=$((py_total - py_fail - py_skip))
fi
echo "[test] Python tests: $(took "$t")"

# Formatting of every C++ file (.clang-format; make format applies it): one test.
echo "[test] C++ formatting (scripts/format_check.sh)"
if bash scripts/format_check.sh >log/format.last.txt 2>&1; then
  fmt_pass=1; fmt_fail=0; tail -n 1 log/format.last.txt
else
  fmt_pass=0; fmt_fail=1; head -n 30 log/format.last.txt
fi

# The sanitizer lane's results.
echo "[test] waiting for the sanitizer lane (fuzz targets, ASan)"
wait $lane
trap - EXIT
echo "[test] fuzz targets: regressions + ${fz_seconds} s of fuzzing each (scripts/fuzz.sh; $(grep '^fuzz' log/lane.times | cut -d' ' -f2-))"
grep -v -E "^\[fuzz\] building|^$|^[0-9]+ passed, [0-9]+ failed" log/fuzz.last.txt
read -r fz_pass fz_fail < <(tail -n 1 log/fuzz.last.txt | sed -nE 's/^([0-9]+) passed, ([0-9]+) failed.*/\1 \2/p')
if ! [[ "${fz_pass:-}" =~ ^[0-9]+$ ]]; then
  echo "[test] could not read the fuzz summary (log/fuzz.last.txt)" >&2; fz_pass=0; fz_fail=1
fi

# Core gtests under AddressSanitizer + UBSan (scripts/test_asan.sh, build_asan/): one test per gtest executable.
echo "[test] core gtests under ASan + UBSan (scripts/test_asan.sh; $(grep '^asan' log/lane.times | cut -d' ' -f2-))"
grep -v -E "^$|^[0-9]+ passed, [0-9]+ failed" log/asan.last.txt
read -r as_pass as_fail < <(tail -n 1 log/asan.last.txt | sed -nE 's/^([0-9]+) passed, ([0-9]+) failed.*/\1 \2/p')
if ! [[ "${as_pass:-}" =~ ^[0-9]+$ ]]; then
  echo "[test] could not read the ASan summary (log/asan.last.txt)" >&2; as_pass=0; as_fail=1
fi

c_pass=$((c_tests - c_fail - c_err - c_skip))
passed=$((c_pass + py_pass + fmt_pass + fz_pass + as_pass))
failed=$((c_fail + c_err + py_fail + fmt_fail + fz_fail + as_fail))
skipped=$((c_skip + py_skip))
echo "[test] all phases: $(took "$t_start")"
echo
echo "$passed passed, $failed failed, $skipped skipped"
[ "$failed" -eq 0 ] && [ "$passed" -gt 0 ]
