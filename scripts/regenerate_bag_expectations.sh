#!/usr/bin/env bash
# Rewrites the bag regression's expectations (test/data/replay_expected_tracks.csv and
# replay_expected_decisions.csv) by replaying test/data/replay.bag with the current code, parameters and
# model: run it after an intended change of the tracker, the DOVS, the parameters or the model (or after
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
# The regression test itself writes the expectations when regenerate is true (same replay, same parameters).
log="$ROS_HOME/regenerate.log"
rostest --text "$root/test/ros/bag_replay.test" regenerate:=true >"$log" 2>&1 || true
if ! grep -E "bag replay: wrote" "$log"; then
  echo "regenerate_bag_expectations: the replay failed; see $log" >&2
  grep -E "Failure|FAILED|rror" "$log" | head -20 >&2
  exit 1
fi
git -C "$root" diff --stat -- test/data/replay_expected_tracks.csv test/data/replay_expected_decisions.csv 2>/dev/null || true
