#!/usr/bin/env bash
# Installs what a fresh Debian 12 machine lacks to build, test and run dqn_dovs:
# Debian's ROS 1 packages and build tools (apt) and the project's Python venv.
# Idempotent and quiet: a second run only checks and returns.
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
# shellcheck source=scripts/env.sh
. "$here/scripts/env.sh"

APT_PACKAGES=(
  build-essential cmake ninja-build pkg-config clang-format
  catkin colcon python3-colcon-ros python3-colcon-test-result python3-colcon-cmake
  python3-catkin-pkg python3-rospkg python3-empy
  ros-base-dev libroscpp-dev librosbag-dev libtf2-ros-dev libtf2-geometry-msgs-dev libtf2-eigen-dev
  librostest-dev python3-rostest python3-roslaunch python3-rosbag python3-rospy python3-rosnode
  python3-rostopic python3-rosservice python3-rosparam rosout python3-rosmaster
  ros-message-generation ros-message-runtime
  libstd-msgs-dev libstd-srvs-dev libsensor-msgs-dev libnav-msgs-dev libgeometry-msgs-dev
  libvisualization-msgs-dev python3-std-srvs python3-sensor-msgs python3-nav-msgs
  python3-geometry-msgs python3-visualization-msgs python3-tf2-ros
  libcv-bridge-dev libimage-transport-dev libopencv-dev
  libactionlib-dev libmove-base-msgs-dev python3-actionlib python3-move-base-msgs
  libdiagnostic-msgs-dev libdynamic-reconfigure-config-init-mutex-dev python3-dynamic-reconfigure
  libeigen3-dev liburdfdom-dev liburdfdom-headers-dev ros-robot-state-publisher
  librviz-dev rviz pluginlib-dev libclass-loader-dev
  libnodeletlib-dev libnodelet-dev libnodeletlib-tools  # the pipeline as nodelets (nodelets:=true)
  googletest libgtest-dev libgmock-dev
  pybind11-dev python3-pybind11 python3-dev python3-venv python3-numpy python3-yaml
  clang libclang-rt-14-dev libfuzzer-14-dev  # fuzz targets (fuzz/, make fuzz)
  ccache  # compiler cache: a clean clone's builds (colcon, ASan, fuzz) reuse what this machine compiled before
  time bc  # make bench: peak memory per benchmark (GNU time), wall times
)

missing=()
for p in "${APT_PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "[setup] installing ${#missing[@]} Debian packages: ${missing[*]}"
  SUDO=""; [ "$(id -u)" -eq 0 ] || SUDO=sudo
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq >/dev/null
  $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/tmp/dqn_dovs_apt.log 2>&1 || {
    echo "[setup] apt-get install failed; see /tmp/dqn_dovs_apt.log" >&2; tail -20 /tmp/dqn_dovs_apt.log >&2; exit 1; }
fi

# Python venv for the trainer and the Python tests (Debian's python3, so ROS python modules stay importable through
# --system-site-packages). The venv (PyTorch and its libraries: gigabytes) is made once per machine and set of
# requirements, in $DQN_DOVS_VENV_CACHE (default ~/.cache/dqn_dovs/venv-HASH, HASH of python/requirements.txt and the
# interpreter), and .venv links to it: a second checkout on the same machine is set up in a second.
# DQN_DOVS_VENV_CACHE=none keeps the venv in .venv itself. An existing .venv folder is kept and brought up to date.
venv="$here/.venv"
req="$here/python/requirements.txt"
python=/usr/bin/python3
install_requirements() {  # $1: the venv
  if [ ! -x "$1/bin/python" ]; then
    echo "[setup] creating Python venv in $1"
    "$python" -m venv --system-site-packages "$1"
  fi
  if [ -f "$req" ] && { [ ! -f "$1/.requirements.stamp" ] || ! cmp -s "$req" "$1/.requirements.stamp"; }; then
    echo "[setup] installing Python requirements into $1"
    "$1/bin/pip" install -q --disable-pip-version-check -r "$req"
    cp "$req" "$1/.requirements.stamp"
  fi
}
cache="${DQN_DOVS_VENV_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/dqn_dovs}"
if [ "$cache" = none ] || { [ -d "$venv" ] && [ ! -L "$venv" ]; }; then
  install_requirements "$venv"
else
  key=$({ cat "$req" 2>/dev/null; "$python" -c 'import sys; print(sys.version)'; } | sha256sum | cut -c1-16)
  shared="$cache/venv-$key"
  mkdir -p "$cache"
  # One checkout at a time makes it; the others wait for it.
  (
    flock 9
    install_requirements "$shared"
  ) 9>"$shared.lock"
  if [ "$(readlink "$venv" 2>/dev/null)" != "$shared" ]; then
    rm -f "$venv"
    ln -s "$shared" "$venv"
    echo "[setup] .venv -> $shared"
  fi
fi
exit 0
