#!/usr/bin/env bash
# make demo: the full ROS pipeline in simulation with the shipped model on a few shared scenarios.
# make demo WORLD=clutter (or crowd, corridor, doorway, junction): generated building worlds with people instead,
# in out/demo_WORLD. Arguments go to scripts/demo.py.
set -euo pipefail
cd "$(dirname "$0")/.."
# shellcheck source=scripts/env.sh
. scripts/env.sh
# shellcheck disable=SC1091
set +u; . install/setup.sh; set -u
world="${WORLD:-room}"
out="out/demo"
if [ "$world" != room ]; then
  out="out/demo_$world"
  set -- --world "$world" "$@"
fi
export ROS_HOME="$(pwd)/$out/ros_home"
mkdir -p "$ROS_HOME"
exec .venv/bin/python scripts/demo.py "$@"
