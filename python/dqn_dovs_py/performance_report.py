"""docs/performance.md from the benchmark results: `python -m dqn_dovs_py.performance_report`.

Reads bench/results/NAME.json (written by `make bench-NAME`, scripts/bench.sh) and bench/results/NAME.rss_kb
(the benchmark process's peak resident memory in KiB, measured by scripts/bench.sh with GNU time) and writes
per-stage latency (tracker, DOVS build, Q-network inference, end to end through the ROS nodes), simulator,
training and evaluation throughput and peak memory, each with the command that produced it. A benchmark
without results is reported as "not measured". `make bench` runs this after every benchmark.
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import os
import sys

DEFAULT_BENCHES = ["sim", "env", "tracker", "dovs", "inference", "training", "e2e", "eval-sdovs", "eval-dqn"]
NOT_MEASURED = "not measured"

# (stage, bench, key, label, unit)
LATENCY = [
    ("tracker update, one scan (thread CPU time)", "tracker", "latency_ms_median", "median", "ms"),
    ("tracker update, one scan (thread CPU time)", "tracker", "latency_ms_p99", "p99", "ms"),
    ("tracker update, one scan (thread CPU time)", "tracker", "latency_ms_max", "max", "ms"),
    ("tracker update, one scan (wall clock)", "tracker", "latency_wall_ms_p99", "p99", "ms"),
    ("DOVS build, one scene (median of 11 builds per scene)", "dovs", "build_ms_median", "median over scenes", "ms"),
    ("DOVS build, one scene (median of 11 builds per scene)", "dovs", "build_ms_p99", "p99 over scenes", "ms"),
    ("DOVS build, one scene (median of 11 builds per scene)", "dovs", "build_ms_max", "max over scenes", "ms"),
    ("DOVS build, every build", "dovs", "build_ms_p99_all_builds", "p99", "ms"),
    ("action shield escape search, one scene (boxed in only)", "dovs", "escape_ms_median", "median over scenes", "ms"),
    ("action shield escape search, one scene (boxed in only)", "dovs", "escape_ms_p99", "p99 over scenes", "ms"),
    ("whole decision: DOVS build + actions + state + shield (escape) + network, one scene", "dovs",
     "decision_ms_median", "median over scenes", "ms"),
    ("whole decision: DOVS build + actions + state + shield (escape) + network, one scene", "dovs",
     "decision_ms_p99", "p99 over scenes", "ms"),
    ("whole decision, scenes where the escape ran (boxed in)", "dovs", "decision_escape_ms_p99", "p99 over scenes",
     "ms"),
    ("learned people prediction's arcs (people_predictor), one scene of 15 obstacles", "dovs",
     "predicted_arcs_ms_median", "median over scenes", "ms"),
    ("learned people prediction's arcs (people_predictor), one scene of 15 obstacles", "dovs",
     "predicted_arcs_ms_p99", "p99 over scenes", "ms"),
    ("Q-network decision, qValues + masked argmax (wall clock)", "inference", "decision_us_median", "median", "us"),
    ("Q-network decision, qValues + masked argmax (wall clock)", "inference", "decision_us_p99", "p99", "us"),
    ("Q-network decision, qValues + masked argmax (wall clock)", "inference", "decision_us_max", "max", "us"),
    ("end to end: scan stamp -> action (ROS nodes)", "e2e", "latency_ms_median", "median", "ms"),
    ("end to end: scan stamp -> action (ROS nodes)", "e2e", "latency_ms_p99", "p99", "ms"),
    ("end to end: scan stamp -> action (ROS nodes)", "e2e", "latency_ms_max", "max", "ms"),
    ("end to end: scan stamp -> action (nodelets)", "e2e", "nodelets_latency_ms_median", "median", "ms"),
    ("end to end: scan stamp -> action (nodelets)", "e2e", "nodelets_latency_ms_p99", "p99", "ms"),
    ("end to end: scan stamp -> action (nodelets)", "e2e", "nodelets_latency_ms_max", "max", "ms"),
]
SIM = [
    ("sim", "steps_per_s", "world steps per second (one 720-beam scan per step, 15 obstacles)", "1/s"),
    ("sim", "step_us_median", "physics step, median", "us"),
    ("sim", "scan_us_median", "LIDAR scan, median", "us"),
    ("sim", "scan_us_p95", "LIDAR scan, p95", "us"),
    ("sim", "crowd_urg04lx_steps_per_s", "world steps per second, crowd of 15 people, URG-04LX", "1/s"),
    ("sim", "clutter_steps_per_s", "world steps per second, clutter with 15 people", "1/s"),
    ("env", "min_sim_steps_per_s",
     "training environment, slowest family and sensor: 0.05 s simulator steps per second, one core", "1/s"),
    ("env", "crowd_urg04lx_env_steps_per_s", "training environment, crowd of 15, URG-04LX: control periods per second",
     "1/s"),
]
TRAINING = [
    ("training", "env_steps_per_s", "environment steps per second, learning included", "1/s"),
    ("training", "updates_per_s", "gradient updates per second, whole loop", "1/s"),
    ("training", "env_only_steps_per_s", "environment steps per second, environments alone", "1/s"),
    ("training", "learn_only_updates_per_s", "gradient updates per second, learning alone", "1/s"),
]


def load_average(results_dir: str, bench: str) -> str | None:
    """The 1/5/15-min load average scripts/bench.sh saw when `bench` started, or None."""
    try:
        with open(os.path.join(results_dir, f"{bench}.loadavg")) as f:
            return " / ".join(f.read().split()[:3]) or None
    except OSError:
        return None


def load_results(results_dir: str, benches: list[str]) -> tuple[dict, dict, dict]:
    """(figures by bench, peak RSS in KiB by bench, modification time by bench) for the benches that ran."""
    figures, rss, when = {}, {}, {}
    for b in benches:
        path = os.path.join(results_dir, f"{b}.json")
        if os.path.exists(path):
            try:
                with open(path) as f:
                    figures[b] = json.load(f)
                when[b] = os.path.getmtime(path)
            except (OSError, ValueError) as e:
                print(f"performance_report: {path}: {e}; reported as {NOT_MEASURED}", file=sys.stderr)
        path = os.path.join(results_dir, f"{b}.rss_kb")
        if os.path.exists(path):
            try:
                with open(path) as f:
                    # GNU time may write a "Command exited with non-zero status" line first.
                    rss[b] = float(f.read().split()[-1])
            except (OSError, ValueError, IndexError):
                pass
    return figures, rss, when


def eval_throughput(figures: dict, bench: str) -> tuple[float, float] | None:
    """(episodes, episodes per second) of an evaluation benchmark, or None when it is missing."""
    f = figures.get(bench)
    if not f or not f.get("wall_s"):
        return None
    episodes = f.get("episodes")
    if episodes is None:  # eval-sdovs: one method over 15 obstacle counts
        per = f.get("episodes_per_count")
        if per is None:
            return None
        episodes = per * 15 * (2 if bench == "eval-dqn" else 1)
    return float(episodes), float(episodes) / float(f["wall_s"])


def _fmt(v) -> str:
    if v is None:
        return NOT_MEASURED
    if isinstance(v, bool):
        return str(v)
    if isinstance(v, int):
        return f"{v:,}" if abs(v) >= 10000 else str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "-"
        a = abs(v)
        if a == 0 or a >= 1000:
            return f"{v:,.0f}"
        if a >= 100:
            return f"{v:.0f}"
        if a >= 10:
            return f"{v:.1f}"
        if a >= 0.01:
            return f"{v:.3g}"
        return f"{v:.3g}"
    return str(v)


def _table(header, rows) -> list[str]:
    return ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)] + \
           ["| " + " | ".join(map(str, r)) + " |" for r in rows]


def _cmd(bench: str) -> str:
    return f"`make bench-{bench}`"


def _date(ts: float | None) -> str:
    if ts is None:
        return "-"
    return datetime.datetime.fromtimestamp(ts, datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")


def machine_info() -> dict:
    cpu = "unknown"
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    mem = None
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemTotal:"):
                    mem = int(line.split()[1]) / 1024 / 1024
                    break
    except OSError:
        pass
    return {"nproc": os.cpu_count(), "cpu_model": cpu, "mem_gib": mem}


def render(figures: dict, rss: dict, when: dict, benches: list[str], machine: dict, now: str,
           loads: dict | None = None, notes: str = "") -> str:
    """The report. `notes`: hand-written measurement notes (docs/performance_notes.md), copied verbatim after the
    per-stage latency table."""
    loads = loads or {}
    out = ["# Performance", "",
           "Generated by `make bench` (python/dqn_dovs_py/performance_report.py) from `bench/results/*.json`; "
           "each figure comes from the command beside it, on this machine:", "",
           f"- Machine: {machine['nproc']} CPU(s) (`nproc`), {machine['cpu_model']}"
           + (f", {machine['mem_gib']:.0f} GiB memory" if machine.get("mem_gib") else ""),
           f"- Report generated: {now}",
           "- The machine may have been shared with other work while the benchmarks ran; the date of each "
           "result file is below.", ""]
    ran = [b for b in benches if b in figures]
    out += ["| benchmark | results from | load average at start (1 / 5 / 15 min) | command |", "|---|---|---|---|"]
    for b in benches:
        load = loads.get(b) if b in figures else None
        out.append(f"| {b} | {_date(when.get(b)) if b in figures else NOT_MEASURED} | {load or '-'} | {_cmd(b)} |")
    out.append("")

    out += ["## Per-stage latency", "",
            "One control period is 0.2 s (200 ms); the LIDAR scans at 10 Hz. Wall-clock tails (p99, max) include "
            "the time the process waited for a core, which a shared machine inflates; the tracker's CPU-time figures "
            "do not.", ""]
    rows = []
    for stage, b, key, label, unit in LATENCY:
        v = figures.get(b, {}).get(key) if b in figures else None
        rows.append([stage, label, _fmt(v) + ("" if v is None else f" {unit}"), _cmd(b)])
    out += _table(["stage", "figure", "value", "command"], rows) + [""]
    if "e2e" in figures:
        out += ["The end-to-end figures run simulator_node -> obstacle_tracker_node -> dovs_node -> planner_node "
                "(launch/pipeline.launch; wall clock, 10 Hz scans) and measure from each scan's stamp to the action "
                "chosen for it: first with each node its own process, then with the three as nodelets in one "
                "manager (`nodelets:=true`). The action reaches `cmd_vel` at the planner's next 0.2 s control tick, "
                "which they leave out.", ""]
    if notes.strip():
        out += ["### Measurement notes", "", notes.strip(), ""]

    out += ["## Simulator throughput", ""]
    out += _table(["figure", "value", "command"],
                  [[label, _fmt(figures.get(b, {}).get(k)) + ("" if b not in figures else f" {u}"), _cmd(b)]
                   for b, k, label, u in SIM]) + [""]

    out += ["## Training throughput", "",
            "The real trainer (C++ environments + PyTorch) on a shortened curriculum, CPU, one torch thread.", ""]
    out += _table(["figure", "value", "command"],
                  [[label, _fmt(figures.get(b, {}).get(k)) + ("" if b not in figures else f" {u}"), _cmd(b)]
                   for b, k, label, u in TRAINING]) + [""]

    out += ["## Evaluation throughput", "",
            "`dqn_dovs_eval` on the shared scenarios (1..15 obstacles, tracker in the loop, `--threads 2`).", ""]
    rows = []
    for b, what in (("eval-dqn", "dqn_dovs + s_dovs"), ("eval-sdovs", "s_dovs")):
        t = eval_throughput(figures, b)
        if t is None:
            rows.append([b, what, NOT_MEASURED, NOT_MEASURED, NOT_MEASURED, NOT_MEASURED, _cmd(b)])
        else:
            rows.append([b, what, _fmt(figures[b].get("episodes_per_count")), f"{t[0]:.0f}",
                         _fmt(float(figures[b]["wall_s"])) + " s", f"{t[1]:.1f}", _cmd(b)])
    out += _table(["benchmark", "methods", "episodes per count", "episodes", "wall time", "episodes / s", "command"],
                  rows) + [""]

    out += ["## Peak memory", "",
            "Maximum resident set size of each benchmark process (with the children it waited for), measured by "
            "scripts/bench.sh with GNU time (`/usr/bin/time -f %M`).", ""]
    rows = []
    for b in benches:
        v = rss.get(b)
        rows.append([b, NOT_MEASURED if v is None else f"{v / 1024:.1f} MiB", _cmd(b)])
    out += _table(["benchmark", "max RSS", "command"], rows) + [""]

    out += ["## All figures", "", "Every figure of every benchmark that ran, as written to bench/results/NAME.json.", ""]
    for b in ran:
        out += [f"### {b}", ""]
        out += _table(["key", "value"], [[k, _fmt(v) if not isinstance(v, (list, dict)) else json.dumps(v)]
                                         for k, v in sorted(figures[b].items())]) + [""]
    missing = [b for b in benches if b not in figures]
    if missing:
        out += [f"Not measured: {', '.join(missing)} (no bench/results/NAME.json; run `make bench-NAME`).", ""]
    return "\n".join(out)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--results", default="bench/results")
    p.add_argument("--benches", default=" ".join(DEFAULT_BENCHES), help="space- or comma-separated names")
    p.add_argument("--out", default="docs/performance.md")
    p.add_argument("--notes", default="docs/performance_notes.md",
                   help="hand-written notes copied into the report (skipped when the file does not exist)")
    a = p.parse_args(argv)
    benches = [b for b in a.benches.replace(",", " ").split() if b]
    figures, rss, when = load_results(a.results, benches)
    now = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    loads = {b: load_average(a.results, b) for b in benches}
    notes = ""
    if os.path.exists(a.notes):
        with open(a.notes) as f:
            notes = "\n".join(line for line in f.read().splitlines() if not line.startswith("<!--"))
    text = render(figures, rss, when, benches, machine_info(), now, loads, notes)
    os.makedirs(os.path.dirname(os.path.abspath(a.out)), exist_ok=True)
    with open(a.out, "w") as f:
        f.write(text)
    print(f"wrote {a.out} ({len(figures)} of {len(benches)} benchmarks measured)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
