"""Paired comparisons of this record, on the same (family, N, episode), pooled over the training seeds. Run from the
repository root:

    python pairs.py sweep [runs/sweep_58]      robot at fault: each fine-tune against the shipped network and S-DOVS
    python pairs.py confirm [runs/confirm58]   (b) on the confirmation seed (confirm.sh): success and fault

A win is an episode where the row's side did well (success, or not at fault) and the rival did not."""
import glob
import os
import sys

sys.path.insert(0, "python")
from dqn_dovs_py.benchmark_report import sign_test_p  # noqa: E402
from dqn_dovs_py.report import read_results  # noqa: E402


def load(folder):
    out = {}
    for path in glob.glob(f"{folder}/*_n*/results.csv"):
        family = os.path.basename(os.path.dirname(path))
        for r in read_results(path):
            out[(family, r.obstacles, r.episode)] = r
    return out


def pooled(seeds, rival, good):
    wins = losses = 0
    for records in seeds:
        for key, r in records.items():
            mine, theirs = good(r), good(rival[key])
            wins += mine and not theirs
            losses += theirs and not mine
    return f"+{wins} / -{losses}, p = {sign_test_p(wins, losses):.3g}"


def success(r):
    return r.outcome == "success"


def not_at_fault(r):
    return r.at_fault is not True


mode = sys.argv[1] if len(sys.argv) > 1 else "sweep"
if mode == "sweep":
    root = sys.argv[2] if len(sys.argv) > 2 else "runs/sweep_58"
    rivals = {"shipped": load(f"{root}/reference"), "s_dovs": load(f"{root}/baselines/s_dovs")}
    for config in ("finetune_deployed", "finetune_deployed_tokens", "finetune_deployed_cvar"):
        seeds = [load(f"{root}/trials/{config}/seed{s}/eval") for s in (1, 2, 3)]
        for name, rival in rivals.items():
            print(f"{config} not at fault vs {name}: {pooled(seeds, rival, not_at_fault)}")
elif mode == "confirm":
    root = sys.argv[2] if len(sys.argv) > 2 else "runs/confirm58"
    sides = {name: load(f"{root}/{name}") for name in ("reference", "s_dovs", "seed1", "seed2", "seed3")}
    for name, records in sides.items():
        s = sum(map(success, records.values())) / len(records)
        f = 1 - sum(map(not_at_fault, records.values())) / len(records)
        print(f"{name}: {len(records)} episodes, success {s:.3f}, at fault {f:.3f}")
    seeds = [sides[f"seed{s}"] for s in (1, 2, 3)]
    for rival in ("reference", "s_dovs"):
        for label, good in (("success", success), ("not at fault", not_at_fault)):
            print(f"(b) vs {rival}, {label}: {pooled(seeds, sides[rival], good)}")
else:
    sys.exit(f"unknown mode {mode!r}: sweep or confirm")
