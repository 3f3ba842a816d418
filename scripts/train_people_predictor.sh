#!/usr/bin/env bash
# Trains the learned people predictor (docs/planners.md, "A learned prediction of the people"): generates crowds
# with dqn_dovs_eval (the oracle drives, so episodes run to the goal and the people's paths are long; the tracker
# runs in the loop and its tracks are recorded beside the true paths), 200 episodes each of 5, 10 and 15 people for
# training (seed 22601) and for validation (seed 22602), then trains and exports the predictor (+ .json with the
# validation errors).
#   bash scripts/train_people_predictor.sh [OUT_DIR]     from the true paths: models/people_predictor.dqnp
#   INPUTS=tracks bash scripts/train_people_predictor.sh  from the tracks:     models/people_predictor_tracks.dqnp
# About 6-8 minutes on two cores.
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-runs/people_predictor}
inputs=${INPUTS:-truth}
eval_tool=${DQN_DOVS_EVAL:-build/dqn_dovs/dqn_dovs_eval}
model=models/people_predictor.dqnp
[ "$inputs" = tracks ] && model=models/people_predictor_tracks.dqnp
mkdir -p "$out"
for seed in 22601 22602; do
  for n in 5 10 15; do
    [ -f "$out/paths_${seed}_$n/paths.json" ] && continue
    "$eval_tool" --generate "$seed" --obstacles "$n" --episodes 200 --threads 2 --world crowd --sensor urg04lx \
      --methods oracle --no-report --trajectories 1000 --out "$out/paths_${seed}_$n" | tail -1
  done
done
PYTHONPATH=python .venv/bin/python -m dqn_dovs_py.people_predictor --inputs "$inputs" \
  --train "$out"/paths_22601_{5,10,15} --valid "$out"/paths_22602_{5,10,15} --out "$model"
