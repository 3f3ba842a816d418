"""Paired comparisons of evaluate.sh's output, on the same (family, N, episode). Run from the repository root:

    python docs/experiments/2026-12-08-training-from-scratch-as-deployed/pairs.py OUT

prints success, timeout and robot-at-fault rates of the trained network, the shipped network and S-DOVS, and the
exact sign test of the trained network against each (a win: an episode it succeeded in, or was not at fault in,
where the rival did not)."""
import csv
import glob
import os
import sys

sys.path.insert(0, "python")
from dqn_dovs_py.benchmark_report import sign_test_p  # noqa: E402


def load(folder, method):
    out = {}
    for path in glob.glob(f"{folder}/*_*/results.csv"):
        cell = os.path.basename(os.path.dirname(path))
        for r in csv.DictReader(open(path)):
            if r["method"] == method:
                out[(cell, r["episode"])] = r
    return out


def main(out):
    sides = {"trained": load(f"{out}/trained", "dqn_dovs"), "shipped": load(f"{out}/shipped", "dqn_dovs"),
             "s_dovs": load(f"{out}/shipped", "s_dovs")}
    keys = sorted(set.intersection(*(set(s) for s in sides.values())))
    for name, rows in sides.items():
        n = len(keys)
        succ = sum(rows[k]["outcome"] == "success" for k in keys) / n
        tout = sum(rows[k]["outcome"] == "timeout" for k in keys) / n
        fault = sum(rows[k]["at_fault"] in ("1", "true", "True") for k in keys) / n
        print(f"{name:8s} episodes {n}  success {succ:.3f}  timeout {tout:.3f}  robot at fault {fault:.3f}")
    for rival in ("shipped", "s_dovs"):
        for what, good in (("success", lambda r: r["outcome"] == "success"),
                           ("not at fault", lambda r: r["at_fault"] not in ("1", "true", "True"))):
            w = sum(good(sides["trained"][k]) and not good(sides[rival][k]) for k in keys)
            l = sum(good(sides[rival][k]) and not good(sides["trained"][k]) for k in keys)
            print(f"trained vs {rival:7s} {what:12s} +{w} / -{l}  p = {sign_test_p(w, l):.3g}")


if __name__ == "__main__":
    main(sys.argv[1])
