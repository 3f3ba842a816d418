"""Paired comparison of DQN-DOVS networks across the world families, on generated held-out episodes.

    python -m dqn_dovs_py.compare_models --model shipped=models/dqn_dovs.dqnw --model worlds=runs/w/model.dqnw \\
        --seed 14301 --episodes 40 --out runs/compare_14301

Every network runs as `dqn_dovs_eval --methods dqn_dovs --model FILE` on the same generated episodes of each point
of the suite (a world family, LIDAR profile, people model and count; POINTS), and so does the baseline (S-DOVS by
default). The first network is the reference. Written into --out: one folder per point and network with
dqn_dovs_eval's results.csv, and compare.md / compare.csv: success per point, pooled over the points, and each
network's paired sign test (exact, two-sided, episodes matched by point, count and number) against the reference
and against the baseline, and against any other network named with --pair. With --reuse, a run whose results are
already in --out from the same command, evaluation tool and network bytes is read instead of run again (networks
can then be added to a comparison later). Decisions are made on seeds kept for them, never on the external benchmark scenarios (docs/external_benchmark.md).

With --predict-people FILE the planners see the people of every world family on the arcs of that learned prediction,
as the robot's dovs_node and `make benchmark-worlds` give them (the room's discs are never predicted); the
decision protocol of docs/planners.md:

    python -m dqn_dovs_py.compare_models --model shipped=models/dqn_dovs.dqnw --model new=runs/n/model.dqnw \
        --seed 29001 --episodes 100 --predict-people models/people_predictor_tracks.dqnp --out runs/compare_29001 \
        --points room,crowd_urg_n5,crowd_urg_n10,crowd_urg_n15,corridor_urg_n6,doorway_urg_n6,clutter_urg_n6,junction_urg_n6
"""

from __future__ import annotations

import argparse
import csv
import os
import subprocess
import sys
import time
from dataclasses import dataclass

from .benchmark_report import paired_comparison, read_results, sign_test_p
from .export import FEATURE_COUNT_WITH_PREVIOUS_CHOICE, load_weights
from .report import Record
from .run_info import sha256_of
from .sweep import find_eval_tool


@dataclass(frozen=True)
class Point:
    """One evaluation setting: a name, dqn_dovs_eval's obstacle counts, the episodes per count as a fraction of
    --episodes, and its world flags."""

    name: str
    obstacles: str
    episode_share: float
    flags: tuple[str, ...]


# The paper's room at every count 3-15 (half the episodes per count: 13 counts), and each world family at the
# densities of docs/benchmark_worlds.md, with the robot's sensors (urg04lx on a Turtlebot 2) where it matters.
POINTS = (
    Point("room", "3-15", 0.5, ()),
    Point("crowd_urg_n5", "5", 1.0, ("--world", "crowd", "--sensor", "urg04lx")),
    Point("crowd_urg_n10", "10", 1.0, ("--world", "crowd", "--sensor", "urg04lx")),
    Point("crowd_urg_n15", "15", 1.0, ("--world", "crowd", "--sensor", "urg04lx")),
    Point("crowd_n10", "10", 1.0, ("--world", "crowd")),
    Point("corridor_urg_n5", "5", 1.0, ("--world", "corridor", "--sensor", "urg04lx")),
    Point("corridor_n10", "10", 1.0, ("--world", "corridor")),
    Point("clutter_n5", "5", 1.0, ("--world", "clutter")),
    Point("clutter_urg_n10", "10", 1.0, ("--world", "clutter", "--sensor", "urg04lx")),
    Point("doorway_n5", "5", 1.0, ("--world", "doorway")),
    Point("junction_n5", "5", 1.0, ("--world", "junction")),
    # The building families at the decision protocol's density (6 people, 60 episodes where the crowds have 100).
    Point("corridor_urg_n6", "6", 0.6, ("--world", "corridor", "--sensor", "urg04lx")),
    Point("doorway_urg_n6", "6", 0.6, ("--world", "doorway", "--sensor", "urg04lx")),
    Point("clutter_urg_n6", "6", 0.6, ("--world", "clutter", "--sensor", "urg04lx")),
    Point("junction_urg_n6", "6", 0.6, ("--world", "junction", "--sensor", "urg04lx")),
)
# The points of the default suite: every one but the building families at 6 people.
DEFAULT_POINTS = tuple(p.name for p in POINTS if not p.name.endswith("_urg_n6"))


class CompareError(ValueError):
    """Bad arguments or a failed evaluation; the message names the thing."""


def parse_models(specs: list[str]) -> list[tuple[str, str]]:
    """["NAME=PATH", ...] -> [(NAME, PATH)], checked: unique names, files that exist."""
    out: list[tuple[str, str]] = []
    for spec in specs:
        name, sep, path = spec.partition("=")
        if not sep or not name or not path:
            raise CompareError(f"--model {spec!r}: expected NAME=PATH")
        if not name.replace("_", "").isalnum():
            raise CompareError(f"--model {spec!r}: the name may hold letters, digits and '_' only")
        if any(name == n for n, _ in out):
            raise CompareError(f"--model {spec!r}: the name {name!r} is given twice")
        if not os.path.isfile(path):
            raise CompareError(f"--model {spec!r}: {path} is not a file")
        out.append((name, path))
    if not out:
        raise CompareError("give at least one --model NAME=PATH")
    return out


def find_eval(explicit: str | None) -> str:
    """--eval when given, else the sweep's search ($DQN_DOVS_BIN_DIR, then the repository's install tree)."""
    if not explicit:
        return find_eval_tool()
    if not (os.path.isfile(explicit) and os.access(explicit, os.X_OK)):
        raise CompareError(f"--eval {explicit}: not an executable file")
    return explicit


def state_flags(model: str) -> list[str]:
    """dqn_dovs_eval flags that build the state the network in `model` was trained on: its graded grid's
    horizon (normalisation entry grid_contact_horizon_s, docs/dovs.md "The graded grid"), its grid channels
    (the file's `state layout: grid channels`, docs/dovs.md "Grid channels") and the previous choice (17 feature
    inputs, docs/dovs.md "The previous action"), the wall rays and the person tokens (format version 3, docs/dovs.md
    "Person tokens") and the route points (format version 4, "The route ahead"); none for the paper's state."""
    weights = load_weights(model)
    horizon = weights.normalization.get("grid_contact_horizon_s", 0.0)
    values = [f"grid_contact_horizon={horizon:.9g}"] if horizon else []
    if weights.grid_channels != 1:
        values.append(f"grid_channels={weights.grid_channels}")
    if weights.feature_count == FEATURE_COUNT_WITH_PREVIOUS_CHOICE:
        values.append("previous_action=1")
    if weights.wall_ray_count:
        values.append(f"wall_rays={weights.wall_ray_count}")
    if weights.person_token_count:
        values.append(f"person_tokens={weights.person_token_count}")
    if weights.route_point_count:
        values.append(f"route_points={weights.route_point_count}")
    return ["--dovs", ",".join(values)] if values else []


def has_people(point: Point) -> bool:
    """Whether the point is a world family (walking people), not the paper's room of discs."""
    return "--world" in point.flags


def point_command(exe: str, point: Point, method: str, model: str | None, args, folder: str) -> list[str]:
    """dqn_dovs_eval's command for `method` at `point`: the network's state flags, and the learned people
    prediction (--predict-people) where the point has people."""
    episodes = max(1, round(args.episodes * point.episode_share))
    cmd = [exe, "--methods", method, "--generate", str(args.seed), "--obstacles", point.obstacles,
           "--episodes", str(episodes), "--threads", str(args.threads), "--out", folder, *point.flags]
    if getattr(args, "predict_people", "") and has_people(point):
        cmd += ["--predict-people", args.predict_people]
    if model:
        cmd += ["--model", model, *state_flags(model)]
    return cmd


def run_point(exe: str, point: Point, method: str, model: str | None, args, folder: str) -> list[Record]:
    """One dqn_dovs_eval run of `method` at `point` into `folder`; its records with the method renamed to the
    folder's last part (the network's name)."""
    cmd = point_command(exe, point, method, model, args, folder)
    os.makedirs(folder, exist_ok=True)
    # What the results depend on: the command, and the bytes of the evaluation tool, the network and the predictor.
    inputs = [exe] + ([model] if model else [])
    if "--predict-people" in cmd:
        inputs.append(cmd[cmd.index("--predict-people") + 1])
    key = " ".join(cmd) + "\n" + "".join(f"{path} sha256 {sha256_of(path)}\n" for path in inputs)
    key_path, results_path = os.path.join(folder, "inputs.txt"), os.path.join(folder, "results.csv")
    reused = False
    if getattr(args, "reuse", False) and os.path.isfile(results_path) and os.path.isfile(key_path):
        with open(key_path) as f:
            reused = f.read() == key
    if not reused:
        for stale in (key_path, results_path):
            if os.path.exists(stale):
                os.remove(stale)
        with open(os.path.join(folder, "command.txt"), "w") as f:
            f.write(" ".join(cmd) + "\n")
        with open(os.path.join(folder, "eval.log"), "w") as log:
            rc = subprocess.call(cmd, stdout=log, stderr=subprocess.STDOUT)
        if rc != 0:
            with open(os.path.join(folder, "eval.log")) as f:
                last = (f.read().strip().splitlines() or ["(no output)"])[-1]
            raise CompareError(f"{point.name}, {os.path.basename(folder)}: dqn_dovs_eval exited with {rc}: {last}")
        with open(key_path, "w") as f:
            f.write(key)
    name = os.path.basename(folder)
    return [Record(**{**r.__dict__, "method": name}) for r in read_results(os.path.join(folder, "results.csv"))]


Records = dict[str, list[Record]]  # point name -> the episodes of every method there


def pooled(records: Records, method: str, rival: str, points: list[str]) -> tuple[int, int, int, float]:
    """Episodes, wins, losses and sign-test p of `method` against `rival` over the points' episodes."""
    episodes = wins = losses = 0
    for p in points:
        c = paired_comparison(records.get(p, []), method, rival).get(None)
        if c:
            episodes, wins, losses = episodes + c.episodes, wins + c.wins, losses + c.losses
    return episodes, wins, losses, sign_test_p(wins, losses)


def success(records: Records, method: str, points: list[str]) -> tuple[int, int]:
    """Successes and episodes of `method` over the points."""
    mine = [r for p in points for r in records.get(p, []) if r.method == method]
    return sum(r.outcome == "success" for r in mine), len(mine)


def _paired_text(records: Records, method: str, rival: str, points: list[str]) -> str:
    e, w, lo, p = pooled(records, method, rival, points)
    return f"+{w} / -{lo}, p = {p:.2g}" if e else "-"


def parse_pairs(specs: list[str], names: list[str]) -> list[tuple[str, str]]:
    """--pair A=B specs as (A, B); both must name compared networks (or the baseline)."""
    pairs = []
    for spec in specs:
        a, sep, b = spec.partition("=")
        if not sep or not a or not b or a == b:
            raise CompareError(f"--pair {spec!r}: expected NAME=OTHER, two different networks")
        unknown = [n for n in (a, b) if n not in names]
        if unknown:
            raise CompareError(f"--pair {spec!r}: {', '.join(unknown)} is not compared (known: {', '.join(names)})")
        pairs.append((a, b))
    return pairs


def render_pairs(records: Records, pairs: list[tuple[str, str]], points: list[str]) -> list[str]:
    """A table of each pair's paired sign test per point and pooled, and, with several pairs, every pair's episodes
    pooled (the same episodes once per pair: e.g. three training seeds each against its twin)."""
    if not pairs:
        return []
    labels = [f"{a} vs {b}" for a, b in pairs]
    lines = ["", "## Pairs (wins / losses of the first, exact sign test)", "",
             "| point | " + " | ".join(labels) + (" | all pairs |" if len(pairs) > 1 else " |"),
             "|---|" + "---|" * (len(pairs) + (len(pairs) > 1))]
    for p in points + [None]:
        at = points if p is None else [p]
        cells = [_paired_text(records, a, b, at) for a, b in pairs]
        if len(pairs) > 1:
            wins = losses = 0
            for a, b in pairs:
                _, w, lo, _ = pooled(records, a, b, at)
                wins, losses = wins + w, losses + lo
            cells.append(f"+{wins} / -{losses}, p = {sign_test_p(wins, losses):.2g}")
        lines.append(f"| {p or '**pooled**'} | " + " | ".join(cells) + " |")
    return lines


def render(records: Records, methods: list[str], reference: str, baseline: str, points: list[str],
           header: str, pairs: list[tuple[str, str]] | None = None) -> tuple[str, list[dict]]:
    rows: list[dict] = []
    lines = [header, "", "## Success per point", "",
             "| point | " + " | ".join(methods) + " |", "|---|" + "---|" * len(methods)]
    for p in points + [None]:
        cells = []
        at = points if p is None else [p]
        for m in methods:
            s, n = success(records, m, at)
            cells.append(f"{s / n:.3f}" if n else "-")
            rows.append({"point": p or "pooled", "method": m, "episodes": n, "successes": s,
                         "success_rate": round(s / n, 4) if n else "",
                         **{f"vs_{rival}_{k}": v for rival in (reference, baseline) if rival != m
                            for k, v in zip(("episodes", "wins", "losses", "p"),
                                            pooled(records, m, rival, at))}})
        lines.append(f"| {p or '**pooled**'} | " + " | ".join(cells) + " |")
    for rival in (reference, baseline):
        others = [m for m in methods if m != rival]
        lines += ["", f"## Paired against {rival} (wins / losses, exact sign test)", "",
                  "| point | " + " | ".join(others) + " |", "|---|" + "---|" * len(others)]
        for p in points + [None]:
            at = points if p is None else [p]
            lines.append(f"| {p or '**pooled**'} | " + " | ".join(_paired_text(records, m, rival, at) for m in others)
                         + " |")
    lines += render_pairs(records, pairs or [], points)
    return "\n".join(lines) + "\n", rows


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m dqn_dovs_py.compare_models", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--model", action="append", default=[], metavar="NAME=PATH",
                    help="a network to compare (repeat; the first is the reference)")
    ap.add_argument("--baseline", default="s_dovs", help="a method of dqn_dovs_eval that needs no model (s_dovs)")
    ap.add_argument("--seed", type=int, required=True, help="generator seed (one kept for decisions)")
    ap.add_argument("--episodes", type=int, default=40, help="episodes per count (the room: half per count)")
    ap.add_argument("--points", default=",".join(DEFAULT_POINTS),
                    help="comma-separated points of the suite (default: every one but the building families at 6 "
                         "people: " + ", ".join(p.name for p in POINTS if p.name not in DEFAULT_POINTS) + ")")
    ap.add_argument("--predict-people", default="", metavar="FILE",
                    help="the learned people prediction the planners see where there are people "
                         "(models/people_predictor_tracks.dqnp, as on the robot; default: none)")
    ap.add_argument("--pair", action="append", default=[], metavar="NAME=OTHER",
                    help="also test NAME against OTHER, paired (repeat; e.g. each seed against its twin)")
    ap.add_argument("--reuse", action="store_true",
                    help="keep a run's results already in --out when its command, evaluation tool and network file "
                         "are the same (inputs.txt); otherwise it runs again")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--eval", default=None, help="dqn_dovs_eval executable (default: the installed one)")
    ap.add_argument("--out", required=True)
    args = ap.parse_args(argv)
    try:
        models = parse_models(args.model)
        if args.episodes < 1:
            raise CompareError(f"--episodes must be at least 1, got {args.episodes}")
        known = {p.name: p for p in POINTS}
        wanted = [s for s in args.points.split(",") if s]
        bad = [s for s in wanted if s not in known]
        if bad or not wanted:
            raise CompareError(f"--points: unknown {bad} (known: {', '.join(known)})")
        if args.predict_people and not os.path.isfile(args.predict_people):
            raise CompareError(f"--predict-people {args.predict_people}: not a file")
        pairs = parse_pairs(args.pair, [n for n, _ in models] + [args.baseline])
        exe = find_eval(args.eval)
        records: Records = {}
        runs = [(name, "dqn_dovs", path) for name, path in models] + [(args.baseline, args.baseline, None)]
        for i, pname in enumerate(wanted):
            for name, method, path in runs:
                t0 = time.perf_counter()
                got = run_point(exe, known[pname], method, path, args, os.path.join(args.out, pname, name))
                records.setdefault(pname, []).extend(got)
                s, n = success({pname: got}, name, [pname])
                print(f"[{i + 1}/{len(wanted)}] {pname:16s} {name:16s} success {s}/{n} "
                      f"({time.perf_counter() - t0:.1f} s)", file=sys.stderr, flush=True)
    except (CompareError, ValueError, OSError) as error:
        print(f"compare_models: {error}", file=sys.stderr)
        return 2
    names = [n for n, _ in models] + [args.baseline]
    header = (f"# Networks compared across worlds\n\nGenerated episodes, seed {args.seed}, {args.episodes} per count "
              f"(the room: {max(1, round(args.episodes * 0.5))} per count 3-15); the tracker in the loop"
              + (f"; people predicted by `{args.predict_people}`" if args.predict_people else "") + ". Networks: "
              + ", ".join(f"`{n}` = `{p}`" for n, p in models) + f"; baseline `{args.baseline}`.\n\n"
              f"Command: `python -m dqn_dovs_py.compare_models {' '.join(argv if argv is not None else sys.argv[1:])}`")
    text, rows = render(records, names, models[0][0], args.baseline, wanted, header, pairs)
    with open(os.path.join(args.out, "compare.md"), "w") as f:
        f.write(text)
    with open(os.path.join(args.out, "compare.csv"), "w", newline="") as f:
        fields = sorted({k for r in rows for k in r}, key=lambda k: (k not in ("point", "method"), k))
        w = csv.DictWriter(f, fieldnames=fields)
        w.writeheader()
        w.writerows(rows)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
