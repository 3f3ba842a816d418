"""dqn_dovs_eval end to end on a few generated episodes: collision kinds, contact speeds and the last decision in
its outputs, the --shield overrides and their errors."""

import csv
import json
import subprocess
from pathlib import Path

from built_tools import built_tool

ROOT = Path(__file__).resolve().parents[2]


def run_eval(tmp_path, *extra):
    out = tmp_path / "out"
    cmd = [str(built_tool("dqn_dovs_eval")), "--methods", "dqn_dovs,dqn_dovs_latest_escape", "--generate", "77",
           "--obstacles", "12", "--episodes", "6", "--trajectories", "0", "--out", str(out),
           "--model", str(ROOT / "models" / "dqn_dovs.dqnw"), *extra]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=600, cwd=ROOT), out


def test_results_carry_collision_kind_and_contact_speed(tmp_path):
    proc, out = run_eval(tmp_path)
    assert proc.returncode == 0, proc.stderr
    rows = list(csv.DictReader(open(out / "results.csv")))
    assert len(rows) == 12
    for r in rows:
        if r["outcome"] == "collision":
            assert r["collision_kind"] in ("static", "rest", "moving"), r
            speed = float(r["contact_speed_mps"])
            assert 0.0 <= speed <= 0.7 + 1e-9
            assert (r["collision_kind"] == "rest") == (speed < 0.05) or r["collision_kind"] == "static"
        else:
            assert r["collision_kind"] == "" and r["contact_speed_mps"] == "", r
        # The planner's note on its last decision: an action or the escape, with the shield level that allowed it.
        # (none when the episode ended before the first decision).
        assert r["last_decision"].startswith(("action ", "escape (shield: ", "decelerate: ")) or (
            r["steps"] == "0" and r["last_decision"] == ""), r
        assert "," not in r["last_decision"]
    figures = json.load(open(out / "summary.json"))
    for m in ("dqn_dovs", "dqn_dovs_latest_escape"):
        kinds = sum(figures[f"{m}.collisions_{k}"] for k in ("static", "rest", "moving"))
        assert kinds == figures[f"{m}.collisions"] == sum(
            1 for r in rows if r["method"] == m and r["outcome"] == "collision")
    summary = (out / "summary.md").read_text()
    assert "## Collisions by kind" in summary and "## Robot speed at contact (m/s)" in summary


def test_shield_overrides_change_the_decisions_and_bad_ones_are_named(tmp_path):
    # The previous release's shield given by parameters reproduces its variant episode for episode.
    proc, out = run_eval(tmp_path, "--shield", "static_safety/enabled=false,passive_escape=false")
    assert proc.returncode == 0, proc.stderr
    rows = list(csv.DictReader(open(out / "results.csv")))
    by_method = {}
    for r in rows:
        by_method.setdefault(r["method"], []).append((r["episode"], r["outcome"], r["steps"]))
    assert by_method["dqn_dovs"] == by_method["dqn_dovs_latest_escape"]

    proc, _ = run_eval(tmp_path, "--shield", "static_safety/margin=-1")
    assert proc.returncode != 0 and "margin" in proc.stderr
    proc, _ = run_eval(tmp_path, "--shield", "no_such_thing=1")
    assert proc.returncode != 0 and "unknown action shield parameter 'no_such_thing'" in proc.stderr
    proc, _ = run_eval(tmp_path, "--shield", "passive_escape")
    assert proc.returncode != 0 and "NAME=VALUE" in proc.stderr


def test_every_world_family_and_sensor_runs_through_the_evaluation(tmp_path):
    # A short smoke run per family (people, walls, furniture), each with another LIDAR profile; the same episodes
    # for every planner, and the world in run.json and summary.md.
    sensors = {"crowd": "urg04lx", "corridor": "rplidar_a1", "doorway": "sim", "clutter": "hokuyo",
               "junction": "urg04lx"}
    for world, sensor in sensors.items():
        out = tmp_path / world
        cmd = [str(built_tool("dqn_dovs_eval")), "--methods", "dqn_dovs,s_dovs", "--world", world, "--sensor", sensor,
               "--generate", "10003", "--obstacles", "4", "--episodes", "2", "--trajectories", "1", "--out", str(out),
               "--model", str(ROOT / "models" / "dqn_dovs.dqnw")]
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600, cwd=ROOT)
        assert proc.returncode == 0, proc.stderr
        rows = list(csv.DictReader(open(out / "results.csv")))
        assert [r["scenario"] for r in rows] == [f"{world}/10003/4/{k}" for k in (1, 2)] * 2
        assert all(int(r["steps"]) > 0 for r in rows), rows
        run = json.load(open(out / "run.json"))
        assert (run["world"], run["sensor"], run["people_model"], run["people_see_robot"]) == (
            world, sensor, "social_force", False)
        assert f"World: {world} (social_force people, the robot invisible to people); LIDAR profile {sensor}" in (
            out / "summary.md").read_text()
        assert list(out.glob("trajectories_*.png"))


def test_odometry_drift_runs_and_is_recorded(tmp_path):
    out = tmp_path / "odom"
    cmd = [str(built_tool("dqn_dovs_eval")), "--methods", "dqn_dovs", "--generate", "10007", "--obstacles", "3",
           "--episodes", "3", "--odom-noise", "high", "--trajectories", "0", "--out", str(out),
           "--model", str(ROOT / "models" / "dqn_dovs.dqnw")]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr
    assert json.load(open(out / "run.json"))["odom_noise"] == "high"
    assert "odometry drift high" in (out / "summary.md").read_text()
    assert len(list(csv.DictReader(open(out / "results.csv")))) == 3


def test_a_people_mix_changes_the_people_and_is_recorded(tmp_path):
    # The same generated corridor episodes with everybody oblivious and everybody attentive: the mix is in run.json,
    # and people who give way change what happens on at least one of the episodes.
    outcomes = {}
    for mix in ("oblivious=1", "attentive=1"):
        out = tmp_path / mix.split("=")[0]
        cmd = [str(built_tool("dqn_dovs_eval")), "--methods", "s_dovs", "--world", "corridor", "--generate", "10011",
               "--obstacles", "8", "--episodes", "4", "--people-mix", mix, "--trajectories", "0", "--no-report",
               "--out", str(out)]
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600, cwd=ROOT)
        assert proc.returncode == 0, proc.stderr
        assert json.load(open(out / "run.json"))["people_mix"] == mix
        outcomes[mix] = [(r["outcome"], r["steps"], r["min_clearance_m"]) for r in csv.DictReader(open(out / "results.csv"))]
    assert outcomes["oblivious=1"] != outcomes["attentive=1"]
    bad = subprocess.run([str(built_tool("dqn_dovs_eval")), "--world", "corridor", "--generate", "1",
                          "--people-mix", "curious=1"], capture_output=True, text=True, timeout=60, cwd=ROOT)
    assert bad.returncode == 2 and "--people-mix: people mix 'curious=1': 'curious' is not one of" in bad.stderr
    bound = subprocess.run([str(built_tool("dqn_dovs_eval")), "--methods", "bound", "--world", "corridor", "--generate",
                            "1", "--obstacles", "4", "--episodes", "1", "--people-mix", "impassive=1", "--out",
                            str(tmp_path / "bound")], capture_output=True, text=True, timeout=60, cwd=ROOT)
    assert bound.returncode != 0 and "method bound needs people who ignore the robot" in bound.stderr


def test_world_flags_are_checked(tmp_path):
    base = [str(built_tool("dqn_dovs_eval")), "--out", str(tmp_path / "x"), "--obstacles", "2", "--episodes", "1"]
    for extra, message in ((["--world", "maze", "--generate", "1"], "--world: 'maze' is not one of room, crowd"),
                           (["--world", "crowd"], "--world crowd needs --generate SEED"),
                           (["--sensor", "sonar"], "--sensor: 'sonar' is not one of sim, hokuyo, urg04lx, rplidar_a1"),
                           (["--people-model", "boids"], "--people-model: 'boids' is not one of social_force, orca, constant"),
                           (["--odom-noise", "wobbly"], "--odom-noise: 'wobbly' is not one of none, low, high")):
        proc = subprocess.run(base + extra, capture_output=True, text=True, timeout=60, cwd=ROOT)
        assert proc.returncode == 2 and message in proc.stderr, proc.stderr


def test_the_oracle_runs_beside_the_planners_and_its_share_is_reported(tmp_path):
    out = tmp_path / "oracle"
    cmd = [str(built_tool("dqn_dovs_eval")), "--methods", "oracle,s_dovs", "--generate", "78", "--obstacles", "4",
           "--episodes", "4", "--trajectories", "0", "--out", str(out), "--oracle", "beam_width=80"]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr
    rows = [r for r in csv.DictReader(open(out / "results.csv")) if r["method"] == "oracle"]
    assert len(rows) == 4
    assert all(r["last_decision"].startswith("oracle: ") for r in rows if r["steps"] != "0")
    assert "## Share of the oracle's successes" in (out / "summary.md").read_text()
    assert "s_dovs.oracle_share" in json.load(open(out / "summary.json"))
    for bad, said in ((["--oracle", "beam=3"], "unknown oracle parameter 'beam'"),
                      (["--oracle", "beam_width=0"], "beam_width 0 must be >= 1"),
                      (["--oracle", "beam_width"], "NAME=VALUE"),
                      (["--oracle-retries", "beam_width=40;horizon"], "--oracle-retries: oracle retry 'horizon': 'horizon' is not"),
                      (["--oracle-retries", "horizon_periods=101"], "horizon_periods 101 not in [1, 100]")):
        proc = subprocess.run(cmd[:-2] + bad, capture_output=True, text=True, timeout=60, cwd=ROOT)
        assert proc.returncode == 2 and said in proc.stderr, proc.stderr
    # The retries are recorded with the run; `none` leaves one search.
    assert json.load(open(out / "run.json"))["oracle_retries"][0] == "terminal_periods=10"
    proc = subprocess.run(cmd + ["--oracle-retries", "none", "--methods", "oracle"], capture_output=True, text=True,
                          timeout=600, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr
    assert json.load(open(out / "run.json"))["oracle_retries"] == []
    assert not any("(search" in r["last_decision"] for r in csv.DictReader(open(out / "results.csv")))


def test_the_bound_runs_through_the_tool_and_its_bad_arguments_are_named(tmp_path):
    out = tmp_path / "bound"
    cmd = [str(built_tool("dqn_dovs_eval")), "--methods", "bound,s_dovs", "--generate", "78", "--obstacles", "4",
           "--episodes", "4", "--trajectories", "0", "--out", str(out), "--bound", "cell_m=0.02"]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr
    rows = {r["episode"]: r for r in csv.DictReader(open(out / "results.csv")) if r["method"] == "bound"}
    planner = {r["episode"]: r for r in csv.DictReader(open(out / "results.csv")) if r["method"] == "s_dovs"}
    assert len(rows) == 4 and all(r["last_decision"].startswith("bound: ") for r in rows.values())
    for k, r in planner.items():  # the planner's successes are the bound's, none sooner
        if r["outcome"] == "success":
            assert rows[k]["outcome"] == "success" and float(rows[k]["time_s"]) <= float(r["time_s"])
    assert "| Obs | bound | s_dovs |" in (out / "summary.md").read_text()  # its success rate beside the planner's
    for bad, said in ((["--bound", "cell=0.02"], "unknown bound parameter 'cell'"),
                      (["--bound", "cell_m=0"], "bound cell_m 0 not in [0.005, 0.5]"),
                      (["--bound", "cell_m"], "NAME=VALUE")):
        proc = subprocess.run(cmd[:-2] + bad, capture_output=True, text=True, timeout=60, cwd=ROOT)
        assert proc.returncode == 2 and said in proc.stderr, proc.stderr
    # People who see the robot: refused before any episode runs, naming why.
    proc = subprocess.run(cmd + ["--world", "crowd", "--people-see-robot"], capture_output=True, text=True,
                          timeout=60, cwd=ROOT)
    assert proc.returncode == 1 and "method bound needs people who ignore the robot" in proc.stderr, proc.stderr


def run_generated(tmp_path, methods, world, obstacles, *extra):
    """dqn_dovs_eval on 6 generated episodes (seed 77) of `world`: the process and its records, keyed by
    (method, episode), as (outcome, steps, path length); no records when it failed."""
    out = tmp_path / f"gen{len(list(tmp_path.iterdir()))}"
    cmd = [str(built_tool("dqn_dovs_eval")), "--methods", methods, "--generate", "77", "--world", world,
           "--obstacles", str(obstacles), "--episodes", "6", "--trajectories", "0", "--no-report", "--out", str(out),
           "--model", str(ROOT / "models" / "dqn_dovs.dqnw"), *extra]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600, cwd=ROOT)
    rows = list(csv.DictReader(open(out / "results.csv"))) if proc.returncode == 0 else []
    return proc, {(r["method"], r["episode"]): (r["outcome"], r["steps"], r["path_length_m"]) for r in rows}


def assert_refused(run, flag, cases):
    """Each `flag VALUE` of `cases` makes the tool fail with a message containing cases[VALUE]."""
    for value, said in cases.items():
        proc, _ = run(flag, value)
        assert proc.returncode != 0 and said in proc.stderr, (flag, value, proc.stderr)


def test_dovs_overrides_reach_every_planner_and_bad_ones_are_named(tmp_path):
    def run(*extra):
        return run_generated(tmp_path, "s_dovs,dqn_dovs", "crowd", 10, *extra)

    proc, plain = run()
    assert proc.returncode == 0, proc.stderr
    proc, grown = run("--dovs", "prediction_growth=0.5,time_horizon=4")
    assert proc.returncode == 0, proc.stderr
    assert plain.keys() == grown.keys()
    for method in ("s_dovs", "dqn_dovs"):  # a larger, longer prediction changes where each planner drives
        assert any(plain[k] != grown[k] for k in plain if k[0] == method), method
    proc, again = run("--dovs", "prediction_growth=0")
    assert proc.returncode == 0 and again == plain  # 0 is the default model, episode for episode

    assert_refused(run, "--dovs", {"prediction_growth=-1": "prediction_growth_mps",
                                   "horizon=3": "unknown DOVS parameter 'horizon'",
                                   "num_trajectories=10.5": "not an integer", "time_horizon": "NAME=VALUE"})


def test_tracker_overrides_follow_config_tracker_yaml_and_bad_ones_are_named(tmp_path):
    import yaml

    def run(*extra, world="crowd"):
        return run_generated(tmp_path, "s_dovs", world, 8, *extra)

    # config/tracker.yaml as the robot loads it, given by name: every key is known and its value is the built-in
    # default, so the room (no legs, the sim LIDAR's 1 cm noise) runs episode for episode as without it.
    shipped = yaml.safe_load(open(ROOT / "config" / "tracker.yaml"))["tracker"]
    as_text = ",".join(f"{k}={str(v).lower() if isinstance(v, bool) else v}" for k, v in shipped.items())
    proc, plain_room = run(world="room")
    assert proc.returncode == 0, proc.stderr
    proc, yaml_room = run("--tracker", as_text, world="room")
    assert proc.returncode == 0, proc.stderr
    assert yaml_room == plain_room

    # Applied after --world, which pairs legs in the crowd: turning pairing off changes the episodes.
    proc, plain = run()
    assert proc.returncode == 0, proc.stderr
    proc, unpaired = run("--tracker", "pair_legs=false")
    assert proc.returncode == 0, proc.stderr
    assert unpaired != plain

    assert_refused(run, "--tracker", {"person_radius=-1": "person_radius",
                                      "radius=0.3": "unknown tracker parameter 'radius'",
                                      "pair_legs=maybe": "not true or false", "confirm_hits": "NAME=VALUE"})


def test_people_are_predicted_by_default_where_legs_are_paired_as_on_the_robot(tmp_path):
    """--predict-people auto (the default) is what launch/pipeline.launch gives dovs_node: the package's predictor in
    worlds with people, none in the room; with perfect information the one learned from true paths; `none` turns it
    off; a missing default file is named."""
    def run(world, *extra, cwd=ROOT):
        out = tmp_path / f"{world}_{len(list(tmp_path.iterdir()))}"
        cmd = [str(built_tool("dqn_dovs_eval")), "--methods", "s_dovs", "--generate", "31", "--obstacles", "10",
               "--episodes", "3", "--world", world, "--sensor", "urg04lx", "--trajectories", "0", "--no-report",
               "--out", str(out), *extra]
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600, cwd=cwd)
        return proc, out

    def records(out):
        predictor = json.load(open(out / "run.json"))["people_predictor"]
        rows = [(r["episode"], r["outcome"], r["steps"], r["path_length_m"]) for r in csv.DictReader(open(out / "results.csv"))]
        return predictor, rows

    proc, default = run("crowd")
    assert proc.returncode == 0, proc.stderr
    proc, explicit = run("crowd", "--predict-people", "models/people_predictor_tracks.dqnp")
    assert proc.returncode == 0, proc.stderr
    proc, off = run("crowd", "--predict-people", "none")
    assert proc.returncode == 0, proc.stderr
    assert records(default) == records(explicit)
    assert records(default)[0] == "models/people_predictor_tracks.dqnp"
    assert records(off)[0] == ""
    assert records(off)[1] != records(default)[1], "the prediction changed none of the crowd's episodes"

    proc, truth = run("crowd", "--perfect-info")
    assert proc.returncode == 0, proc.stderr
    proc, truth_explicit = run("crowd", "--perfect-info", "--predict-people", "models/people_predictor.dqnp")
    assert proc.returncode == 0, proc.stderr
    assert records(truth) == records(truth_explicit)
    assert records(truth)[0] == "models/people_predictor.dqnp"

    proc, room = run("room")
    assert proc.returncode == 0, proc.stderr
    assert records(room)[0] == ""

    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    proc, _ = run("crowd", cwd=elsewhere)
    assert proc.returncode == 2
    assert "models/people_predictor_tracks.dqnp" in proc.stderr and "--predict-people none" in proc.stderr
    proc, _ = run("crowd", "--predict-people", "none", cwd=elsewhere)
    assert proc.returncode == 0, proc.stderr


def test_the_tracks_can_be_given_the_truth_and_the_warmup_set(tmp_path):
    """--track-truth (what the tracker costs the planners) and --sensor-warmup are recorded, change the episodes, and
    bad values are named."""
    def run(name, *extra):
        out = tmp_path / name
        cmd = [str(built_tool("dqn_dovs_eval")), "--methods", "s_dovs", "--generate", "28", "--obstacles", "10",
               "--episodes", "6", "--trajectories", "0", "--no-report", "--out", str(out), *extra]
        return subprocess.run(cmd, capture_output=True, text=True, timeout=600, cwd=ROOT), out

    def rows(out):
        return [(r["outcome"], r["steps"], r["path_length_m"]) for r in csv.DictReader(open(out / "results.csv"))]

    runs = {}
    for name, extra in (("plain", ()), ("motion", ("--track-truth", "motion")), ("state", ("--track-truth", "state")),
                        ("warm", ("--sensor-warmup", "1.5"))):
        proc, out = run(name, *extra)
        assert proc.returncode == 0, proc.stderr
        runs[name] = out
    info = {k: json.load(open(v / "run.json")) for k, v in runs.items()}
    assert [info[k]["track_truth"] for k in ("plain", "motion", "state")] == ["none", "motion", "state"]
    assert info["warm"]["sensor_warmup_s"] == 1.5 and info["plain"]["sensor_warmup_s"] == 0.3
    for name in ("motion", "state", "warm"):
        assert rows(runs[name]) != rows(runs["plain"]), f"{name} changed none of the episodes"

    for extra, message in ((["--track-truth", "velocity"], "'velocity' is none of none, motion, state"),
                           (["--track-truth", "state", "--perfect-info"], "with --perfect-info there is no tracker"),
                           (["--sensor-warmup", "9"], "--sensor-warmup")):
        proc, _ = run("bad", *extra)
        assert proc.returncode == 2 and message in proc.stderr, proc.stderr
