# The environment every script of this repository runs in, sourced once near its top (scripts/*.sh,
# bench/*.sh, the Makefile's recipes through them): Debian's python3 and ROS tools first on PATH (another
# python3 earlier on PATH breaks catkin, rostest and roslaunch), and the user's site-packages kept out of
# the project's venv.
export PATH=/usr/bin:/bin:/usr/sbin:/sbin:$PATH
export PYTHONNOUSERSITE=1

# The core gtest sources, one folder per component: test/<component>/test_*.cpp (not the ROS tests, not Python).
core_test_sources() { ls test/*/test_*.cpp | grep -v -E '^test/(ros|ros_unit|python)/'; }
