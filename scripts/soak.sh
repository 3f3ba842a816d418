#!/usr/bin/env bash
# The soak (test/ros/soak.test): the full pipeline in simulation, in real time, over generated scenarios
# for SOAK_SECONDS of wall time (default 3600). Figures: bench/results/soak.json and bench/results/soak.md.
# `make test` runs the same test for 300 s.
set -uo pipefail
cd "$(dirname "$0")/.."
root="$(pwd)"
# shellcheck source=scripts/env.sh
. scripts/env.sh
export ROS_HOME="$root/log/ros_home"
export ROS_LOG_DIR="$ROS_HOME/log"
mkdir -p "$ROS_LOG_DIR" bench/results
seconds="${SOAK_SECONDS:-3600}"
env_sh="build/dqn_dovs/catkin_generated/env_cached.sh"  # the devel space, where the test executables are
if [ ! -x "$env_sh" ]; then echo "[soak] no $env_sh: run make build first" >&2; exit 2; fi
echo "[soak] ${seconds} s of random scenarios in real time (log: log/soak.last.txt)"
"$env_sh" rostest --text "$root/test/ros/soak.test" soak_seconds:="$seconds" ${SOAK_ARGS:-} 2>&1 | tee log/soak.last.txt \
  | grep --line-buffered -E "^\[soak\]|FAILURE|Failure|\[  FAILED  \]|\[       OK \]"
rc=${PIPESTATUS[0]}
[ -f bench/results/soak.md ] && cat bench/results/soak.md
exit "$rc"
