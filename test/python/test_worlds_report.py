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
from dqn_dovs_py.report import RESULTS_COLUMNS

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
    """results.csv and run.json of `spec`'s run, as dqn_dovs_eval writes them."""
    folder = runs / spec.name
    folder.mkdir(parents=True)
    solved = solved or {"dqn_dovs": ODD, "s_dovs": ODD}
    with open(folder / "results.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(RESULTS_COLUMNS)
        for method in ("dqn_dovs", "s_dovs"):
            for k in range(1, EPISODES + 1):
                ok = k in solved[method]
                w.writerow([method, spec.n, k, f"{spec.world}/11001/{spec.n}/{k}", "success" if ok else "collision",
                            SUCCESS_S if ok else COLLISION_S, 5.0, 0.3, 0, 60 if ok else 15, 0,
                            "" if ok else "moving", "" if ok else 0.4, "action 1 (shield: robust)"])
    run = {"command": f"dqn_dovs_eval --world {spec.world} --obstacles {spec.n} --out {folder}",
           "scenarios": "generated", "seed": 11001, "obstacles_min": spec.n, "obstacles_max": spec.n,
           "episodes": EPISODES, "dynamic_fraction": 0.85, "world": spec.world, "sensor": spec.sensor,
           "people_model": spec.people_model, "people_see_robot": spec.people_see_robot, "perfect_info": False,
           "step_s": 0.2, "max_steps": 500, "wall_s": 1.25, "threads": 2, "methods": ["dqn_dovs", "s_dovs"],
           "reference": "dqn_dovs", "goal_tolerance_m": 0.15}
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


def test_how_it_was_made_lists_every_command(runs: Path, tmp_path: Path):
    text = make_report(runs, tmp_path)
    assert text.count("| 1.2 |") == len(wr.all_specs())  # run.json's wall_s 1.25 with one decimal
    assert f"`dqn_dovs_eval --world junction --obstacles 15 --out {runs / 'junction_n15'}`" in text
    assert "seed 11001" in text and "10 episodes per run and method" in text
    assert "run_info.json is missing" in text


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
