#!/bin/bash
# The oblivious stress test at 8 people in every family, seed 58501: the shipped network, S-DOVS and the nine
# fine-tuned networks of runs/sweep_58.
set -euo pipefail
cd "$(dirname "$0")/../../.."
export LD_LIBRARY_PATH=$PWD/install/lib
EVAL=install/lib/dqn_dovs/dqn_dovs_eval
OUT=runs/post58/stress
run() {  # name method model-and-flags...
  local name=$1 method=$2; shift 2
  for f in crowd corridor doorway clutter junction; do
    $EVAL --methods $method "$@" --generate 58501 --obstacles 8 --episodes 40 --threads 2 --trajectories 0 \
      --no-report --world $f --people-mix oblivious=1 --out $OUT/$name/${f}_n8/ > $OUT/$name.${f}.log 2>&1
  done
  echo "done $name"
}
mkdir -p $OUT
run shipped dqn_dovs --model models/dqn_dovs.dqnw
run s_dovs s_dovs
for c in finetune_deployed finetune_deployed_tokens finetune_deployed_cvar; do
  for s in 1 2 3; do
    m=runs/sweep_58/trials/$c/seed$s/run/model.dqnw
    flags=$(PYTHONPATH=python .venv/bin/python -c "from dqn_dovs_py.compare_models import state_flags; print(' '.join(state_flags('$m')))")
    run ${c}_s$s dqn_dovs --model $m $flags
  done
done
