"""docs/benchmark_worlds.md: every planner and the oracle across the building families under three protocols of how
people treat the robot, from the run folders scripts/benchmark_worlds.sh (make benchmark-worlds) writes.

    python -m dqn_dovs_py.worlds_report --runs results/benchmark_worlds --out docs/benchmark_worlds.md

The runs folder holds one folder per protocol (PROTOCOLS: headline, oblivious, attentive) and in it one folder per
family and N (FAMILY_nN, FAMILIES x COUNTS), each one dqn_dovs_eval run of the planners (PLANNERS) and, unless the
script ran with ORACLE=0, the oracle, on the same episodes (results.csv, run.json). A protocol folder that is absent
is reported as not run; a run folder with failed.txt is shown as not run with its error.

The report gives, per protocol: success and robot-at-fault rate per family and planner (N pooled), success per
family and N, the paired comparison of DQN-DOVS with each baseline on the same episodes (exact two-sided sign test;
the oblivious stress test is judged on robot-at-fault contacts), the oracle's success per family and N, and the
comfort, cost-to-others and efficiency figures per planner. One figure, RUNS/success_and_fault.png: success and
robot-at-fault rate per family, the planners side by side, one row per protocol.

With --commit, --model and --total-wall (the script's record of the run) it first writes RUNS/run_info.json (date,
commit, model and its sha256, machine, total wall time, episodes and seed); without them it reads the one there. The
hand-written discussion file is copied verbatim between the markers of the "What this shows" section.
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import os
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from .benchmark_report import ORACLE, SIGNIFICANCE, Paired, sign_test_p
from .performance_report import machine_info
from .report import Record, RunInfo, fixed, nan_mean, read_results, read_run
from .run_info import sha256_of

METHOD = "dqn_dovs"
PLANNERS = ("dqn_dovs", "s_dovs", "orca_diffdrive", "dwa")
PLANNER_LABELS = {"dqn_dovs": "DQN-DOVS", "s_dovs": "S-DOVS", "orca_diffdrive": "ORCA (diff-drive)", "dwa": "DWA",
                  ORACLE: "oracle"}
FAMILIES = ("crowd", "corridor", "doorway", "clutter", "junction")
COUNTS = (4, 8, 12)
# The oracle's target: the share of a family's episodes at ORACLE_TARGET_N people it must solve at the headline mix.
ORACLE_TARGET, ORACLE_TARGET_N = 0.95, 8


@dataclass(frozen=True)
class Protocol:
    name: str  # the folder under the runs folder
    title: str
    mix: str  # run.json's people_mix
    judged_on: str  # "success" or "fault": what the paired comparison counts
    text: str


PROTOCOLS = (
    Protocol("headline", "Headline mix (the main table)", "attentive=0.7,impassive=0.2,oblivious=0.1", "success",
             "`--people-mix headline`: seven in ten people notice the robot and give way, two in ten walk around it "
             "without giving way, one in ten never sees it (docs/simulator.md, \"The headline mix\")."),
    Protocol("oblivious", "Oblivious stress test", "oblivious=1", "fault",
             "`--people-mix oblivious=1`: nobody sees the robot. Success is bounded by what no sensor can know, so "
             "the planners are judged on the contacts they cause: the robot-at-fault rate and the passive-safety "
             "rate (1 - robot-at-fault rate); the paired test counts episodes without a robot-at-fault contact."),
    Protocol("attentive", "All attentive", "attentive=1", "success",
             "`--people-mix attentive=1`: everybody notices the robot and gives way to it."),
)
FAMILY_LAYOUTS = {
    "crowd": "an 8 x 8 m room; start and goal on opposite sides",
    "corridor": "14 m long, 2-3 m wide, two-way traffic keeping right; start and goal at the ends",
    "doorway": "two 6 x 6 m rooms joined by a 0.9-1.2 m door passed one at a time; from one room to the other",
    "clutter": "an 8 x 8 m room with 6-10 tables, shelves and chairs; opposite sides",
    "junction": "an L or T junction of 2-3 m corridors with 7 m arms, keeping right; from one arm's end to another's",
}
RUN_INFO, PLOT = "run_info.json", "success_and_fault.png"
FAILED = "failed.txt"
NOT_RUN = "not run"
DISCUSSION_BEGIN = "<!-- BEGIN {path}: hand-written, copied verbatim by worlds_report -->"
DISCUSSION_END = "<!-- END {path} -->"


# ----------------------------------------------------------------------------------------------- run folders


@dataclass
class Run:
    """One run folder: its run.json and records, or why it has none (the tool's error, or not run)."""

    protocol: str
    family: str
    n: int
    info: RunInfo | None
    records: list[Record]
    error: str | None = None


def run_name(family: str, n: int) -> str:
    return f"{family}_n{n}"


def load_run(runs_dir: str, protocol: Protocol, family: str, n: int) -> Run:
    """One run folder; a missing protocol folder gives a run that was not run. Raises ValueError naming the folder
    or file when a run folder is missing or describes another run."""
    base = os.path.join(runs_dir, protocol.name)
    if not os.path.isdir(base):
        return Run(protocol.name, family, n, None, [], NOT_RUN)
    folder = os.path.join(base, run_name(family, n))
    if not os.path.isdir(folder):
        raise ValueError(f"{folder}: missing run folder ({family}, N = {n}, protocol {protocol.name})")
    if os.path.isfile(os.path.join(folder, FAILED)):
        with open(os.path.join(folder, FAILED)) as f:
            return Run(protocol.name, family, n, None, [], f.read().strip() or "no error recorded")
    run_json = os.path.join(folder, "run.json")
    info = read_run(run_json)
    wrong = []
    if info.world != family:
        wrong.append(f"world {info.world!r} (expected {family!r})")
    if (info.obstacles_min, info.obstacles_max) != (n, n):
        wrong.append(f"obstacles {info.obstacles_min}-{info.obstacles_max} (expected {n}-{n})")
    if info.people_mix != protocol.mix:
        wrong.append(f"people_mix {info.people_mix!r} (expected {protocol.mix!r})")
    if wrong:
        raise ValueError(f"{run_json}: not the run of {family}, N = {n}, protocol {protocol.name}: {', '.join(wrong)}")
    records = read_results(os.path.join(folder, "results.csv"))
    if not any(r.method == METHOD for r in records):
        raise ValueError(f"{os.path.join(folder, 'results.csv')}: no episodes of {METHOD}")
    return Run(protocol.name, family, n, info, records)


def load_runs(runs_dir: str) -> dict[tuple[str, str, int], Run]:
    """Every run by (protocol, family, N); raises ValueError listing every missing or malformed one."""
    if not os.path.isdir(runs_dir):
        raise ValueError(f"{runs_dir}: no such folder (scripts/benchmark_worlds.sh writes it)")
    runs, problems = {}, []
    for p in PROTOCOLS:
        for family in FAMILIES:
            for n in COUNTS:
                try:
                    runs[(p.name, family, n)] = load_run(runs_dir, p, family, n)
                except ValueError as e:
                    problems.append(str(e))
    if problems:
        raise ValueError("\n".join(problems))
    if all(r.error == NOT_RUN for r in runs.values()):
        raise ValueError(f"{runs_dir}: none of the protocol folders ({', '.join(p.name for p in PROTOCOLS)})")
    return runs


# ----------------------------------------------------------------------------------------------- figures


def of(records: Sequence[Record], method: str) -> list[Record]:
    return [r for r in records if r.method == method]


def success_rate(records: Sequence[Record]) -> float:
    return sum(r.outcome == "success" for r in records) / len(records) if records else math.nan


def at_fault(r: Record) -> bool:
    """A collision with the robot at fault (results.csv's at_fault)."""
    return r.outcome == "collision" and bool(r.at_fault)


def fault_rate(records: Sequence[Record]) -> float:
    return sum(at_fault(r) for r in records) / len(records) if records else math.nan


def paired(records: Sequence[Record], method: str, rival: str, good: Callable[[Record], bool]) -> Paired:
    """`method` against `rival` on the episodes both ran (matched by scenario, N and episode, so that records pooled
    over families pair up within each): episodes good for one and not for the other, and the exact two-sided sign
    test."""
    mine = {(r.scenario, r.obstacles, r.episode): good(r) for r in records if r.method == method}
    theirs = {(r.scenario, r.obstacles, r.episode): good(r) for r in records if r.method == rival}
    p = Paired()
    for key, ok in mine.items():
        if key not in theirs:
            continue
        p.episodes += 1
        p.wins += ok and not theirs[key]
        p.losses += theirs[key] and not ok
    p.p_value = sign_test_p(p.wins, p.losses)
    return p


def good_of(protocol: Protocol) -> Callable[[Record], bool]:
    return (lambda r: not at_fault(r)) if protocol.judged_on == "fault" else (lambda r: r.outcome == "success")


def pooled(runs: dict[tuple[str, str, int], Run], protocol: str, family: str | None = None) -> list[Record]:
    """The records of a protocol (one family, or every family), every N."""
    return [r for (p, f, _), run in runs.items() if p == protocol and (family is None or f == family)
            for r in run.records]


# ----------------------------------------------------------------------------------------------- document


def markdown_table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    return "\n".join(lines + ["| " + " | ".join(row) + " |" for row in rows])


def methods_of(runs: dict[tuple[str, str, int], Run], protocol: str) -> list[str]:
    present = {r.method for run in runs.values() if run.protocol == protocol for r in run.records}
    return [m for m in PLANNERS + (ORACLE,) if m in present]


def p_text(p: Paired) -> str:
    star = " *" if p.p_value < SIGNIFICANCE else ""
    return f"+{p.wins} / -{p.losses}, p = {p.p_value:.2g}{star}" if p.episodes else "-"


def family_table(runs: dict, protocol: Protocol, methods: Sequence[str]) -> str:
    """Per family (N pooled): success / robot-at-fault rate of each method."""
    rows = []
    for family in FAMILIES + (None,):
        records = pooled(runs, protocol.name, family)
        rows.append([family or "**all**"] + [f"{fixed(success_rate(of(records, m)))} / "
                                            f"{fixed(fault_rate(of(records, m)))}" for m in methods])
    return markdown_table(["family"] + [PLANNER_LABELS[m] for m in methods], rows)


def per_n_table(runs: dict, protocol: Protocol, methods: Sequence[str]) -> str:
    rows = []
    for family in FAMILIES:
        for n in COUNTS:
            run = runs[(protocol.name, family, n)]
            if run.error:
                rows.append([family, str(n)] + [f"{NOT_RUN}: {run.error}"] + [""] * (len(methods) - 1))
                continue
            rows.append([family, str(n)] + [fixed(success_rate(of(run.records, m))) for m in methods])
    return markdown_table(["family", "N"] + [PLANNER_LABELS[m] for m in methods], rows)


def paired_table(runs: dict, protocol: Protocol, methods: Sequence[str]) -> str:
    rivals = [m for m in methods if m not in (METHOD, ORACLE)]
    good = good_of(protocol)
    rows = [[family or "**all**"] + [p_text(paired(pooled(runs, protocol.name, family), METHOD, r, good))
                                     for r in rivals] for family in FAMILIES + (None,)]
    return markdown_table(["family"] + [f"DQN-DOVS vs {PLANNER_LABELS[r]}" for r in rivals], rows)


def oracle_table(runs: dict, protocol: Protocol) -> str:
    rows = []
    for family in FAMILIES:
        cells = []
        for n in COUNTS:
            o = of(runs[(protocol.name, family, n)].records, ORACLE)
            cells.append(fixed(success_rate(o)) if o else NOT_RUN)
        rows.append([family] + cells)
    return markdown_table(["family"] + [f"N = {n}" for n in COUNTS], rows)


def oracle_short(runs: dict, protocol: Protocol) -> list[str]:
    """The families where the oracle solves fewer than ORACLE_TARGET of the episodes at ORACLE_TARGET_N."""
    out = []
    for family in FAMILIES:
        run = runs.get((protocol.name, family, ORACLE_TARGET_N))
        o = of(run.records, ORACLE) if run else []
        if o and success_rate(o) < ORACLE_TARGET:
            out.append(f"{family} ({fixed(success_rate(o))})")
    return out


COST_FIELDS = (("intimate_s", "intimate (s)"), ("personal_s", "personal (s)"), ("blocking_s", "blocking (s)"),
               ("delay_s", "delay to others (s)"), ("time_ratio", "time / route at v_max"),
               ("path_irregularity", "irregularity (rad/m)"))


def cost_table(runs: dict, protocol: Protocol, methods: Sequence[str]) -> str:
    records = pooled(runs, protocol.name)
    rows = [[PLANNER_LABELS[m]] + [fixed(nan_mean(getattr(r, f) for r in of(records, m)), 1 if f == "delay_s" else 2)
                                   for f, _ in COST_FIELDS] for m in methods]
    return markdown_table(["method"] + [label for _, label in COST_FIELDS], rows)


def protocol_section(runs: dict, protocol: Protocol) -> list[str]:
    out = [f"## {protocol.title}", "", protocol.text, ""]
    if all(runs[(protocol.name, f, n)].error == NOT_RUN for f in FAMILIES for n in COUNTS):
        return out + [f"{NOT_RUN}.", ""]
    methods = methods_of(runs, protocol.name)
    judged = "without a robot-at-fault contact" if protocol.judged_on == "fault" else "reaching the goal"
    out += ["Success / robot-at-fault rate per family, N = 4, 8 and 12 pooled (robot at fault: any static contact, a "
            "contact with the robot moving at 0.05 m/s or more, or at rest for less than 0.5 s before it):", "",
            family_table(runs, protocol, methods), "",
            f"DQN-DOVS against each baseline on the same episodes, counting episodes {judged}: +episodes only "
            f"DQN-DOVS / -episodes only the baseline, exact two-sided sign test (*: p < {SIGNIFICANCE}):", "",
            paired_table(runs, protocol, methods), ""]
    if ORACLE in methods:
        short = oracle_short(runs, protocol)
        verdict = (f"short of {ORACLE_TARGET:.2f} at N = {ORACLE_TARGET_N}: {', '.join(short)}" if short else
                   f"at least {ORACLE_TARGET:.2f} of every family at N = {ORACLE_TARGET_N}")
        out += [f"The oracle (a search that steps the true simulator, people's reactions included): {verdict}.", "",
                oracle_table(runs, protocol), ""]
    out += ["Comfort, cost to others and efficiency, means per episode over every family and N: time with a person "
            "within 0.45 m / 1.2 m while the robot moves; time standing in a door or a corridor's middle third while "
            "someone who reacts to it waits or detours; the delay caused to the attentive people who noticed it "
            "(against the same people without the robot; noisy per episode); time to the goal over the route length "
            "at v_max (successes); turning per metre.", "", cost_table(runs, protocol, methods), "",
            "Success per family and N:", "", per_n_table(runs, protocol, methods), ""]
    return out


def plot_success_and_fault(runs: dict, path: str) -> Figure:
    """Success and robot-at-fault rate per family, the planners side by side, one row per protocol that ran."""
    shown = [p for p in PROTOCOLS if any(runs[(p.name, f, n)].records for f in FAMILIES for n in COUNTS)]
    fig = Figure(figsize=(12, 3.2 * max(1, len(shown))))
    FigureCanvasAgg(fig)
    axes = fig.subplots(max(1, len(shown)), 2, squeeze=False)
    for row, protocol in enumerate(shown):
        methods = methods_of(runs, protocol.name)
        width = 0.8 / max(1, len(methods))
        for col, (rate, label) in enumerate(((success_rate, "success rate"), (fault_rate, "robot-at-fault rate"))):
            ax = axes[row][col]
            for k, m in enumerate(methods):
                values = [rate(of(pooled(runs, protocol.name, f), m)) for f in FAMILIES]
                ax.bar([i + (k - (len(methods) - 1) / 2) * width for i in range(len(FAMILIES))],
                       [0.0 if math.isnan(v) else v for v in values], width, label=PLANNER_LABELS[m])
            ax.set_xticks(range(len(FAMILIES)))
            ax.set_xticklabels(FAMILIES)
            ax.set_ylim(0.0, 1.0)
            ax.set_ylabel(label)
            ax.set_title(f"{protocol.title}: {label}", fontsize=10)
            ax.grid(axis="y", alpha=0.3)
    if shown:
        axes[0][0].legend(fontsize=8, ncol=3, loc="lower left")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    return fig


def record_run_info(runs_dir: str, commit: str, model: str, total_wall_s: float, episodes: int | None = None,
                    seed: int | None = None, now: datetime.datetime | None = None) -> dict:
    """Writes RUNS/run_info.json: date (UTC), commit, model and its sha256, the machine, total wall time."""
    machine = machine_info()
    now = now or datetime.datetime.now(datetime.timezone.utc)
    info = {"date": now.strftime("%Y-%m-%d %H:%M UTC"), "commit": commit, "model": model,
            "model_sha256": sha256_of(model), "nproc": machine["nproc"], "cpu_model": machine["cpu_model"],
            "total_wall_s": float(total_wall_s), "episodes": episodes, "seed": seed}
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


def how_made(runs: dict, run_info: dict | None) -> list[str]:
    out = ["## How this was made", ""]
    if run_info:
        out += [f"- Date: {run_info.get('date', '?')}; commit `{run_info.get('commit', '?')}`; model "
                f"`{run_info.get('model', '?')}` (sha256 `{str(run_info.get('model_sha256', '?'))[:16]}`)",
                f"- Machine: {run_info.get('nproc', '?')} CPU(s), {run_info.get('cpu_model', '?')}; wall time of the "
                f"whole script: {float(run_info.get('total_wall_s', math.nan)):.0f} s"]
    infos = [run.info for run in runs.values() if run.info is not None]
    if infos:
        i = infos[0]
        predictor = f"`{i.people_predictor}`" if i.people_predictor else "none"
        out += [f"- Generated episodes, seed {i.seed} (the seed of this report, never used to tune anything); "
                f"{i.episodes} episodes per family, N and method, the same episodes for every method; LIDAR "
                f"({i.sensor}) + tracker in the loop; people prediction the planners saw: {predictor}; step "
                f"{i.step_s} s, limit {i.max_steps} steps",
                f"- One run, for example: `{i.command}`"]
    out += ["- Regenerate: `make benchmark-worlds` (EPISODES=K, PROTOCOLS='headline', ORACLE=0 for less)", ""]
    return out


def discussion_section(discussion_path: str) -> list[str]:
    out = ["## What this shows", "", DISCUSSION_BEGIN.format(path=discussion_path)]
    if os.path.isfile(discussion_path):
        with open(discussion_path) as f:
            out.append(f.read().rstrip("\n"))
    else:
        out.append(f"({discussion_path} does not exist yet.)")
    return out + [DISCUSSION_END.format(path=discussion_path), ""]


def render(runs: dict, run_info: dict | None, plot_rel: str, discussion_path: str) -> str:
    out = ["# Benchmark: the planners among people who notice the robot, and among people who do not", "",
           "Generated by `make benchmark-worlds` (scripts/benchmark_worlds.sh, python/dqn_dovs_py/worlds_report.py);"
           f" do not edit by hand except `{discussion_path}`, included below.", "",
           "Families (docs/simulator.md, \"World families\"), N people each:", ""]
    out += [f"- `{f}`: {FAMILY_LAYOUTS[f]}" for f in FAMILIES] + [""]
    out += how_made(runs, run_info)
    out += [f"![Success and robot-at-fault rate per family and protocol]({plot_rel})", ""]
    out += discussion_section(discussion_path)
    for protocol in PROTOCOLS:
        out += protocol_section(runs, protocol)
    return "\n".join(out)


def write_report(runs_dir: str, out: str, discussion_path: str) -> list[str]:
    runs = load_runs(runs_dir)
    plot = os.path.join(runs_dir, PLOT)
    plot_success_and_fault(runs, plot)
    plot_rel = os.path.relpath(plot, os.path.dirname(os.path.abspath(out)))
    with open(out, "w") as f:
        f.write(render(runs, read_run_info(runs_dir), plot_rel, discussion_path))
    return [plot, out]


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m dqn_dovs_py.worlds_report", description=__doc__.splitlines()[0])
    p.add_argument("--runs", default="results/benchmark_worlds", help="folder of the protocol folders")
    p.add_argument("--out", default="docs/benchmark_worlds.md")
    p.add_argument("--discussion", default="docs/benchmark_worlds_discussion.md")
    p.add_argument("--commit", help="with --model and --total-wall: write RUNS/run_info.json first")
    p.add_argument("--model")
    p.add_argument("--total-wall", type=float, metavar="SECONDS")
    p.add_argument("--episodes", type=int)
    p.add_argument("--seed", type=int)
    a = p.parse_args(argv)
    record = (a.commit, a.model, a.total_wall)
    if any(v is not None for v in record) and not all(v is not None for v in record):
        p.error("--commit, --model and --total-wall go together")
    try:
        if a.commit is not None:
            record_run_info(a.runs, a.commit, a.model, a.total_wall, a.episodes, a.seed)
        written = write_report(a.runs, a.out, a.discussion)
    except (OSError, ValueError) as e:
        print(f"worlds_report: {e}", file=sys.stderr)
        return 1
    for path in written:
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
