#!/usr/bin/env bash
# Rewrites the bag regressions' expectations (test/data/replay_expected_*.csv for test/data/replay.bag, the room,
# and test/data/replay_people_map_expected_*.csv for replay_people_map.bag, people with the map) by replaying each
# bag with the current code, parameters and model: run it after an intended change of the tracker, the DOVS, the parameters or the model (or after
# recording a new bag with scripts/record_test_bag.sh), then review the CSV diff before committing it.
# Environment: DQN_DOVS_SETUP (default install/setup.sh; e.g. build_me/devel/setup.sh).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
cd "$root"
# shellcheck source=scripts/env.sh
. "$root/scripts/env.sh"
setup="${DQN_DOVS_SETUP:-install/setup.sh}"
[ -f "$setup" ] || { echo "regenerate_bag_expectations: $setup does not exist (build first, or set DQN_DOVS_SETUP)" >&2; exit 2; }
# shellcheck disable=SC1090
set +u; . "$setup"; set -u
export ROS_HOME="${ROS_HOME:-/tmp/dqn_dovs_regenerate_ros}"
mkdir -p "$ROS_HOME"
# The regression tests themselves write the expectations when regenerate is true (same replay, same parameters).
for test in bag_replay bag_replay_people_map; do
  log="$ROS_HOME/regenerate_$test.log"
  rostest --text "$root/test/ros/$test.test" regenerate:=true >"$log" 2>&1 || true
  if ! grep -E "bag replay: wrote" "$log"; then
    echo "regenerate_bag_expectations: the replay of $test failed; see $log" >&2
    grep -E "Failure|FAILED|rror" "$log" | head -20 >&2
    exit 1
  fi
done
git -C "$root" diff --stat -- 'test/data/replay*_expected_*.csv' 2>/dev/null || true
