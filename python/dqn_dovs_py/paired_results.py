"""Paired comparison of evaluation runs on the same episodes: two or more dqn_dovs_eval results.csv files.

    python -m dqn_dovs_py.paired_results shipped=runs/a/results.csv tol0.1=runs/b/results.csv [NAME=FILE ...] \\
        [--method dqn_dovs] [--out FILE.md]

Each file holds one evaluation (`dqn_dovs_eval ... --out DIR` writes DIR/results.csv) of the same generated
episodes, e.g. one planner under different --shield or --tracker settings. The first file is the reference. For every
other run, per obstacle count and pooled: success rate, collisions, and the wins and losses against the reference
(episodes one solved and the other not, matched by count and episode number) with the exact two-sided sign test.
--method picks one method from files that hold several. Episodes missing from either side are left out, and how many
were compared is said.
"""

from __future__ import annotations

import argparse
import os
import sys

from .benchmark_report import paired_comparison, read_results, sign_test_p
from .report import Record


class PairedError(ValueError):
    """Bad arguments or files; the message names the thing."""


def load_runs(specs: list[str], method: str | None) -> tuple[list[str], list[Record]]:
    """NAME=FILE specs -> (names, every run's records renamed to its NAME)."""
    if len(specs) < 2:
        raise PairedError("give at least two runs as NAME=results.csv (the first is the reference)")
    names: list[str] = []
    records: list[Record] = []
    for spec in specs:
        name, sep, path = spec.partition("=")
        if not sep or not name or not path:
            raise PairedError(f"{spec!r}: expected NAME=results.csv")
        if name in names:
            raise PairedError(f"{spec!r}: the name {name!r} is given twice")
        if os.path.isdir(path):
            path = os.path.join(path, "results.csv")
        if not os.path.isfile(path):
            raise PairedError(f"{spec!r}: {path} is not a file")
        rows = read_results(path)
        methods = sorted({r.method for r in rows})
        if method is not None:
            rows = [r for r in rows if r.method == method]
            if not rows:
                raise PairedError(f"{path}: no episode of method {method!r} (it holds {', '.join(methods)})")
        elif len(methods) > 1:
            raise PairedError(f"{path} holds several methods ({', '.join(methods)}); pick one with --method")
        names.append(name)
        records += [Record(**{**r.__dict__, "method": name}) for r in rows]
    return names, records


def render(names: list[str], records: list[Record]) -> str:
    reference = names[0]
    counts = sorted({r.obstacles for r in records})
    by = {(r.method, r.obstacles, r.episode): r for r in records}
    lines = ["| run | N | episodes | success | collisions | vs " + reference + " (wins / losses, p) |",
             "|---|---|---|---|---|---|"]
    for name in names:
        comparison = paired_comparison(records, name, reference) if name != reference else {}
        for n in counts + [None]:
            mine = [r for (m, c, _), r in by.items() if m == name and (n is None or c == n)]
            if not mine:
                continue
            success = sum(r.outcome == "success" for r in mine) / len(mine)
            collisions = sum(r.outcome == "collision" for r in mine)
            c = comparison.get(n)
            versus = (f"+{c.wins} / -{c.losses}, p = {sign_test_p(c.wins, c.losses):.2g} ({c.episodes} paired)"
                      if c else "")
            label = "all" if n is None else str(n)
            if n is None or len(counts) > 1:
                lines.append(f"| {name} | {label} | {len(mine)} | {success:.3f} | {collisions} | "
                             f"{versus} |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m dqn_dovs_py.paired_results", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("runs", nargs="+", metavar="NAME=results.csv", help="the runs (a folder means its results.csv)")
    ap.add_argument("--method", default=None, help="the method to compare when a file holds several")
    ap.add_argument("--out", default=None, help="also write the table to this Markdown file")
    args = ap.parse_args(argv)
    try:
        names, records = load_runs(args.runs, args.method)
    except (PairedError, ValueError, OSError) as error:
        print(f"paired_results: {error}", file=sys.stderr)
        return 2
    text = render(names, records)
    if args.out:
        with open(args.out, "w") as f:
            f.write(text)
    print(text, end="")
    return 0


if __name__ == "__main__":
    sys.exit(main())
