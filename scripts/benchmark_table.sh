#!/usr/bin/env bash
# Regenerates docs/benchmark.md: every method on a folder of room scenarios (SCENARIOS, default the package's own
# data/scenarios/room; an external set such as the authors' RUMOR test scenarios by SCENARIOS=DIR,
# docs/external_benchmark.md) with the evaluation CLI, once with the
# LIDAR + tracker in the loop (results/benchmark/tracker/) and once with perfect information
# (results/benchmark/perfect/), then python/dqn_dovs_py/benchmark_report.py writes the tables, plots and verdicts.
# `oracle` (docs/planners.md section 9: the physical limit, a search that reads the simulator's future) runs on the
# same episodes in both runs; the report gives its column, each method's share of its successes and the episodes it
# did not solve. It is a ceiling, never a baseline. ORACLE=0 leaves it out. `bound` (the limit from above: the
# episodes no robot within the limits can solve; it does not depend on the perception) runs once on the same
# episodes into results/benchmark/bound/ (about 1 min); BOUND=0 leaves it out.
# Run from anywhere (make benchmark-table does). With the defaults (2 x 13500 episodes) about 20 min on a 2-core
# machine (1188 s measured, 2347 CPU-s). The eight planners: 1000 CPU-s measured from a 2-episode run (tracker 0.065,
# perfect information 0.042 CPU-s per episode); the oracle: the rest, about 0.45 CPU-s per episode in either run, its
# first search 0.32 (dqn_dovs_eval --methods oracle --obstacles 1-15 --episodes 2 --threads 1, 9.6 s) and its further
# searches on the 8 % of episodes the first one does not solve (docs/planners.md, "Several searches"). With ORACLE=0
# about 10 min. Proportionally longer when the cores are shared.
# Environment: SCENARIOS (data/scenarios/room: a folder laid out as 1-N/K.dovs), PAPER (none: a CSV of the paper's
# Table 1, whose columns are then drawn beside ours), EPISODES (100 per obstacle count), OBSTACLES (1-15), THREADS (2), MODEL (models/dqn_dovs.dqnw),
# METHODS (all eight), ORACLE (1: add oracle to METHODS unless it is there; 0: leave it out), BOUND (1: the bound's
# run; 0: none), DQN_DOVS_EVAL (default
# install/lib/dqn_dovs/dqn_dovs_eval), OUT_DOC (docs/benchmark.md), OUT_DIR (results/benchmark).
set -euo pipefail
cd "$(dirname "$0")/.."
# shellcheck source=scripts/env.sh
. scripts/env.sh
root="$(pwd)"
episodes="${EPISODES:-100}"
obstacles="${OBSTACLES:-1-15}"
threads="${THREADS:-2}"
model="${MODEL:-models/dqn_dovs.dqnw}"
methods="${METHODS:-dqn_dovs,dqn_dovs_latest_escape,dqn_dovs_no_escape,dqn_dovs_unshielded,s_dovs,orca_holonomic,orca_diffdrive,dwa}"
case "${ORACLE:-1}" in
  1) [[ ",$methods," == *,oracle,* ]] || methods="$methods,oracle" ;;
  0) methods=$(echo ",$methods," | sed 's/,oracle,/,/g; s/^,//; s/,$//') ;;
  *) echo "benchmark_table: ORACLE must be 0 or 1 (got '$ORACLE')" >&2; exit 2 ;;
esac
scenarios="${SCENARIOS:-data/scenarios/room}"
paper="${PAPER:-}"
[ -z "$paper" ] || [ -f "$paper" ] || { echo "benchmark_table: PAPER=$paper is not a file" >&2; exit 2; }
exe="${DQN_DOVS_EVAL:-install/lib/dqn_dovs/dqn_dovs_eval}"
out_doc="${OUT_DOC:-docs/benchmark.md}"
out_dir="${OUT_DIR:-results/benchmark}"
# The installed tools find the core library through the install tree.
export LD_LIBRARY_PATH="$root/install/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"

[ -x "$exe" ] || { echo "benchmark_table: $exe not found; run 'make build' (or set DQN_DOVS_EVAL)" >&2; exit 2; }
[ -f "$model" ] || { echo "benchmark_table: model $model not found" >&2; exit 2; }
[ -d "$scenarios" ] || { echo "benchmark_table: SCENARIOS=$scenarios is not a folder (laid out as 1-N/K.dovs)" >&2; exit 2; }
[ -x .venv/bin/python ] || { echo "benchmark_table: .venv missing; run 'make setup'" >&2; exit 2; }

mkdir -p "$out_dir"
declare -A wall cmd
total_start=$(date +%s.%N)
for perception in tracker perfect; do
  dir="$out_dir/$perception"
  rm -rf "$dir"
  mkdir -p "$dir"
  args=(--methods "$methods" --scenarios "$scenarios" --obstacles "$obstacles" --episodes "$episodes"
        --threads "$threads" --model "$model" --trajectories 1 --out "$dir/")
  [ "$perception" = perfect ] && args+=(--perfect-info)
  cmd[$perception]="dqn_dovs_eval ${args[*]}"
  echo "=== benchmark-table: $perception (${cmd[$perception]})"
  start=$(date +%s.%N)
  "$exe" "${args[@]}" >"$dir/eval.log" 2>&1 || { echo "benchmark_table: evaluation failed; see $dir/eval.log" >&2; tail -20 "$dir/eval.log" >&2; exit 1; }
  end=$(date +%s.%N)
  wall[$perception]=$(echo "$end - $start" | bc)
  tail -n 1 "$dir/eval.log"
  rm -f "$dir/eval.log"  # one progress line per episode; summary.md holds the figures
  # One trajectory picture is kept (dqn_dovs's); the others only make the folder heavy.
  find "$dir" -name 'trajectories_*.png' ! -name 'trajectories_dqn_dovs_n[0-9]*' -delete
done
case "${BOUND:-1}" in
  1)
    dir="$out_dir/bound"
    rm -rf "$dir"
    mkdir -p "$dir"
    args=(--methods bound --scenarios "$scenarios" --obstacles "$obstacles" --episodes "$episodes" --threads "$threads"
          --trajectories 0 --no-report --out "$dir/")
    echo "=== benchmark-table: bound (dqn_dovs_eval ${args[*]})"
    "$exe" "${args[@]}" >"$dir/eval.log" 2>&1 || { echo "benchmark_table: the bound failed; see $dir/eval.log" >&2; tail -20 "$dir/eval.log" >&2; exit 1; }
    tail -n 1 "$dir/eval.log"
    rm -f "$dir/eval.log"
    ;;
  0) rm -rf "$out_dir/bound" ;;
  *) echo "benchmark_table: BOUND must be 0 or 1 (got '$BOUND')" >&2; exit 2 ;;
esac
total_end=$(date +%s.%N)

commit=$(git rev-parse --short HEAD 2>/dev/null || echo unknown)
dirty=$(git status --porcelain --untracked-files=no 2>/dev/null | grep -q . && echo "+local changes" || true)
PYTHONPATH="$root/python" .venv/bin/python -m dqn_dovs_py.run_info --out "$out_dir/run_info.json" \
  --commit "$commit$dirty" --model "$model" --tracker-command "${cmd[tracker]}" --tracker-wall "${wall[tracker]}" \
  --perfect-command "${cmd[perfect]}" --perfect-wall "${wall[perfect]}" \
  --total-wall "$(echo "$total_end - $total_start" | bc)"

MPLBACKEND=Agg PYTHONPATH="$root/python" .venv/bin/python -m dqn_dovs_py.benchmark_report \
  --tracker "$out_dir/tracker/results.csv" --perfect "$out_dir/perfect/results.csv" \
  --paper "$paper" --discussion docs/benchmark_discussion.md \
  --run-info "$out_dir/run_info.json" --plots "$out_dir" --out "$out_doc" --bound "$out_dir/bound/results.csv"
