#!/usr/bin/env bash
# Regenerates docs/benchmark_worlds.md: dqn_dovs and s_dovs, and oracle (the physical limit, a search that reads
# the simulator's future; docs/planners.md section 9) on the same episodes, with the evaluation CLI on generated
# worlds, LIDAR + tracker in the loop, seed 11001 (the seed of this report, never used to tune anything):
# - every world family (room, crowd, corridor, doorway, clutter, junction) at N = 5, 10 and 15 with the sim LIDAR
#   and social-force people to whom the robot is invisible: docs/benchmark_worlds/FAMILY_nN/;
# - crowd at N = 10 with the hokuyo, urg04lx and rplidar_a1 profiles (crowd_n10_PROFILE/; sim is crowd_n10/);
# - crowd at N = 10 with people avoiding each other by ORCA (crowd_n10_orca/), constant-velocity people
#   (crowd_n10_constant/) and people who give way to the robot (crowd_n10_see_robot/).
# Each run folder keeps results.csv, run.json, summary.json and summary.md; FAMILY_n10/ also keeps dqn_dovs's
# first trajectory picture. Then python/dqn_dovs_py/worlds_report.py writes the tables and
# docs/benchmark_worlds/success_by_world.png, including docs/benchmark_worlds_discussion.md (hand-written).
# A run the tool stops (a world it cannot generate) keeps only failed.txt, its error; the others go on, the report
# shows it as not run and the script exits 1 at the end.
# Run from anywhere (make benchmark-worlds does); one progress line per run with its wall time. With the defaults
# (24 runs x 3 methods x 50 episodes) about 31 min on 2 cores (1879 s measured). The planners: about 3 min (189 s
# measured while the machine also compiled). The rest is the oracle, mostly its further searches on the episodes its
# first search does not solve (docs/planners.md, "Several searches"), each a whole episode of up to 100 s of
# simulated time: the doorway at N = 15 about 6 min, the corridor, clutter and junction at N = 15 3-3.5 min each, at
# N = 10 1-3.5 min, the crowds and the room under 1 min.
# ORACLE=0 leaves it out (about 3 min).
# The planners see people as the robot's pipeline shows them where legs are paired (every family but the room): moving
# on the arc of the learned people prediction (dqn_dovs_eval --predict-people; launch/pipeline.launch's default).
# Environment: EPISODES (50 per run and method), THREADS (2), ORACLE (1: with oracle; 0: dqn_dovs and s_dovs only),
# MODEL (models/dqn_dovs.dqnw), PEOPLE_PREDICTOR (models/people_predictor_tracks.dqnp; empty: none), DQN_DOVS_EVAL
# (default install/lib/dqn_dovs/dqn_dovs_eval), OUT_DIR
# (docs/benchmark_worlds), OUT_DOC (docs/benchmark_worlds.md).
set -euo pipefail
cd "$(dirname "$0")/.."
# shellcheck source=scripts/env.sh
. scripts/env.sh
root="$(pwd)"
seed=11001  # fixed: the report's seed
episodes="${EPISODES:-50}"
threads="${THREADS:-2}"
model="${MODEL:-models/dqn_dovs.dqnw}"
predictor="${PEOPLE_PREDICTOR-models/people_predictor_tracks.dqnp}"
exe="${DQN_DOVS_EVAL:-install/lib/dqn_dovs/dqn_dovs_eval}"
out_dir="${OUT_DIR:-docs/benchmark_worlds}"
out_doc="${OUT_DOC:-docs/benchmark_worlds.md}"
families=(room crowd corridor doorway clutter junction)
case "${ORACLE:-1}" in
  1) methods=dqn_dovs,s_dovs,oracle ;;
  0) methods=dqn_dovs,s_dovs ;;
  *) echo "benchmark_worlds: ORACLE must be 0 or 1 (got '$ORACLE')" >&2; exit 2 ;;
esac
counts=(5 10 15)
# The installed tools find the core library through the install tree.
export LD_LIBRARY_PATH="$root/install/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"

[ -x "$exe" ] || { echo "benchmark_worlds: $exe not found; run 'make build' (or set DQN_DOVS_EVAL)" >&2; exit 2; }
[ -f "$model" ] || { echo "benchmark_worlds: model $model not found" >&2; exit 2; }
[ -z "$predictor" ] || [ -f "$predictor" ] || {
  echo "benchmark_worlds: people predictor $predictor not found (PEOPLE_PREDICTOR= for none)" >&2
  exit 2
}
predict=(--predict-people none)
[ -z "$predictor" ] || predict=(--predict-people "$predictor")
[ -x .venv/bin/python ] || { echo "benchmark_worlds: .venv missing; run 'make setup'" >&2; exit 2; }

total_runs=$(( ${#families[@]} * ${#counts[@]} + 6 ))
done_runs=0
failed=()

# evaluate NAME N TRAJECTORIES [dqn_dovs_eval options...]: one run of the methods at N into OUT_DIR/NAME/.
evaluate() {
  local name=$1 n=$2 trajectories=$3
  shift 3
  local dir="$out_dir/$name"
  rm -rf "$dir"
  mkdir -p "$dir"
  local args=(--methods "$methods" --generate "$seed" --obstacles "$n" --episodes "$episodes"
              --threads "$threads" --model "$model" --trajectories "$trajectories" --out "$dir" "$@")
  local start end
  start=$(date +%s.%N)
  local outcome
  if "$exe" "${args[@]}" >"$dir/eval.log" 2>&1; then
    # The console table's mean row: success, c = collision, t = timeout of each method in order.
    outcome="${methods//,/ / }:$(grep -E '^ +mean ' "$dir/eval.log" | sed -E 's/^ +mean//; s/ +/ /g')"
  else
    # The tool stops at its first error (its last line); the report shows the run as not run, with it.
    tail -n 1 "$dir/eval.log" >"$dir/failed.txt"
    failed+=("$name")
    outcome="FAILED: $(cat "$dir/failed.txt")"
  fi
  end=$(date +%s.%N)
  done_runs=$((done_runs + 1))
  printf '[%2d/%d] %-20s %6.1f s  %s\n' "$done_runs" "$total_runs" "$name" "$(echo "$end - $start" | bc)" "$outcome"
  # What the report needs stays; paths.json, the success plot and every other picture would make the folder heavy.
  find "$dir" -type f ! -name results.csv ! -name run.json ! -name summary.json ! -name summary.md \
    ! -name failed.txt ! -name 'trajectories_dqn_dovs_*' -delete
}

mkdir -p "$out_dir"
total_start=$(date +%s.%N)
for family in "${families[@]}"; do
  for n in "${counts[@]}"; do
    keep=0
    [ "$n" = 10 ] && keep=1  # one dqn_dovs trajectory per family
    if [ "$family" = room ]; then
      evaluate "${family}_n$n" "$n" "$keep" --world "$family" --sensor sim
    else
      evaluate "${family}_n$n" "$n" "$keep" --world "$family" --sensor sim "${predict[@]}"
    fi
  done
done
for sensor in hokuyo urg04lx rplidar_a1; do
  evaluate "crowd_n10_$sensor" 10 0 --world crowd --sensor "$sensor" "${predict[@]}"
done
evaluate crowd_n10_orca 10 0 --world crowd --sensor sim --people-model orca "${predict[@]}"
evaluate crowd_n10_constant 10 0 --world crowd --sensor sim --people-model constant "${predict[@]}"
evaluate crowd_n10_see_robot 10 0 --world crowd --sensor sim --people-see-robot "${predict[@]}"
total_end=$(date +%s.%N)
total_wall=$(echo "$total_end - $total_start" | bc)
printf "=== benchmark-worlds: %d runs in %.1f s\n" "$total_runs" "$total_wall"

commit=$(git rev-parse --short HEAD 2>/dev/null || echo unknown)
dirty=$(git status --porcelain --untracked-files=no 2>/dev/null | grep -q . && echo "+local changes" || true)
MPLBACKEND=Agg PYTHONPATH="$root/python" .venv/bin/python -m dqn_dovs_py.worlds_report --runs "$out_dir" \
  --out "$out_doc" --discussion docs/benchmark_worlds_discussion.md --commit "$commit$dirty" --model "$model" \
  --total-wall "$total_wall"
if [ ${#failed[@]} -gt 0 ]; then
  echo "benchmark_worlds: ${#failed[@]} run(s) failed (${failed[*]}); the report shows them as not run" >&2
  exit 1
fi
