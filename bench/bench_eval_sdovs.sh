#!/usr/bin/env bash
# S-DOVS over the package's room scenarios (SCENARIOS=DIR for another set) (1..15 obstacles, tracker in the loop) with the evaluation CLI;
# writes the flat figures (success_mean, success_1..success_15, episodes_per_count, wall_s) to the JSON path $1.
# Run from the repository root (scripts/bench.sh does): bash bench/bench_eval_sdovs.sh bench/results/eval-sdovs.json
set -euo pipefail
out_json="${1:-bench/results/eval-sdovs.json}"
episodes="${EPISODES:-100}"
exe="install/lib/dqn_dovs/dqn_dovs_eval"
if [ ! -x "$exe" ]; then
  exe="${DQN_DOVS_BIN_DIR:-}/dqn_dovs_eval"
fi
if [ ! -x "$exe" ]; then
  echo "bench_eval_sdovs: dqn_dovs_eval not found (install/lib/dqn_dovs/ or \$DQN_DOVS_BIN_DIR); run 'make build'" >&2
  exit 2
fi
out_dir="bench/results/eval-sdovs"
mkdir -p "$out_dir" "$(dirname "$out_json")"
start=$(date +%s.%N)
"$exe" --methods s_dovs --scenarios "${SCENARIOS:-data/scenarios/room}" --obstacles 1-15 --episodes "$episodes" \
  --threads 2 --out "$out_dir/"
end=$(date +%s.%N)
PYTHONPATH="$(pwd)/python" .venv/bin/python -m dqn_dovs_py.eval_figures --eval-dir "$out_dir" --method s_dovs \
  --episodes-per-count "$episodes" --wall "$(echo "$end - $start" | bc)" --out "$out_json"
echo "wrote $out_json"
