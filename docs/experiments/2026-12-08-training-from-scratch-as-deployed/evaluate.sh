#!/bin/bash
# The headline people mix in every family at 4 / 8 / 12 people, 34 episodes each (seed $3): the network $1 (with the
# state flags its file names), the shipped network and S-DOVS on the same episodes. $2: output folder (absolute).
set -e
cd "$(dirname "$0")/../../.."
model=$1; out=$2; seed=${3:-58901}
mkdir -p "$out"
flags=$(PYTHONPATH=python .venv/bin/python -c "from dqn_dovs_py.compare_models import state_flags; print(' '.join(state_flags('$model')))")
E="env LD_LIBRARY_PATH=$PWD/install/lib install/lib/dqn_dovs/dqn_dovs_eval"
for fam in crowd corridor doorway clutter junction; do for n in 4 8 12; do
  common="--world $fam --generate $seed --obstacles $n --episodes 34 --people-mix headline --predict-people models/people_predictor_tracks.dqnp --threads 2 --trajectories 0 --no-report"
  $E --methods dqn_dovs --model "$model" $flags $common --out "$out/trained/${fam}_$n" >>"$out/eval.log" 2>&1
  $E --methods dqn_dovs,s_dovs --model models/dqn_dovs.dqnw $common --out "$out/shipped/${fam}_$n" >>"$out/eval.log" 2>&1
done; done
echo "wrote $out"
