"""python -m dqn_dovs_py.sweep end to end on a local Ray with 2 CPUs: two tiny configurations and one whose trainer
fails, x 2 seeds, with the s_dovs baseline and the shipped model as the reference, on 4 held-out generated episodes
(about a minute on 2 cores). The ranked table is checked against the trials' own results.csv files (rates, ranking,
paired wins and losses, sign tests); the failing trial is listed with its error and the sweep exits 1. Bad input is
named before Ray starts.

Needs dqn_dovs_py._core (skipped without it unless DQN_DOVS_REQUIRE_CORE=1) and dqn_dovs_eval in DQN_DOVS_BIN_DIR.
"""

import csv
import json
import math
import os
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml
from built_tools import built_tool
from dqn_dovs_py.benchmark_report import sign_test_p
from dqn_dovs_py.sweep import main as sweep_main

REPO = Path(__file__).resolve().parents[2]
CURRICULUM = REPO / "config" / "curriculum.yaml"
MODEL = REPO / "models" / "dqn_dovs.dqnw"
SEEDS = (1, 2)
COUNTS = (3, 4)
EPISODES = 2  # per count: 4 episodes per evaluation


def _core_or_skip() -> None:
    try:
        from dqn_dovs_py import _core  # noqa: F401, PLC0415
    except ImportError as error:
        message = f"dqn_dovs_py._core cannot be imported ({error}); make build links it into python/dqn_dovs_py/"
        if os.environ.get("DQN_DOVS_REQUIRE_CORE") == "1":
            pytest.fail(message + " [DQN_DOVS_REQUIRE_CORE=1]")
        pytest.skip(message)


def tiny_config(path: Path, **top) -> Path:
    """config/curriculum.yaml cut to its last stage of 3 episodes on 2 environments, a small replay that learns
    from the start, only the final training evaluation (2 episodes), no checkpoint or plot on the way."""
    raw = yaml.safe_load(CURRICULUM.read_text())
    raw["num_envs"] = 2
    raw["replay"].update(capacity=5000, batch_size=16, learning_starts=64, transitions_per_update=16)
    raw["evaluation"].update(every_episodes=0, episodes=2, num_envs=2, keep_snapshots=False)
    raw["checkpoint"].update(every_episodes=0, save_replay=False)
    raw["log"]["plot_every_episodes"] = 0
    raw["curriculum"]["stages"] = [dict(raw["curriculum"]["stages"][-1], episodes=3)]
    raw.update(top)
    path.write_text(yaml.safe_dump(raw))
    return path


@pytest.fixture(scope="module")
def sweep(tmp_path_factory):
    _core_or_skip()
    tool = built_tool("dqn_dovs_eval")
    tmp = tmp_path_factory.mktemp("sweep")
    configs = [tiny_config(tmp / "fast.yaml"), tiny_config(tmp / "short_sighted.yaml", gamma=0.9),
               # Passes the configuration check; the trainer fails on the missing shield files.
               tiny_config(tmp / "broken.yaml", decision_config=str(tmp / "no_such_folder"))]
    out = tmp / "sweep_out"
    command = [sys.executable, "-m", "dqn_dovs_py.sweep", "--configs", *map(str, configs),
               "--seeds", *map(str, SEEDS), "--out", str(out), "--num-cpus", "2",
               "--eval-obstacles", f"{COUNTS[0]}-{COUNTS[-1]}", "--eval-episodes", str(EPISODES),
               "--eval-generate", "9401", "--reference", str(MODEL)]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(REPO / "python"), os.environ.get("PYTHONPATH", "")]),
               DQN_DOVS_BIN_DIR=str(tool.parent))
    t0 = time.perf_counter()
    result = subprocess.run(command, capture_output=True, text=True, timeout=600, env=env, cwd=REPO)
    wall = time.perf_counter() - t0
    assert (out / "sweep.json").is_file(), f"exit {result.returncode}\n{result.stdout}\n{result.stderr}"
    with open(out / "sweep.csv", newline="") as f:
        rows = {r["name"]: r for r in csv.DictReader(f)}
    return {"result": result, "out": out, "rows": rows, "json": json.loads((out / "sweep.json").read_text()),
            "wall": wall}


def _outcomes(path: Path) -> dict[tuple[int, int], str]:
    with open(path, newline="") as f:
        return {(int(r["obstacles"]), int(r["episode"])): r["outcome"] for r in csv.DictReader(f)}


def _trial(sweep, name: str, seed: int) -> dict[tuple[int, int], str]:
    return _outcomes(sweep["out"] / "trials" / name / f"seed{seed}" / "eval" / "results.csv")


def _rate(outcomes: dict, outcome: str) -> float:
    """The mean over the counts of the per-count rates."""
    return sum(sum(o == outcome for (n, _), o in outcomes.items() if n == c) / EPISODES for c in COUNTS) / len(COUNTS)


def _paired(pairs: list[tuple[dict, dict]]) -> tuple[int, int, int]:
    episodes = wins = losses = 0
    for mine, theirs in pairs:
        for key, outcome in mine.items():
            episodes += 1
            wins += outcome == "success" and theirs[key] != "success"
            losses += theirs[key] == "success" and outcome != "success"
    return episodes, wins, losses


def test_every_trial_runs_and_the_failed_one_sets_the_exit_status(sweep):
    result, out = sweep["result"], sweep["out"]
    assert result.returncode == 1, result.stderr
    for name in ("sweep.md", "sweep.csv", "sweep.json"):
        assert (out / name).is_file()
    progress = [line for line in result.stdout.splitlines() if line.startswith("sweep: [")]
    assert len(progress) == 3 * len(SEEDS) + 2  # the trials, the baseline and the reference, one line each
    assert [line.split("]")[0] for line in progress] == [f"sweep: [{i}/8" for i in range(1, 9)]
    assert all("wall" in line for line in progress if "FAILED" not in line)
    for seed in SEEDS:
        for name in ("fast", "short_sighted"):
            trial = out / "trials" / name / f"seed{seed}"
            for file in ("train.log", "run/model.dqnw", "run/summary.json", "eval/results.csv", "trial.json"):
                assert (trial / file).is_file(), trial / file
            assert any(line.startswith("sweep: [") and f"] {name} seed {seed}: success" in line for line in progress)
        assert (out / "trials" / "broken" / f"seed{seed}" / "train.log").is_file()
    assert (out / "baselines" / "s_dovs" / "results.csv").is_file()
    assert (out / "reference" / "results.csv").is_file()


def test_the_failed_trial_is_listed_with_its_error(sweep):
    result, out, rows = sweep["result"], sweep["out"], sweep["rows"]
    broken = rows["broken"]
    assert broken["rank"] == "" and broken["success"] == ""
    assert broken["status"].startswith("failed: seed 1: training exited with status 2")
    assert "no_such_folder/dovs.yaml: cannot be read" in broken["status"] and "seed 2:" in broken["status"]
    assert sum("broken seed" in line and "FAILED" in line for line in result.stdout.splitlines()) == 2
    assert "2 of 8 trial(s) failed" in result.stderr
    md = (out / "sweep.md").read_text()
    assert "## Failed trials" in md and "- broken seed 1: training exited with status 2" in md
    assert sweep["json"]["failed"] == 2


def test_the_table_holds_every_trial_with_the_figures_of_its_results(sweep):
    rows, data = sweep["rows"], sweep["json"]
    assert set(rows) == {"fast", "short_sighted", "broken", "s_dovs", "reference"}
    trials = {(t["name"], t["seed"]): t for t in data["trials"]}
    assert len(trials) == 3 * len(SEEDS) + 2
    for name in ("fast", "short_sighted"):
        row = rows[name]
        assert row["kind"] == "config" and row["seeds"] == "1 2" and row["status"] == "ok"
        assert int(row["episodes"]) == len(SEEDS) * len(COUNTS) * EPISODES
        for outcome, column in (("success", "success"), ("collision", "collision"), ("timeout", "timeout")):
            rates = [_rate(_trial(sweep, name, seed), outcome) for seed in SEEDS]
            assert float(row[column]) == pytest.approx(sum(rates) / len(rates), abs=1e-4)
        for seed in SEEDS:
            outcomes = _trial(sweep, name, seed)
            assert len(outcomes) == len(COUNTS) * EPISODES
            assert float(row[f"success_seed{seed}"]) == pytest.approx(_rate(outcomes, "success"), abs=1e-4)
            t = trials[(name, seed)]
            assert t["ok"] and t["episodes"] == len(outcomes)
            assert t["successes"] == sum(o == "success" for o in outcomes.values())
            assert t["train_s"] > 0 and t["wall_s"] >= t["train_s"] + t["eval_s"] - 1e-6
            assert "--generate 9401" in t["eval_command"] and f"--seed {seed}" in t["train_command"]
    for name, folder in (("s_dovs", "baselines/s_dovs"), ("reference", "reference")):
        outcomes = _outcomes(sweep["out"] / folder / "results.csv")
        assert len(outcomes) == len(COUNTS) * EPISODES
        assert float(rows[name]["success"]) == pytest.approx(_rate(outcomes, "success"), abs=1e-4)
    # Ranked by mean success, ties by the lower mean collision rate.
    ranked = sorted(("fast", "short_sighted"), key=lambda n: int(rows[n]["rank"]))
    keys = [(-float(rows[n]["success"]), float(rows[n]["collision"])) for n in ranked]
    assert keys == sorted(keys) and [int(rows[n]["rank"]) for n in ranked] == [1, 2]
    text = (sweep["out"] / "sweep.md").read_text()
    assert f"`best`: {ranked[0]}." in text
    for name in ("fast", "short_sighted", "broken"):
        assert f"`{name}`" in text


def test_paired_counts_pool_the_seeds_on_the_same_episodes(sweep):
    rows, out = sweep["rows"], sweep["out"]
    best = min(("fast", "short_sighted"), key=lambda n: int(rows[n]["rank"]))
    other = "short_sighted" if best == "fast" else "fast"
    s_dovs = _outcomes(out / "baselines" / "s_dovs" / "results.csv")
    reference = _outcomes(out / "reference" / "results.csv")

    def check(row, label, expected):
        episodes, wins, losses = expected
        assert (int(row[f"vs_{label}_episodes"]), int(row[f"vs_{label}_wins"]),
                int(row[f"vs_{label}_losses"])) == expected
        assert float(row[f"vs_{label}_p"]) == pytest.approx(sign_test_p(wins, losses), abs=1e-4)
        assert episodes == len(SEEDS) * len(COUNTS) * EPISODES

    check(rows[other], "best", _paired([(_trial(sweep, other, s), _trial(sweep, best, s)) for s in SEEDS]))
    assert rows[best]["vs_best_wins"] == ""  # not against itself
    for name in (best, other):
        trials = [_trial(sweep, name, s) for s in SEEDS]
        check(rows[name], "s_dovs", _paired([(t, s_dovs) for t in trials]))
        check(rows[name], "reference", _paired([(t, reference) for t in trials]))
    # A comparator against the best configuration is the mirror of the best against it.
    for name in ("s_dovs", "reference"):
        assert (rows[name]["vs_best_wins"], rows[name]["vs_best_losses"]) == \
            (rows[best][f"vs_{name}_losses"], rows[best][f"vs_{name}_wins"])
    assert rows["s_dovs"]["vs_reference_episodes"] == str(len(COUNTS) * EPISODES)
    assert math.isclose(float(rows["s_dovs"]["vs_reference_p"]), float(rows["reference"]["vs_s_dovs_p"]))


# ---- bad input: named, exit 2, nothing started --------------------------------------------------------------------


def _free_loopback_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def eval_bin(monkeypatch):
    monkeypatch.setenv("DQN_DOVS_BIN_DIR", str(built_tool("dqn_dovs_eval").parent))


def _sweep_main(capsys, *argv):
    status = sweep_main(list(argv))
    return status, capsys.readouterr().err


def test_missing_and_invalid_configs_are_named(tmp_path, capsys, eval_bin):
    out = tmp_path / "out"
    missing = tmp_path / "missing.yaml"
    status, err = _sweep_main(capsys, "--configs", str(CURRICULUM), str(missing), "--seeds", "1", "--out", str(out))
    assert status == 2 and f"--configs: {missing}: no such file" in err
    assert not out.exists()
    bad = tmp_path / "bad.yaml"
    bad.write_text(CURRICULUM.read_text() + "\ngamma_typo: 0.9\n")
    status, err = _sweep_main(capsys, "--configs", str(bad), "--seeds", "1", "--out", str(out))
    assert status == 2 and str(bad) in err and "gamma_typo" in err
    status, err = _sweep_main(capsys, "--configs", str(CURRICULUM), str(CURRICULUM), "--seeds", "1", "--out",
                              str(out))
    assert status == 2 and "is the same file as" in err


def test_duplicate_seeds_and_a_used_folder_are_refused(tmp_path, capsys, eval_bin):
    status, err = _sweep_main(capsys, "--configs", str(CURRICULUM), "--seeds", "1", "2", "1", "--out",
                              str(tmp_path / "out"))
    assert status == 2 and "--seeds: 1 given more than once" in err
    used = tmp_path / "used"
    used.mkdir()
    (used / "sweep.md").write_text("an earlier sweep\n")
    status, err = _sweep_main(capsys, "--configs", str(CURRICULUM), "--seeds", "1", "--out", str(used))
    assert status == 2 and f"--out {used}: already exists" in err


def test_an_unreachable_cluster_fails_at_once(tmp_path, capsys, eval_bin):
    address = f"127.0.0.1:{_free_loopback_port()}"
    status, err = _sweep_main(capsys, "--configs", str(CURRICULUM), "--seeds", "1", "--out", str(tmp_path / "out"),
                              "--address", address)
    assert status == 2 and f"--address {address}: cannot reach a Ray cluster there" in err
    status, err = _sweep_main(capsys, "--configs", str(CURRICULUM), "--seeds", "1", "--out", str(tmp_path / "out"),
                              "--address", "not an address")
    assert status == 2 and "expected HOST:PORT" in err


def test_a_missing_evaluation_tool_is_named(tmp_path, capsys, monkeypatch):
    empty = tmp_path / "bin"
    empty.mkdir()
    monkeypatch.setenv("DQN_DOVS_BIN_DIR", str(empty))
    status, err = _sweep_main(capsys, "--configs", str(CURRICULUM), "--seeds", "1", "--out", str(tmp_path / "out"))
    assert status == 2 and f"dqn_dovs_eval not found or not executable in DQN_DOVS_BIN_DIR={empty}" in err
    assert not (tmp_path / "out").exists()


# ---- the table from hand-made evaluations (no Ray, no training) ---------------------------------------------------

EPISODE_KEYS = ((3, 1), (3, 2), (4, 1), (4, 2))
LETTERS = {"S": "success", "C": "collision", "T": "timeout"}


def _results(folder: Path, method: str, outcomes: str) -> str:
    """A results.csv of `method` with the outcomes of EPISODE_KEYS, e.g. "SSCT"."""
    from dqn_dovs_py.report import RESULTS_COLUMNS  # noqa: PLC0415

    folder.mkdir(parents=True)
    lines = [",".join(RESULTS_COLUMNS)]
    for (n, k), letter in zip(EPISODE_KEYS, outcomes):
        outcome = LETTERS[letter]
        kind, speed = ("moving", "0.3") if outcome == "collision" else ("", "")
        lines.append(f"{method},{n},{k},generated/1/{n}/{k},{outcome},10,4,0.3,0,50,0,{kind},{speed},action 1")
    (folder / "results.csv").write_text("\n".join(lines) + "\n")
    return str(folder / "results.csv")


def test_ranking_ties_failures_and_pairs_from_known_outcomes(tmp_path):
    from dqn_dovs_py.sweep import ConfigEntry, Settings, TrialOutcome, write_outputs  # noqa: PLC0415

    names = ("a", "b", "c", "d")
    s = Settings(configs=[ConfigEntry(n, f"/configs/{n}.yaml") for n in names], seeds=[1, 2], out=str(tmp_path),
                 address=None, num_cpus=2, cpus_per_trial=1, gpus_per_trial=0, device="cpu", scale=None,
                 init_from=None, model_file="model.dqnw", eval_tool="dqn_dovs_eval", eval_generate=1,
                 eval_obstacles="3-4", eval_episodes=2, eval_threads=1, eval_flags=[], baselines=["s_dovs", "dwa"],
                 reference=None, python=sys.executable, cwd=str(tmp_path))
    outcomes = []
    # d has a's success (0.625) without its collisions, so it ranks above it; b's second seed failed.
    plan = {("a", 1): "SSCT", ("a", 2): "SCSS", ("b", 1): "SSSS", ("b", 2): None, ("c", 1): "CCCC",
            ("c", 2): "STTT", ("d", 1): "SSTT", ("d", 2): "STSS"}
    for (name, seed), letters in plan.items():
        d = tmp_path / "trials" / name / f"seed{seed}"
        o = TrialOutcome("trial", name, seed, str(d), ok=letters is not None, node="here", wall_s=1.0)
        if letters:
            o.results = _results(d / "eval", "dqn_dovs", letters)
        else:
            o.error = "training exited with status 1: boom"
        outcomes.append(o)
    outcomes.append(TrialOutcome("baseline", "s_dovs", None, str(tmp_path / "s_dovs"), ok=True,
                                 results=_results(tmp_path / "s_dovs", "s_dovs", "SCSC")))
    outcomes.append(TrialOutcome("baseline", "dwa", None, str(tmp_path / "dwa"), error="evaluation exited with "
                                                                                     "status 1: no such method"))
    rows = {r["name"]: r for r in write_outputs(s, outcomes, {"command": "test", "date": "today", "commit": "x",
                                                               "ray": "none"})}
    assert [rows[n]["rank"] for n in ("b", "d", "a", "c")] == [1, 2, 3, 4]
    assert rows["a"]["success"] == pytest.approx(0.625) and rows["a"]["collision"] == pytest.approx(0.25)
    assert rows["d"]["success"] == pytest.approx(0.625) and rows["d"]["collision"] == 0
    assert rows["b"]["seeds"] == "1" and rows["b"]["status"] == "failed: seed 2: training exited with status 1: boom"
    assert math.isnan(rows["b"]["success_seed2"]) and rows["b"]["success_seed1"] == 1.0
    # Against the best (b): only seed 1, where b solved everything.
    assert (rows["a"]["vs_best_episodes"], rows["a"]["vs_best_wins"], rows["a"]["vs_best_losses"]) == (4, 0, 2)
    assert rows["a"]["vs_best_p"] == pytest.approx(sign_test_p(0, 2))
    assert (rows["c"]["vs_best_wins"], rows["c"]["vs_best_losses"]) == (0, 4)
    assert rows["c"]["vs_best_p"] == pytest.approx(0.125)
    # Against s_dovs (SCSC): every seed of a pairs with the one baseline run.
    assert (rows["a"]["vs_s_dovs_episodes"], rows["a"]["vs_s_dovs_wins"], rows["a"]["vs_s_dovs_losses"]) == (8, 2, 1)
    assert (rows["b"]["vs_s_dovs_episodes"], rows["b"]["vs_s_dovs_wins"], rows["b"]["vs_s_dovs_losses"]) == (4, 2, 0)
    assert (rows["s_dovs"]["vs_best_wins"], rows["s_dovs"]["vs_best_losses"]) == (0, 2)
    # The failed baseline has no figures and no pairs.
    assert rows["dwa"]["status"].startswith("failed: evaluation exited with status 1")
    assert all(rows[n]["vs_dwa_episodes"] == "" for n in names)
    with open(tmp_path / "sweep.csv", newline="") as f:
        table = list(csv.DictReader(f))
    assert [r["name"] for r in table] == ["b", "d", "a", "c", "s_dovs", "dwa"]
    md = (tmp_path / "sweep.md").read_text()
    assert "| 1 | `b` | 1 | 1.000 | 0.000 | 0.000 | 1.000 / failed | - | +2 / -0 (p = 0.5) | - | failed (below) |" in md
    assert "- a seed" not in md and "- b seed 2: training exited with status 1: boom" in md
    assert "- baseline dwa: evaluation exited with status 1: no such method" in md
    data = json.loads((tmp_path / "sweep.json").read_text())
    assert data["failed"] == 2 and data["table"][0]["name"] == "b"
    assert {(t["name"], t["seed"]): t["successes"] for t in data["trials"]}[("a", 2)] == 3
