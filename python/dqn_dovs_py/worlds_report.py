"""docs/benchmark_worlds.md: dqn_dovs and s_dovs (and the oracle, the physical limit) across the generated world
families, LIDAR profiles and people models, from the run folders scripts/benchmark_worlds.sh (make benchmark-worlds)
writes.

    python -m dqn_dovs_py.worlds_report --runs docs/benchmark_worlds --out docs/benchmark_worlds.md

Each run folder holds one dqn_dovs_eval run of both methods, and of `oracle` unless the script ran with ORACLE=0, at
one count N (results.csv, run.json), LIDAR + tracker in the loop:

- FAMILY_nN for every family (room, crowd, corridor, doorway, clutter, junction) and N = 5, 10, 15: LIDAR profile
  sim, social-force people to whom the robot is invisible;
- crowd_n10_PROFILE for the LIDAR profiles hokuyo, urg04lx and rplidar_a1 (the sim profile is crowd_n10);
- crowd_n10_orca (reciprocal avoidance among people), crowd_n10_constant (people keep their start velocity) and
  crowd_n10_see_robot (people give way to the robot).

The figures are dqn_dovs_py.report's (success / collision / timeout rate, mean time on success; the `all N` row
averages the per-N rates) and the paired comparison is dqn_dovs_py.benchmark_report's (episodes one method solved
and the other did not, exact two-sided sign test). The oracle (docs/planners.md section 9) is a ceiling, never a
baseline: with it, the report gives its success per family and N, each method's share of its successes
(report.oracle_share) and its unsolved episodes (the truly unavoidable ones as far as its search tells) per run, the
first MAX_LISTED_EPISODES of each listed; runs without it show it as not run. Writes the Markdown file and
RUNS/success_by_world.png.

With --commit, --model and --total-wall (the script's record of the run) it first writes RUNS/run_info.json (date,
commit, model and its sha256, machine, total wall time); without them it reads the one there, if any. The
hand-written discussion file is copied verbatim between the markers of the "What this shows" section.
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import os
import sys
from collections.abc import Sequence
from dataclasses import dataclass, field

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from .benchmark_report import ORACLE, SIGNIFICANCE, Paired, Unsolved, oracle_unsolved, paired_comparison
from .performance_report import machine_info
from .report import (EMPTY, HIT_CAUSES, Cell, Record, RunInfo, Summary, fixed, oracle_share, read_results, read_run,
                     summarize)
from .run_info import sha256_of

METHOD, RIVAL = "dqn_dovs", "s_dovs"
FAMILIES = ("room", "crowd", "corridor", "doorway", "clutter", "junction")
# What N counts in each family and where the robot goes (docs/simulator.md, "World families").
FAMILY_LAYOUTS = {
    "room": "The paper's 8 x 8 m room with N disc obstacles (85 % of them moving)",
    "crowd": "An 8 x 8 m room with N people; start and goal on opposite sides",
    "corridor": "A corridor 14 m long and 2-3 m wide with two-way traffic of N people; start and goal at the ends",
    "doorway": "Two 6 x 6 m rooms joined by a 0.9-1.2 m door, N people; start in one room, goal in the other",
    "clutter": "An 8 x 8 m room with 6-10 tables, shelves and chairs among N people; opposite sides",
    "junction": "An L or T junction of 2-3 m wide corridors with 7 m arms, N people; from one arm's end to another's",
}
COUNTS = (5, 10, 15)
SENSORS = ("sim", "hokuyo", "urg04lx", "rplidar_a1")
# The world of the sensor and people-model tables.
PROBE_WORLD, PROBE_N = "crowd", 10
RUN_INFO, PLOT = "run_info.json", "success_by_world.png"
# What the script leaves in a run folder when the tool stopped: its error.
FAILED = "failed.txt"
NOT_RUN = "not run"
DISCUSSION_BEGIN = "<!-- BEGIN {path}: hand-written, copied verbatim by worlds_report -->"
DISCUSSION_END = "<!-- END {path} -->"
# The oracle's unsolved episodes listed per run; the others are in the run's results.csv.
MAX_LISTED_EPISODES = 8


# ----------------------------------------------------------------------------------------------- run folders


@dataclass(frozen=True)
class RunSpec:
    """The run one folder must hold."""

    name: str  # the folder, under the runs folder
    world: str
    n: int
    sensor: str = "sim"
    people_model: str = "social_force"
    people_see_robot: bool = False

    def describe(self) -> str:
        sees = ", people give way to the robot" if self.people_see_robot else ""
        return f"{self.world}, N = {self.n}, LIDAR {self.sensor}, {self.people_model} people{sees}"


def family_spec(world: str, n: int) -> RunSpec:
    return RunSpec(f"{world}_n{n}", world, n)


def sensor_spec(sensor: str) -> RunSpec:
    if sensor == "sim":
        return family_spec(PROBE_WORLD, PROBE_N)
    return RunSpec(f"{PROBE_WORLD}_n{PROBE_N}_{sensor}", PROBE_WORLD, PROBE_N, sensor=sensor)


def people_specs() -> list[tuple[str, RunSpec]]:
    """The rows of the people-model table: a label and the run."""
    base = f"{PROBE_WORLD}_n{PROBE_N}"
    return [("social force, robot invisible to people", family_spec(PROBE_WORLD, PROBE_N)),
            ("reciprocal avoidance (ORCA), robot invisible to people",
             RunSpec(f"{base}_orca", PROBE_WORLD, PROBE_N, people_model="orca")),
            ("constant velocity, robot invisible to people",
             RunSpec(f"{base}_constant", PROBE_WORLD, PROBE_N, people_model="constant")),
            ("social force, people give way to the robot",
             RunSpec(f"{base}_see_robot", PROBE_WORLD, PROBE_N, people_see_robot=True))]


def all_specs() -> list[RunSpec]:
    """Every run of the report, each once, in the order the script runs them."""
    specs = [family_spec(w, n) for w in FAMILIES for n in COUNTS]
    specs += [sensor_spec(s) for s in SENSORS] + [spec for _, spec in people_specs()]
    return list(dict.fromkeys(specs))


@dataclass
class Run:
    """One run folder: its run.json and records, or, when the tool stopped, its error (no info, no records)."""

    spec: RunSpec
    info: RunInfo | None
    records: list[Record]
    error: str | None = None


def _check_setting(path: str, info: RunInfo, spec: RunSpec) -> None:
    """Raises ValueError naming run.json when it describes another run than `spec`."""
    expected = {"world": spec.world, "sensor": spec.sensor, "people_model": spec.people_model,
                "people_see_robot": spec.people_see_robot, "obstacles": f"{spec.n}-{spec.n}", "perfect_info": False}
    actual = {"world": info.world, "sensor": info.sensor, "people_model": info.people_model,
              "people_see_robot": info.people_see_robot, "obstacles": f"{info.obstacles_min}-{info.obstacles_max}",
              "perfect_info": info.perfect_info}
    wrong = [f"{key} {actual[key]!r} (expected {value!r})" for key, value in expected.items() if actual[key] != value]
    if wrong:
        raise ValueError(f"{path}: not the run of {spec.describe()}: {', '.join(wrong)}")


def load_run(runs_dir: str, spec: RunSpec) -> Run:
    """One run folder, or its error when it holds FAILED; raises ValueError naming the folder or file and what is
    missing or wrong."""
    folder = os.path.join(runs_dir, spec.name)
    if not os.path.isdir(folder):
        raise ValueError(f"{folder}: missing run folder (the run of {spec.describe()})")
    if os.path.isfile(os.path.join(folder, FAILED)):
        with open(os.path.join(folder, FAILED)) as f:
            return Run(spec, None, [], f.read().strip() or "no error recorded")
    missing = [f for f in ("results.csv", "run.json") if not os.path.isfile(os.path.join(folder, f))]
    if missing:
        raise ValueError(f"{folder}: missing {' and '.join(missing)} (the run of {spec.describe()})")
    run_json, results = os.path.join(folder, "run.json"), os.path.join(folder, "results.csv")
    info = read_run(run_json)
    _check_setting(run_json, info, spec)
    records = read_results(results)
    lacking = [m for m in (METHOD, RIVAL) if not any(r.method == m for r in records)]
    if lacking:
        raise ValueError(f"{results}: no episodes of {' and '.join(lacking)}")
    return Run(spec, info, records)


def load_runs(runs_dir: str) -> dict[str, Run]:
    """Every run of all_specs() by folder name; raises ValueError listing every missing or malformed one."""
    if not os.path.isdir(runs_dir):
        raise ValueError(f"{runs_dir}: no such folder (scripts/benchmark_worlds.sh writes it)")
    runs: dict[str, Run] = {}
    problems = []
    for spec in all_specs():
        try:
            runs[spec.name] = load_run(runs_dir, spec)
        except ValueError as e:
            problems.append(str(e))
    if problems:
        raise ValueError("\n".join(problems))
    return runs


# ----------------------------------------------------------------------------------------------- figures


@dataclass
class Comparison:
    """Both methods over some runs: report.summarize's cells per N and mean row (the oracle's too when the runs
    hold its episodes), the paired comparison of METHOD against RIVAL per N and pooled (key None), the counts whose
    run the tool stopped, with its error, and the oracle's unsolved episodes."""

    summary: Summary
    paired: dict[int | None, Paired]
    not_run: dict[int, str] = field(default_factory=dict)
    unsolved: list[Unsolved] = field(default_factory=list)

    def significant(self, n: int | None) -> bool:
        p = self.paired.get(n)
        return p is not None and p.p_value < SIGNIFICANCE

    def oracle_cell(self, n: int | None) -> Cell:
        """The oracle at `n` (None: over every N); an empty cell when it did not run."""
        if ORACLE not in self.summary.methods:
            return Cell()
        return self.summary.overall[ORACLE] if n is None else self.summary.cell(ORACLE, n)


def compare(runs: Sequence[Run]) -> Comparison:
    """Both methods over the runs that ran; empty cells (no episodes) when none did."""
    records = [r for run in runs for r in run.records]
    not_run = {run.spec.n: run.error for run in runs if run.error is not None}
    if not records:
        return Comparison(Summary([METHOD, RIVAL], [], METHOD, overall={METHOD: Cell(), RIVAL: Cell()}), {}, not_run)
    return Comparison(summarize(records, METHOD, (METHOD, RIVAL)), paired_comparison(records, METHOD, RIVAL),
                      not_run, oracle_unsolved(records))


def family_comparisons(runs: dict[str, Run]) -> dict[str, Comparison]:
    return {w: compare([runs[family_spec(w, n).name] for n in COUNTS]) for w in FAMILIES}


# ----------------------------------------------------------------------------------------------- Markdown


def markdown_table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    return "\n".join(lines + ["| " + " | ".join(row) + " |" for row in rows])


def p_text(p: float) -> str:
    """The sign test's p with two significant digits, bold when significant."""
    return f"**{p:.2g}**" if p < SIGNIFICANCE else f"{p:.2g}"


def method_cells(c: Cell) -> list[str]:
    """Success, collision and timeout rate and mean time on success; EMPTY without episodes."""
    if not c.episodes:
        return [EMPTY] * 4
    return [fixed(c.success_rate), fixed(c.collision_rate), fixed(c.timeout_rate), fixed(c.mean_time_success_s, 1)]


def paired_cells(p: Paired | None) -> list[str]:
    return [EMPTY, EMPTY] if p is None else [f"+{p.wins} / -{p.losses} of {p.episodes}", p_text(p.p_value)]


COMPARISON_COLUMNS = [f"`{METHOD}` success", "collision", "timeout", "time (s)", f"`{RIVAL}` success", "collision",
                      "timeout", "time (s)", "wins / losses", "p"]
COMPARISON_NOTE = (f"Rates over the episodes; time: mean time on success. Wins / losses: episodes `{METHOD}` solved "
                   f"and `{RIVAL}` did not, and the reverse, of the episodes both ran; p: the exact two-sided sign "
                   f"test on those discordant episodes, **bold** below {SIGNIFICANCE}.")


def comparison_row(label: str, c: Comparison, n: int | None) -> list[str]:
    """A row of the comparison tables: both methods at `n` (None: the mean row and the pooled pairs); NOT_RUN and
    empty cells when the run at `n` did not run."""
    if n in c.not_run:
        return [label, NOT_RUN] + [EMPTY] * (len(COMPARISON_COLUMNS) - 1)
    s = c.summary
    cells = [s.overall[m] if n is None else s.cell(m, n) for m in (METHOD, RIVAL)]
    return [label] + method_cells(cells[0]) + method_cells(cells[1]) + paired_cells(c.paired.get(n))


def all_label(c: Comparison) -> str:
    return "all N that ran" if c.not_run else "all N"


def family_table(c: Comparison) -> str:
    rows = [comparison_row(str(n), c, n) for n in COUNTS] + [comparison_row(all_label(c), c, None)]
    return markdown_table(["N"] + COMPARISON_COLUMNS, rows)


def summary_table(families: dict[str, Comparison]) -> str:
    """Family x N: both methods' success rates, a star where the paired difference is significant."""
    def cell(c: Comparison, n: int | None) -> str:
        if n in c.not_run:
            return NOT_RUN
        s = c.summary
        rates = [s.overall[m] if n is None else s.cell(m, n) for m in (METHOD, RIVAL)]
        return " / ".join(fixed(r.success_rate) for r in rates) + (" *" if c.significant(n) else "")

    rows = [[w] + [cell(c, n) for n in COUNTS] + [cell(c, None)] for w, c in families.items()]
    return markdown_table(["family"] + [f"N = {n}" for n in COUNTS] + ["all N"], rows)


def significant_lines(families: dict[str, Comparison]) -> list[str]:
    """One line per significant per-N or pooled difference, or one saying there is none."""
    lines = []
    for w, c in families.items():
        for n in list(COUNTS) + [None]:
            if c.significant(n):
                p = c.paired[n]
                better = METHOD if p.wins > p.losses else RIVAL
                where = "all N pooled" if n is None else f"N = {n}"
                lines.append(f"- {w}, {where}: `{better}` better (+{p.wins} / -{p.losses}, p = {p.p_value:.2g})")
    return lines or [f"- None: no family and N has a paired difference with p < {SIGNIFICANCE}."]


def not_run_lines(c: Comparison) -> list[str]:
    """The error of each run the tool stopped, then a blank line; nothing when every run ran."""
    if not c.not_run:
        return []
    return [f"N = {n} not run: {error}" for n, error in sorted(c.not_run.items())] + [""]


def probe_table(label: str, rows: Sequence[tuple[str, Comparison]]) -> str:
    return markdown_table([label] + COMPARISON_COLUMNS, [comparison_row(name, c, PROBE_N) for name, c in rows])


ORACLE_COLUMNS = ["world", "N", f"`{ORACLE}` success", f"`{METHOD}` share", f"`{RIVAL}` share", "unsolved",
                  "collisions (rest / moving / static)", "timeouts", "solved by a planner"]


def oracle_row(world: str, c: Comparison, n: int | None, n_label: str) -> list[str]:
    """A row of the oracle table: its success at `n` (None: the mean of the per-N rates, shares and counts pooled),
    both methods' shares of its successes and its unsolved episodes; NOT_RUN when the run or the oracle did not
    run."""
    o = c.oracle_cell(n)
    if n in c.not_run or not o.episodes:
        return [world, n_label, NOT_RUN] + [EMPTY] * (len(ORACLE_COLUMNS) - 3)
    unsolved = [u for u in c.unsolved if n is None or u.obstacles == n]
    crashes = [u for u in unsolved if u.outcome == "collision"]
    kinds = ("-" if any(u.collision_kind is None for u in crashes) else
             " / ".join(str(sum(u.collision_kind == k for u in crashes)) for k in ("rest", "moving", "static")))
    rescued = sum(any(m in (METHOD, RIVAL) for m in u.solved_by) for u in unsolved)
    return [world, n_label, fixed(o.success_rate), fixed(oracle_share(c.summary, METHOD, n)),
            fixed(oracle_share(c.summary, RIVAL, n)), f"{len(unsolved)} of {o.episodes}", kinds,
            str(len(unsolved) - len(crashes)), str(rescued)]


def oracle_table(families: dict[str, Comparison], probes: Sequence[tuple[str, Comparison]]) -> str:
    """Per family and N (and all N), then the probe runs at PROBE_N: the oracle's figures (oracle_row)."""
    rows = []
    for w, c in families.items():
        rows += [oracle_row(w, c, n, str(n)) for n in COUNTS] + [oracle_row(w, c, None, all_label(c))]
    rows += [oracle_row(label, c, PROBE_N, str(PROBE_N)) for label, c in probes]
    return markdown_table(ORACLE_COLUMNS, rows)


HIT_NOTE = ("Collisions with a moving body (the robot at rest or moving), counted by what the planner had been shown "
            "of the body that hit it (results.csv's `hit_cause`, docs/planners.md section 4): unseen at its last "
            "decision / late (shown then, not 1 s before the contact) / mispredicted (shown 1 s before, its motion "
            "as shown then more than 0.3 m from where it was at the contact) / foreseen (within 0.3 m); `-`: runs "
            "written before the column.")


def hits_row(label: str, n_label: str, c: Comparison, n: int | None) -> list[str]:
    """Both methods' collisions with moving bodies by cause at `n` (None: every N pooled)."""
    def text(method: str) -> str:
        cell = c.summary.overall.get(method, Cell()) if n is None else c.summary.cell(method, n)
        if not cell.episodes:
            return NOT_RUN
        if cell.hits_by_cause is None:
            return "-"
        return " / ".join(str(cell.hits_by_cause[k]) for k in HIT_CAUSES)
    return [label, n_label, text(METHOD), text(RIVAL)]


def hits_section(families: dict[str, Comparison], probes: Sequence[tuple[str, Comparison]]) -> list[str]:
    """Per family with people (every N pooled), then the probe runs: what the planners knew of what hit them."""
    header = ["world", "N", f"`{METHOD}` unseen / late / mispredicted / foreseen",
              f"`{RIVAL}` unseen / late / mispredicted / foreseen"]
    rows = [hits_row(w, all_label(c), c, None) for w, c in families.items()]
    rows += [hits_row(label, str(PROBE_N), c, PROBE_N) for label, c in probes]
    return ["## What the planners knew of what hit them", "", HIT_NOTE, "", markdown_table(header, rows), ""]


def episode_text(u: Unsolved) -> str:
    """An unsolved episode in the list: "7 (timeout; solved by s_dovs)"."""
    solved = [m for m in u.solved_by if m != ORACLE]
    return f"{u.episode} ({u.outcome_text()}" + (f"; solved by {', '.join(solved)})" if solved else ")")


def unsolved_table(runs: dict[str, Run], runs_dir: str) -> str | None:
    """One row per run whose oracle did not solve every episode: how many, and the first MAX_LISTED_EPISODES with
    their outcome (and the planners that solved them), the rest pointed to in the run's results.csv; None when no
    run has an unsolved oracle episode."""
    rows = []
    for name, run in runs.items():
        unsolved = oracle_unsolved(run.records)
        if not unsolved:
            continue
        ran = sum(r.method == ORACLE for r in run.records)
        listed = ", ".join(episode_text(u) for u in unsolved[:MAX_LISTED_EPISODES])
        if len(unsolved) > MAX_LISTED_EPISODES:
            listed += (f"; {len(unsolved) - MAX_LISTED_EPISODES} more in "
                       f"`{os.path.join(runs_dir, name, 'results.csv')}`")
        rows.append([f"`{name}`", f"{len(unsolved)} of {ran}", listed])
    return markdown_table(["run", "unsolved", "episodes (outcome)"], rows) if rows else None


def oracle_section(runs: dict[str, Run], families: dict[str, Comparison], probes: Sequence[tuple[str, Comparison]],
                   runs_dir: str) -> list[str]:
    """The oracle's section: its table and its unsolved episodes, or NOT_RUN when no run holds its episodes."""
    out = ["## The oracle: the physical limit", ""]
    if not any(r.method == ORACLE for run in runs.values() for r in run.records):
        return out + [f"Not run: no run folder holds `{ORACLE}` episodes (`ORACLE=0`, or runs from before the "
                      "oracle was in this benchmark).", ""]
    out += [f"`{ORACLE}` (docs/planners.md section 9) searches the robot's commands knowing the people's future "
            "(they ignore the robot, so it is fixed by the seed): not deployable, a ceiling and never a baseline. "
            f"Share: a planner's successes over the oracle's on the same episodes (above 1 where the planner solves "
            "episodes the oracle does not: the search is a lower bound of the limit). Unsolved: the oracle's "
            "collisions (robot at rest / moving / static geometry) and timeouts, unavoidable as far as its search "
            f"tells; `solved by a planner`: those `{METHOD}` or `{RIVAL}` solved all the same. `all N` averages the "
            "per-N success rates and pools the shares and counts. The probe runs are crowd, N = "
            f"{PROBE_N} (the sim LIDAR and social-force rows are the family's).", "",
            oracle_table(families, probes), "", "### Episodes the oracle did not solve", ""]
    table = unsolved_table(runs, runs_dir)
    if table is None:
        return out + ["None: the oracle solved every episode of every run.", ""]
    return out + [f"Per run (episodes in order, the first {MAX_LISTED_EPISODES}; every one: the `{ORACLE}` rows of "
                  "the run's results.csv whose outcome is not success). Runs not listed: the oracle solved every "
                  "episode, or did not run.", "", table, ""]


# ----------------------------------------------------------------------------------------------- how it was made


def record_run_info(runs_dir: str, commit: str, model: str, total_wall_s: float,
                    now: datetime.datetime | None = None) -> dict:
    """Writes RUNS/run_info.json: date (UTC), commit, model and its sha256, the machine, total wall time."""
    machine = machine_info()
    now = now or datetime.datetime.now(datetime.timezone.utc)
    info = {"date": now.strftime("%Y-%m-%d %H:%M UTC"), "commit": commit, "model": model,
            "model_sha256": sha256_of(model), "nproc": machine["nproc"], "cpu_model": machine["cpu_model"],
            "total_wall_s": float(total_wall_s)}
    with open(os.path.join(runs_dir, RUN_INFO), "w") as f:
        json.dump(info, f, indent=2)
        f.write("\n")
    return info


def read_run_info(runs_dir: str) -> dict | None:
    path = os.path.join(runs_dir, RUN_INFO)
    if not os.path.isfile(path):
        return None
    with open(path) as f:
        try:
            return json.load(f)
        except json.JSONDecodeError as e:
            raise ValueError(f"{path}: not valid JSON ({e})") from None


def _joined(values: Sequence[object]) -> str:
    return ", ".join(str(v) for v in sorted(set(values)))


def predictions(infos: Sequence[RunInfo]) -> str:
    """Which learned people prediction the planners saw, and in which worlds: "`F` (crowd, ...); none (room)"."""
    worlds: dict[str, set[str]] = {}
    for i in infos:
        worlds.setdefault(i.people_predictor, set()).add(i.world)
    parts = [f"{f'`{p}`' if p else 'none'} ({_joined(w)})" for p, w in sorted(worlds.items(), key=lambda kv: kv[0] == "")]
    return "; ".join(parts) if parts else "none"


def how_made(runs: dict[str, Run], run_info: dict | None, runs_dir: str) -> list[str]:
    """The section on how the runs were made: the record, the setting, each run's command and wall time."""
    out = ["## How this was made", ""]
    if run_info:
        out += [f"- Date: {run_info.get('date', '?')}; commit `{run_info.get('commit', '?')}`; model "
                f"`{run_info.get('model', '?')}` (sha256 `{str(run_info.get('model_sha256', '?'))[:16]}`)",
                f"- Machine: {run_info.get('nproc', '?')} CPU(s) (`nproc`), {run_info.get('cpu_model', '?')}",
                f"- Wall time of the whole script (every evaluation and its summary): "
                f"{fixed(run_info.get('total_wall_s', math.nan), 1)} s"]
    else:
        out.append(f"- Run information not recorded ({os.path.join(runs_dir, RUN_INFO)} is missing)")
    infos = [r.info for r in runs.values() if r.info is not None]
    out += [f"- Generated episodes, seed {_joined([i.seed for i in infos])} (the seed of this report, not used to "
            f"tune anything); {_joined([i.episodes for i in infos])} episodes per run and method, the same episodes "
            f"for every method; LIDAR + tracker in the loop; step {_joined([i.step_s for i in infos])} s, "
            f"limit {_joined([i.max_steps for i in infos])} steps",
            f"- People prediction the planners saw: {predictions(infos)}",
            "- Regenerate: `make benchmark-worlds` (EPISODES=K for a shorter run)", "",
            "The runs (`wall`: the evaluation's own wall time, from run.json; a run the tool stopped shows its "
            "error):", ""]
    rows = [[f"`{name}`", f"{NOT_RUN}: {r.error}", EMPTY] if r.info is None else
            [f"`{name}`", f"`{r.info.command}`", f"{r.info.wall_s:.1f}"] for name, r in runs.items()]
    return out + [markdown_table(["run", "command", "wall (s)"], rows), ""]


# ----------------------------------------------------------------------------------------------- plot


def plot_success_by_world(families: dict[str, Comparison], path: str) -> Figure:
    """Success against N, a panel per family with both methods, a star over each N with a significant paired
    difference, NOT_RUN where the tool stopped; the legend inside the figure below the panels. Writes the PNG and
    returns the figure."""
    fig = Figure(figsize=(11.0, 7.0), dpi=100, layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(2, math.ceil(len(families) / 2), sharex=True, sharey=True, squeeze=False)
    for ax, (world, c) in zip(axes.flat, families.items()):
        for m in (METHOD, RIVAL):
            ax.plot(COUNTS, [c.summary.cell(m, n).success_rate for n in COUNTS], marker="o", ms=4, label=m)
        if c.oracle_cell(None).episodes:
            ax.plot(COUNTS, [c.oracle_cell(n).success_rate for n in COUNTS], marker="o", ms=4, color="k", ls=":",
                    label=ORACLE)
        for n in COUNTS:
            if c.significant(n):
                ax.annotate("*", (n, 1.0), ha="center", fontsize=14)
            if n in c.not_run:
                ax.annotate(NOT_RUN, (n, 0.5), ha="center", rotation=90, color="0.4")
        ax.set_title(world)
        ax.set_xticks(COUNTS)
        ax.set_ylim(-0.03, 1.1)
        ax.grid(alpha=0.3)
    for ax in axes[-1]:
        ax.set_xlabel("N (people; disc obstacles in room)")
    for ax in axes[:, 0]:
        ax.set_ylabel("success rate")
    legend = {}
    for ax in axes.flat:  # the oracle may be in some panels only
        for handle, label in zip(*ax.get_legend_handles_labels()):
            legend.setdefault(label, handle)
    fig.legend(list(legend.values()), list(legend), loc="outside lower center", ncol=len(legend),
               title=f"method (*: paired sign test p < {SIGNIFICANCE})")
    fig.suptitle("Success rate vs N per world family (LIDAR + tracker in the loop)")
    fig.savefig(path)
    return fig


# ----------------------------------------------------------------------------------------------- document


def discussion_section(discussion_path: str) -> list[str]:
    """The marked place of the hand-written discussion, with the file verbatim when it exists."""
    out = ["## What this shows", "", DISCUSSION_BEGIN.format(path=discussion_path)]
    if os.path.isfile(discussion_path):
        with open(discussion_path) as f:
            out.append(f.read().rstrip("\n"))
    else:
        out.append(f"({discussion_path} does not exist yet.)")
    return out + [DISCUSSION_END.format(path=discussion_path), ""]


def render(runs: dict[str, Run], run_info: dict | None, runs_dir: str, plot_rel: str, discussion_path: str) -> str:
    families = family_comparisons(runs)
    out = ["# Benchmark: DQN-DOVS and S-DOVS across world families, LIDAR profiles and people models", "",
           "Generated by `make benchmark-worlds` (scripts/benchmark_worlds.sh, python/dqn_dovs_py/worlds_report.py);"
           f" do not edit by hand except `{discussion_path}`, included below.", ""]
    out += how_made(runs, run_info, runs_dir)
    out += ["## Summary", "",
            f"Success rate `{METHOD}` / `{RIVAL}` per family and N (`all N`: the mean of the rates of the N that ran); "
            f"*: the paired sign test on the same episodes gives p < {SIGNIFICANCE} (per N, or pooled over N).", "",
            summary_table(families), "", "Significant paired differences:", ""]
    out += significant_lines(families) + ["", f"![Success rate vs N per family]({plot_rel})", ""]
    out += discussion_section(discussion_path)
    sensors = [(f"`{s}`", compare([runs[sensor_spec(s).name]])) for s in SENSORS]
    people = [(label, compare([runs[spec.name]])) for label, spec in people_specs()]
    probes = [(f"{PROBE_WORLD}, LIDAR {s}", c) for s, c in zip(SENSORS, (c for _, c in sensors)) if s != "sim"]
    probes += [(f"{PROBE_WORLD}, {label}", c) for label, c in people[1:]]
    out += oracle_section(runs, families, probes, runs_dir)
    out += hits_section(families, probes)
    out += ["## Per family", "", "LIDAR profile sim, social-force people to whom the robot is invisible. "
            + COMPARISON_NOTE + " The `all N` row averages the per-N rates and pools the pairs.", ""]
    for w, c in families.items():
        out += [f"### {w}", "", FAMILY_LAYOUTS[w] + ".", "", family_table(c), ""] + not_run_lines(c)
    out += ["## LIDAR profiles", "", f"{PROBE_WORLD}, N = {PROBE_N}, social-force people; the LIDAR profiles of "
            "docs/simulator.md (`sim` is the run of the family table). " + COMPARISON_NOTE, "",
            probe_table("profile", sensors), ""]
    out += ["## People models", "", f"{PROBE_WORLD}, N = {PROBE_N}, LIDAR profile sim (the first row is the run of "
            "the family table). " + COMPARISON_NOTE, "", probe_table("people", people), ""]
    return "\n".join(out)


def write_report(runs_dir: str, out: str, discussion_path: str) -> list[str]:
    """Reads every run folder, writes the plot and the Markdown file; returns the files written. Raises ValueError
    naming each missing or malformed run."""
    runs = load_runs(runs_dir)
    run_info = read_run_info(runs_dir)
    plot = os.path.join(runs_dir, PLOT)
    plot_success_by_world(family_comparisons(runs), plot)
    plot_rel = os.path.relpath(plot, os.path.dirname(os.path.abspath(out)))
    with open(out, "w") as f:
        f.write(render(runs, run_info, runs_dir, plot_rel, discussion_path))
    return [plot, out]


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m dqn_dovs_py.worlds_report", description=__doc__.splitlines()[0])
    p.add_argument("--runs", default="docs/benchmark_worlds", help="folder of the run folders")
    p.add_argument("--out", default="docs/benchmark_worlds.md")
    p.add_argument("--discussion", default="docs/benchmark_worlds_discussion.md")
    p.add_argument("--commit", help="with --model and --total-wall: write RUNS/run_info.json first")
    p.add_argument("--model")
    p.add_argument("--total-wall", type=float, metavar="SECONDS")
    a = p.parse_args(argv)
    record = (a.commit, a.model, a.total_wall)
    if any(v is not None for v in record) and not all(v is not None for v in record):
        p.error("--commit, --model and --total-wall go together")
    try:
        if a.commit is not None:
            record_run_info(a.runs, a.commit, a.model, a.total_wall)
        written = write_report(a.runs, a.out, a.discussion)
    except (OSError, ValueError) as e:
        print(f"worlds_report: {e}", file=sys.stderr)
        return 1
    for path in written:
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
