#!/usr/bin/env bash
# End-to-end latency of the ROS pipeline: simulator_node (wall clock, 10 Hz scans of one of the package's scenarios) ->
# obstacle_tracker_node -> dovs_node -> planner_node as launch/pipeline.launch starts them, twice: each node its
# own process, then the three as nodelets in one manager (nodelets:=true). planner_node publishes on
# planner/latency, for every velocity space it chooses an action for, the time from the stamp of the scan
# behind it to that choice. Writes latency_ms_median, latency_ms_p99 (+ mean, max, samples) of the processes
# and the same keys prefixed nodelets_ to the JSON path $1. The chosen action reaches cmd_vel at the planner's
# next control tick (every 0.2 s, by design), which this figure leaves out.
# Run from the repository root (scripts/bench.sh does): bash bench/bench_e2e.sh bench/results/e2e.json
# Environment: DQN_DOVS_SETUP (default install/setup.sh), ROS_PORT (11474), DURATION (40 s of sampling),
# SCENARIO (a .dovs file; default data/scenarios/room/1-8/3).
set -euo pipefail
out_json="${1:-bench/results/e2e.json}"
root="$(pwd)"
# shellcheck source=scripts/env.sh
. "$root/scripts/env.sh"
setup="${DQN_DOVS_SETUP:-install/setup.sh}"
[ -f "$setup" ] || { echo "bench_e2e: $setup does not exist; run 'make build' (or set DQN_DOVS_SETUP)" >&2; exit 2; }
scenario="$(realpath -m "${SCENARIO:-$root/data/scenarios/room/1-8/3.dovs}")"
[ -f "$scenario" ] || { echo "bench_e2e: scenario $scenario does not exist" >&2; exit 2; }
model="$root/models/dqn_dovs.dqnw"
port="${ROS_PORT:-11474}"
# shellcheck disable=SC1090
set +u; . "$setup"; set -u
export ROS_MASTER_URI="http://localhost:$port"
export ROS_HOME="${ROS_HOME:-/tmp/dqn_dovs_bench_e2e_ros}"
mkdir -p "$ROS_HOME" "$(dirname "$out_json")"
log="$ROS_HOME/bench_e2e.log"

pids=()
cleanup() {
  for ((i = ${#pids[@]} - 1; i >= 0; i--)); do
    kill -INT "${pids[$i]}" 2>/dev/null || true
    for _ in $(seq 50); do kill -0 "${pids[$i]}" 2>/dev/null || break; sleep 0.2; done
    kill -KILL "${pids[$i]}" 2>/dev/null || true
  done
}
trap cleanup EXIT
# Our own master, stopped with everything else whatever happens.
roscore -p "$port" >"$log" 2>&1 &
pids+=($!)
for _ in $(seq 50); do rosparam list >/dev/null 2>&1 && break; sleep 0.2; done
rm -f "$out_json"
for nodelets in false true; do
  roslaunch "$root/bench/e2e.launch" scenario:="$scenario" model:="$model" nodelets:=$nodelets >>"$log" 2>&1 &
  launch_pid=$!
  pids+=($launch_pid)
  prefix=""; label="3 processes"
  if [ "$nodelets" = true ]; then prefix="nodelets_"; label="3 nodelets in one process"; fi
  if ! /usr/bin/python3 "$root/bench/e2e_collect.py" --out "$out_json" --duration "${DURATION:-40}" \
      --key-prefix "$prefix" --label "$label"; then
    echo "bench_e2e: failed (nodelets:=$nodelets); last lines of $log:" >&2
    tail -20 "$log" >&2
    exit 1
  fi
  # Stop this pipeline before the next one starts.
  kill -INT "$launch_pid" 2>/dev/null || true
  for _ in $(seq 75); do kill -0 "$launch_pid" 2>/dev/null || break; sleep 0.2; done
  kill -KILL "$launch_pid" 2>/dev/null || true
  unset 'pids[${#pids[@]}-1]'
done
echo "wrote $out_json"
