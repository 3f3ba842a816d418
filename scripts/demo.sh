#!/usr/bin/env bash
# make demo: the full ROS pipeline in simulation with the shipped model on a few shared scenarios.
set -euo pipefail
cd "$(dirname "$0")/.."
# shellcheck source=scripts/env.sh
. scripts/env.sh
# shellcheck disable=SC1091
set +u; . install/setup.sh; set -u
export ROS_HOME="$(pwd)/out/demo/ros_home"
mkdir -p "$ROS_HOME"
exec .venv/bin/python scripts/demo.py "$@"
