"""docs/benchmark.md from two evaluation runs (tracker in the loop, perfect information) and the paper's table.

    python -m dqn_dovs_py.benchmark_report --tracker results/benchmark/tracker/results.csv \
        --perfect results/benchmark/perfect/results.csv [--paper PAPER_TABLE1.csv] \
        --discussion docs/benchmark_discussion.md --run-info results/benchmark/run_info.json \
        --plots results/benchmark --out docs/benchmark.md

Reads the per-episode results.csv files written by dqn_dovs_eval (method, obstacles, episode, scenario,
outcome, time_s, path_length_m, min_clearance_m, danger_steps, steps, planner_errors, collision_kind,
contact_speed_mps, last_decision; files from before the last three read as "not recorded") and computes, per
method and obstacle count, the figures of an evaluation's summary (dqn_dovs_py.report, their one implementation):

- success / collision / timeout rate; the mean row is the mean of the per-count rates (the paper's mean row);
- time ratio to the reference method: the method's total time over the reference's total time on the
  episodes both solved (episodes are matched by obstacle count and episode number);
- danger frequency: sum of danger_steps (clearance < 0.2 m) over sum of steps;
- mean time on success;
- collisions by kind (static geometry / robot at rest / robot moving) and the robot's speed at contact (mean and
  nearest-rank 95th percentile over the collisions); the pooled row sums every count;
- collisions by the planner's last decision before the contact (the network's action and the shield level that
  allowed it, or the escape and its tier), pooled over every count;
- with `oracle` among the methods (the physical limit, docs/planners.md section 9): its success rate beside the
  others, each method's share of its successes (report.oracle_share) per count and overall, and the episodes it did
  not solve with the methods that solved them all the same. The oracle is a ceiling, never a baseline: it is left
  out of the paired comparisons and of the "beats every baseline" verdicts. A file without oracle episodes shows
  it as not run;
- with the reachability bound's run (`--bound`, method `bound`: the physical limit from above, docs/planners.md
  section 9): per count, the share of the episodes some robot within the limits might solve, the episodes where a
  collision is certain and those out of reach, and whether any method's success lies outside it (the holonomic
  baseline, without the acceleration limits, is another robot and is not checked).

scripts/benchmark_table.sh (make benchmark-table) runs the evaluations and then this module. The discussion
file is hand-written and included verbatim.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import re
import sys
from collections.abc import Callable
from dataclasses import dataclass

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402 - the backend must be chosen first

from . import report  # noqa: E402
from .performance_report import machine_info  # noqa: E402 - /proc/cpuinfo model and nproc, one reader
from .report import (  # noqa: E402,F401 - the figures, re-exported for this module's users
    COLLISION_KINDS, REST_SPEED_MPS, Cell, Record, Summary, danger_frequency, nearest_rank, time_ratio)
from .report import fixed as _f  # noqa: E402
from .report import nan_mean as _mean  # noqa: E402

REFERENCE = "dqn_dovs"
# The physical limit (a search that reads the simulator's future): a ceiling, never a baseline.
ORACLE = report.ORACLE
# The reachability bound (the physical limit from above): where no robot within the limits can get.
BOUND = report.BOUND
# Methods the bound does not cover: a holonomic robot without the acceleration limits.
OUTSIDE_BOUND = ("orca_holonomic",)
NOT_RUN = "not run"
# At most this many of the oracle's unsolved episodes are listed per perception; the rest are in results.csv.
MAX_UNSOLVED_ROWS = 100
# Ablations of our own method, not baselines.
ABLATIONS = ("dqn_dovs_latest_escape", "dqn_dovs_no_escape", "dqn_dovs_unshielded")
# Baselines that drive the differential-drive robot within its acceleration limits (orca_holonomic does not).
KINODYNAMIC_BASELINES = ("s_dovs", "orca_diffdrive", "dwa")
# The paper's columns that have a time ratio beside them.
PAPER_RATIO_SUFFIX = "_time_ratio"
STAND_COUNTS = range(5, 16)
# The columns every results.csv has; the later ones (collision_kind, contact_speed_mps, last_decision) may be absent.
REQUIRED_COLUMNS = ("method", "obstacles", "episode", "outcome", "time_s", "danger_steps", "steps")


def read_results(path: str) -> list[Record]:
    """The episodes of one results.csv; raises ValueError naming the file and line on a malformed row.

    collision_kind, contact_speed_mps and last_decision are optional (files written before them): absent, they
    read as None, NaN and None."""
    return report.read_results(path, required=REQUIRED_COLUMNS)


def summarize(records: list[Record], reference: str = REFERENCE) -> Summary:
    """Per (method, count) cells and a per-method overall cell (report.summarize); the methods in the order of the
    records, the oracle last."""
    order = list(dict.fromkeys(r.method for r in records if r.method != ORACLE))
    return report.summarize(records, reference, order)


def baselines_of(summary: Summary, method: str = REFERENCE) -> list[str]:
    """Every method but `method`, the ablations, the oracle and the bound (limits, not baselines)."""
    return [m for m in summary.methods if m != method and m not in ABLATIONS and m not in report.CEILINGS]


def has_oracle(s: Summary) -> bool:
    """Whether the summary's records hold oracle episodes."""
    return ORACLE in s.methods and s.overall[ORACLE].episodes > 0


@dataclass
class Unsolved:
    """An episode the oracle did not solve, and the other methods that solved it (same count and episode number)."""

    obstacles: int
    episode: int
    scenario: str
    outcome: str  # collision or timeout
    collision_kind: str | None  # report.COLLISION_KINDS, None when not recorded
    time_s: float
    solved_by: list[str]

    def outcome_text(self) -> str:
        if self.outcome != "collision" or not self.collision_kind:
            return self.outcome
        return {"rest": "collision, robot at rest", "moving": "collision, robot moving",
                "static": "collision, static geometry"}[self.collision_kind]


def oracle_unsolved(records: list[Record]) -> list[Unsolved]:
    """The oracle's episodes that did not end in success, by obstacle count and episode, each with the methods
    (in the records' order) that solved the same episode; empty without oracle episodes."""
    solved: dict[tuple[int, int], list[str]] = {}
    for r in records:
        if r.method != ORACLE and r.outcome == "success":
            names = solved.setdefault((r.obstacles, r.episode), [])
            if r.method not in names:
                names.append(r.method)
    out = [Unsolved(r.obstacles, r.episode, r.scenario, r.outcome, r.collision_kind, r.time_s,
                    solved.get((r.obstacles, r.episode), []))
           for r in records if r.method == ORACLE and r.outcome != "success"]
    return sorted(out, key=lambda u: (u.obstacles, u.episode))


def unsolved_counts(unsolved: list[Unsolved]) -> str:
    """"C collisions (R robot at rest, M robot moving, S static geometry), T timeouts"."""
    crashes = [u for u in unsolved if u.outcome == "collision"]
    kinds = [f"{sum(u.collision_kind == k for u in crashes)} {label}" for k, label in
             (("rest", "robot at rest"), ("moving", "robot moving"), ("static", "static geometry"))]
    unknown = sum(u.collision_kind is None for u in crashes)
    if unknown:
        kinds.append(f"{unknown} of kind not recorded")
    timeouts = sum(u.outcome == "timeout" for u in unsolved)
    return (f"{len(crashes)} collision{'s' * (len(crashes) != 1)} ({', '.join(kinds)}), "
            f"{timeouts} timeout{'s' * (timeouts != 1)}")


def beats_every_baseline(summary: Summary, n: int, method: str = REFERENCE,
                         baselines: list[str] | None = None) -> tuple[bool | None, str | None, float]:
    """Whether `method`'s success rate at `n` obstacles is strictly above every baseline's.

    Returns (verdict, strongest baseline, its success rate); verdict None when `method` or every baseline has
    no episodes at `n`."""
    if baselines is None:
        baselines = baselines_of(summary, method)
    mine = summary.cell(method, n)
    rivals = [(summary.cell(b, n).success_rate, b) for b in baselines if summary.cell(b, n).episodes]
    if not mine.episodes or not rivals:
        return None, None, math.nan
    best_rate, best = max(rivals, key=lambda t: t[0])
    return mine.success_rate > best_rate, best, best_rate


@dataclass
class Paired:
    """Success of two methods on the same episodes (matched by obstacle count and episode number)."""

    episodes: int = 0  # episodes both methods ran
    wins: int = 0      # the first method succeeded, the second did not
    losses: int = 0    # the second succeeded, the first did not
    p_value: float = 1.0  # exact two-sided sign test (McNemar) on the wins and losses


def sign_test_p(wins: int, losses: int) -> float:
    """Exact two-sided sign test: the probability, with both methods equally good (each discordant episode a fair
    coin), of a split at least as uneven as wins : losses. 1 without discordant episodes."""
    n = wins + losses
    if n == 0:
        return 1.0
    k = min(wins, losses)
    tail = sum(math.comb(n, i) for i in range(k + 1)) / 2.0 ** n
    return min(1.0, 2.0 * tail)


def paired_comparison(records: list[Record], method: str, rival: str) -> dict[int | None, Paired]:
    """Per obstacle count (and pooled over every count, key None): wins, losses and the sign test of `method`
    against `rival` on the episodes both ran."""
    ok = {(r.method, r.obstacles, r.episode): r.outcome == "success" for r in records if r.method in (method, rival)}
    out: dict[int | None, Paired] = {}
    for (m, n, k), mine in ok.items():
        if m != method or (rival, n, k) not in ok:
            continue
        theirs = ok[(rival, n, k)]
        for key in (n, None):
            c = out.setdefault(key, Paired())
            c.episodes += 1
            c.wins += mine and not theirs
            c.losses += theirs and not mine
    for c in out.values():
        c.p_value = sign_test_p(c.wins, c.losses)
    return out


def read_paper(path: str) -> dict[str, dict[int, float]]:
    """Columns of paper_table1.csv (comment lines start with '#') keyed by obstacle count."""
    with open(path, newline="") as f:
        rows = list(csv.DictReader(line for line in f if not line.lstrip().startswith("#")))
    cols: dict[str, dict[int, float]] = {}
    for row in rows:
        n = int(row["obstacles"])
        for k, v in row.items():
            if k != "obstacles" and v not in ("", None):
                cols.setdefault(k, {})[n] = float(v)
    return cols


# ----------------------------------------------------------------------------------------------- Markdown


def _table(header: list[str], rows: list[list[str]]) -> str:
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    out += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(out)


def _paper_methods(paper: dict[str, dict[int, float]]) -> list[str]:
    return [k for k in paper if not k.endswith(PAPER_RATIO_SUFFIX)]


def _paper_cell(paper, method: str, n: int | None) -> str:
    col = paper.get(method, {})
    ratio = paper.get(method + PAPER_RATIO_SUFFIX)
    if n is None:
        v = _mean(col.values())
        r = _mean(ratio.values()) if ratio else None
    else:
        v = col.get(n, math.nan)
        r = ratio.get(n, math.nan) if ratio else None
    return _f(v) + (f" ({_f(r)})" if r is not None else "")


def success_table(s: Summary, paper: dict[str, dict[int, float]] | None) -> str:
    """Success rate (time ratio) per N and the mean row: every method, the oracle last (NOT_RUN without oracle
    episodes), then the paper's columns."""
    pm = _paper_methods(paper) if paper else []
    methods = s.methods if has_oracle(s) else [m for m in s.methods if m != ORACLE]
    header = ["N"] + methods + ([] if has_oracle(s) else [ORACLE]) + [f"paper {m}" for m in pm]
    rows = []
    for n in list(s.counts) + [None]:
        row = ["mean" if n is None else str(n)]
        for m in methods:
            c = s.overall[m] if n is None else s.cell(m, n)
            row.append(_f(c.success_rate) + ("" if m == s.reference else f" ({_f(c.time_ratio)})"))
        if not has_oracle(s):
            row.append(NOT_RUN)
        for m in pm:
            if n is not None and n not in paper[m]:
                row.append("-")
            else:
                row.append(_paper_cell(paper, m, n))
        rows.append(row)
    return _table(header, rows)


def method_table(s: Summary, value: Callable[[Cell], str], last: str = "mean") -> str:
    """One row per N and a last row (labelled `last`) of the overall cells; one column per method."""
    rows = []
    for n in list(s.counts) + [None]:
        cells = [s.overall[m] if n is None else s.cell(m, n) for m in s.methods]
        rows.append([last if n is None else str(n)] + [value(c) for c in cells])
    return _table(["N"] + s.methods, rows)


def metric_table(s: Summary, attr: str, digits: int = 2) -> str:
    return method_table(s, lambda c: _f(getattr(c, attr), digits))


def _kinds_text(c: Cell) -> str:
    return "-" if c.collisions_by_kind is None else " / ".join(str(c.collisions_by_kind[k]) for k in COLLISION_KINDS)


def _contact_speed_text(c: Cell) -> str:
    if math.isnan(c.mean_contact_speed_mps):
        return "-"
    return f"{_f(c.mean_contact_speed_mps, 3)} ({_f(c.p95_contact_speed_mps, 3)})"


def collision_kind_table(s: Summary) -> str:
    """Per N and pooled (`all`): static / rest / moving collision counts; "-" where a kind was not recorded."""
    return method_table(s, _kinds_text, last="all")


def contact_speed_table(s: Summary) -> str:
    """Per N and pooled (`all`): mean robot speed at contact (95th percentile); "-" without a recorded speed."""
    return method_table(s, _contact_speed_text, last="all")


def stand_list(s: Summary, counts=STAND_COUNTS, method: str = REFERENCE) -> list[str]:
    """One line per obstacle count: does `method` beat every baseline, and every kinodynamic one?"""
    lines = []
    kin = [b for b in KINODYNAMIC_BASELINES if b in s.methods]
    for n in counts:
        if n not in s.counts:
            lines.append(f"- N = {n}: not evaluated")
            continue
        verdict, best, best_rate = beats_every_baseline(s, n, method)
        mine = s.cell(method, n).success_rate
        if verdict is None:
            lines.append(f"- N = {n}: no baseline evaluated")
            continue
        if verdict:
            word = "**beats every baseline**"
        elif mine == best_rate:
            word = "does **not** beat every baseline (ties)"
        else:
            word = "does **not** beat every baseline"
        text = f"- N = {n}: {method} {_f(mine)} - {word} (strongest: {best} {_f(best_rate)})"
        if kin and set(kin) != set(baselines_of(s, method)):
            v2, b2, r2 = beats_every_baseline(s, n, method, kin)
            text += (f"; kinodynamic baselines ({', '.join(kin)}): "
                     + ("beats all" if v2 else f"not all (strongest: {b2} {_f(r2)})"))
        lines.append(text)
    wins = sum(beats_every_baseline(s, n, method)[0] is True for n in counts if n in s.counts)
    evaluated = sum(n in s.counts for n in counts)
    lines.append(f"- Overall: beats every baseline at {wins} of {evaluated} obstacle counts in "
                 f"{min(counts)}..{max(counts)}.")
    return lines


def oracle_share_table(s: Summary) -> str:
    """Per N and over every N (`all`): the oracle's success rate, each other method's share of its successes
    (report.oracle_share) and the oracle's unsolved episodes (collisions / timeouts). Needs oracle episodes."""
    methods = [m for m in s.methods if m != ORACLE]
    rows = []
    for n in list(s.counts) + [None]:
        o = s.overall[ORACLE] if n is None else s.cell(ORACLE, n)
        label = "all" if n is None else str(n)
        if not o.episodes:
            rows.append([label, NOT_RUN] + ["-"] * len(methods) + ["-"])
            continue
        rows.append([label, _f(o.success_rate)]
                    + [_f(report.oracle_share(s, m, n)) for m in methods] + [f"{o.collisions} / {o.timeouts}"])
    return _table(["N", "oracle success"] + methods + ["oracle unsolved (collisions / timeouts)"], rows)


def unsolved_table(unsolved: list[Unsolved], limit: int | None = None) -> str:
    """The oracle's unsolved episodes, the first `limit` (default MAX_UNSOLVED_ROWS) of them: N, episode, scenario,
    outcome, time, solved by."""
    limit = MAX_UNSOLVED_ROWS if limit is None else limit
    rows = [[str(u.obstacles), str(u.episode), f"`{u.scenario}`" if u.scenario else "-", u.outcome_text(),
             _f(u.time_s, 1), ", ".join(u.solved_by) or "none"] for u in unsolved[:limit]]
    return _table(["N", "episode", "scenario", "outcome", "time (s)", "solved by"], rows)


def oracle_lines(s: Summary, records: list[Record] | None, source: str | None = None) -> list[str]:
    """The oracle's subsections of a perception: the share of its successes and its unsolved episodes; NOT_RUN
    without oracle episodes."""
    out = ["### Share of the oracle's successes", ""]
    if not has_oracle(s):
        return out + [f"Not run: no `{ORACLE}` episodes in this run (`ORACLE=0`, or a run from before the oracle "
                      "was in the benchmark).", ""]
    out += [f"`{ORACLE}` is the physical limit (docs/planners.md section 9): a search that knows the obstacles' "
            "future, not deployable; a ceiling, so it is in no paired comparison and no \"beats every baseline\" "
            "verdict. Each method's cell: its successes over the oracle's on the same episodes (`all`: pooled over "
            "every N; the oracle's column there is the mean of its per-N rates). Above 1 where a method solves "
            "episodes the oracle does not: its search is a lower bound of the limit, not the limit.", "",
            oracle_share_table(s), ""]
    unsolved = oracle_unsolved(records or [])
    out += ["### Episodes the oracle did not solve", ""]
    if not unsolved:
        return out + ["None: the oracle solved every episode.", ""]
    out += ["Unavoidable as far as the oracle's search tells (a collision: every searched trajectory collides; a "
            "timeout: no sequence reaches the goal in time): no method is to blame for these. `solved by`: the "
            "methods that solved the episode all the same, where the search and not physics is the limit. "
            "Scenario: the file under the scenarios folder (N-obstacle folder / episode).", "",
            f"- {len(unsolved)} of the oracle's {s.overall[ORACLE].episodes} episodes unsolved: "
            f"{unsolved_counts(unsolved)}; {sum(bool(u.solved_by) for u in unsolved)} of them solved by another "
            "method, the others by none.", ""]
    out += [unsolved_table(unsolved), ""]
    if len(unsolved) > MAX_UNSOLVED_ROWS:
        where = f"`{source}`" if source else "results.csv"
        out += [f"The first {MAX_UNSOLVED_ROWS} of {len(unsolved)}; every one: the `{ORACLE}` rows of {where} "
                "whose outcome is not success.", ""]
    return out


SIGNIFICANCE = 0.05


def paired_table(records: list[Record], s: Summary, method: str = REFERENCE) -> tuple[str, list[str]]:
    """Markdown table of `method` against every baseline, per N and pooled: wins - losses (p), and the summary
    lines naming the counts where a difference is significant at SIGNIFICANCE."""
    rivals = baselines_of(s, method)
    paired = {b: paired_comparison(records, method, b) for b in rivals}
    rows = []
    for n in list(s.counts) + [None]:
        row = ["all" if n is None else str(n)]
        for b in rivals:
            c = paired[b].get(n)
            row.append("-" if c is None else f"+{c.wins} / -{c.losses} ({c.p_value:.2g})")
        rows.append(row)
    lines = []
    for b in rivals:
        better = [n for n in s.counts if n in paired[b] and paired[b][n].p_value < SIGNIFICANCE
                  and paired[b][n].wins > paired[b][n].losses]
        worse = [n for n in s.counts if n in paired[b] and paired[b][n].p_value < SIGNIFICANCE
                 and paired[b][n].losses > paired[b][n].wins]
        pooled = paired[b].get(None, Paired())
        verdict = ("better" if pooled.wins > pooled.losses else "worse") if pooled.p_value < SIGNIFICANCE else \
            "no significant difference"
        lines.append(f"- vs {b}: pooled +{pooled.wins} / -{pooled.losses} of {pooled.episodes} paired episodes, "
                     f"p = {pooled.p_value:.2g} ({verdict}); significantly better at N = "
                     f"{', '.join(map(str, better)) or 'none'}, significantly worse at N = "
                     f"{', '.join(map(str, worse)) or 'none'}")
    return _table(["N"] + [f"vs {b}" for b in rivals], rows), lines


# ----------------------------------------------------------------------------------------------- plots


def plot_success(s: Summary, paper, title: str, path: str) -> None:
    fig, ax = plt.subplots(figsize=(8, 5))
    colors = {}
    for m in s.methods:
        style = {"color": "k", "ls": ":"} if m == ORACLE else {}
        line = ax.plot(s.counts, [s.cell(m, n).success_rate for n in s.counts], marker="o", ms=3, label=m,
                       **style)[0]
        colors[m] = line.get_color()
    if paper:
        # Dashed, in the colour of our counterpart (the paper's ORCA is CrowdNav's holonomic one).
        for m, ours in (("dqn_dovs", "dqn_dovs"), ("s_dovs", "s_dovs"), ("orca", "orca_holonomic")):
            if m in paper:
                ns = sorted(paper[m])
                ax.plot(ns, [paper[m][n] for n in ns], ls="--", marker="x", ms=4, color=colors.get(ours),
                        label=f"paper {m}")
    ax.set_xlabel("obstacles N")
    ax.set_ylabel("success rate")
    ax.set_ylim(0, 1.02)
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, ncol=2)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def plot_collision(summaries: dict[str, Summary], path: str) -> None:
    fig, ax = plt.subplots(figsize=(8, 5))
    styles = {"tracker": "-", "perfect": ":"}
    colors = {}
    for label, s in summaries.items():
        for m in s.methods:
            line = ax.plot(s.counts, [s.cell(m, n).collision_rate for n in s.counts], ls=styles.get(label, "-"),
                           marker="o", ms=3, color=colors.get(m), label=f"{m} ({label})")[0]
            colors.setdefault(m, line.get_color())
    ax.set_xlabel("obstacles N")
    ax.set_ylabel("collision rate")
    ax.set_ylim(0, 1.02)
    ax.set_title("Collision rate (solid: tracker in the loop, dotted: perfect information)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


# ----------------------------------------------------------------------------------------------- report


def decision_category(note: str) -> str:
    """A last_decision note as a category: the action's number dropped, the escape's shield level and tier kept
    ("action (shield robust)", "escape: rest (shield latest)", "decelerate", "before the first decision")."""
    if note == "":
        return "before the first decision"
    m = re.fullmatch(r"action \d+(?: \(shield: (\w+)\))?", note)
    if m:
        return f"action (shield {m.group(1)})" if m.group(1) else "action"
    m = re.fullmatch(r"escape \(shield: (\w+)[;,] (\w+)\)", note)
    if m:
        return f"escape: {m.group(2)} (shield {m.group(1)})"
    if note.startswith("decelerate"):
        return "decelerate"
    return note


def last_decision_table(records: list[Record], methods: list[str]) -> str | None:
    """Collisions per last-decision category (rows) and method (columns), each cell `rest / moving / static`
    over every count; None when no collision carries its last decision (files from before the column)."""
    tally: dict[str, dict[str, dict[str, int]]] = {}
    for r in records:
        if r.outcome != "collision" or r.last_decision is None or r.method not in methods:
            continue
        kinds = tally.setdefault(decision_category(r.last_decision), {}).setdefault(
            r.method, dict.fromkeys(COLLISION_KINDS, 0))
        if r.collision_kind in kinds:
            kinds[r.collision_kind] += 1
    if not tally:
        return None
    order = ("rest", "moving", "static")
    rows = []
    for category in sorted(tally, key=lambda c: -sum(sum(k.values()) for k in tally[c].values())):
        cells = [" / ".join(str(tally[category][m][k]) for k in order) if m in tally[category] else "-"
                 for m in methods]
        rows.append([category] + cells)
    return _table(["last decision"] + methods, rows)


def _perception_section(title: str, s: Summary, paper, plot_rel: str,
                        records: list[Record] | None = None, source: str | None = None) -> list[str]:
    out = [f"## {title}", ""]
    out += ["### Success rate", "",
            "Reached the goal and stopped on it. In brackets: total time of the method over total time of "
            f"`{s.reference}` on the episodes both solved (the paper's ratio). `{ORACLE}`: the physical limit "
            "(below). The `paper` columns are the paper's Table 1 (its own simulator and baselines); `mean` "
            "averages the per-N rates.", "",
            success_table(s, paper), "", f"![Success rate vs N]({plot_rel})", ""]
    out += oracle_lines(s, records, source)
    out += ["### Collision rate", "", "Episodes ending in contact with an obstacle or a wall.", "",
            metric_table(s, "collision_rate"), ""]
    out += ["### Collisions by kind", "",
            "Counts, static / rest / moving: the robot hit a wall or a static obstacle (must be 0) / the robot was "
            f"at rest (below {REST_SPEED_MPS} m/s: walked into) / the robot moved into a moving obstacle. `all` "
            "sums every N; `-`: kinds not recorded (results.csv from before `collision_kind`).", "",
            collision_kind_table(s), ""]
    out += ["### Robot speed at contact (m/s)", "",
            "The robot's linear speed when it collided: mean over the method's collisions, 95th percentile "
            "(nearest rank) in brackets. `all` pools every N; `-`: no collision (or speeds not recorded).", "",
            contact_speed_table(s), ""]
    if s.faults_recorded:
        out += ["### Passive-safety rate", "",
                "1 - the rate of collisions with the robot at fault (any static contact, the robot moving at "
                f"{REST_SPEED_MPS} m/s or more, or at rest for less than 0.5 s before it), beside strict success "
                "above; in brackets: collisions with the robot at fault / hit at rest. `-`: not recorded.", "",
                method_table(s, lambda c: "-" if c.at_fault is None else
                             f"{_f(c.passive_safety_rate)} ({c.at_fault} / {c.hit_at_rest})"), ""]
    by_decision = last_decision_table(records, s.methods) if records is not None else None
    if by_decision is not None:
        out += ["### Collisions by the last decision", "",
                "What the planner did at the last decision before each contact, pooled over every N; each cell: "
                "robot at rest / moving / static. `action (shield L)`: the network's action among those the "
                "shield allowed at level L; `escape: T (shield L)`: the shield's escape velocity of tier T (free, "
                "rest, slowest, unsafe, dodge; docs/planners.md, \"Passive safety\").", "", by_decision, ""]
    out += ["### Timeout rate", "", "Episodes still running after 500 steps (100 s).", "",
            metric_table(s, "timeout_rate"), ""]
    out += ["### Danger frequency", "",
            "Fraction of steps ending with clearance below 0.2 m (sum of danger steps over sum of steps, "
            "all episodes).", "", metric_table(s, "danger_frequency", 3), ""]
    out += ["### Mean time on success (s)", "", metric_table(s, "mean_time_success_s", 1), ""]
    if records is not None and s.reference in s.methods and baselines_of(s):
        table, lines = paired_table(records, s)
        out += ["### Paired comparison", "",
                f"Each cell: episodes `{s.reference}` solved and the baseline did not (+), the reverse (-), and in "
                "brackets the exact two-sided sign test (McNemar) on those discordant episodes: the chance of a split "
                "at least this uneven if both methods were equally good. Episodes both solve or both fail say "
                f"nothing about the difference. Significant: p < {SIGNIFICANCE}.", "", table, ""] + lines + [""]
    return out


def beyond_bound(bound: list[Record], records: list[Record]) -> dict[str, tuple[int, int]]:
    """Per method of `records` (not the bound, nor those OUTSIDE_BOUND): (successes the bound rules out or that came
    sooner than it allows, episodes the bound says end in a collision where the method did not collide by then).
    Both must be 0 for a method that drives the robot within its limits. Episodes pair by (count, episode)."""
    by_key = {(r.obstacles, r.episode): r for r in bound}
    out: dict[str, tuple[int, int]] = {}
    for r in records:
        if r.method == BOUND or r.method in OUTSIDE_BOUND or (r.obstacles, r.episode) not in by_key:
            continue
        b = by_key[(r.obstacles, r.episode)]
        beyond, survived = out.get(r.method, (0, 0))
        if r.outcome == "success" and (b.outcome != "success" or r.time_s + 1e-6 < b.time_s):
            beyond += 1
        if b.outcome == "collision" and not (r.outcome == "collision" and r.time_s <= b.time_s + 1e-6):
            survived += 1
        out[r.method] = (beyond, survived)
    return out


def bound_lines(bound: list[Record] | None, records: dict[str, list[Record]], command: str | None = None) -> list[str]:
    """The section of the reachability bound: per count the bound's success rate (an upper limit of any method's),
    its certain collisions and episodes out of reach, and the check of every method against it."""
    out = ["## Episodes no robot can solve: the reachability bound", ""]
    if not bound:
        return out + [f"Not run: no `{BOUND}` results (`BOUND=0`, or a run from before the bound).", ""]
    out += [f"`{BOUND}` (docs/planners.md section 9, \"An upper bound\") steps each episode's obstacles ahead and keeps "
            "every position the robot's centre could hold, relaxed so that it can only do more than the robot (any "
            "direction, instant stops). Its success rate is an upper limit of every method's on these episodes; its "
            "collisions are certain for any robot within the limits (truly unavoidable), its timeouts out of reach. It "
            "does not depend on the perception: one run serves both sections."
            + (f" Command: `{command}`." if command else ""), ""]
    counts = sorted({r.obstacles for r in bound})
    rows = []
    for n in counts + [None]:
        cell = [r for r in bound if n is None or r.obstacles == n]
        rate = sum(r.outcome == "success" for r in cell) / len(cell)
        rows.append(["all" if n is None else str(n), str(len(cell)), _f(rate),
                     str(sum(r.outcome == "collision" for r in cell)), str(sum(r.outcome == "timeout" for r in cell))])
    out += [_table(["N", "episodes", "bound success (upper limit)", "collision certain", "goal out of reach"], rows),
            ""]
    for key, label in (("tracker", "tracker in the loop"), ("perfect", "perfect information")):
        if key not in records:
            continue
        checked = beyond_bound(bound, records[key])
        bad = {m: v for m, v in checked.items() if v != (0, 0)}
        if bad:
            out.append(f"- {label}: **outside the bound**: " + "; ".join(
                f"`{m}` {b} successes it rules out or sooner, {c} certain collisions avoided"
                for m, (b, c) in bad.items()))
        else:
            out.append(f"- {label}: no success of {', '.join(f'`{m}`' for m in checked)} lies outside the bound, "
                       "and each collided, no later than it says, in every episode where it says a collision is "
                       f"certain (`{', '.join(OUTSIDE_BOUND)}` is another robot: holonomic, without the acceleration "
                       "limits).")
    return out + [""]


def render(tracker: Summary | None, perfect: Summary | None, paper, run_info: dict, discussion: str | None,
           plots: dict[str, str], records: dict[str, list[Record]] | None = None,
           sources: dict[str, str] | None = None, bound: list[Record] | None = None,
           bound_command: str | None = None) -> str:
    """sources: the results.csv of each perception, named where the list of the oracle's unsolved episodes is cut;
    bound: the reachability bound's episodes (None: its section says not run)."""
    records = records or {}
    sources = sources or {}
    out = ["# Benchmark: DQN-DOVS and the baselines on the shared scenarios", "",
           "Generated by `make benchmark-table` (scripts/benchmark_table.sh, python/dqn_dovs_py/benchmark_report.py); "
           "do not edit by hand except `docs/benchmark_discussion.md`, included below.", ""]
    out += ["## How this was produced", ""]
    if run_info:
        out.append(f"- Date: {run_info.get('date', 'not recorded')}; commit `{run_info.get('commit', '?')}`; "
                   f"model `{run_info.get('model', '?')}` (sha256 `{run_info.get('model_sha256', '?')[:16]}`)")
        out.append(f"- Machine: {run_info.get('nproc', '?')} CPU(s) (`nproc`), {run_info.get('cpu_model', '?')}")
        for key, label in (("tracker", "Tracker in the loop"), ("perfect", "Perfect information")):
            r = run_info.get(key)
            if r:
                out.append(f"- {label}: `{r.get('command', '?')}`; wall time {_f(r.get('wall_s', math.nan), 1)} s")
        if "total_wall_s" in run_info:
            out.append(f"- Total wall time of `make benchmark-table`'s evaluations: "
                       f"{_f(run_info['total_wall_s'], 1)} s")
    else:
        m = machine_info()
        out.append(f"- Run information not recorded (no run_info.json); this machine: {m['nproc']} CPU(s), "
                   f"{m['cpu_model']}")
    out.append("- Regenerate: `make benchmark-table` (EPISODES=K for a shorter run)")
    out.append("")
    s0 = tracker or perfect
    if s0 is not None:
        eps = sorted({c.episodes for c in s0.cells.values() if c.episodes})
        out += [f"Methods: {', '.join(f'`{m}`' for m in s0.methods)}; obstacle counts "
                f"{min(s0.counts)}..{max(s0.counts)}; {', '.join(map(str, eps))} episode(s) per count and method; "
                "the same episodes for every method. Step 0.2 s, 500-step limit (docs/planners.md for the planners).",
                ""]
    out += ["## Where we stand", "",
            "Computed from the tables below: for each N, whether `dqn_dovs`'s success rate is strictly above every "
            f"baseline's ({', '.join(baselines_of(s0)) if s0 else '-'}; "
            f"{', '.join(f'`{m}`' for m in ABLATIONS)} are our ablations and `{ORACLE}` the physical limit, not "
            "baselines).", ""]
    for label, s in (("Tracker in the loop", tracker), ("Perfect information", perfect)):
        if s is None:
            continue
        out += [f"**{label}**", ""] + stand_list(s) + [""]
    if tracker is not None:
        out += _perception_section("Tracker in the loop (LIDAR + obstacle tracker)", tracker, paper,
                                   plots.get("tracker", ""), records.get("tracker"), sources.get("tracker"))
    else:
        out += ["## Tracker in the loop", "", "Not run (no results.csv).", ""]
    if perfect is not None:
        out += _perception_section("Perfect information (simulator ground truth)", perfect, paper,
                                   plots.get("perfect", ""), records.get("perfect"), sources.get("perfect"))
    else:
        out += ["## Perfect information", "", "Not run (no results.csv).", ""]
    if "collision" in plots:
        out += ["## Collision rate vs N", "", f"![Collision rate vs N]({plots['collision']})", ""]
    out += bound_lines(bound, records, bound_command)
    out += ["## Discussion", ""]
    out += [discussion.rstrip("\n"), ""] if discussion else ["(docs/benchmark_discussion.md is missing.)", ""]
    return "\n".join(out)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--tracker", default="results/benchmark/tracker/results.csv")
    p.add_argument("--perfect", default="results/benchmark/perfect/results.csv")
    p.add_argument("--paper", default="", help="CSV of the paper's Table 1 (optional: its columns beside ours)")
    p.add_argument("--discussion", default="docs/benchmark_discussion.md")
    p.add_argument("--run-info", default="results/benchmark/run_info.json")
    p.add_argument("--plots", default="results/benchmark", help="folder of the PNGs")
    p.add_argument("--out", default="docs/benchmark.md")
    p.add_argument("--bound", default="results/benchmark/bound/results.csv",
                   help="results.csv of the reachability bound's run (method bound); missing: not run")
    a = p.parse_args(argv)

    summaries, records, sources = {}, {}, {}
    for key, path in (("tracker", a.tracker), ("perfect", a.perfect)):
        if path and os.path.exists(path):
            records[key] = read_results(path)
            sources[key] = path
            summaries[key] = summarize(records[key])
        else:
            print(f"benchmark_report: {path} does not exist; that section says 'not run'", file=sys.stderr)
    if not summaries:
        print("benchmark_report: no results.csv to report", file=sys.stderr)
        return 1
    paper = read_paper(a.paper) if a.paper and os.path.exists(a.paper) else None
    run_info = {}
    if a.run_info and os.path.exists(a.run_info):
        with open(a.run_info) as f:
            run_info = json.load(f)
    discussion = None
    if a.discussion and os.path.exists(a.discussion):
        with open(a.discussion) as f:
            discussion = f.read()

    os.makedirs(a.plots, exist_ok=True)
    out_dir = os.path.dirname(os.path.abspath(a.out))
    plots = {}
    titles = {"tracker": "Success rate, tracker in the loop (ours) vs paper",
              "perfect": "Success rate, perfect information (ours) vs paper"}
    for key, s in summaries.items():
        path = os.path.join(a.plots, f"success_vs_n_{key}.png")
        plot_success(s, paper, titles[key], path)
        plots[key] = os.path.relpath(path, out_dir)
    path = os.path.join(a.plots, "collision_vs_n.png")
    plot_collision(summaries, path)
    plots["collision"] = os.path.relpath(path, out_dir)

    bound, bound_command = None, None
    if a.bound and os.path.exists(a.bound):
        bound = [r for r in read_results(a.bound) if r.method == BOUND] or None
        run_json = os.path.join(os.path.dirname(a.bound), "run.json")
        if os.path.exists(run_json):
            with open(run_json) as f:
                bound_command = json.load(f).get("command")
    elif a.bound:
        print(f"benchmark_report: {a.bound} does not exist; the bound's section says 'not run'", file=sys.stderr)
    text = render(summaries.get("tracker"), summaries.get("perfect"), paper, run_info, discussion, plots, records,
                  sources, bound, bound_command)
    with open(a.out, "w") as f:
        f.write(text)
    print(f"wrote {a.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
