# The environment every script of this repository runs in, sourced once near its top (scripts/*.sh,
# bench/*.sh, the Makefile's recipes through them): Debian's python3 and ROS tools first on PATH (another
# python3 earlier on PATH breaks catkin, rostest and roslaunch), and the user's site-packages kept out of
# the project's venv.
export PATH=/usr/bin:/bin:/usr/sbin:/sbin:$PATH
export PYTHONNOUSERSITE=1

# The core gtest sources, one folder per component: test/<component>/test_*.cpp (not the ROS tests, not Python).
core_test_sources() { ls test/*/test_*.cpp | grep -v -E '^test/(ros|ros_unit|python)/'; }

# ccache (scripts/setup.sh installs it) for the three builds (colcon, build_asan/, build_fuzz/): paths under the
# checkout are hashed relative to it, so that a second clone, anywhere, reuses what the first compiled.
DQN_DOVS_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
export CCACHE_BASEDIR="$DQN_DOVS_ROOT"
export CCACHE_NOHASHDIR=1
export CCACHE_SLOPPINESS=${CCACHE_SLOPPINESS:-include_file_mtime,include_file_ctime,time_macros}
# The compiler launcher flags of a CMake configure: ccache when it is there.
ccache_args() { command -v ccache >/dev/null 2>&1 && echo "-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_C_COMPILER_LAUNCHER=ccache"; true; }
