"""Summary, figures and plots of one dqn_dovs_eval run, from the records the tool writes into its output folder.

    python -m dqn_dovs_py.report OUT_DIR [--reference METHOD]

Reads OUT_DIR/results.csv (one row per episode), OUT_DIR/run.json (how the run was made) and, when the run kept
trajectories, OUT_DIR/paths.json. Writes into OUT_DIR:

- summary.md: the run's header, then per obstacle count and method the success rate with the time ratio in brackets,
  collision rate, collisions by kind, robot speed at contact, timeout rate, mean time on success and danger
  frequency, each with a mean row;
- summary.json: the flat figures (success_mean, success_N, collision_mean, timeout_mean, time_ratio_mean,
  episodes, ...; keys prefixed "METHOD." when the run has several methods; figures that are NaN left out);
- success_vs_obstacles.png: success rate against obstacle count, one line per method;
- trajectories_METHOD_nN_eK.png: one per episode of paths.json, seen from above.

It prints the success / collision / timeout table and the files written. The figures, per method and obstacle
count (a cell) and per method over every count (the mean row):

- success / collision / timeout rate; the mean row is the mean of the per-count rates (the paper's mean row);
- time ratio: the method's total time over the reference method's total time on the episodes both solved
  (episodes matched by obstacle count and episode number); the mean row pools every such episode;
- mean time on success, danger frequency (danger steps over steps), mean smallest clearance, collisions by kind
  (static geometry / robot at rest / robot moving), robot speed at contact (mean and nearest-rank 95th percentile);
  the mean row pools every episode.

A method with no episodes at a count has an empty cell: every figure of it is NaN (left out of summary.json, shown
as "–" in the tables). A figure without data (no success, no collision, no episode both solved) is NaN too ("-").
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import sys
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Circle, Rectangle

# results.csv's header, as dqn_dovs_eval writes it.
RESULTS_COLUMNS = ("method", "obstacles", "episode", "scenario", "outcome", "time_s", "path_length_m",
                   "min_clearance_m", "danger_steps", "steps", "planner_errors", "collision_kind", "contact_speed_mps",
                   "last_decision")
# Optional columns (runs written before them lack them): what the planners knew of the body that hit the robot.
HIT_COLUMNS = ("hit_cause", "hit_seen_s", "hit_prediction_error_m", "hit_prediction_error_2s_m", "hit_bearing_deg")
# Optional columns (runs written before them lack them): who hit whom, and whether the robot was at fault.
FAULT_COLUMNS = ("contact", "at_fault")
# Optional comfort columns: time with a person within Hall's intimate (0.45 m) and personal (1.2 m) distances, body to
# body, while the robot moves (s).
COMFORT_COLUMNS = ("intimate_s", "personal_s")
# Optional columns of cost to others and efficiency: time blocking a passage while someone waits or detours (s); the
# delay caused to the attentive people who noticed the robot, against the same people without it (s, empty when none
# did); time to the goal over the route length at v_max (successes only); path irregularity (rad of turning per m).
COST_COLUMNS = ("blocking_s", "delay_s", "time_ratio", "path_irregularity")
# The outcome judged by who caused a collision (dqn_dovs_eval's verdictName), an optional column.
VERDICTS = ("success", "collision_robot_at_fault", "hit_at_rest", "timeout")
# contact values of a collision (dqn_dovs_eval's ContactClass); empty without one.
CONTACT_CLASSES = ("static", "robot_on_person", "person_on_robot")
# hit_cause values of a collision with a moving body (dqn_dovs_eval's HitCause); empty otherwise.
HIT_CAUSES = ("unseen", "late", "mispredicted", "foreseen")
OUTCOMES = ("success", "collision", "timeout")
# collision_kind values of a collision; empty for an episode without one.
COLLISION_KINDS = ("static", "rest", "moving")
# Below this robot speed at contact, m/s, a collision is "rest": the robot was walked into.
REST_SPEED_MPS = 0.05
CONTACT_SPEED_QUANTILE = 0.95
# An empty cell (no episodes) in the tables and on stdout.
EMPTY = "–"
SUMMARY_MD, SUMMARY_JSON, SUCCESS_PNG = "summary.md", "summary.json", "success_vs_obstacles.png"


# ----------------------------------------------------------------------------------------------- records


@dataclass
class Record:
    """One results.csv row. Columns a reader did not require may be absent: they read as the defaults below
    (collision_kind and last_decision None: not recorded)."""

    method: str
    obstacles: int
    episode: int
    outcome: str
    time_s: float
    danger_steps: int
    steps: int
    min_clearance_m: float = math.nan
    collision_kind: str | None = None  # one of COLLISION_KINDS, "" without collision
    contact_speed_mps: float = math.nan  # the robot's linear speed at contact; NaN without collision
    last_decision: str | None = None  # the planner's note on its last decision
    scenario: str = ""
    path_length_m: float = math.nan
    planner_errors: int = 0
    hit_cause: str | None = None  # one of HIT_CAUSES, "" without a collision with a moving body, None: not recorded
    hit_seen_s: float = math.nan
    hit_prediction_error_m: float = math.nan
    hit_prediction_error_2s_m: float = math.nan
    hit_bearing_deg: float = math.nan
    contact: str | None = None  # one of CONTACT_CLASSES, "" without collision, None: not recorded
    at_fault: bool | None = None  # with a collision: the robot at fault; None without one or not recorded
    intimate_s: float = math.nan  # NaN: not recorded
    personal_s: float = math.nan
    verdict: str | None = None  # one of VERDICTS, None: not recorded
    blocking_s: float = math.nan  # NaN: not recorded (COST_COLUMNS)
    delay_s: float = math.nan  # NaN: not recorded, or no attentive person noticed the robot
    time_ratio: float = math.nan  # NaN: not recorded, or not a success
    path_irregularity: float = math.nan


def _contact(text: str | None) -> str | None:
    """A contact cell: "" (no collision), one of CONTACT_CLASSES, or None when the column is absent."""
    if text is not None and text not in ("",) + CONTACT_CLASSES:
        raise ValueError(f"unknown contact '{text}' (expected one of {', '.join(CONTACT_CLASSES)})")
    return text


def _verdict(text: str | None) -> str | None:
    """A verdict cell: one of VERDICTS, or None when the column is absent or empty."""
    if text in (None, ""):
        return None
    if text not in VERDICTS:
        raise ValueError(f"unknown verdict '{text}' (expected one of {', '.join(VERDICTS)})")
    return text


def _at_fault(text: str | None) -> bool | None:
    """An at_fault cell: "1" or "0" with a collision, "" without one; None when empty or absent."""
    if text in (None, ""):
        return None
    if text not in ("0", "1"):
        raise ValueError(f"at_fault must be 0, 1 or empty, got '{text}'")
    return text == "1"


def _optional_float(text: str | None) -> float:
    return float(text) if text else math.nan


def _outcome(text: str) -> str:
    if text not in OUTCOMES:
        raise ValueError(f"unknown outcome '{text}' (expected one of {', '.join(OUTCOMES)})")
    return text


def _collision_kind(text: str | None) -> str | None:
    """A collision_kind cell: "" (no collision), one of COLLISION_KINDS, or None when the column is absent."""
    if text is not None and text not in ("",) + COLLISION_KINDS:
        raise ValueError(f"unknown collision_kind '{text}' (expected one of {', '.join(COLLISION_KINDS)})")
    return text


def _hit_cause(text: str | None) -> str | None:
    """A hit_cause cell: "" (no collision with a moving body), one of HIT_CAUSES, or None when the column is absent."""
    if text is not None and text not in ("",) + HIT_CAUSES:
        raise ValueError(f"unknown hit_cause '{text}' (expected one of {', '.join(HIT_CAUSES)})")
    return text


def _record(row: dict[str, str | None]) -> Record:
    return Record(
        method=row["method"], obstacles=int(row["obstacles"]), episode=int(row["episode"]),
        outcome=_outcome(row["outcome"]), time_s=float(row["time_s"]), danger_steps=int(row["danger_steps"]),
        steps=int(row["steps"]), min_clearance_m=_optional_float(row.get("min_clearance_m")),
        collision_kind=_collision_kind(row.get("collision_kind")),
        contact_speed_mps=_optional_float(row.get("contact_speed_mps")), last_decision=row.get("last_decision"),
        scenario=row.get("scenario") or "", path_length_m=_optional_float(row.get("path_length_m")),
        planner_errors=int(row.get("planner_errors") or 0), hit_cause=_hit_cause(row.get("hit_cause")),
        hit_seen_s=_optional_float(row.get("hit_seen_s")),
        hit_prediction_error_m=_optional_float(row.get("hit_prediction_error_m")),
        hit_prediction_error_2s_m=_optional_float(row.get("hit_prediction_error_2s_m")),
        hit_bearing_deg=_optional_float(row.get("hit_bearing_deg")), contact=_contact(row.get("contact")),
        at_fault=_at_fault(row.get("at_fault")), intimate_s=_optional_float(row.get("intimate_s")),
        personal_s=_optional_float(row.get("personal_s")), verdict=_verdict(row.get("verdict")),
        blocking_s=_optional_float(row.get("blocking_s")), delay_s=_optional_float(row.get("delay_s")),
        time_ratio=_optional_float(row.get("time_ratio")),
        path_irregularity=_optional_float(row.get("path_irregularity")))


def read_results(path: str, required: Iterable[str] = RESULTS_COLUMNS) -> list[Record]:
    """The episodes of a results.csv. Raises ValueError naming the file when it is missing or lacks one of the
    `required` columns, and the file and line on a malformed row."""
    if not os.path.isfile(path):
        raise ValueError(f"{path}: no such file")
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        missing = set(required) - set(reader.fieldnames or [])
        if missing:
            raise ValueError(f"{path}: missing columns {sorted(missing)}")
        records = []
        for line, row in enumerate(reader, start=2):
            try:
                records.append(_record(row))
            except (TypeError, ValueError) as e:
                raise ValueError(f"{path}:{line}: {e}") from None
    return records


# ----------------------------------------------------------------------------------------------- figures


@dataclass
class Cell:
    """One method at one obstacle count, or over every count (the mean row). NaN: no data."""

    episodes: int = 0
    successes: int = 0
    collisions: int = 0
    timeouts: int = 0
    success_rate: float = math.nan
    collision_rate: float = math.nan
    timeout_rate: float = math.nan
    mean_time_success_s: float = math.nan
    time_ratio: float = math.nan
    both_solved: int = 0  # episodes behind time_ratio
    danger_frequency: float = math.nan
    mean_min_clearance_m: float = math.nan
    # Collisions per kind (COLLISION_KINDS); None when a collision's kind was not recorded.
    collisions_by_kind: dict[str, int] | None = field(default_factory=lambda: dict.fromkeys(COLLISION_KINDS, 0))
    mean_contact_speed_mps: float = math.nan
    p95_contact_speed_mps: float = math.nan
    # Collisions with a moving body per HitCause; None when a collision's cause was not recorded.
    hits_by_cause: dict[str, int] | None = field(default_factory=lambda: dict.fromkeys(HIT_CAUSES, 0))
    # Collisions with the robot at fault, and hit at rest (the others); None when a collision's fault was not recorded.
    at_fault: int | None = 0
    hit_at_rest: int | None = 0
    # 1 - the rate of collisions with the robot at fault (NaN: not recorded).
    passive_safety_rate: float = math.nan
    # Mean time per episode with a person within the intimate / personal distance while the robot moves, s.
    mean_intimate_s: float = math.nan
    mean_personal_s: float = math.nan
    # Means per episode of COST_COLUMNS (NaN: not recorded; delay_s and time_ratio over the episodes that have one).
    mean_blocking_s: float = math.nan
    mean_delay_s: float = math.nan
    mean_time_ratio: float = math.nan
    mean_path_irregularity: float = math.nan


@dataclass
class Summary:
    methods: list[str]  # table order
    counts: list[int]  # ascending
    reference: str  # the method of the time ratios
    cells: dict[tuple[str, int], Cell] = field(default_factory=dict)
    overall: dict[str, Cell] = field(default_factory=dict)  # the mean row
    hits_recorded: bool = False  # the records carry hit_cause (runs written before it do not)
    faults_recorded: bool = False  # the records carry contact and at_fault (runs written before them do not)
    costs_recorded: bool = False  # the records carry COST_COLUMNS (runs written before them do not)

    def cell(self, method: str, n: int) -> Cell:
        return self.cells.get((method, n), Cell())


def nan_mean(values: Iterable[float]) -> float:
    """The mean of the values that are not NaN; NaN when there are none."""
    kept = [v for v in values if not math.isnan(v)]
    return sum(kept) / len(kept) if kept else math.nan


def nearest_rank(values: Sequence[float], q: float) -> float:
    """The q-quantile by nearest rank (the ceil(q n)-th smallest, not interpolated); NaN without values."""
    if not values:
        return math.nan
    return sorted(values)[max(math.ceil(q * len(values)), 1) - 1]


def time_ratio(mine: Sequence[Record], reference: Sequence[Record]) -> tuple[float, int]:
    """Total time of `mine` over total time of `reference` on the episodes both solved, and how many those are.

    Episodes are matched by (obstacles, episode); NaN when none was solved by both."""
    ref = {(r.obstacles, r.episode): r for r in reference if r.outcome == "success"}
    t_mine = t_ref = 0.0
    both = 0
    for r in mine:
        other = ref.get((r.obstacles, r.episode))
        if r.outcome == "success" and other is not None:
            both += 1
            t_mine += r.time_s
            t_ref += other.time_s
    return (t_mine / t_ref if both and t_ref > 0 else math.nan), both


def danger_frequency(records: Sequence[Record]) -> float:
    """Danger steps (clearance below the reward's safe distance) over steps, pooled over the episodes; NaN without
    episodes, 0 when they took no step."""
    if not records:
        return math.nan
    steps = sum(r.steps for r in records)
    return sum(r.danger_steps for r in records) / steps if steps else 0.0


def collisions_by_kind(records: Sequence[Record]) -> dict[str, int] | None:
    """Collisions per kind; None when a collision's kind was not recorded. A collision of empty kind counts in none."""
    crashes = [r for r in records if r.outcome == "collision"]
    if any(r.collision_kind is None for r in crashes):
        return None
    return {k: sum(r.collision_kind == k for r in crashes) for k in COLLISION_KINDS}


def hits_by_cause(records: Sequence[Record]) -> dict[str, int] | None:
    """Collisions with a moving body (robot at rest or moving) per hit cause; None when one was not recorded."""
    hits = [r for r in records if r.outcome == "collision" and r.collision_kind in ("rest", "moving")]
    if any(r.hit_cause is None for r in hits):
        return None
    return {k: sum(r.hit_cause == k for r in hits) for k in HIT_CAUSES}


def contact_speeds(records: Sequence[Record]) -> list[float]:
    """The robot's recorded speeds at contact, over the collisions."""
    return [r.contact_speed_mps for r in records if r.outcome == "collision" and math.isfinite(r.contact_speed_mps)]


def cell_of(records: Sequence[Record], reference: Sequence[Record]) -> Cell:
    """The figures of `records` (one method), time ratios against the `reference` method's records."""
    c = Cell(episodes=len(records))
    if not records:
        return c
    c.successes = sum(r.outcome == "success" for r in records)
    c.collisions = sum(r.outcome == "collision" for r in records)
    c.timeouts = sum(r.outcome == "timeout" for r in records)
    c.success_rate = c.successes / len(records)
    c.collision_rate = c.collisions / len(records)
    c.timeout_rate = c.timeouts / len(records)
    if c.successes:
        c.mean_time_success_s = sum(r.time_s for r in records if r.outcome == "success") / c.successes
    c.time_ratio, c.both_solved = time_ratio(records, reference)
    c.danger_frequency = danger_frequency(records)
    c.mean_min_clearance_m = sum(r.min_clearance_m for r in records) / len(records)
    c.collisions_by_kind = collisions_by_kind(records)
    c.hits_by_cause = hits_by_cause(records)
    crashes = [r for r in records if r.outcome == "collision"]
    if any(r.at_fault is None for r in crashes):
        c.at_fault = c.hit_at_rest = None
    else:
        c.at_fault = sum(bool(r.at_fault) for r in crashes)
        c.hit_at_rest = len(crashes) - c.at_fault
        c.passive_safety_rate = 1.0 - c.at_fault / len(records)
    c.mean_intimate_s = nan_mean(r.intimate_s for r in records)
    c.mean_personal_s = nan_mean(r.personal_s for r in records)
    c.mean_blocking_s = nan_mean(r.blocking_s for r in records)
    c.mean_delay_s = nan_mean(r.delay_s for r in records)
    c.mean_time_ratio = nan_mean(r.time_ratio for r in records)
    c.mean_path_irregularity = nan_mean(r.path_irregularity for r in records)
    speeds = contact_speeds(records)
    c.mean_contact_speed_mps = sum(speeds) / len(speeds) if speeds else math.nan
    c.p95_contact_speed_mps = nearest_rank(speeds, CONTACT_SPEED_QUANTILE)
    return c


def _method_order(records: Sequence[Record], methods: Sequence[str]) -> list[str]:
    order = list(methods)
    for r in records:
        if r.method not in order:
            order.append(r.method)
    return order


def _check_reference(records: Sequence[Record], reference: str, methods: Sequence[str]) -> None:
    seen: set[tuple[int, int]] = set()
    for r in records:
        if r.method != reference:
            continue
        if (r.obstacles, r.episode) in seen:
            raise ValueError(f"reference method '{reference}' has two records for {r.obstacles} obstacles, "
                             f"episode {r.episode}")
        seen.add((r.obstacles, r.episode))
    if not seen:
        raise ValueError(f"reference method '{reference}' has no episodes (methods: {', '.join(methods)})")


def summarize(records: Sequence[Record], reference: str, methods: Sequence[str] = ()) -> Summary:
    """Per (method, count) cells and per method the mean row. Methods come in the order of `methods`, then any
    other method of the records in first-seen order; counts are those of the records. Raises ValueError when the
    reference method has no records or two for the same episode."""
    order = _method_order(records, methods)
    _check_reference(records, reference, order)
    s = Summary(methods=order, counts=sorted({r.obstacles for r in records}), reference=reference,
                hits_recorded=any(r.hit_cause is not None for r in records),
                faults_recorded=any(r.contact is not None for r in records),
                costs_recorded=any(not math.isnan(r.path_irregularity) for r in records))
    by: dict[tuple[str, int], list[Record]] = {}
    for r in records:
        by.setdefault((r.method, r.obstacles), []).append(r)
    ref_all = [r for r in records if r.method == reference]
    for m in order:
        for n in s.counts:
            s.cells[(m, n)] = cell_of(by.get((m, n), []), by.get((reference, n), []))
        o = cell_of([r for r in records if r.method == m], ref_all)
        per = [s.cells[(m, n)] for n in s.counts]  # empty cells are NaN: the mean is over the counts m ran
        o.success_rate = nan_mean(c.success_rate for c in per)
        o.collision_rate = nan_mean(c.collision_rate for c in per)
        o.timeout_rate = nan_mean(c.timeout_rate for c in per)
        s.overall[m] = o
    return s


def _kind_count(c: Cell, kind: str) -> float:
    return math.nan if c.collisions_by_kind is None else c.collisions_by_kind[kind]


def summary_figures(s: Summary) -> dict[str, float]:
    """The flat figures of summary.json, NaN included; keys prefixed "METHOD." when there are several methods.
    Every figure of a method without episodes is NaN."""
    out: dict[str, float] = {}
    for m in s.methods:
        p = f"{m}." if len(s.methods) > 1 else ""
        o = s.overall[m]
        figures: list[tuple[str, float]] = [
            ("success_mean", o.success_rate), ("collision_mean", o.collision_rate), ("timeout_mean", o.timeout_rate)]
        if m != s.reference:
            figures.append(("time_ratio_mean", o.time_ratio))
        figures += [("mean_time_success_s", o.mean_time_success_s), ("danger_frequency", o.danger_frequency),
                    ("episodes", o.episodes), ("collisions", o.collisions)]
        figures += [(f"collisions_{k}", _kind_count(o, k)) for k in COLLISION_KINDS]
        figures += [("contact_speed_mean", o.mean_contact_speed_mps), ("contact_speed_p95", o.p95_contact_speed_mps)]
        figures += [(f"hits_{k}", math.nan if o.hits_by_cause is None else o.hits_by_cause[k])
                    for k in HIT_CAUSES]
        figures += [(f"success_{n}", s.cell(m, n).success_rate) for n in s.counts]
        if ORACLE in s.methods and m != ORACLE:
            figures.append(("oracle_share", oracle_share(s, m)))
        figures += [("passive_safety_rate", o.passive_safety_rate), ("intimate_s_mean", o.mean_intimate_s),
                    ("personal_s_mean", o.mean_personal_s), ("blocking_s_mean", o.mean_blocking_s),
                    ("delay_s_mean", o.mean_delay_s), ("time_ratio_route_mean", o.mean_time_ratio),
                    ("path_irregularity_mean", o.mean_path_irregularity)]
        for key, value in figures:
            out[p + key] = value if o.episodes else math.nan
    return out


def summary_json(s: Summary) -> str:
    """summary_figures as a flat JSON object without the NaN figures."""
    return json.dumps({k: v for k, v in summary_figures(s).items() if not math.isnan(v)}, indent=2) + "\n"


# ----------------------------------------------------------------------------------------------- run.json


@dataclass
class RunInfo:
    """run.json: how dqn_dovs_eval ran."""

    command: str
    scenarios: str  # "generated" or the scenario folder
    seed: int
    obstacles_min: int
    obstacles_max: int
    episodes: int
    dynamic_fraction: float
    perfect_info: bool
    step_s: float
    max_steps: int
    wall_s: float
    threads: int
    methods: list[str]
    reference: str
    goal_tolerance_m: float
    # Optional (older runs lack them): the world family, LIDAR profile and people model of generated episodes.
    world: str = "room"
    sensor: str = "sim"
    people_model: str = "social_force"
    people_see_robot: bool = False
    odom_noise: str = "none"
    route: str = "off"  # runs made before routes existed drove at the goal itself
    people_predictor: str = ""  # the learned people prediction the planners saw (dqn_dovs_eval --predict-people)
    tracker_map: bool = False  # the tracker was given the map's walls and furniture (dqn_dovs_eval --tracker-map)
    dovs_map: bool = False  # the velocity space took the map's walls near the robot (dqn_dovs_eval --dovs-map)
    people_mix: str = "oblivious=1"  # how people treat the robot (dqn_dovs_eval --people-mix, normalised shares)


def _type_ok(value: object, kind: type) -> bool:
    if kind is float:
        return isinstance(value, (int, float)) and not isinstance(value, bool)
    if kind is int:
        return isinstance(value, int) and not isinstance(value, bool)
    if kind is list:
        return isinstance(value, list) and bool(value) and all(isinstance(v, str) for v in value)
    return isinstance(value, kind)


_RUN_TYPES: dict[str, type] = {"command": str, "scenarios": str, "seed": int, "obstacles_min": int,
                               "obstacles_max": int, "episodes": int, "dynamic_fraction": float, "perfect_info": bool,
                               "step_s": float, "max_steps": int, "wall_s": float, "threads": int, "methods": list,
                               "reference": str, "goal_tolerance_m": float}
_OPTIONAL_RUN_TYPES: dict[str, type] = {"world": str, "sensor": str, "people_model": str, "people_see_robot": bool,
                                        "odom_noise": str, "route": str, "people_predictor": str,
                                        "tracker_map": bool, "dovs_map": bool, "people_mix": str}
_TYPE_NAMES = {str: "a string", int: "an integer", float: "a number", bool: "true or false",
               list: "a non-empty list of strings"}


def read_run(path: str) -> RunInfo:
    """run.json; raises ValueError naming the file and the missing or malformed key."""
    if not os.path.isfile(path):
        raise ValueError(f"{path}: no such file")
    with open(path) as f:
        try:
            data = json.load(f)
        except json.JSONDecodeError as e:
            raise ValueError(f"{path}: not valid JSON ({e})") from None
    if not isinstance(data, dict):
        raise ValueError(f"{path}: expected a JSON object")
    for key, kind in _RUN_TYPES.items():
        if key not in data:
            raise ValueError(f"{path}: missing key '{key}'")
        if not _type_ok(data[key], kind):
            raise ValueError(f"{path}: '{key}' must be {_TYPE_NAMES[kind]}, got {data[key]!r}")
    for key, kind in _OPTIONAL_RUN_TYPES.items():
        if key in data and not _type_ok(data[key], kind):
            raise ValueError(f"{path}: '{key}' must be {_TYPE_NAMES[kind]}, got {data[key]!r}")
    keys = list(_RUN_TYPES) + [k for k in _OPTIONAL_RUN_TYPES if k in data]
    return RunInfo(**{key: data[key] for key in keys})


# ----------------------------------------------------------------------------------------------- summary.md


def fixed(x: float | None, digits: int = 2) -> str:
    """x with `digits` decimals; "-" for None or NaN."""
    return "-" if x is None or math.isnan(x) else f"{x:.{digits}f}"


def run_header(run: RunInfo) -> str:
    """The lines above the tables: command, scenarios, perception, wall time."""
    scenarios = f"generated, seed {run.seed}" if run.scenarios == "generated" else f"`{run.scenarios}`"
    perception = "perfect information (ground truth)" if run.perfect_info else "LIDAR + tracker in the loop"
    if run.people_predictor:
        perception += f"; moving obstacles on the arcs of the learned prediction `{run.people_predictor}`"
    if run.tracker_map:
        perception += "; the tracker given the map's walls and furniture"
    if run.dovs_map:
        perception += "; the map's walls near the robot beside the scan's"
    world = ""
    if run.world != "room" or run.sensor != "sim" or run.odom_noise != "none":
        sees = ("people give way to the robot" if run.people_see_robot else
                "the robot invisible to people" if run.people_mix == "oblivious=1" else f"people mix {run.people_mix}")
        odom = "" if run.odom_noise == "none" else f"; odometry drift {run.odom_noise}"
        route = f"; route {run.route}"
        world = (f"World: {run.world} ({run.people_model} people, {sees}); LIDAR profile {run.sensor}{odom}{route}  \n"
                 if run.world != "room" else f"World: room; LIDAR profile {run.sensor}{odom}  \n")
    return (f"Command: `{run.command}`  \n"
            f"Scenarios: {scenarios}; obstacles {run.obstacles_min}-{run.obstacles_max}, {run.episodes} episodes "
            f"each; dynamic fraction {run.dynamic_fraction:g}  \n" + world +
            f"Perception: {perception}; step {run.step_s:g} s, limit {run.max_steps} steps  \n"
            f"Wall time: {run.wall_s:.1f} s on {run.threads} thread(s)")


CellText = Callable[[Cell, str], str]


def _table(s: Summary, title: str, note: str, text: CellText) -> str:
    """One section: a row per count and the mean row, a column per method; empty cells EMPTY."""
    def value(c: Cell, m: str) -> str:
        return text(c, m) if c.episodes else EMPTY

    lines = [f"## {title}", "", note, "", "| Obs |" + "".join(f" {m} |" for m in s.methods),
             "|---|" + "---|" * len(s.methods)]
    for n in s.counts:
        lines.append(f"| {n} |" + "".join(f" {value(s.cell(m, n), m)} |" for m in s.methods))
    lines.append("| mean |" + "".join(f" {value(s.overall[m], m)} |" for m in s.methods))
    return "\n".join(lines) + "\n\n"


def _success_text(reference: str) -> CellText:
    return lambda c, m: fixed(c.success_rate) + ("" if m == reference else f" ({fixed(c.time_ratio)})")


def _kinds_text(c: Cell, _: str) -> str:
    return "-" if c.collisions_by_kind is None else " / ".join(str(c.collisions_by_kind[k]) for k in COLLISION_KINDS)


def _causes_text(c: Cell, _: str) -> str:
    return "-" if c.hits_by_cause is None else " / ".join(str(c.hits_by_cause[k]) for k in HIT_CAUSES)


ORACLE = "oracle"
# The reachability bound (docs/planners.md section 9): the physical limit from above, where no robot can get.
BOUND = "bound"
# Methods that read the simulator's future: limits to measure against, never planners to compare with.
CEILINGS = (ORACLE, BOUND)


def oracle_share(s: Summary, method: str, n: int | None = None) -> float:
    """Successes of `method` over the oracle's (the physical limit, on the same episodes), at count n or over all
    counts; NaN without an oracle in the run or when it solved none."""
    if ORACLE not in s.methods:
        return math.nan
    mine = s.overall[method] if n is None else s.cell(method, n)
    best = s.overall[ORACLE] if n is None else s.cell(ORACLE, n)
    return mine.successes / best.successes if best.successes else math.nan


def _oracle_table(s: Summary) -> str:
    planners = [m for m in s.methods if m not in CEILINGS]
    lines = ["## Share of the oracle's successes", "",
             "Successes of each method over those of `oracle` (the physical limit: a search that knows the "
             "obstacles' future, not deployable) on the same episodes. Last column: episodes the oracle could not "
             "solve (collisions / timeouts), the truly unavoidable ones as far as its search tells.", "",
             "| Obs |" + "".join(f" {m} |" for m in planners) + " oracle fails |",
             "|---|" + "---|" * len(planners) + "---|"]
    def fails(c: Cell) -> str:
        return f"{c.collisions} / {c.timeouts}" if c.episodes else EMPTY
    for n in s.counts:
        lines.append(f"| {n} |" + "".join(f" {fixed(oracle_share(s, m, n))} |" for m in planners)
                     + f" {fails(s.cell(ORACLE, n))} |")
    lines.append("| all |" + "".join(f" {fixed(oracle_share(s, m))} |" for m in planners)
                 + f" {fails(s.overall[ORACLE])} |")
    return "\n".join(lines) + "\n\n"


def summary_tables(s: Summary) -> str:
    """The tables of summary.md in the paper's layout (and, with an oracle in the run, the share of its
    successes)."""
    causes = ("Collisions with moving bodies by what the planner knew",
              "Counts: unseen (not among what the planner was shown at its last decision) / late (shown then, not 1 s "
              "before the contact) / mispredicted (shown 1 s before, its motion as shown put it more than 0.3 m from "
              "where it was at the contact) / foreseen (within 0.3 m).", _causes_text)
    passive = ("Passive safety",
               "1 - the rate of collisions with the robot at fault (any static contact, the robot moving at "
               f"{REST_SPEED_MPS:.2f} m/s or more, or at rest for less than 0.5 s before it). In brackets: collisions "
               "with the robot at fault / hit at rest (the others).",
               lambda c, _: "-" if c.at_fault is None else
               f"{fixed(c.passive_safety_rate)} ({c.at_fault} / {c.hit_at_rest})")
    sections: list[tuple[str, str, CellText]] = [
        ("Success rate", "Reached the goal and stopped on it. In brackets: total time of the method over total time "
         f"of `{s.reference}` on the episodes both solved.", _success_text(s.reference)),
        ("Collision rate", "Episodes ending in contact with an obstacle or a wall.",
         lambda c, _: fixed(c.collision_rate)),
        ("Collisions by kind", "Counts: static geometry (walls, static obstacles; must be 0) / robot at rest (below "
         f"{REST_SPEED_MPS:.2f} m/s: walked into) / robot moving.", _kinds_text),
        ("Robot speed at contact (m/s)", "Mean over the collisions, 95th percentile in brackets.",
         lambda c, _: f"{fixed(c.mean_contact_speed_mps, 3)} ({fixed(c.p95_contact_speed_mps, 3)})"),
        ("Timeout rate", "Episodes still running after the step limit.", lambda c, _: fixed(c.timeout_rate)),
        ("Mean time on success (s)", "Over each method's own successful episodes.",
         lambda c, _: fixed(c.mean_time_success_s, 1)),
        ("Danger frequency", "Fraction of steps ending closer than the reward's safe distance to anything.",
         lambda c, _: fixed(c.danger_frequency, 3)),
    ]
    if s.hits_recorded:  # after the contact speeds
        sections.insert(4, causes)
    if s.faults_recorded:  # after the collisions by kind; the comfort figures after the danger frequency
        sections.insert(3, passive)
        sections.append(("Time close to people while moving (s per episode)",
                         "Mean time with a person's body within 0.45 m (intimate) / 1.2 m (personal) of the robot's "
                         "while the robot moves.",
                         lambda c, _: f"{fixed(c.mean_intimate_s, 2)} / {fixed(c.mean_personal_s, 2)}"))
    if s.costs_recorded:
        sections.append(("Cost to others (s per episode)",
                         "Mean time the robot stood in a door or a corridor's middle third while someone who reacts to "
                         "it waited or detoured / mean delay it caused the attentive people who noticed it, against the "
                         "same people without the robot (over the episodes where someone noticed it; noisy per "
                         "episode, a crowd amplifies small differences).",
                         lambda c, _: f"{fixed(c.mean_blocking_s, 2)} / {fixed(c.mean_delay_s, 1)}"))
        sections.append(("Efficiency", "Time to the goal over the route length at v_max (successes) / path "
                         "irregularity (rad of turning per metre driven).",
                         lambda c, _: f"{fixed(c.mean_time_ratio, 2)} / {fixed(c.mean_path_irregularity, 2)}"))
    return "".join(_table(s, *section) for section in sections) + (_oracle_table(s) if ORACLE in s.methods else "")


def summary_markdown(s: Summary, run: RunInfo) -> str:
    """summary.md: title, the run's header, the tables."""
    return f"# Evaluation summary\n\n{run_header(run)}\n\n{summary_tables(s)}"


def console_table(s: Summary) -> str:
    """Success, collision and timeout rate per count and method and the mean row, in fixed-width columns."""
    def row(label: str, cells: list[Cell]) -> str:
        texts = [f"{c.success_rate:.2f} c{c.collision_rate:.2f} t{c.timeout_rate:.2f}" if c.episodes else EMPTY
                 for c in cells]
        return f"{label:>9}" + "".join(f"  {t:>22}" for t in texts)

    lines = ["obstacles" + "".join(f"  {m:>22}" for m in s.methods)]
    lines += [row(str(n), [s.cell(m, n) for m in s.methods]) for n in s.counts]
    lines.append(row("mean", [s.overall[m] for m in s.methods]))
    lines.append("(success, c = collision, t = timeout rates)")
    return "\n".join(lines)


# ----------------------------------------------------------------------------------------------- plots


def _figure(width_in: float, height_in: float) -> Figure:
    fig = Figure(figsize=(width_in, height_in), dpi=100, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def plot_success_vs_obstacles(s: Summary, path: str) -> Figure:
    """Success rate against obstacle count, a line per method labelled with its mean, the legend right of the
    axes inside the figure; writes the PNG and returns the figure."""
    fig = _figure(8.5, 5.0)
    ax = fig.add_subplot()
    for m in s.methods:
        ax.plot(s.counts, [s.cell(m, n).success_rate for n in s.counts], marker="o", ms=4,
                label=f"{m} ({fixed(s.overall[m].success_rate)})")
    ax.set_xticks(s.counts)
    ax.set_ylim(0.0, 1.02)
    ax.set_xlabel("obstacles")
    ax.set_ylabel("success rate")
    ax.set_title("Success rate vs number of obstacles")
    ax.grid(alpha=0.3)
    fig.legend(loc="outside right upper", fontsize=9, title="method (mean)")
    fig.savefig(path)
    return fig


@dataclass
class ObstaclePath:
    radius: float
    static: bool
    path: list[tuple[float, float]]


@dataclass
class KeptEpisode:
    """One episode of paths.json: its record and the paths kept for the plot."""

    method: str
    obstacles: int
    episode: int
    scenario: str
    outcome: str
    time_s: float
    path_length_m: float
    min_clearance_m: float
    goal: tuple[float, float]
    goal_tolerance_m: float
    room_half_size_m: float
    walls: list[tuple[float, float, float, float]]
    robot_path: list[tuple[float, float, float]]
    obstacle_paths: list[ObstaclePath]

    @property
    def file_name(self) -> str:
        return f"trajectories_{self.method}_n{self.obstacles}_e{self.episode}.png"



def _number(data: dict, key: str) -> float:
    if not _type_ok(data.get(key), float):
        raise ValueError(f"'{key}' must be a number, got {data.get(key)!r}")
    return float(data[key])


def _text(data: dict, key: str) -> str:
    if not isinstance(data.get(key), str):
        raise ValueError(f"'{key}' must be a string, got {data.get(key)!r}")
    return data[key]


def _points(data: dict, key: str, size: int) -> list[tuple[float, ...]]:
    value = data.get(key)
    if not isinstance(value, list) or not all(
            isinstance(p, list) and len(p) == size and all(_type_ok(v, float) for v in p) for p in value):
        raise ValueError(f"'{key}' must be a list of [{size} numbers]")
    return [tuple(float(v) for v in p) for p in value]


def _obstacle(data: object) -> ObstaclePath:
    if not isinstance(data, dict) or not isinstance(data.get("static"), bool):
        raise ValueError("an obstacle needs 'radius' (a number), 'static' (true or false) and 'path'")
    return ObstaclePath(_number(data, "radius"), data["static"], _points(data, "path", 2))


def _kept_episode(data: object) -> KeptEpisode:
    if not isinstance(data, dict):
        raise ValueError("expected an object")
    if not isinstance(data.get("obstacle_paths"), list):
        raise ValueError("'obstacle_paths' must be the list of obstacle paths")
    count = data.get("obstacles")
    robot = _points(data, "robot_path", 3)
    goal = data.get("goal")
    if not robot:
        raise ValueError("'robot_path' is empty")
    if not _type_ok(count, int) or not _type_ok(data.get("episode"), int):
        raise ValueError("the obstacle count and 'episode' must be integers")
    if not (isinstance(goal, list) and len(goal) == 2 and all(_type_ok(v, float) for v in goal)):
        raise ValueError(f"'goal' must be [x, y], got {goal!r}")
    return KeptEpisode(
        method=_text(data, "method"), obstacles=count, episode=data["episode"], scenario=_text(data, "scenario"),
        outcome=_outcome(data.get("outcome")), time_s=_number(data, "time_s"),
        path_length_m=_number(data, "path_length_m"), min_clearance_m=_number(data, "min_clearance_m"),
        goal=(float(goal[0]), float(goal[1])), goal_tolerance_m=_number(data, "goal_tolerance_m"),
        room_half_size_m=_number(data, "room_half_size_m"), walls=_points(data, "walls", 4), robot_path=robot,
        obstacle_paths=[_obstacle(o) for o in data["obstacle_paths"]])


def read_paths(path: str) -> list[KeptEpisode]:
    """The episodes of paths.json; raises ValueError naming the file, the episode and the malformed item."""
    with open(path) as f:
        try:
            data = json.load(f)
        except json.JSONDecodeError as e:
            raise ValueError(f"{path}: not valid JSON ({e})") from None
    if not isinstance(data, dict) or not isinstance(data.get("episodes"), list):
        raise ValueError(f"{path}: expected an object with a list 'episodes'")
    episodes = []
    for i, item in enumerate(data["episodes"]):
        try:
            episodes.append(_kept_episode(item))
        except ValueError as e:
            raise ValueError(f"{path}: episodes[{i}]: {e}") from None
    return episodes


MOVING_COLOUR, STATIC_COLOUR, ROBOT_COLOUR, GOAL_COLOUR = "tab:red", "0.45", "tab:blue", "tab:green"
STATIC_FILL = "0.85"
ROBOT_RADIUS_M, HEADING_M = 0.2, 0.3


def _draw_obstacle(ax, o: ObstaclePath) -> None:
    if not o.path:
        return
    colour = STATIC_COLOUR if o.static else MOVING_COLOUR
    xs, ys = zip(*o.path)
    ax.plot(xs, ys, color=colour, lw=1)
    ax.add_patch(Circle(o.path[0], o.radius, ec=colour, fc=STATIC_FILL if o.static else "none", lw=1))
    ax.plot(xs[-1], ys[-1], marker="x", ms=9, mew=2, color=colour)


def _draw_robot(ax, e: KeptEpisode) -> None:
    xs, ys, _ = zip(*e.robot_path)
    ax.plot(xs, ys, color=ROBOT_COLOUR, lw=2)
    ax.add_patch(Circle((xs[0], ys[0]), ROBOT_RADIUS_M, fill=False, color=ROBOT_COLOUR, lw=1))
    x, y, theta = e.robot_path[-1]
    ax.add_patch(Circle((x, y), ROBOT_RADIUS_M, fill=False, color=ROBOT_COLOUR, lw=2))
    ax.annotate("", xy=(x + HEADING_M * math.cos(theta), y + HEADING_M * math.sin(theta)), xytext=(x, y),
                arrowprops={"arrowstyle": "->", "color": ROBOT_COLOUR, "lw": 2})


def _trajectory_legend() -> tuple[list[Line2D], list[str]]:
    entries = [
        (Line2D([], [], color=ROBOT_COLOUR, lw=2), "robot path"),
        (Line2D([], [], color=ROBOT_COLOUR, marker="o", mfc="none", ls="none"), "robot start, end and heading"),
        (Line2D([], [], color=GOAL_COLOUR, marker="o", alpha=0.4, ms=10, ls="none"), "goal with its tolerance"),
        (Line2D([], [], color=MOVING_COLOUR, lw=1), "moving obstacle path"),
        (Line2D([], [], color=STATIC_COLOUR, marker="o", mfc=STATIC_FILL, ms=9, ls="none"), "static obstacle"),
        (Line2D([], [], color="k", marker="o", mfc="none", ls="none"), "obstacle start"),
        (Line2D([], [], color="k", marker="x", mew=2, ls="none"), "final obstacle position"),
        (Line2D([], [], color="k", lw=2.5), "walls"),
    ]
    return [h for h, _ in entries], [label for _, label in entries]


def plot_trajectory(e: KeptEpisode, path: str) -> Figure:
    """One episode from above: the room and its walls, every obstacle's path (start circled, final position an X,
    static ones grey), the robot's path, start and end heading, the goal with its tolerance; axes in metres, a
    legend with the path length and the smallest clearance inside the figure. Writes the PNG, returns the figure."""
    fig = _figure(9.0, 6.5)
    ax = fig.add_subplot()
    half = e.room_half_size_m
    ax.add_patch(Rectangle((-half, -half), 2 * half, 2 * half, fill=False, color="k", lw=2.5))
    for x1, y1, x2, y2 in e.walls:
        ax.plot([x1, x2], [y1, y2], color="k", lw=2.5)
    for o in e.obstacle_paths:
        _draw_obstacle(ax, o)
    ax.add_patch(Circle(e.goal, e.goal_tolerance_m, color=GOAL_COLOUR, alpha=0.4, lw=0))
    ax.plot(*e.goal, marker="+", ms=8, color=GOAL_COLOUR)
    _draw_robot(ax, e)
    margin = 0.3
    ax.set_xlim(-half - margin, half + margin)
    ax.set_ylim(-half - margin, half + margin)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(f"{e.method}  scenario {e.scenario}  {e.outcome} after {e.time_s:.1f} s")
    handles, labels = _trajectory_legend()
    handles += [Line2D([], [], ls="none")] * 2
    labels += [f"path {fixed(e.path_length_m)} m", f"min clearance {fixed(e.min_clearance_m)} m"]
    fig.legend(handles, labels, loc="outside right upper", fontsize=9)
    fig.savefig(path)
    return fig


# ----------------------------------------------------------------------------------------------- report


def report(out_dir: str, reference: str | None = None) -> tuple[Summary, list[str]]:
    """Reads OUT_DIR's records and writes its summary, figures and plots; returns the summary and the files written.
    `reference` defaults to run.json's. Raises ValueError naming the file and the reason."""
    results = os.path.join(out_dir, "results.csv")
    run = read_run(os.path.join(out_dir, "run.json"))
    records = read_results(results)
    try:
        s = summarize(records, reference or run.reference, run.methods)
    except ValueError as e:
        raise ValueError(f"{results}: {e}") from None
    written = []
    for name, text in ((SUMMARY_MD, summary_markdown(s, run)), (SUMMARY_JSON, summary_json(s))):
        written.append(os.path.join(out_dir, name))
        with open(written[-1], "w") as f:
            f.write(text)
    written.append(os.path.join(out_dir, SUCCESS_PNG))
    plot_success_vs_obstacles(s, written[-1])
    paths = os.path.join(out_dir, "paths.json")
    for e in read_paths(paths) if os.path.exists(paths) else []:
        written.append(os.path.join(out_dir, e.file_name))
        plot_trajectory(e, written[-1])
    return s, written


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m dqn_dovs_py.report", description=__doc__.splitlines()[0])
    p.add_argument("out_dir", metavar="OUT_DIR", help="dqn_dovs_eval's --out folder (results.csv, run.json)")
    p.add_argument("--reference", metavar="METHOD", help="method of the time ratios (default: run.json's)")
    a = p.parse_args(argv)
    try:
        s, written = report(a.out_dir, a.reference)
    except (OSError, ValueError) as e:
        print(f"report: {e}", file=sys.stderr)
        return 1
    print(console_table(s))
    for path in written:
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
