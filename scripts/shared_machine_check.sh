#!/usr/bin/env bash
# The soak rostest on a machine that runs another copy of the pipeline: the other copy (sim.launch under its own
# master on port 11577, the same node names) starts first and is stopped 40 s into a 60 s soak. The soak finds its
# nodes through its own master (test/ros/test_soak.cpp, findNodePid), so it must pass; a test that looked its
# nodes up by name among the machine's processes would watch the other copy and report it gone.
# Usage (after make build): bash scripts/shared_machine_check.sh; exits with the rostest's status.
set -uo pipefail
cd "$(dirname "$0")/.."
root="$(pwd)"
# shellcheck source=scripts/env.sh
. scripts/env.sh
# The test executables live in the build's devel space (as colcon test runs them).
setup=build/dqn_dovs/devel/setup.sh
[ -f "$setup" ] || { echo "shared_machine_check: $setup missing; run 'make build' first" >&2; exit 2; }
# shellcheck disable=SC1090
set +u; . "$setup"; set -u
export ROS_HOME="$root/log/shared_machine_check"
mkdir -p "$ROS_HOME"
port=11577
ROS_MASTER_URI=http://localhost:$port roslaunch -p $port "$root/launch/sim.launch" >"$ROS_HOME/other_copy.log" 2>&1 &
other=$!
trap 'kill -INT $other 2>/dev/null; wait $other 2>/dev/null' EXIT
sleep 12
kill -0 $other 2>/dev/null || { echo "shared_machine_check: the other copy did not start ($ROS_HOME/other_copy.log)" >&2; exit 1; }
echo "[shared] other copy running (master port $port): $(pgrep -fc '__name:=planner') planner process(es) on the machine"
( sleep 40; kill -INT $other 2>/dev/null && echo "[shared] other copy stopped 40 s into the soak" ) &
rostest --text "$root/test/ros/soak.test" soak_seconds:=60 >"$ROS_HOME/soak.log" 2>&1
status=$?
wait
grep -E "^\[ +(OK|FAILED) +\]|gone|no process" "$ROS_HOME/soak.log"
echo "[shared] soak rostest exit status $status"
exit $status
