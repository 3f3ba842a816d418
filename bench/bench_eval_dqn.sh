#!/usr/bin/env bash
# DQN-DOVS (models/dqn_dovs.dqnw) and S-DOVS over the package's room scenarios (SCENARIOS=DIR for another set) (1..15 obstacles, tracker in
# the loop) with the evaluation CLI; writes to the JSON path $1 the flat figures of dqn_dovs (success_mean,
# success_1..success_15, collision_mean, timeout_mean, danger_frequency), s_dovs_success_mean,
# time_ratio_vs_sdovs (s_dovs's total time over dqn_dovs's on the episodes both solved), episodes_per_count,
# episodes (all methods), wall_s and episodes_per_s; and the paired comparison pooled over the counts:
# wins_vs_sdovs (episodes dqn_dovs solved and s_dovs did not), losses_vs_sdovs (the reverse) and
# sign_test_p_vs_sdovs (exact two-sided sign test on those, python/dqn_dovs_py/benchmark_report.py).
# Run from the repository root (scripts/bench.sh does): bash bench/bench_eval_dqn.sh bench/results/eval-dqn.json
# Environment: EPISODES (100 per obstacle count), OBSTACLES (1-15), MODEL (models/dqn_dovs.dqnw).
set -euo pipefail
out_json="${1:-bench/results/eval-dqn.json}"
episodes="${EPISODES:-100}"
obstacles="${OBSTACLES:-1-15}"
model="${MODEL:-models/dqn_dovs.dqnw}"
exe="install/lib/dqn_dovs/dqn_dovs_eval"
if [ ! -x "$exe" ]; then
  exe="${DQN_DOVS_BIN_DIR:-}/dqn_dovs_eval"
fi
if [ ! -x "$exe" ]; then
  echo "bench_eval_dqn: dqn_dovs_eval not found (install/lib/dqn_dovs/ or \$DQN_DOVS_BIN_DIR); run 'make build'" >&2
  exit 2
fi
[ -f "$model" ] || { echo "bench_eval_dqn: model $model not found" >&2; exit 2; }
export LD_LIBRARY_PATH="$(pwd)/install/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
out_dir="bench/results/eval-dqn"
mkdir -p "$out_dir" "$(dirname "$out_json")"
start=$(date +%s.%N)
"$exe" --methods dqn_dovs,s_dovs --model "$model" --scenarios "${SCENARIOS:-data/scenarios/room}" --obstacles "$obstacles" \
  --episodes "$episodes" --threads 2 --trajectories 0 --out "$out_dir/"
end=$(date +%s.%N)
PYTHONPATH="$(pwd)/python" .venv/bin/python -m dqn_dovs_py.eval_figures --eval-dir "$out_dir" --method dqn_dovs --rival s_dovs \
  --episodes-per-count "$episodes" --wall "$(echo "$end - $start" | bc)" --out "$out_json"
echo "wrote $out_json"
