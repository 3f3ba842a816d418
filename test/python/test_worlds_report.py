"""docs/benchmark_worlds.md generator on hand-built run folders: the family, summary, sensor and people-model tables,
the paired wins / losses and exact sign-test p-values, the plot, runs the tool stopped, the discussion's marked
place, the run record, and the errors for missing or mismatched run folders."""

from __future__ import annotations

import csv
import json
import os
from pathlib import Path

import pytest

from dqn_dovs_py import worlds_report as wr
from dqn_dovs_py.report import HIT_COLUMNS, RESULTS_COLUMNS

EPISODES = 10
SUCCESS_S, COLLISION_S = 12.0, 3.0
# Per run folder: the episodes each method solved (every other episode collides). Runs not listed: both methods
# solve the odd episodes, so no episode is discordant.
ODD = set(range(1, EPISODES + 1, 2))
SOLVED = {
    "room_n5": {"dqn_dovs": {1}, "s_dovs": {2, 3, 4}},  # +1 / -3
    "room_n10": {"dqn_dovs": set(range(1, 11)), "s_dovs": {1, 2}},  # +8 / -0
    "crowd_n10_hokuyo": {"dqn_dovs": set(), "s_dovs": {1, 2, 3, 4, 5, 6}},  # +0 / -6
}


def write_run(runs: Path, spec: wr.RunSpec, solved: dict[str, set[int]] | None = None) -> Path:
    """results.csv and run.json of `spec`'s run, as dqn_dovs_eval writes them: the methods of `solved` (default
    both planners solving ODD). A planner's failure is a collision while moving; the oracle's is a collision at rest
    on odd episodes and a timeout on even ones."""
    folder = runs / spec.name
    folder.mkdir(parents=True)
    solved = solved or {"dqn_dovs": ODD, "s_dovs": ODD}
    with open(folder / "results.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(RESULTS_COLUMNS)
        for method in solved:
            for k in range(1, EPISODES + 1):
                ok = k in solved[method]
                timeout = not ok and method == "oracle" and k % 2 == 0
                outcome = "success" if ok else "timeout" if timeout else "collision"
                kind = "" if ok or timeout else "rest" if method == "oracle" else "moving"
                w.writerow([method, spec.n, k, f"{spec.world}/11001/{spec.n}/{k}", outcome,
                            SUCCESS_S if ok else 100.0 if timeout else COLLISION_S, 5.0, 0.3, 0,
                            60 if ok else 500 if timeout else 15, 0, kind,
                            "" if ok or timeout else 0.0 if method == "oracle" else 0.4, "action 1 (shield: robust)"])
    run = {"command": f"dqn_dovs_eval --world {spec.world} --obstacles {spec.n} --out {folder}",
           "scenarios": "generated", "seed": 11001, "obstacles_min": spec.n, "obstacles_max": spec.n,
           "episodes": EPISODES, "dynamic_fraction": 0.85, "world": spec.world, "sensor": spec.sensor,
           "people_model": spec.people_model, "people_see_robot": spec.people_see_robot, "perfect_info": False,
           "step_s": 0.2, "max_steps": 500, "wall_s": 1.25, "threads": 2, "methods": ["dqn_dovs", "s_dovs"],
           "reference": "dqn_dovs", "goal_tolerance_m": 0.15,
           # As make benchmark-worlds runs them: the learned people prediction wherever there are people.
           "people_predictor": "" if spec.world == "room" else "models/people_predictor_tracks.dqnp"}
    (folder / "run.json").write_text(json.dumps(run))
    return folder


@pytest.fixture
def runs(tmp_path: Path) -> Path:
    root = tmp_path / "benchmark_worlds"
    for spec in wr.all_specs():
        write_run(root, spec, SOLVED.get(spec.name))
    return root


def make_report(runs: Path, tmp_path: Path, discussion: Path | None = None) -> str:
    out = tmp_path / "benchmark_worlds.md"
    wr.write_report(str(runs), str(out), str(discussion or tmp_path / "no_discussion.md"))
    return out.read_text()


def test_every_run_folder_is_expected(runs: Path):
    names = [s.name for s in wr.all_specs()]
    assert len(names) == 6 * 3 + 3 + 3  # the sensor table's sim row and the people table's first are crowd_n10
    assert {"room_n5", "junction_n15", "crowd_n10_rplidar_a1", "crowd_n10_constant", "crowd_n10_orca",
            "crowd_n10_see_robot"} <= set(names)
    assert "crowd_n10_sim" not in names


def test_paired_counts_and_exact_sign_test(runs: Path):
    families = wr.family_comparisons(wr.load_runs(str(runs)))
    room = families["room"]
    assert (room.paired[5].wins, room.paired[5].losses, room.paired[5].episodes) == (1, 3, 10)
    assert room.paired[5].p_value == pytest.approx(2 * (1 + 4) / 2 ** 4)
    assert (room.paired[10].wins, room.paired[10].losses) == (8, 0)
    assert room.paired[10].p_value == pytest.approx(2 / 2 ** 8)
    pooled = room.paired[None]
    assert (pooled.wins, pooled.losses, pooled.episodes) == (9, 3, 30)
    assert pooled.p_value == pytest.approx(2 * (1 + 12 + 66 + 220) / 2 ** 12)
    assert room.significant(10) and not room.significant(5) and not room.significant(None)
    assert families["crowd"].paired[None].wins == families["crowd"].paired[None].losses == 0
    assert families["crowd"].paired[None].p_value == 1.0


def test_family_and_summary_tables(runs: Path, tmp_path: Path):
    text = make_report(runs, tmp_path)
    header = ("| N | `dqn_dovs` success | collision | timeout | time (s) | `s_dovs` success | collision | timeout | "
              "time (s) | wins / losses | p |")
    assert text.count(header) == 6
    assert "| 10 | 1.00 | 0.00 | 0.00 | 12.0 | 0.20 | 0.80 | 0.00 | 12.0 | +8 / -0 of 10 | **0.0078** |" in text
    assert "| 5 | 0.10 | 0.90 | 0.00 | 12.0 | 0.30 | 0.70 | 0.00 | 12.0 | +1 / -3 of 10 | 0.62 |" in text
    # The mean row averages the per-N rates (0.1, 1.0, 0.5) and pools the pairs.
    assert "| all N | 0.53 | 0.47 | 0.00 | 12.0 | 0.33 | 0.67 | 0.00 | 12.0 | +9 / -3 of 30 | 0.15 |" in text
    assert "| room | 0.10 / 0.30 | 1.00 / 0.20 * | 0.50 / 0.50 | 0.53 / 0.33 |" in text
    assert "| crowd | 0.50 / 0.50 | 0.50 / 0.50 | 0.50 / 0.50 | 0.50 / 0.50 |" in text
    assert "- room, N = 10: `dqn_dovs` better (+8 / -0, p = 0.0078)" in text
    assert "- room, N = 5" not in text and "- room, all N pooled" not in text


def test_sensor_and_people_tables(runs: Path, tmp_path: Path):
    text = make_report(runs, tmp_path)
    sensors = text.split("## LIDAR profiles")[1].split("## People models")[0]
    rows = [line for line in sensors.splitlines() if line.startswith("| `")]
    assert [r.split(" | ")[0] for r in rows] == ["| `sim`", "| `hokuyo`", "| `urg04lx`", "| `rplidar_a1`"]
    assert rows[1].endswith("| 0.00 | 1.00 | 0.00 | - | 0.60 | 0.40 | 0.00 | 12.0 | +0 / -6 of 10 | **0.031** |")
    assert rows[0].endswith("+0 / -0 of 10 | 1 |")
    people = text.split("## People models")[1]
    for label in ("social force, robot invisible to people", "constant velocity, robot invisible to people",
                  "social force, people give way to the robot"):
        assert f"| {label} | 0.50 | 0.50 | 0.00 | 12.0 |" in people


def test_what_the_planners_knew_of_what_hit_them(runs: Path, tmp_path: Path):
    # The crowd's runs as dqn_dovs_eval writes them now, with the hit columns: every collision of dqn_dovs came from
    # a body it was never shown, every one of s_dovs from one it foresaw; the other runs lack the columns.
    cause = {"dqn_dovs": ("unseen", "0", "", "", "150"), "s_dovs": ("foreseen", "2.4", "0.1", "0.2", "20")}
    for n in wr.COUNTS:
        path = runs / wr.family_spec("crowd", n).name / "results.csv"
        with open(path, newline="") as f:
            rows = list(csv.DictReader(f))
        with open(path, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=RESULTS_COLUMNS + HIT_COLUMNS)
            w.writeheader()
            for row in rows:
                hit = row["outcome"] == "collision" and row["collision_kind"] in ("rest", "moving")
                row.update(zip(HIT_COLUMNS, cause[row["method"]] if hit else ("",) * len(HIT_COLUMNS)))
                w.writerow(row)
    text = make_report(runs, tmp_path)
    section = text.split("## What the planners knew of what hit them")[1].split("\n## ")[0]
    assert "| crowd | all N | 15 / 0 / 0 / 0 | 0 / 0 / 0 / 15 |" in section
    assert "| room | all N | - | - |" in section  # written before the columns
    assert "| crowd, LIDAR urg04lx | 10 | - | - |" in section
    assert text.index("## What the planners knew") < text.index("## Per family")


def test_how_it_was_made_lists_every_command(runs: Path, tmp_path: Path):
    text = make_report(runs, tmp_path)
    assert text.count("| 1.2 |") == len(wr.all_specs())  # run.json's wall_s 1.25 with one decimal
    assert f"`dqn_dovs_eval --world junction --obstacles 15 --out {runs / 'junction_n15'}`" in text
    assert "seed 11001" in text and "10 episodes per run and method" in text
    assert "run_info.json is missing" in text
    assert ("People prediction the planners saw: `models/people_predictor_tracks.dqnp` (clutter, corridor, crowd, "
            "doorway, junction); none (room)") in text


def test_plot_has_a_panel_per_family_and_the_legend_inside(runs: Path, tmp_path: Path):
    make_report(runs, tmp_path)
    png = runs / wr.PLOT
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    fig = wr.plot_success_by_world(wr.family_comparisons(wr.load_runs(str(runs))), str(tmp_path / "again.png"))
    assert sorted(ax.get_title() for ax in fig.axes) == sorted(wr.FAMILIES)
    (legend,) = fig.legends
    box, frame = legend.get_window_extent(), fig.bbox
    assert frame.x0 <= box.x0 and box.x1 <= frame.x1 and frame.y0 <= box.y0 and box.y1 <= frame.y1
    assert [t.get_text() for t in legend.get_texts()] == ["dqn_dovs", "s_dovs"]


def test_discussion_is_included_verbatim_in_its_place(runs: Path, tmp_path: Path):
    missing = make_report(runs, tmp_path)
    assert "no_discussion.md does not exist yet" in missing
    discussion = tmp_path / "discussion.md"
    discussion.write_text("Line one with `code`.\n\n- a point\n")
    text = make_report(runs, tmp_path, discussion)
    begin = wr.DISCUSSION_BEGIN.format(path=discussion)
    end = wr.DISCUSSION_END.format(path=discussion)
    assert f"## What this shows\n\n{begin}\nLine one with `code`.\n\n- a point\n{end}\n" in text


def test_missing_run_folder_is_named(runs: Path, tmp_path: Path, capsys):
    for f in (runs / "doorway_n15").iterdir():
        f.unlink()
    (runs / "doorway_n15").rmdir()
    (runs / "crowd_n10_constant" / "results.csv").unlink()
    with pytest.raises(ValueError) as e:
        wr.load_runs(str(runs))
    lines = str(e.value).splitlines()
    assert lines == [f"{runs / 'doorway_n15'}: missing run folder (the run of doorway, N = 15, LIDAR sim, "
                     "social_force people)",
                     f"{runs / 'crowd_n10_constant'}: missing results.csv (the run of crowd, N = 10, LIDAR sim, "
                     "constant people)"]
    out = tmp_path / "out.md"
    assert wr.main(["--runs", str(runs), "--out", str(out)]) == 1
    assert "doorway_n15: missing run folder" in capsys.readouterr().err
    assert not out.exists()
    with pytest.raises(ValueError, match="no such folder"):
        wr.load_runs(str(tmp_path / "nowhere"))


def test_a_run_of_another_setting_is_refused(runs: Path):
    run_json = runs / "crowd_n10_urg04lx" / "run.json"
    data = json.loads(run_json.read_text())
    data["sensor"] = "hokuyo"
    run_json.write_text(json.dumps(data))
    with pytest.raises(ValueError) as e:
        wr.load_runs(str(runs))
    assert str(e.value) == (f"{run_json}: not the run of crowd, N = 10, LIDAR urg04lx, social_force people: "
                            "sensor 'hokuyo' (expected 'urg04lx')")


def test_a_run_the_tool_stopped_shows_as_not_run(runs: Path, tmp_path: Path):
    folder = runs / "corridor_n15"
    for f in folder.iterdir():
        f.unlink()
    (folder / wr.FAILED).write_text("dqn_dovs_eval: no free place for person 11\n")
    text = make_report(runs, tmp_path)
    assert "| corridor | 0.50 / 0.50 | 0.50 / 0.50 | not run | 0.50 / 0.50 |" in text
    assert "| 15 | not run | – | – | – | – | – | – | – | – | – |" in text
    assert "| all N that ran | 0.50 |" in text
    assert "N = 15 not run: dqn_dovs_eval: no free place for person 11" in text
    assert "| `corridor_n15` | not run: dqn_dovs_eval: no free place for person 11 | – |" in text


def test_main_records_the_run_then_reports(runs: Path, tmp_path: Path, capsys):
    model = tmp_path / "model.dqnw"
    model.write_bytes(b"weights")
    out = tmp_path / "doc" / "benchmark_worlds.md"
    out.parent.mkdir()
    args = ["--runs", str(runs), "--out", str(out), "--discussion", str(tmp_path / "none.md")]
    assert wr.main(args + ["--commit", "abc1234", "--model", str(model), "--total-wall", "321.5"]) == 0
    info = json.loads((runs / wr.RUN_INFO).read_text())
    assert info["commit"] == "abc1234" and info["total_wall_s"] == 321.5 and len(info["model_sha256"]) == 64
    text = out.read_text()
    assert "commit `abc1234`" in text and "321.5 s" in text
    assert f"![Success rate vs N per family]({os.path.relpath(runs / wr.PLOT, out.parent)})" in text
    assert f"wrote {out}" in capsys.readouterr().out
    # Regenerating without the record keeps it.
    assert wr.main(args) == 0 and "commit `abc1234`" in out.read_text()


# The same runs with the oracle: it solves episodes 1-9 (10 times out) unless listed. In doorway_n10 it solves only
# episode 1, and the planners solve 2 (s_dovs) and 3 (dqn_dovs) of its failures; crowd_n10_orca ran without it.
ORACLE_SOLVED = set(range(1, EPISODES))
SOLVED_WITH_ORACLE = {
    "doorway_n10": {"dqn_dovs": {1, 3}, "s_dovs": {2}, "oracle": {1}},
    "crowd_n10_orca": {"dqn_dovs": ODD, "s_dovs": ODD},
}


@pytest.fixture
def oracle_runs(tmp_path: Path) -> Path:
    root = tmp_path / "with_oracle"
    for spec in wr.all_specs():
        solved = SOLVED_WITH_ORACLE.get(spec.name) or {**SOLVED.get(spec.name, {"dqn_dovs": ODD, "s_dovs": ODD}),
                                                       "oracle": ORACLE_SOLVED}
        write_run(root, spec, solved)
    return root


def oracle_rows(text: str) -> dict[tuple[str, str], str]:
    """The oracle table's rows by (world, N)."""
    section = text.split("## The oracle: the physical limit")[1].split("### Episodes the oracle")[0]
    rows = [line for line in section.splitlines() if line.startswith("| ") and not line.startswith("| world")]
    return {tuple(row.split(" | ")[:2]): row for row in rows}


def test_oracle_success_share_and_unsolved_counts(oracle_runs: Path, tmp_path: Path):
    text = make_report(oracle_runs, tmp_path)
    rows = oracle_rows(text)
    assert rows[("| room", "5")] == "| room | 5 | 0.90 | 0.11 | 0.33 | 1 of 10 | 0 / 0 / 0 | 1 | 0 |"
    # Oracle 1 success, dqn_dovs 2, s_dovs 1; unsolved: 4 collisions at rest (3, 5, 7, 9), 5 timeouts, 2 solved.
    assert rows[("| doorway", "10")] == "| doorway | 10 | 0.10 | 2.00 | 1.00 | 9 of 10 | 4 / 0 / 0 | 5 | 2 |"
    # all N: the mean of 0.9, 0.1, 0.9; shares pooled, (5 + 2 + 5) / 19 and (5 + 1 + 5) / 19.
    assert rows[("| doorway", "all N")] == "| doorway | all N | 0.63 | 0.63 | 0.58 | 11 of 30 | 4 / 0 / 0 | 7 | 2 |"
    assert rows[("| crowd, LIDAR hokuyo", "10")] == (
        "| crowd, LIDAR hokuyo | 10 | 0.90 | 0.00 | 0.67 | 1 of 10 | 0 / 0 / 0 | 1 | 0 |")
    orca = ("| crowd, reciprocal avoidance (ORCA), robot invisible to people", "10")
    assert rows[orca].split(" | ")[2:4] == ["not run", "–"]
    assert len(rows) == 6 * 4 + 3 + 3  # every family's N and all N, then the probe runs
    # The paired comparison and the summary do not change with the oracle beside them.
    assert "| 10 | 1.00 | 0.00 | 0.00 | 12.0 | 0.20 | 0.80 | 0.00 | 12.0 | +8 / -0 of 10 | **0.0078** |" in text
    assert "| room | 0.10 / 0.30 | 1.00 / 0.20 * | 0.50 / 0.50 | 0.53 / 0.33 |" in text
    assert "oracle` better" not in text


def test_oracle_unsolved_episodes_are_listed_and_cut(oracle_runs: Path, tmp_path: Path):
    text = make_report(oracle_runs, tmp_path)
    listing = text.split("### Episodes the oracle did not solve")[1].split("## Per family")[0]
    lines = {line.split(" | ")[0]: line for line in listing.splitlines() if line.startswith("| `")}
    assert lines["| `doorway_n10`"] == (
        "| `doorway_n10` | 9 of 10 | 2 (timeout; solved by s_dovs), 3 (collision, robot at rest; solved by dqn_dovs), "
        "4 (timeout), 5 (collision, robot at rest), 6 (timeout), 7 (collision, robot at rest), 8 (timeout), "
        f"9 (collision, robot at rest); 1 more in `{oracle_runs / 'doorway_n10' / 'results.csv'}` |")
    assert lines["| `room_n5`"] == "| `room_n5` | 1 of 10 | 10 (timeout) |"
    assert "| `crowd_n10_orca`" not in lines  # ran without the oracle
    assert len(lines) == len(wr.all_specs()) - 1


def test_a_stopped_run_and_the_plot_with_the_oracle(oracle_runs: Path, tmp_path: Path):
    folder = oracle_runs / "corridor_n15"
    for f in folder.iterdir():
        f.unlink()
    (folder / wr.FAILED).write_text("dqn_dovs_eval: no free place for person 11\n")
    text = make_report(oracle_runs, tmp_path)
    rows = oracle_rows(text)
    assert rows[("| corridor", "15")].split(" | ")[2] == "not run"
    assert rows[("| corridor", "all N that ran")] == (
        "| corridor | all N that ran | 0.90 | 0.56 | 0.56 | 2 of 20 | 0 / 0 / 0 | 2 | 0 |")
    fig = wr.plot_success_by_world(wr.family_comparisons(wr.load_runs(str(oracle_runs))), str(tmp_path / "p.png"))
    (legend,) = fig.legends
    assert [t.get_text() for t in legend.get_texts()] == ["dqn_dovs", "s_dovs", "oracle"]
    doorway = next(ax for ax in fig.axes if ax.get_title() == "doorway")
    oracle_line = next(line for line in doorway.get_lines() if line.get_label() == "oracle")
    assert list(oracle_line.get_ydata()) == pytest.approx([0.9, 0.1, 0.9])


def test_runs_without_the_oracle_say_so(runs: Path, tmp_path: Path):
    text = make_report(runs, tmp_path)
    assert ("## The oracle: the physical limit\n\nNot run: no run folder holds `oracle` episodes (`ORACLE=0`, or "
            "runs from before the oracle was in this benchmark).") in text
    assert "### Episodes the oracle did not solve" not in text
    assert wr.family_comparisons(wr.load_runs(str(runs)))["room"].unsolved == []
