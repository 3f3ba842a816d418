#!/bin/bash
# Confirmation of the exploratory robot-at-fault finding on a fresh generation seed (58601): experiment (b)'s three
# networks, the shipped network and S-DOVS on 510 headline-mix episodes each (5 families x N = 4, 8, 12 x 34).
# Run from the repository root after the sweep of this record (runs/sweep_58); results in runs/confirm58/.
set -euo pipefail
export LD_LIBRARY_PATH=$PWD/install/lib
EVAL=install/lib/dqn_dovs/dqn_dovs_eval
OUT=runs/confirm58
run() {  # name method [model flags...]
  local name=$1 method=$2; shift 2
  for f in crowd corridor doorway clutter junction; do
    for n in 4 8 12; do
      $EVAL --methods "$method" "$@" --generate 58601 --obstacles $n --episodes 34 --threads 2 --trajectories 0 \
        --no-report --world $f --people-mix headline --out $OUT/$name/${f}_n$n/ > /dev/null 2>&1
    done
  done
  echo "done $name"
}
run reference dqn_dovs --model models/dqn_dovs.dqnw
run s_dovs s_dovs
for s in 1 2 3; do
  run seed$s dqn_dovs --model runs/sweep_58/trials/finetune_deployed_tokens/seed$s/run/model.dqnw \
    --dovs wall_rays=8,person_tokens=6
done
