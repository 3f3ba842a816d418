#!/usr/bin/env bash
# Regenerates docs/benchmark_worlds.md: every planner (dqn_dovs, s_dovs, orca_diffdrive, dwa) and the oracle (the
# physical limit, a search that reads the true simulator; docs/planners.md section 9) on the same generated episodes
# of every building family (crowd, corridor, doorway, clutter, junction) at N = 4, 8 and 12 people, LIDAR + tracker in
# the loop, seed 57101 (the seed of this report, never used to tune anything), under three protocols of how people
# treat the robot (docs/simulator.md, "People who notice the robot"):
# - headline: --people-mix headline (attentive=0.7,impassive=0.2,oblivious=0.1), the main table;
# - oblivious: --people-mix oblivious=1, the stress test (nobody sees the robot), judged on robot-at-fault contacts;
# - attentive: --people-mix attentive=1, everybody gives way.
# One run folder per protocol, family and N (results/benchmark_worlds/PROTOCOL/FAMILY_nN/) keeps results.csv, run.json,
# summary.json and summary.md. Then python/dqn_dovs_py/worlds_report.py writes the tables, the paired tests and
# results/benchmark_worlds/success_and_fault.png, including docs/benchmark_worlds_discussion.md (hand-written).
# A run the tool stops (a world it cannot generate) keeps only failed.txt, its error; the others go on, the report
# shows it as not run and the script exits 1 at the end.
# Run from anywhere (make benchmark-worlds does); one progress line per run with its wall time.
# Environment: EPISODES (30 per run and method), THREADS (2), ORACLE (1: with the oracle; 0: the planners only),
# PROTOCOLS (headline oblivious attentive), MODEL (models/dqn_dovs.dqnw), PEOPLE_PREDICTOR
# (models/people_predictor_tracks.dqnp; empty: none), DQN_DOVS_EVAL (default install/lib/dqn_dovs/dqn_dovs_eval),
# OUT_DIR (results/benchmark_worlds), OUT_DOC (docs/benchmark_worlds.md).
set -euo pipefail
cd "$(dirname "$0")/.."
# shellcheck source=scripts/env.sh
. scripts/env.sh
root="$(pwd)"
seed=57101  # fixed: the report's seed
episodes="${EPISODES:-30}"
threads="${THREADS:-2}"
model="${MODEL:-models/dqn_dovs.dqnw}"
predictor="${PEOPLE_PREDICTOR-models/people_predictor_tracks.dqnp}"
exe="${DQN_DOVS_EVAL:-install/lib/dqn_dovs/dqn_dovs_eval}"
out_dir="${OUT_DIR:-results/benchmark_worlds}"
out_doc="${OUT_DOC:-docs/benchmark_worlds.md}"
families=(crowd corridor doorway clutter junction)
counts=(4 8 12)
read -r -a protocols <<<"${PROTOCOLS:-headline oblivious attentive}"
case "${ORACLE:-1}" in
  1) methods=dqn_dovs,s_dovs,orca_diffdrive,dwa,oracle ;;
  0) methods=dqn_dovs,s_dovs,orca_diffdrive,dwa ;;
  *) echo "benchmark_worlds: ORACLE must be 0 or 1 (got '$ORACLE')" >&2; exit 2 ;;
esac
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

mix_of() {
  case "$1" in
    headline) echo headline ;;
    oblivious) echo oblivious=1 ;;
    attentive) echo attentive=1 ;;
    *) echo "benchmark_worlds: unknown protocol '$1' (headline, oblivious, attentive)" >&2; exit 2 ;;
  esac
}
for protocol in "${protocols[@]}"; do mix_of "$protocol" >/dev/null; done

total_runs=$(( ${#protocols[@]} * ${#families[@]} * ${#counts[@]} ))
done_runs=0
failed=()

# evaluate PROTOCOL FAMILY N: one run of the methods into OUT_DIR/PROTOCOL/FAMILY_nN/.
evaluate() {
  local protocol=$1 family=$2 n=$3
  local dir="$out_dir/$protocol/${family}_n$n"
  rm -rf "$dir"
  mkdir -p "$dir"
  local args=(--methods "$methods" --world "$family" --generate "$seed" --obstacles "$n" --episodes "$episodes"
              --people-mix "$(mix_of "$protocol")" --sensor sim "${predict[@]}" --threads "$threads"
              --model "$model" --trajectories 0 --out "$dir")
  local start end outcome
  start=$(date +%s.%N)
  if "$exe" "${args[@]}" >"$dir/eval.log" 2>&1; then
    # The console table's mean row: success, c = collision, t = timeout of each method in order.
    outcome="$(grep -E '^ +mean ' "$dir/eval.log" | sed -E 's/^ +mean//; s/ +/ /g')"
  else
    tail -n 1 "$dir/eval.log" >"$dir/failed.txt"
    failed+=("$protocol/${family}_n$n")
    outcome="FAILED: $(cat "$dir/failed.txt")"
  fi
  end=$(date +%s.%N)
  done_runs=$((done_runs + 1))
  printf '[%2d/%d] %-24s %6.1f s  %s\n' "$done_runs" "$total_runs" "$protocol/${family}_n$n" \
    "$(echo "$end - $start" | bc)" "$outcome"
  # What the report needs stays; paths.json and the pictures would make the folder heavy.
  find "$dir" -type f ! -name results.csv ! -name run.json ! -name summary.json ! -name summary.md \
    ! -name failed.txt -delete
}

mkdir -p "$out_dir"
echo "benchmark_worlds: ${total_runs} runs of ${methods} x ${episodes} episodes (protocols: ${protocols[*]})"
total_start=$(date +%s.%N)
for protocol in "${protocols[@]}"; do
  for family in "${families[@]}"; do
    for n in "${counts[@]}"; do
      evaluate "$protocol" "$family" "$n"
    done
  done
done
total_end=$(date +%s.%N)
total_wall=$(echo "$total_end - $total_start" | bc)
printf "=== benchmark-worlds: %d runs in %.1f s\n" "$total_runs" "$total_wall"

commit=$(git rev-parse --short HEAD 2>/dev/null || echo unknown)
dirty=$(git status --porcelain --untracked-files=no 2>/dev/null | grep -q . && echo "+local changes" || true)
MPLBACKEND=Agg PYTHONPATH="$root/python" .venv/bin/python -m dqn_dovs_py.worlds_report --runs "$out_dir" \
  --out "$out_doc" --discussion docs/benchmark_worlds_discussion.md --commit "$commit$dirty" --model "$model" \
  --total-wall "$total_wall" --episodes "$episodes" --seed "$seed"
if [ ${#failed[@]} -gt 0 ]; then
  echo "benchmark_worlds: ${#failed[@]} run(s) failed (${failed[*]}); the report shows them as not run" >&2
  exit 1
fi
