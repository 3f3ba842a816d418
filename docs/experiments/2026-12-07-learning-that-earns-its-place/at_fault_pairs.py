"""Paired robot-at-fault comparison of the sweep's fine-tunes against the shipped network and S-DOVS: the same
(family, N, episode), pooled over the three seeds; a win is an episode the fine-tune ends without being at fault
and the rival does not. Run from the repository root after the sweep of this record (runs/sweep_58)."""
import glob
import os
import sys

sys.path.insert(0, "python")
from dqn_dovs_py.benchmark_report import sign_test_p  # noqa: E402
from dqn_dovs_py.report import read_results  # noqa: E402

SWEEP = sys.argv[1] if len(sys.argv) > 1 else "runs/sweep_58"


def load(folder):
    out = {}
    for path in glob.glob(f"{folder}/*_n*/results.csv"):
        family = os.path.basename(os.path.dirname(path))
        for r in read_results(path):
            out[(family, r.obstacles, r.episode)] = r
    return out


rivals = {"shipped": load(f"{SWEEP}/reference"), "s_dovs": load(f"{SWEEP}/baselines/s_dovs")}
for config in ("finetune_deployed", "finetune_deployed_tokens", "finetune_deployed_cvar"):
    for name, rival in rivals.items():
        wins = losses = 0
        for seed in (1, 2, 3):
            for key, r in load(f"{SWEEP}/trials/{config}/seed{seed}/eval").items():
                mine, theirs = r.at_fault is True, rival[key].at_fault is True
                wins += theirs and not mine
                losses += mine and not theirs
        print(f"{config} not at fault vs {name}: +{wins} / -{losses}, p = {sign_test_p(wins, losses):.3g}")
