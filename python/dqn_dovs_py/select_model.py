"""Ranking of a training run's candidate networks (the last step of scripts/select_model.sh).

The script evaluates each candidate into SELECTION/cI/SEED/summary.json (dqn_dovs_eval, one method) with the
candidate's path in cI/model_path and the paths of byte-identical files in cI/aliases. This ranks them by mean
success over the obstacle counts (ties: the mean over the upper half of the counts), writes
SELECTION/selection.csv and selection.md, lists the ranking on stderr and prints the winner's path on stdout.

    python -m dqn_dovs_py.select_model --selection RUN/selection --seeds "9101 9102" --obstacles 3-15 --episodes 40
"""

from __future__ import annotations

import argparse
import json
import os
import re
import sys
from dataclasses import dataclass, field


@dataclass
class Candidate:
    model: str
    also: str
    success: dict[int, float] = field(default_factory=dict)  # per obstacle count, over the seeds

    def mean(self) -> float:
        return sum(self.success.values()) / len(self.success)

    def upper_mean(self, upper: list[int]) -> float:
        return sum(self.success[n] for n in upper) / len(upper)


def obstacle_counts(spec: str) -> list[int]:
    """"3-15" -> [3, ..., 15]; "7" -> [7]."""
    lo, _, hi = spec.partition("-")
    return list(range(int(lo), int(hi or lo) + 1))


def upper_half(counts: list[int]) -> list[int]:
    return counts[len(counts) // 2:]


def read_candidates(selection: str, seeds: list[str], counts: list[int]) -> list[Candidate]:
    """Every cI folder of `selection`, in I order, with its success per count averaged over `seeds`."""
    folders = sorted((d for d in os.listdir(selection) if re.fullmatch(r"c\d+", d)), key=lambda d: int(d[1:]))
    out = []
    for c in folders:
        with open(os.path.join(selection, c, "model_path")) as f:
            model = f.read().strip()
        with open(os.path.join(selection, c, "aliases")) as f:
            also = f.read().strip()
        candidate = Candidate(model, also)
        for n in counts:
            rates = []
            for seed in seeds:
                with open(os.path.join(selection, c, seed, "summary.json")) as f:
                    rates.append(json.load(f)[f"success_{n}"])  # one method: unprefixed keys
            candidate.success[n] = sum(rates) / len(rates)
        out.append(candidate)
    return out


def rank(candidates: list[Candidate], counts: list[int]) -> list[Candidate]:
    """Best first: by mean success, then by the mean over the upper half of the counts (stable otherwise)."""
    upper = upper_half(counts)
    return sorted(candidates, key=lambda c: (-c.mean(), -c.upper_mean(upper)))


def write_selection(selection: str, ranked: list[Candidate], seeds: list[str], counts: list[int],
                    episodes: str) -> None:
    upper = upper_half(counts)
    with open(os.path.join(selection, "selection.csv"), "w") as f:
        f.write(",".join(["model", "also", "mean", "upper_mean"] + [f"success_{n}" for n in counts]) + "\n")
        for c in ranked:
            f.write(",".join([c.model, c.also, f"{c.mean():.4f}", f"{c.upper_mean(upper):.4f}"]
                             + [f"{c.success[n]:.4f}" for n in counts]) + "\n")
    with open(os.path.join(selection, "selection.md"), "w") as f:
        f.write(f"# Model selection\n\nHeld-out generated scenarios (seeds {' '.join(seeds)}, obstacles "
                f"{counts[0]}-{counts[-1]}, {episodes} episodes per count and seed), tracker in the loop, method "
                "dqn_dovs. Ranked by mean success, then by the mean over the upper half of the counts "
                f"({upper[0]}-{upper[-1]}).\n\n| rank | model | mean | {upper[0]}-{upper[-1]} |\n|---|---|---|---|\n")
        for i, c in enumerate(ranked, 1):
            also = f" (same file: {', '.join(f'`{a}`' for a in c.also.split())})" if c.also else ""
            f.write(f"| {i} | `{c.model}`{also} | {c.mean():.3f} | {c.upper_mean(upper):.3f} |\n")


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m dqn_dovs_py.select_model", description=__doc__.splitlines()[0])
    p.add_argument("--selection", required=True, help="the selection folder scripts/select_model.sh filled")
    p.add_argument("--seeds", required=True, help="generator seeds, space-separated")
    p.add_argument("--obstacles", required=True, help="obstacle counts A-B")
    p.add_argument("--episodes", required=True, help="episodes per count and seed (for the report)")
    args = p.parse_args(argv)
    seeds, counts = args.seeds.split(), obstacle_counts(args.obstacles)
    try:
        candidates = read_candidates(args.selection, seeds, counts)
    except (OSError, KeyError, ValueError) as e:
        print(f"select_model: cannot read the evaluations in {args.selection}: {e}", file=sys.stderr)
        return 1
    if not candidates:
        print(f"select_model: no evaluated candidates in {args.selection}", file=sys.stderr)
        return 1
    ranked = rank(candidates, counts)
    write_selection(args.selection, ranked, seeds, counts, args.episodes)
    upper = upper_half(counts)
    for c in ranked:
        print(f"  {c.mean():.3f}  {c.upper_mean(upper):.3f}  {c.model}", file=sys.stderr)
    print(ranked[0].model)
    return 0


if __name__ == "__main__":
    sys.exit(main())
