#!/usr/bin/env bash
# Records a replay regression bag: simulator_node + the pipeline with the shipped model (launch/sim.launch, sim
# time, real time) on one scenario, topics scan, odom, tf, tf_static, the goal, the planner's local goals (the
# route's subgoals in worlds with walls) and the map (when the simulator publishes one), for DURATION simulated
# seconds (default 14), lz4-compressed. After recording a new bag, regenerate the expectations with
# scripts/regenerate_bag_expectations.sh.
#   scripts/record_test_bag.sh [SCENARIO.dovs] [OUT.bag]      test/data/replay.bag: one of the package's scenarios, the room
#   SIM_ARGS="world:=clutter seed:=3 obstacles:=6 odom_noise:=low tracker_map:=true dovs_map:=true" \
#     scripts/record_test_bag.sh - test/data/replay_people_map.bag   a generated building world with people and map
# Environment: DQN_DOVS_SETUP (default install/setup.sh; e.g. build_me/devel/setup.sh), ROS_PORT (11472),
# DURATION (14), SIM_ARGS (more sim.launch arguments; a scenario of "-" lets the simulator generate its world).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
# Absolute paths: the nodes run in ROS_HOME.
scenario="${1:-$root/data/scenarios/room/1-2/1.dovs}"
[ "$scenario" = - ] || scenario="$(realpath -m "$scenario")"
out="$(realpath -m "${2:-$root/test/data/replay.bag}")"
cd "$root"
# shellcheck source=scripts/env.sh
. "$root/scripts/env.sh"
port="${ROS_PORT:-11472}"
duration="${DURATION:-14}"
setup="${DQN_DOVS_SETUP:-install/setup.sh}"
[ "$scenario" = - ] || [ -f "$scenario" ] || { echo "record_test_bag: scenario $scenario does not exist" >&2; exit 2; }
sim_args=()
[ "$scenario" = - ] || sim_args+=(scenario:="$scenario")
# shellcheck disable=SC2206
sim_args+=(${SIM_ARGS:-})
[ -f "$setup" ] || { echo "record_test_bag: $setup does not exist (build first, or set DQN_DOVS_SETUP)" >&2; exit 2; }
# shellcheck disable=SC1090
set +u; . "$setup"; set -u
export ROS_MASTER_URI="http://localhost:$port"
export ROS_HOME="${ROS_HOME:-/tmp/dqn_dovs_record_ros}"
mkdir -p "$ROS_HOME" "$(dirname "$out")"
log="$ROS_HOME/record.log"

pids=()
cleanup() {
  for ((i = ${#pids[@]} - 1; i >= 0; i--)); do kill -INT "${pids[$i]}" 2>/dev/null || true; done
  sleep 2
  for pid in "${pids[@]}"; do kill -KILL "$pid" 2>/dev/null || true; done
}
trap cleanup EXIT

roscore -p "$port" >"$log" 2>&1 &
pids+=($!)
for _ in $(seq 50); do rosparam list >/dev/null 2>&1 && break; sleep 0.2; done
rosparam set /use_sim_time true
# The recorder subscribes first (the goal is latched, so it is caught whenever it comes) and counts
# DURATION in sim time, which starts with the simulator's first /clock.
rm -f "$out" "$out.active"
rosbag record --lz4 -O "$out" --duration="$duration" /scan /odom /tf /tf_static /move_base_simple/goal /planner/local_goal /map \
  >>"$log" 2>&1 &
recorder=$!
sleep 1
# By path: a build tree and an install tree may both provide the package.
roslaunch "$root/launch/sim.launch" "${sim_args[@]}" realtime_factor:=1.0 >>"$log" 2>&1 &
launcher=$!
pids+=($launcher)
deadline=$((SECONDS + 3 * duration + 60))
while kill -0 "$recorder" 2>/dev/null; do
  if ! kill -0 "$launcher" 2>/dev/null || [ "$SECONDS" -gt "$deadline" ]; then
    echo "record_test_bag: the simulation stopped or the recording took too long; see $log" >&2
    kill -INT "$recorder" 2>/dev/null || true
    exit 1
  fi
  sleep 0.5
done
wait "$recorder" || { echo "record_test_bag: rosbag record failed; see $log" >&2; exit 1; }
rosbag info "$out"
