#!/bin/bash
# Evaluation outputs on generated episodes, for byte-identical checks of a refactor. $1: output folder. LIBDIR and
# EVAL select the build (default: install/).
set -e
cd "$(dirname "$0")/../../.."
out=$1; mkdir -p $out
E="env LD_LIBRARY_PATH=${LIBDIR:-$PWD/install/lib} ${EVAL:-install/lib/dqn_dovs/dqn_dovs_eval}"
$E --methods dqn_dovs,s_dovs --generate 59001 --obstacles 6 --episodes 12 --threads 2 --model models/dqn_dovs.dqnw --trajectories 0 --no-report --out $out/room >/dev/null
$E --methods dqn_dovs,s_dovs --world crowd --generate 59002 --obstacles 8 --episodes 8 --people-mix headline --predict-people models/people_predictor_tracks.dqnp --threads 2 --model models/dqn_dovs.dqnw --trajectories 0 --no-report --out $out/crowd >/dev/null
$E --methods dqn_dovs,s_dovs --world doorway --generate 59003 --obstacles 4 --episodes 8 --people-mix headline --threads 2 --model models/dqn_dovs.dqnw --trajectories 0 --no-report --out $out/doorway >/dev/null
$E --methods dqn_dovs --world clutter --generate 59004 --obstacles 8 --episodes 6 --perfect-info --threads 2 --model models/dqn_dovs.dqnw --trajectories 0 --no-report --out $out/clutter_perfect >/dev/null
echo done
