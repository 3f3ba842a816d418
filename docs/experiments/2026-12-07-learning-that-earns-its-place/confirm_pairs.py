"""Paired comparison on the confirmation seed (confirm.sh): experiment (b)'s three networks pooled against the shipped
network and S-DOVS, on success and on not being at fault. Run from the repository root."""
import glob
import os
import sys

sys.path.insert(0, "python")
from dqn_dovs_py.benchmark_report import sign_test_p  # noqa: E402
from dqn_dovs_py.report import read_results  # noqa: E402

ROOT = sys.argv[1] if len(sys.argv) > 1 else "runs/confirm58"


def load(name):
    out = {}
    for path in glob.glob(f"{ROOT}/{name}/*_n*/results.csv"):
        family = os.path.basename(os.path.dirname(path))
        for r in read_results(path):
            out[(family, r.obstacles, r.episode)] = r
    return out


def rate(records, good):
    return sum(good(r) for r in records.values()) / len(records)


success = lambda r: r.outcome == "success"  # noqa: E731
not_at_fault = lambda r: r.at_fault is not True  # noqa: E731
sides = {name: load(name) for name in ("reference", "s_dovs", "seed1", "seed2", "seed3")}
for name, records in sides.items():
    print(f"{name}: {len(records)} episodes, success {rate(records, success):.3f}, "
          f"at fault {1 - rate(records, not_at_fault):.3f}")
for rival in ("reference", "s_dovs"):
    for label, good in (("success", success), ("not at fault", not_at_fault)):
        wins = losses = 0
        for seed in ("seed1", "seed2", "seed3"):
            for key, r in sides[seed].items():
                mine, theirs = good(r), good(sides[rival][key])
                wins += mine and not theirs
                losses += theirs and not mine
        print(f"(b) vs {rival}, {label}: +{wins} / -{losses}, p = {sign_test_p(wins, losses):.3g}")
