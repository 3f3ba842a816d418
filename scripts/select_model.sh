#!/usr/bin/env bash
# Model selection on held-out generated scenarios: every candidate weight file of a training run (its
# snapshots/ep*.dqnw, best.dqnw and model.dqnw, plus any files named in EXTRA) is evaluated as `dqn_dovs` with the
# tracker in the loop on seeded generated episodes, never on the shared evaluation files, and ranked by mean
# success (ties: the higher mean success at the top half of the obstacle counts).
# Identical files are evaluated once (the others are listed as aliases).
# Usage: scripts/select_model.sh RUN_DIR    -> RUN_DIR/selection/{selection.csv,selection.md}, best file on stdout.
# Environment: SEEDS (generator seeds, default "9101 9102"), OBSTACLES (3-15), EPISODES (40 per count and seed),
# THREADS (2), EXTRA (more .dqnw files, space-separated), DQN_DOVS_EVAL (default install/lib/dqn_dovs/dqn_dovs_eval).
set -euo pipefail
cd "$(dirname "$0")/.."
# shellcheck source=scripts/env.sh
. scripts/env.sh
root="$(pwd)"
run="${1:?usage: scripts/select_model.sh RUN_DIR}"
seeds="${SEEDS:-9101 9102}"
obstacles="${OBSTACLES:-3-15}"
episodes="${EPISODES:-40}"
threads="${THREADS:-2}"
exe="${DQN_DOVS_EVAL:-install/lib/dqn_dovs/dqn_dovs_eval}"
export LD_LIBRARY_PATH="$root/install/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"

[ -d "$run" ] || { echo "select_model: run directory $run not found" >&2; exit 2; }
[ -x "$exe" ] || { echo "select_model: $exe not found; run 'make build' (or set DQN_DOVS_EVAL)" >&2; exit 2; }
[ -x .venv/bin/python ] || { echo "select_model: .venv missing; run 'make setup'" >&2; exit 2; }

# A file with the same bytes as an earlier candidate (best.dqnw and model.dqnw are copies of snapshots) is not
# evaluated again; it is listed as that candidate's alias.
candidates=()
declare -A first_of aliases
for f in "$run"/snapshots/ep*.dqnw "$run"/best.dqnw "$run"/model.dqnw ${EXTRA:-}; do
  [ -f "$f" ] || continue
  sum=$(sha256sum "$f" | cut -d' ' -f1)
  if [ -n "${first_of[$sum]:-}" ]; then
    aliases[$sum]="${aliases[$sum]:+${aliases[$sum]} }$f"
  else
    first_of[$sum]="$f"
    candidates+=("$f")
  fi
done
[ ${#candidates[@]} -gt 0 ] || { echo "select_model: no .dqnw files in $run (snapshots/, best.dqnw, model.dqnw)" >&2; exit 2; }

out="$run/selection"
rm -rf "$out"
mkdir -p "$out"
i=0
for f in "${candidates[@]}"; do
  i=$((i + 1))
  for seed in $seeds; do
    dir="$out/c$i/$seed"
    mkdir -p "$dir"
    echo "select_model: [$i/${#candidates[@]}] $f, generator seed $seed" >&2
    "$exe" --methods dqn_dovs --model "$f" --generate "$seed" --obstacles "$obstacles" --episodes "$episodes" \
      --threads "$threads" --trajectories 0 --out "$dir/" >"$dir/eval.log" 2>&1 ||
      { echo "select_model: evaluation of $f failed; see $dir/eval.log" >&2; tail -5 "$dir/eval.log" >&2; exit 1; }
    rm -f "$dir/eval.log" "$dir/results.csv" "$dir/success_vs_obstacles.png"
  done
  echo "$f" >"$out/c$i/model_path"
  echo "${aliases[$(sha256sum "$f" | cut -d' ' -f1)]:-}" >"$out/c$i/aliases"
done

PYTHONPATH="$root/python" .venv/bin/python -m dqn_dovs_py.select_model --selection "$out" --seeds "$seeds" \
  --obstacles "$obstacles" --episodes "$episodes"
