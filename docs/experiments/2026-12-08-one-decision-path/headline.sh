#!/bin/bash
# The headline people mix in every family at 4 / 8 / 12 people, 34 episodes each (seed 59101), shipped network with
# and without the shield. $1: output folder; LIBDIR and EVAL select the build (default: install/).
cd "$(dirname "$0")/../../.."
out=$1; mkdir -p $out
for fam in crowd corridor doorway clutter junction; do for n in 4 8 12; do
env LD_LIBRARY_PATH=${LIBDIR:-$PWD/install/lib} ${EVAL:-install/lib/dqn_dovs/dqn_dovs_eval} --methods dqn_dovs,dqn_dovs_unshielded --world $fam --generate 59101 --obstacles $n --episodes 34 --people-mix headline --predict-people models/people_predictor_tracks.dqnp --threads 2 --model models/dqn_dovs.dqnw --trajectories 0 --no-report --out $out/${fam}_$n >/dev/null 2>&1
done; done
echo finished
