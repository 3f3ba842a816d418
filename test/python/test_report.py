"""dqn_dovs_py.report: every figure on a hand-built results.csv with known answers (rates, mean row, time ratio on
episodes both solved, danger frequency, clearance, collision kinds, contact speed with its nearest-rank 95th
percentile, empty cells as NaN), summary.md's layout, summary.json's keys, the PNGs and their legends, the
trajectory plot from paths.json, the errors and the command line."""

import csv
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest
from PIL import Image

from dqn_dovs_py import report as rp

ROOT = Path(__file__).resolve().parents[2]

# (method, obstacles, episode, outcome, time_s, danger_steps, steps, min_clearance_m, collision_kind, contact_speed)
# dqn_dovs is the reference. s_dovs's (3, 2) is solved by s_dovs only: it must not enter the time ratio. dwa has no
# episode with 2 obstacles: an empty cell.
ROWS = [
    ("dqn_dovs", 2, 1, "success", 10.0, 1, 50, 0.5, "", ""),
    ("dqn_dovs", 2, 2, "success", 20.0, 0, 100, 0.3, "", ""),
    ("dqn_dovs", 3, 1, "success", 10.0, 4, 50, 0.2, "", ""),
    ("dqn_dovs", 3, 2, "collision", 3.0, 5, 15, 0.0, "rest", 0.01),
    ("s_dovs", 2, 1, "success", 15.0, 0, 75, 0.4, "", ""),
    ("s_dovs", 2, 2, "timeout", 100.0, 10, 500, 0.6, "", ""),
    ("s_dovs", 3, 1, "success", 12.0, 2, 60, 0.3, "", ""),
    ("s_dovs", 3, 2, "success", 50.0, 0, 250, 0.5, "", ""),
    ("dwa", 3, 1, "collision", 2.0, 3, 10, 0.0, "static", 0.8),
    ("dwa", 3, 2, "collision", 2.0, 3, 10, 0.0, "moving", 0.4),
    ("dwa", 3, 3, "collision", 2.0, 3, 10, 0.0, "moving", 0.6),
]
METHODS = ["dqn_dovs", "s_dovs", "dwa"]

RUN = {"command": "dqn_dovs_eval --methods dqn_dovs,s_dovs,dwa --generate 7 --obstacles 2-3 --episodes 3",
       "scenarios": "generated", "seed": 7, "obstacles_min": 2, "obstacles_max": 3, "episodes": 3,
       "dynamic_fraction": 0.85, "perfect_info": False, "step_s": 0.2, "max_steps": 500, "wall_s": 1.26,
       "threads": 2, "methods": METHODS, "reference": "dqn_dovs", "goal_tolerance_m": 0.15}

# One kept episode as the evaluation writes it: the obstacle count, then the obstacles' paths.
PATHS_JSON = """{"episodes": [{"method": "dqn_dovs", "obstacles": 2, "episode": 1, "scenario": "generated/7/2/1",
  "outcome": "success", "time_s": 9.2, "path_length_m": 4.93, "min_clearance_m": 0.346, "goal": [2.0, 1.5],
  "goal_tolerance_m": 0.15, "room_half_size_m": 3.0, "walls": [[-1.0, -3.0, -1.0, -1.5]],
  "robot_path": [[-2.0, -2.0, 0.0], [-1.0, -1.0, 0.7], [0.5, 0.5, 0.8], [2.0, 1.45, 0.6]],
  "obstacle_paths": [{"radius": 0.3, "static": false, "path": [[1.0, -2.0], [1.0, -1.0], [1.2, 0.0]]},
                {"radius": 0.25, "static": true, "path": [[-2.0, 1.0], [-2.0, 1.0]]}]}]}
"""


def write_results(path: Path, rows=ROWS, columns=rp.RESULTS_COLUMNS) -> Path:
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(columns)
        for m, n, k, outcome, t, danger, steps, clearance, kind, speed in rows:
            row = {"method": m, "obstacles": n, "episode": k, "scenario": f"generated/7/{n}/{k}", "outcome": outcome,
                   "time_s": t, "path_length_m": 5.0, "min_clearance_m": clearance, "danger_steps": danger,
                   "steps": steps, "planner_errors": 0, "collision_kind": kind, "contact_speed_mps": speed,
                   "last_decision": "action 1 (shield: robust)"}
            w.writerow([row[c] for c in columns])
    return path


def add_columns(path: Path, extra: tuple[str, ...], cells) -> None:
    """Rewrites the results.csv at `path` with the `extra` columns after the others, each row's values cells(row) (a
    dict of them), as dqn_dovs_eval writes its optional columns."""
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        columns, rows = list(reader.fieldnames) + list(extra), list(reader)
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=columns)
        w.writeheader()
        for row in rows:
            row.update(cells(row))
            w.writerow(row)


def make_run(tmp_path: Path, rows=ROWS, run=RUN, paths: str | None = PATHS_JSON) -> Path:
    out = tmp_path / "run"
    out.mkdir(parents=True)
    write_results(out / "results.csv", rows)
    (out / "run.json").write_text(json.dumps(run))
    if paths is not None:
        (out / "paths.json").write_text(paths)
    return out


@pytest.fixture
def summary(tmp_path):
    return rp.summarize(rp.read_results(write_results(tmp_path / "results.csv")), "dqn_dovs", METHODS)


# ----------------------------------------------------------------------------------------------- figures


def test_rates_and_the_mean_row(summary):
    c = summary.cell("s_dovs", 2)
    assert (c.episodes, c.success_rate, c.collision_rate, c.timeout_rate) == (2, 0.5, 0.0, 0.5)
    assert summary.cell("dqn_dovs", 3).collision_rate == 0.5
    # The mean row is the mean of the per-count rates.
    assert summary.overall["dqn_dovs"].success_rate == pytest.approx((1.0 + 0.5) / 2)
    assert summary.overall["s_dovs"].timeout_rate == pytest.approx((0.5 + 0.0) / 2)
    assert summary.methods == METHODS and summary.counts == [2, 3]


def test_time_ratio_on_episodes_both_solved(summary):
    assert summary.cell("s_dovs", 2).time_ratio == pytest.approx(15 / 10)
    # (3, 2): dqn_dovs collided, so s_dovs's 50 s do not count.
    assert summary.cell("s_dovs", 3).time_ratio == pytest.approx(12 / 10)
    assert summary.cell("s_dovs", 3).both_solved == 1
    # The mean row pools every episode both solved: (15 + 12) / (10 + 10), not the mean of 1.5 and 1.2.
    assert summary.overall["s_dovs"].time_ratio == pytest.approx(27 / 20)
    assert summary.overall["s_dovs"].both_solved == 2
    assert summary.cell("dqn_dovs", 2).time_ratio == 1.0
    assert math.isnan(summary.cell("dwa", 3).time_ratio)  # no success


def test_time_danger_and_clearance(summary):
    assert summary.cell("dqn_dovs", 2).mean_time_success_s == pytest.approx(15.0)
    assert summary.overall["s_dovs"].mean_time_success_s == pytest.approx((15 + 12 + 50) / 3)
    assert math.isnan(summary.cell("dwa", 3).mean_time_success_s)
    assert summary.cell("dqn_dovs", 3).danger_frequency == pytest.approx(9 / 65)
    assert summary.overall["dqn_dovs"].danger_frequency == pytest.approx(10 / 215)  # pooled, not a mean of ratios
    assert summary.cell("dqn_dovs", 2).mean_min_clearance_m == pytest.approx(0.4)
    assert summary.overall["s_dovs"].mean_min_clearance_m == pytest.approx(1.8 / 4)


def test_collision_kinds_and_contact_speed(summary):
    dwa = summary.cell("dwa", 3)
    assert dwa.collisions == 3 and dwa.collisions_by_kind == {"static": 1, "rest": 0, "moving": 2}
    assert dwa.mean_contact_speed_mps == pytest.approx(0.6)
    assert dwa.p95_contact_speed_mps == 0.8  # rank ceil(2.85) = 3; interpolation would give 0.78
    assert summary.overall["dqn_dovs"].collisions_by_kind == {"static": 0, "rest": 1, "moving": 0}
    assert summary.overall["dqn_dovs"].p95_contact_speed_mps == 0.01
    assert math.isnan(summary.cell("s_dovs", 3).mean_contact_speed_mps)
    assert math.isnan(summary.cell("s_dovs", 3).p95_contact_speed_mps)


def test_nearest_rank():
    assert math.isnan(rp.nearest_rank([], 0.95))
    assert rp.nearest_rank(list(range(20, 0, -1)), 0.95) == 19  # ceil(19) = 19, not the largest
    assert rp.nearest_rank(list(range(1, 22)), 0.95) == 20  # ceil(19.95) = 20


def test_a_method_without_episodes_at_a_count_is_nan_not_zero(summary):
    empty = summary.cell("dwa", 2)
    assert empty.episodes == 0
    for value in (empty.success_rate, empty.collision_rate, empty.timeout_rate, empty.danger_frequency,
                  empty.mean_min_clearance_m, empty.time_ratio):
        assert math.isnan(value)
    # The mean row averages the counts the method ran: 1.0, not (0 + 1.0) / 2.
    assert summary.overall["dwa"].collision_rate == 1.0
    figures = rp.summary_figures(summary)
    assert math.isnan(figures["dwa.success_2"]) and figures["dwa.success_3"] == 0.0
    assert "dwa.success_2" not in json.loads(rp.summary_json(summary))


def test_reference_errors(tmp_path):
    records = rp.read_results(write_results(tmp_path / "results.csv"))
    with pytest.raises(ValueError, match=r"reference method 'orca' has no episodes \(methods: dqn_dovs, s_dovs, dwa\)"):
        rp.summarize(records, "orca")
    twice = records + [records[0]]
    with pytest.raises(ValueError, match="'dqn_dovs' has two records for 2 obstacles, episode 1"):
        rp.summarize(twice, "dqn_dovs")


# ----------------------------------------------------------------------------------------------- files


def test_summary_json_keys(summary):
    figures = json.loads(rp.summary_json(summary))
    assert list(figures)[:13] == [
        "dqn_dovs.success_mean", "dqn_dovs.collision_mean", "dqn_dovs.timeout_mean", "dqn_dovs.mean_time_success_s",
        "dqn_dovs.danger_frequency", "dqn_dovs.episodes", "dqn_dovs.collisions", "dqn_dovs.collisions_static",
        "dqn_dovs.collisions_rest", "dqn_dovs.collisions_moving", "dqn_dovs.contact_speed_mean",
        "dqn_dovs.contact_speed_p95", "dqn_dovs.success_2"]
    assert figures["s_dovs.time_ratio_mean"] == pytest.approx(1.35)
    assert "dqn_dovs.time_ratio_mean" not in figures  # the reference has no ratio
    assert figures["dwa.collision_mean"] == 1.0 and figures["dwa.episodes"] == 3
    assert figures["dwa.collisions_static"] == 1 and figures["dwa.contact_speed_p95"] == 0.8
    # NaN figures are left out: no success, no contact, no ratio.
    assert not {"dwa.mean_time_success_s", "dwa.time_ratio_mean", "s_dovs.contact_speed_mean"} & set(figures)
    assert all(isinstance(v, (int, float)) and math.isfinite(v) for v in figures.values())


def test_collisions_with_moving_bodies_are_counted_by_what_the_planner_knew(tmp_path):
    path = write_results(tmp_path / "r.csv")
    # The hit columns of each row as dqn_dovs_eval writes them: empty but for collisions with a moving body.
    causes = {("dqn_dovs", "3", "2"): ("unseen", "0", "", "", "172.5"),
              ("dwa", "3", "2"): ("foreseen", "2", "0.12", "0.4", "3"),
              ("dwa", "3", "3"): ("mispredicted", "1.4", "0.61", "", "40")}
    add_columns(path, rp.HIT_COLUMNS, lambda row: dict(zip(rp.HIT_COLUMNS, causes.get(
        (row["method"], row["obstacles"], row["episode"]), ("",) * len(rp.HIT_COLUMNS)))))
    records = rp.read_results(str(path))
    assert records[3].hit_cause == "unseen" and records[3].hit_bearing_deg == 172.5
    assert math.isnan(records[3].hit_prediction_error_m) and records[0].hit_cause == ""
    assert records[9].hit_prediction_error_2s_m == 0.4 and math.isnan(records[10].hit_prediction_error_2s_m)
    s = rp.summarize(records, "dqn_dovs", METHODS)
    # dwa's wall contact is not a hit by a moving body: it counts in no cause.
    assert s.overall["dwa"].hits_by_cause == {"unseen": 0, "late": 0, "mispredicted": 1, "foreseen": 1}
    assert s.cell("dqn_dovs", 3).hits_by_cause == {"unseen": 1, "late": 0, "mispredicted": 0, "foreseen": 0}
    figures = json.loads(rp.summary_json(s))
    assert figures["dwa.hits_foreseen"] == 1 and figures["dqn_dovs.hits_unseen"] == 1
    md = rp.summary_tables(s)
    assert "## Collisions with moving bodies by what the planner knew" in md
    assert "| mean | 1 / 0 / 0 / 0 | 0 / 0 / 0 / 0 | 0 / 0 / 1 / 1 |" in md
    assert md.index("## Robot speed at contact") < md.index("## Collisions with moving bodies") < md.index(
        "## Timeout rate")
    # Without the columns (runs written before them) the causes are not recorded: `-`, no figure.
    old = rp.summarize(rp.read_results(write_results(tmp_path / "old.csv")), "dqn_dovs", METHODS)
    assert old.overall["dqn_dovs"].hits_by_cause is None
    assert "dqn_dovs.hits_unseen" not in json.loads(rp.summary_json(old))
    assert "by what the planner knew" not in rp.summary_tables(old)
    # A cause the reader does not know is named with its file and line.
    bad = tmp_path / "bad.csv"
    bad.write_text(path.read_text().replace("mispredicted", "bad luck"))
    with pytest.raises(ValueError, match=r"bad\.csv:\d+: unknown hit_cause 'bad luck'"):
        rp.read_results(str(bad))


def test_contacts_say_who_hit_whom_and_the_passive_safety_rate_follows(tmp_path):
    path = write_results(tmp_path / "r.csv")
    # dqn_dovs was hit at rest; dwa hit a wall, drove into a person, and was walked into right after stopping.
    faults = {("dqn_dovs", "3", "2"): ("person_on_robot", "0"), ("dwa", "3", "1"): ("static", "1"),
              ("dwa", "3", "2"): ("robot_on_person", "1"), ("dwa", "3", "3"): ("person_on_robot", "1")}
    def cells(row):
        contact, fault = faults.get((row["method"], row["obstacles"], row["episode"]), ("", ""))
        verdict = row["outcome"] if not fault else "collision_robot_at_fault" if fault == "1" else "hit_at_rest"
        return {"contact": contact, "at_fault": fault, "intimate_s": "0.4" if row["method"] == "dwa" else "0",
                "personal_s": "1.2", "verdict": verdict}
    add_columns(path, rp.FAULT_COLUMNS + rp.COMFORT_COLUMNS + ("verdict",), cells)
    records = rp.read_results(str(path))
    assert records[3].contact == "person_on_robot" and records[3].at_fault is False and records[0].at_fault is None
    assert [records[i].verdict for i in (0, 3, 5, 8)] == ["success", "hit_at_rest", "timeout",
                                                         "collision_robot_at_fault"]
    s = rp.summarize(records, "dqn_dovs", METHODS)
    assert s.faults_recorded
    assert (s.overall["dqn_dovs"].at_fault, s.overall["dqn_dovs"].hit_at_rest) == (0, 1)
    assert s.overall["dqn_dovs"].passive_safety_rate == 1.0
    assert s.cell("dwa", 3).at_fault == 3 and s.cell("dwa", 3).passive_safety_rate == 0.0
    md = rp.summary_tables(s)
    assert "## Passive safety" in md and "| 3 | 1.00 (0 / 1) | 1.00 (0 / 0) | 0.00 (3 / 0) |" in md
    assert md.index("## Collisions by kind") < md.index("## Passive safety") < md.index("## Robot speed at contact")
    assert "| mean | 0.00 / 1.20 | 0.00 / 1.20 | 0.40 / 1.20 |" in md
    # Without the columns the section is left out, and a value the reader does not know is named.
    assert "## Passive safety" not in rp.summary_tables(rp.summarize(rp.read_results(write_results(
        tmp_path / "old.csv")), "dqn_dovs", METHODS))
    bad = tmp_path / "bad.csv"
    bad.write_text(path.read_text().replace("robot_on_person", "robot_on_cat"))
    with pytest.raises(ValueError, match=r"bad\.csv:\d+: unknown contact 'robot_on_cat'"):
        rp.read_results(str(bad))
    bad.write_text(path.read_text().replace("hit_at_rest", "bad luck"))
    with pytest.raises(ValueError, match=r"bad\.csv:\d+: unknown verdict 'bad luck'"):
        rp.read_results(str(bad))


def test_summary_json_of_one_method_has_no_prefix(tmp_path):
    records = rp.read_results(write_results(tmp_path / "r.csv", [r for r in ROWS if r[0] == "s_dovs"]))
    figures = json.loads(rp.summary_json(rp.summarize(records, "s_dovs")))
    assert figures["success_mean"] == 0.75 and figures["success_3"] == 1.0 and "time_ratio_mean" not in figures


def test_summary_markdown_layout(summary):
    text = rp.summary_markdown(summary, rp.RunInfo(**RUN))
    assert text.startswith(
        "# Evaluation summary\n\n"
        f"Command: `{RUN['command']}`  \n"
        "Scenarios: generated, seed 7; obstacles 2-3, 3 episodes each; dynamic fraction 0.85  \n"
        "Perception: LIDAR + tracker in the loop; step 0.2 s, limit 500 steps  \n"
        "Wall time: 1.3 s on 2 thread(s)\n\n"
        "## Success rate\n\n"
        "Reached the goal and stopped on it. In brackets: total time of the method over total time of `dqn_dovs` on "
        "the episodes both solved.\n\n"
        "| Obs | dqn_dovs | s_dovs | dwa |\n|---|---|---|---|\n"
        "| 2 | 1.00 | 0.50 (1.50) | – |\n"
        "| 3 | 0.50 | 1.00 (1.20) | 0.00 (-) |\n"
        "| mean | 0.75 | 0.75 (1.35) | 0.00 (-) |\n\n## Collision rate\n\n")
    assert text.endswith("| mean | 0.047 | 0.014 | 0.300 |\n\n")
    titles = [line for line in text.splitlines() if line.startswith("## ")]
    assert titles == ["## Success rate", "## Collision rate", "## Collisions by kind",
                      "## Robot speed at contact (m/s)", "## Timeout rate", "## Mean time on success (s)",
                      "## Danger frequency"]
    assert "| 3 | 0 / 1 / 0 | 0 / 0 / 0 | 1 / 0 / 2 |\n" in text
    assert "| 3 | 0.010 (0.010) | - (-) | 0.600 (0.800) |\n" in text
    assert "| 2 | 15.0 | 15.0 | – |\n" in text
    assert "(below 0.05 m/s: walked into)" in text


def test_header_of_a_scenario_folder_with_perfect_information():
    run = rp.RunInfo(**{**RUN, "scenarios": "data/scenarios/room", "perfect_info": True, "dynamic_fraction": 1})
    header = rp.run_header(run).splitlines()
    assert header[1] == "Scenarios: `data/scenarios/room`; obstacles 2-3, 3 episodes each; dynamic fraction 1  "
    assert header[2].startswith("Perception: perfect information (ground truth); ")
    predicted = rp.run_header(rp.RunInfo(**{**RUN, "people_predictor": "models/people_predictor_tracks.dqnp"}))
    assert ("Perception: LIDAR + tracker in the loop; moving obstacles on the arcs of the learned prediction "
            "`models/people_predictor_tracks.dqnp`; step 0.2 s") in predicted
    mapped = rp.run_header(rp.RunInfo(**{**RUN, "tracker_map": True}))
    assert "Perception: LIDAR + tracker in the loop; the tracker given the map's walls and furniture; step" in mapped
    both = rp.run_header(rp.RunInfo(**{**RUN, "tracker_map": True, "dovs_map": True}))
    assert "the tracker given the map's walls and furniture; the map's walls near the robot beside the scan's" in both


def test_console_table(summary):
    lines = rp.console_table(summary).splitlines()
    assert lines[0] == "obstacles" + "".join(f"  {m:>22}" for m in METHODS)
    assert lines[1] == f"{'2':>9}  {'1.00 c0.00 t0.00':>22}  {'0.50 c0.00 t0.50':>22}  {'–':>22}"
    assert lines[3] == f"{'mean':>9}  {'0.75 c0.25 t0.00':>22}  {'0.75 c0.00 t0.25':>22}  {'0.00 c1.00 t0.00':>22}"


def _legend_inside(fig) -> bool:
    fig.canvas.draw()
    box, page = fig.legends[0].get_window_extent(), fig.bbox
    return page.x0 <= box.x0 and box.x1 <= page.x1 and page.y0 <= box.y0 and box.y1 <= page.y1


def _png_size(path: Path) -> tuple[int, int]:
    with Image.open(path) as img:
        assert img.format == "PNG"
        img.verify()
        return img.size


def test_success_plot_has_every_method_and_its_legend_inside(tmp_path, summary):
    path = tmp_path / "success.png"
    fig = rp.plot_success_vs_obstacles(summary, str(path))
    assert _png_size(path) == (round(fig.bbox.width), round(fig.bbox.height))
    assert [t.get_text() for t in fig.legends[0].get_texts()] == ["dqn_dovs (0.75)", "s_dovs (0.75)", "dwa (0.00)"]
    assert _legend_inside(fig)
    dwa = fig.axes[0].get_lines()[2].get_ydata()
    assert math.isnan(dwa[0]) and dwa[1] == 0.0  # the empty cell is a gap, not 0


def test_trajectory_plot(tmp_path):
    (tmp_path / "paths.json").write_text(PATHS_JSON)
    [episode] = rp.read_paths(str(tmp_path / "paths.json"))
    assert (episode.obstacles, episode.file_name) == (2, "trajectories_dqn_dovs_n2_e1.png")
    assert [o.static for o in episode.obstacle_paths] == [False, True]
    path = tmp_path / episode.file_name
    fig = rp.plot_trajectory(episode, str(path))
    assert _png_size(path) == (round(fig.bbox.width), round(fig.bbox.height))
    ax = fig.axes[0]
    assert ax.get_title() == "dqn_dovs  scenario generated/7/2/1  success after 9.2 s"
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert "path 4.93 m" in labels and "min clearance 0.35 m" in labels and "goal with its tolerance" in labels
    assert _legend_inside(fig)
    colours = {tuple(line.get_xdata()): line.get_color() for line in ax.get_lines()}
    assert colours[(1.0, 1.0, 1.2)] == rp.MOVING_COLOUR and colours[(-2.0, -2.0)] == rp.STATIC_COLOUR
    assert colours[(-2.0, -1.0, 0.5, 2.0)] == rp.ROBOT_COLOUR
    assert ax.get_xlim() == pytest.approx((-3.3, 3.3))


# ----------------------------------------------------------------------------------------------- end to end


def test_report_writes_every_file(tmp_path):
    out = make_run(tmp_path)
    s, written = rp.report(str(out))
    names = [os.path.basename(p) for p in written]
    assert names == ["summary.md", "summary.json", "success_vs_obstacles.png", "trajectories_dqn_dovs_n2_e1.png"]
    assert all(os.path.getsize(p) > 0 for p in written)
    assert json.loads((out / "summary.json").read_text())["s_dovs.time_ratio_mean"] == pytest.approx(1.35)
    # Another reference: the ratios are against it.
    s, _ = rp.report(str(out), "s_dovs")
    assert s.reference == "s_dovs" and s.cell("dqn_dovs", 2).time_ratio == pytest.approx(10 / 15)
    assert "total time of `s_dovs`" in (out / "summary.md").read_text()


def run_cli(*args: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT / "python"), os.environ.get("PYTHONPATH", "")])}
    return subprocess.run([sys.executable, "-m", "dqn_dovs_py.report", *args], capture_output=True, text=True,
                          env=env, timeout=120)


def test_cli_prints_the_table_and_the_files(tmp_path):
    out = make_run(tmp_path, paths=None)
    proc = run_cli(str(out))
    assert proc.returncode == 0, proc.stderr
    assert "Warning" not in proc.stderr
    lines = proc.stdout.splitlines()
    assert lines[0].startswith("obstacles") and lines[3].lstrip().startswith("mean  ")
    assert lines[4] == "(success, c = collision, t = timeout rates)"
    assert lines[5:] == [f"wrote {out / name}" for name in ("summary.md", "summary.json", "success_vs_obstacles.png")]


@pytest.mark.parametrize("case, message", [
    ("no results", r"results\.csv: no such file"),
    ("missing column", r"results\.csv: missing columns \['collision_kind'\]"),
    ("bad row", r"results\.csv:3: invalid literal for int\(\)"),
    ("bad outcome", r"results\.csv:2: unknown outcome 'crashed'"),
    ("unknown reference", r"results\.csv: reference method 'orca' has no episodes"),
    ("no run", r"run\.json: no such file"),
    ("run not json", r"run\.json: not valid JSON"),
    ("run missing key", r"run\.json: missing key 'seed'"),
    ("run wrong type", r"run\.json: 'perfect_info' must be true or false, got 'no'"),
    ("paths malformed", r"paths\.json: episodes\[0\]: 'robot_path' must be a list of \[3 numbers\]"),
])
def test_errors_name_the_file_and_the_reason(tmp_path, case, message):
    out = make_run(tmp_path)
    if case == "no results":
        (out / "results.csv").unlink()
    elif case == "missing column":
        write_results(out / "results.csv", columns=[c for c in rp.RESULTS_COLUMNS if c != "collision_kind"])
    elif case == "bad row":
        write_results(out / "results.csv", ROWS[:1])
        with open(out / "results.csv", "a") as f:
            f.write("dwa,3,x,s,success,1,1,1,0,1,0,,,\n")
    elif case == "bad outcome":
        write_results(out / "results.csv", [ROWS[0][:3] + ("crashed",) + ROWS[0][4:]])
    elif case == "unknown reference":
        (out / "run.json").write_text(json.dumps({**RUN, "reference": "orca"}))
    elif case == "no run":
        (out / "run.json").unlink()
    elif case == "run not json":
        (out / "run.json").write_text("{command: x")
    elif case == "run missing key":
        (out / "run.json").write_text(json.dumps({k: v for k, v in RUN.items() if k != "seed"}))
    elif case == "run wrong type":
        (out / "run.json").write_text(json.dumps({**RUN, "perfect_info": "no"}))
    elif case == "paths malformed":
        (out / "paths.json").write_text(PATHS_JSON.replace("[0.5, 0.5, 0.8]", "[0.5, 0.5]"))
    with pytest.raises(ValueError, match=message):
        rp.report(str(out))


def test_cli_error_exit_code_and_message(tmp_path):
    out = make_run(tmp_path)
    (out / "results.csv").unlink()
    proc = run_cli(str(out))
    assert proc.returncode == 1
    assert proc.stdout == ""
    assert proc.stderr.strip() == f"report: {out / 'results.csv'}: no such file"
    proc = run_cli(str(make_run(tmp_path / "b")), "--reference", "orca")
    assert proc.returncode == 1 and "reference method 'orca' has no episodes" in proc.stderr


def test_share_of_the_oracles_successes(tmp_path):
    # The oracle solves 3 of the 4 two- and three-obstacle episodes dqn_dovs and s_dovs ran; it fails (3, 2).
    oracle = [("oracle", 2, 1, "success", 8.0, 0, 40, 0.3, "", ""), ("oracle", 2, 2, "success", 9.0, 0, 45, 0.3, "", ""),
              ("oracle", 3, 1, "success", 8.0, 0, 40, 0.3, "", ""),
              ("oracle", 3, 2, "collision", 1.0, 2, 5, 0.0, "moving", 0.3)]
    rows = [r for r in ROWS if r[0] != "dwa"] + oracle
    s = rp.summarize(rp.read_results(write_results(tmp_path / "results.csv", rows)), "dqn_dovs",
                     ["dqn_dovs", "s_dovs", "oracle"])
    assert rp.oracle_share(s, "dqn_dovs", 2) == pytest.approx(1.0)  # 2 of 2
    assert rp.oracle_share(s, "s_dovs", 2) == pytest.approx(0.5)
    assert rp.oracle_share(s, "s_dovs", 3) == pytest.approx(2.0)  # solved one the oracle's search did not
    assert rp.oracle_share(s, "dqn_dovs") == pytest.approx(3 / 3)
    assert rp.summary_figures(s)["s_dovs.oracle_share"] == pytest.approx(3 / 3)  # 1 + 2 of 2 + 1
    text = rp.summary_tables(s)
    assert "## Share of the oracle's successes" in text
    assert "| 3 | 1.00 | 2.00 | 1 / 0 |" in text
    # The bound (the limit from above) is a limit too: no column of its own in the share of the oracle's successes.
    bound = [("bound", n, k, "success", 6.0, 0, 30, 0.3, "", "") for n in (2, 3) for k in (1, 2)]
    with_bound = rp.summarize(rp.read_results(write_results(tmp_path / "bound.csv", rows + bound)), "dqn_dovs",
                              ["dqn_dovs", "s_dovs", "oracle", "bound"])
    shares = rp.summary_tables(with_bound).split("## Share of the oracle's successes")[1]
    assert "| Obs | dqn_dovs | s_dovs | oracle fails |" in shares and "bound" not in shares
    assert "| 3 | 1.00 | 2.00 | 1 / 0 |" in shares
    # Without an oracle in the run: no such table, no such figure.
    plain = rp.summarize(rp.read_results(write_results(tmp_path / "plain.csv")), "dqn_dovs", METHODS)
    assert "oracle" not in rp.summary_tables(plain)
    assert math.isnan(rp.oracle_share(plain, "dqn_dovs"))
    assert not any(k.endswith("oracle_share") for k in rp.summary_figures(plain))
