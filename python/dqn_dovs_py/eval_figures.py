"""The figures of the evaluation benchmarks (bench/bench_eval_dqn.sh, bench/bench_eval_sdovs.sh) from one
dqn_dovs_eval output folder: the method's rates from summary.json, the run's size and wall time, and against a
rival method its success and time ratio and the paired comparison pooled over the counts (wins, losses, exact
sign test; benchmark_report.paired_comparison).

    python -m dqn_dovs_py.eval_figures --eval-dir bench/results/eval-dqn --method dqn_dovs --rival s_dovs \
        --episodes-per-count 100 --wall 95.3 --out bench/results/eval-dqn.json
"""

from __future__ import annotations

import argparse
import json
import os
import re
import sys

from .benchmark_report import paired_comparison, read_results

# The method's figures kept from summary.json (keys "METHOD.figure" when the run had several methods): the rates
# per count and their means; with a rival also the danger frequency and the mean time on success.
RATES = re.compile(r"success_(mean|\d+)|collision_mean|timeout_mean")
MORE = re.compile(r"danger_frequency|mean_time_success_s")


def figures(summary: dict, results_csv: str, method: str, rival: str | None, episodes_per_count: int,
            wall_s: float) -> dict:
    """The benchmark's flat figures (see the module comment); raises KeyError / ValueError naming what is missing."""
    prefixed = any(k.startswith(method + ".") for k in summary)
    out: dict = {}
    for key, value in summary.items():
        if prefixed:
            if not key.startswith(method + "."):
                continue
            key = key[len(method) + 1:]
        if RATES.fullmatch(key) or (rival and MORE.fullmatch(key)):
            out[key] = value
    if "success_mean" not in out:
        raise ValueError(f"no success_mean of method '{method}' in summary.json")
    if rival:
        tag = rival.replace("_", "")
        out[f"{rival}_success_mean"] = summary[f"{rival}.success_mean"]
        # The rival's total time over the reference method's on the episodes both solved.
        out[f"time_ratio_vs_{tag}"] = summary[f"{rival}.time_ratio_mean"]
    out["episodes_per_count"] = int(episodes_per_count)
    if rival:
        records = read_results(results_csv)
        out["episodes"] = len(records)
    out["wall_s"] = round(float(wall_s), 1)
    if rival:
        out["episodes_per_s"] = round(out["episodes"] / wall_s, 2) if wall_s > 0 else 0.0
        pooled = paired_comparison(records, method, rival)[None]
        out.update({f"wins_vs_{tag}": pooled.wins, f"losses_vs_{tag}": pooled.losses,
                    f"sign_test_p_vs_{tag}": pooled.p_value})
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m dqn_dovs_py.eval_figures", description=__doc__.splitlines()[0])
    p.add_argument("--eval-dir", required=True, help="dqn_dovs_eval's --out folder (summary.json, results.csv)")
    p.add_argument("--method", required=True)
    p.add_argument("--rival", default=None, help="a second method of the same run to compare with")
    p.add_argument("--episodes-per-count", type=int, required=True)
    p.add_argument("--wall", type=float, required=True, help="the evaluation's wall time, s")
    p.add_argument("--out", required=True, help="the benchmark's JSON file")
    a = p.parse_args(argv)
    try:
        with open(os.path.join(a.eval_dir, "summary.json")) as f:
            summary = json.load(f)
        out = figures(summary, os.path.join(a.eval_dir, "results.csv"), a.method, a.rival, a.episodes_per_count,
                      a.wall)
    except (OSError, KeyError, ValueError) as e:
        print(f"eval_figures: {a.eval_dir}: {e}", file=sys.stderr)
        return 1
    os.makedirs(os.path.dirname(os.path.abspath(a.out)), exist_ok=True)
    with open(a.out, "w") as f:
        json.dump(out, f, indent=2)
        f.write("\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
