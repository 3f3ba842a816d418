#!/usr/bin/env bash
# Trains the learned people predictor (docs/planners.md, "A learned prediction of the people"): generates episodes of
# every world family with dqn_dovs_eval (the oracle drives, its first search only as when the shipped files were
# learned, so episodes run to the goal and the paths are long; the
# tracker runs in the loop and its tracks are recorded beside the true paths): crowds of 5, 10 and 15 walking people,
# and corridors, doorways, clutter and junctions of 4, 8 and 12 people (the people, never the paper's discs: the
# planners apply the prediction to people only); seed 22601 to train on, 22602 (half as many episodes) to measure on. Then it trains and exports the predictor (+ .json
# with the validation errors, overall and per family).
#   bash scripts/train_people_predictor.sh [OUT_DIR]     from the true paths: models/people_predictor.dqnp
#   INPUTS=tracks bash scripts/train_people_predictor.sh  from the tracks:     models/people_predictor_tracks.dqnp
# About 20 minutes on two cores (the episodes are kept in OUT_DIR and reused by the second run).
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-runs/people_predictor}
inputs=${INPUTS:-truth}
eval_tool=${DQN_DOVS_EVAL:-build/dqn_dovs/dqn_dovs_eval}
model=models/people_predictor.dqnp
[ "$inputs" = tracks ] && model=models/people_predictor_tracks.dqnp
# family:sensor:counts:training episodes per count
worlds="crowd:urg04lx:5,10,15:200 corridor:urg04lx:4,8,12:80 doorway:urg04lx:4,8,12:80
        clutter:urg04lx:4,8,12:80 junction:urg04lx:4,8,12:80"
mkdir -p "$out"
train=() valid=()
for spec in $worlds; do
  IFS=: read -r family sensor counts episodes <<<"$spec"
  for seed in 22601 22602; do
    k=$episodes
    [ "$seed" = 22602 ] && k=$((episodes / 2))
    for n in ${counts//,/ }; do
      dir="$out/${family}_${seed}_$n"
      if [ "$seed" = 22601 ]; then train+=("$dir"); else valid+=("$dir"); fi
      [ -f "$dir/paths.json" ] && continue
      "$eval_tool" --generate "$seed" --obstacles "$n" --episodes "$k" --threads 2 --world "$family" \
        --sensor "$sensor" --methods oracle --oracle-retries none --predict-people none --no-report --trajectories 1000 \
        --out "$dir" | tail -1
    done
  done
done
PYTHONPATH=python .venv/bin/python -m dqn_dovs_py.people_predictor --inputs "$inputs" \
  --train "${train[@]}" --valid "${valid[@]}" --out "$model"
