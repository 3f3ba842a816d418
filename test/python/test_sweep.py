"""python -m dqn_dovs_py.sweep end to end on a local Ray with 2 CPUs: two tiny configurations and one whose trainer
fails, x 2 seeds, with the s_dovs baseline and the shipped model as the reference, on 4 held-out generated episodes
(about a minute on 2 cores). The ranked table is checked against the trials' own results.csv files (rates, ranking,
paired wins and losses, sign tests); the failing trial is listed with its error and the sweep exits 1. Bad input is
named before Ray starts. --eval-worlds: the commands it builds, a baseline's task run without Ray (one real
dqn_dovs_eval per family and count), and the table from hand-written results.csv files (pairs within each family).

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


# ---- --eval-worlds: the commands built, one real worlds evaluation, the table from hand-made results -------------


def _worlds_settings(tmp_path, *extra):
    from dqn_dovs_py.sweep import build_parser, settings_from  # noqa: PLC0415

    argv = ["--configs", str(CURRICULUM), "--seeds", "1", "2", "--out", str(tmp_path / "out"), "--reference",
            str(MODEL), *extra]
    return settings_from(build_parser().parse_args(argv))


def _flag(command: list[str], flag: str) -> str:
    return command[command.index(flag) + 1]


def test_worlds_mode_builds_one_evaluation_per_family_and_count(tmp_path, eval_bin):
    from dqn_dovs_py.sweep import trial_specs  # noqa: PLC0415

    s = _worlds_settings(tmp_path, "--eval-worlds", "crowd,corridor", "--eval-people-mix", "headline",
                         "--eval-obstacles", "8,4", "--eval-episodes", "34", "--eval-threads", "3",
                         "--eval-sensor", "urg04lx")
    assert s.eval_worlds == ["crowd", "corridor"] and s.eval_threads == 3
    specs = {(spec.kind, spec.name, spec.seed): spec for spec in trial_specs(s)}
    assert set(specs) == {("baseline", "s_dovs", None), ("reference", "reference", None), ("trial", "curriculum", 1),
                          ("trial", "curriculum", 2)}
    out = Path(s.out)
    for (kind, name, seed), spec in specs.items():
        eval_dir = {"baseline": out / "baselines" / "s_dovs", "reference": out / "reference",
                    "trial": out / "trials" / "curriculum" / f"seed{seed}" / "eval"}[kind]
        assert [e.label for e in spec.evaluations] == ["crowd_n4", "crowd_n8", "corridor_n4", "corridor_n8"]
        for e in spec.evaluations:
            family, n = e.label.split("_n")
            c = e.command
            assert e.out_dir == str(eval_dir / e.label) and e.log == str(eval_dir / e.label / "eval.log")
            assert (_flag(c, "--world"), _flag(c, "--obstacles"), _flag(c, "--out")) == (family, n, e.out_dir + os.sep)
            assert (_flag(c, "--generate"), _flag(c, "--episodes"), _flag(c, "--threads")) == ("9301", "34", "3")
            assert (_flag(c, "--people-mix"), _flag(c, "--sensor")) == ("headline", "urg04lx")
            assert c.count("--world") == 1 and "--no-report" in c
            method, model = _flag(c, "--methods"), (_flag(c, "--model") if "--model" in c else None)
            assert (method, model) == {"baseline": ("s_dovs", None), "reference": ("dqn_dovs", str(MODEL)),
                                       "trial": ("dqn_dovs", spec.model)}[kind]
    assert specs[("trial", "curriculum", 1)].model == str(out / "trials/curriculum/seed1/run/model.dqnw")
    # The default counts of a worlds evaluation are the benchmark's; the room mode keeps its one evaluation.
    assert _worlds_settings(tmp_path, "--eval-worlds", "junction").eval_obstacles == "4,8,12"
    room = _worlds_settings(tmp_path)
    (spec,) = [x for x in trial_specs(room) if x.kind == "trial" and x.seed == 1]
    (e,) = spec.evaluations
    assert e.label == "" and _flag(e.command, "--obstacles") == "3-15" and "--world" not in e.command
    assert e.log == os.path.join(spec.directory, "eval.log") and e.out_dir == os.path.join(spec.directory, "eval")
    assert _flag(e.command, "--threads") == "1"  # --cpus-per-trial's default


@pytest.mark.parametrize("extra, message", [
    (["--eval-worlds", "crowd,moon"], "--eval-worlds crowd,moon: 'moon' is not a world family (room, crowd,"),
    (["--eval-worlds", "crowd,crowd"], "a family is named more than once"),
    (["--eval-worlds", "crowd", "--eval-world", "crowd"], "--eval-world and --eval-worlds: give one"),
    (["--eval-obstacles", "4,8"], "--eval-obstacles 4,8: expected A-B with A <= B, or one count (a list of counts "
                                  "needs --eval-worlds)"),
    (["--eval-worlds", "crowd", "--eval-obstacles", "4,8,4"], "--eval-obstacles 4,8,4: expected a list N1,N2,... of "
                                                              "different counts"),
    (["--eval-threads", "0"], "--eval-threads must be >= 1, got 0"),
    (["--eval-people-mix", "headline", "--eval-people-see-robot"], "--eval-people-mix and --eval-people-see-robot"),
])
def test_bad_worlds_options_are_named(tmp_path, capsys, eval_bin, extra, message):
    status, err = _sweep_main(capsys, "--configs", str(CURRICULUM), "--seeds", "1", "--out", str(tmp_path / "out"),
                              *extra)
    assert status == 2 and message in err, err
    assert not (tmp_path / "out").exists()


def test_a_worlds_task_runs_every_family_and_count(tmp_path, eval_bin):
    """The baseline's task, run here without Ray: real dqn_dovs_eval runs, one per family and count."""
    from dqn_dovs_py.sweep import outcome_figures, run_trial, trial_specs  # noqa: PLC0415

    s = _worlds_settings(tmp_path, "--eval-worlds", "crowd,doorway", "--eval-people-mix", "headline",
                         "--eval-obstacles", "4", "--eval-episodes", "2", "--eval-generate", "9402")
    (spec,) = [x for x in trial_specs(s) if x.kind == "baseline"]
    o = run_trial(spec)
    assert o.ok, o.error
    base = Path(s.out) / "baselines" / "s_dovs"
    assert o.world_results == {label: str(base / label / "results.csv") for label in ("crowd_n4", "doorway_n4")}
    assert o.results == "" and json.loads((base / "trial.json").read_text())["world_results"] == o.world_results
    for label in ("crowd_n4", "doorway_n4"):
        run = json.loads((base / label / "run.json").read_text())
        assert (run["world"], run["obstacles_min"], run["episodes"]) == (label.split("_n")[0], 4, 2)
        assert run["people_mix"] == "attentive=0.7,impassive=0.2,oblivious=0.1"
        assert (base / label / "eval.log").read_text().startswith("$ ")
    f = outcome_figures(o)
    assert f.episodes == 4 and set(f.families) == {"crowd", "doorway"}
    assert {r.scenario.split("/")[0] for r in f.records} == {"crowd", "doorway"}
    assert not math.isnan(f.at_fault)  # today's results.csv records it


def _world_results(folder: Path, method: str, family: str, n: int, outcomes: str) -> str:
    """A results.csv of one family and count with the at_fault column: S success, C a collision the robot is at
    fault for, P one it is not (the person walked into it at rest), T timeout."""
    from dqn_dovs_py.report import RESULTS_COLUMNS  # noqa: PLC0415

    folder.mkdir(parents=True)
    lines = [",".join(RESULTS_COLUMNS + ("contact", "at_fault"))]
    for k, letter in enumerate(outcomes, 1):
        outcome = {"S": "success", "C": "collision", "P": "collision", "T": "timeout"}[letter]
        kind, speed = ("moving", "0.3") if outcome == "collision" else ("", "")
        contact, fault = {"C": ("robot_on_person", "1"), "P": ("person_on_robot", "0")}.get(letter, ("", ""))
        lines.append(f"{method},{n},{k},{family}/1/{n}/{k},{outcome},10,4,0.3,0,50,0,{kind},{speed},action 1,"
                     f"{contact},{fault}")
    (folder / "results.csv").write_text("\n".join(lines) + "\n")
    return str(folder / "results.csv")


def test_worlds_table_pairs_within_each_family_and_pools_the_seeds(tmp_path):
    from dqn_dovs_py.sweep import ConfigEntry, Settings, TrialOutcome, write_outputs  # noqa: PLC0415

    s = Settings(configs=[ConfigEntry(n, f"/configs/{n}.yaml") for n in ("a", "b")], seeds=[1, 2], out=str(tmp_path),
                 address=None, num_cpus=2, cpus_per_trial=1, gpus_per_trial=0, device="cpu", scale=None,
                 init_from=None, model_file="model.dqnw", eval_tool="dqn_dovs_eval", eval_generate=1,
                 eval_obstacles="4,8", eval_episodes=2, eval_threads=1, eval_flags=["--people-mix", "headline"],
                 baselines=["s_dovs"], reference=None, python=sys.executable, cwd=str(tmp_path),
                 eval_worlds=["crowd", "doorway"])
    # Each side's outcomes per (family, count), 2 episodes each: the same (count, episode) in both families, so
    # pairs that ignored the family would mix crowd and doorway episodes.
    plan = {
        ("a", 1): {"crowd": {4: "SS", 8: "SC"}, "doorway": {4: "TT", 8: "CP"}},
        ("a", 2): {"crowd": {4: "SS", 8: "SS"}, "doorway": {4: "ST", 8: "TT"}},
        ("b", 1): {"crowd": {4: "TC", 8: "CC"}, "doorway": {4: "SS", 8: "SS"}},
        ("b", 2): {"crowd": {4: "SP", 8: "TT"}, "doorway": {4: "SS", 8: "SS"}},
        ("s_dovs", None): {"crowd": {4: "TT", 8: "TT"}, "doorway": {4: "SS", 8: "ST"}},
    }
    outcomes = []
    for (name, seed), worlds in plan.items():
        kind = "baseline" if seed is None else "trial"
        d = tmp_path / ("baselines" if seed is None else f"trials/{name}/seed{seed}")
        files = {f"{family}_n{n}": _world_results(d / "eval" / f"{family}_n{n}", "s_dovs" if seed is None else
                                                  "dqn_dovs", family, n, letters)
                 for family, counts in worlds.items() for n, letters in counts.items()}
        outcomes.append(TrialOutcome(kind, name, seed, str(d), ok=True, world_results=files, node="here"))
    rows = {r["name"]: r for r in write_outputs(s, outcomes, {"command": "test", "date": "today", "commit": "x",
                                                               "ray": "none"})}
    # Rates: the mean of the four family x count rates of a run, then over the seeds. a: seed 1 (1 + 0.5 + 0 + 0) / 4,
    # seed 2 (1 + 1 + 0.5 + 0) / 4; b: (0 + 0 + 1 + 1) / 4 and (0.5 + 0 + 1 + 1) / 4.
    assert rows["a"]["success"] == pytest.approx(0.5) and rows["b"]["success"] == pytest.approx(0.5625)
    assert [rows["b"]["rank"], rows["a"]["rank"]] == [1, 2]
    # Robot at fault: C only (P is a collision the robot is not at fault for). a: seed 1 (0 + 0.5 + 0 + 0.5) / 4.
    assert rows["a"]["at_fault"] == pytest.approx(0.125) and rows["b"]["at_fault"] == pytest.approx(0.1875)
    assert rows["s_dovs"]["at_fault"] == 0 and rows["s_dovs"]["success"] == pytest.approx(0.375)
    # Per family: the mean over the counts, then over the seeds.
    assert (rows["a"]["success_crowd"], rows["a"]["success_doorway"]) == pytest.approx((0.875, 0.125))
    assert (rows["a"]["at_fault_crowd"], rows["a"]["at_fault_doorway"]) == pytest.approx((0.125, 0.125))
    assert (rows["b"]["at_fault_crowd"], rows["b"]["at_fault_doorway"]) == pytest.approx((0.375, 0.0))
    assert rows["a"]["episodes"] == 16 and rows["s_dovs"]["episodes"] == 8
    # a against the best (b), episode by episode within each family, the seeds pooled: seed 1 +3 / -4 (crowd +2, +1;
    # doorway -2, -2), seed 2 +3 / -3. Matched on (count, episode) alone, crowd and doorway would overwrite each other.
    assert (rows["a"]["vs_best_episodes"], rows["a"]["vs_best_wins"], rows["a"]["vs_best_losses"]) == (16, 6, 7)
    assert rows["a"]["vs_best_p"] == pytest.approx(sign_test_p(6, 7))
    assert (rows["b"]["vs_best_wins"], rows["b"]["vs_best_episodes"]) == ("", "")
    # Against s_dovs (crowd TT TT, doorway SS ST), its one run paired with each seed's: seed 1 +3 / -3, seed 2 +4 / -2.
    assert (rows["a"]["vs_s_dovs_episodes"], rows["a"]["vs_s_dovs_wins"], rows["a"]["vs_s_dovs_losses"]) == (16, 7, 5)
    assert rows["a"]["vs_s_dovs_p"] == pytest.approx(sign_test_p(7, 5))
    assert (rows["s_dovs"]["vs_best_wins"], rows["s_dovs"]["vs_best_losses"]) == \
        (rows["b"]["vs_s_dovs_losses"], rows["b"]["vs_s_dovs_wins"])
    md = (tmp_path / "sweep.md").read_text()
    assert "in each of the world families crowd and doorway at N = 4 and 8" in md
    assert "`--people-mix headline`" in md and ": 8 episodes per trial" in md
    assert "| rank | configuration | seeds | success | collision | timeout | at fault | success per seed |" in md
    assert ("| 2 | `a` | 1 2 | 0.500 | 0.188 | 0.312 | 0.125 | 0.375 / 0.625 | +6 / -7 (p = 1) | +7 / -5 (p = 0.77) "
            "| ok |") in md
    assert "## Per family" in md and "| configuration | crowd | doorway |" in md
    assert "| `a` | 0.875 / 0.125 | 0.125 / 0.125 |" in md
    assert "| baseline `s_dovs` | 0.000 / 0.000 | 0.750 / 0.000 |" in md
    with open(tmp_path / "sweep.csv", newline="") as f:
        table = {r["name"]: r for r in csv.DictReader(f)}
    assert table["a"]["at_fault"] == "0.1250" and table["b"]["at_fault_doorway"] == "0.0000"


def test_a_trained_network_is_evaluated_on_the_state_its_file_says_it_reads(tmp_path):
    """The flags come from the weight file when the evaluation runs (after training wrote it): a network with wall
    rays and person tokens gets --dovs wall_rays=8,person_tokens=6; the paper's network and a method without a
    model get nothing; a command that sets --dovs itself is left alone."""
    from dqn_dovs_py.export import export_model
    from dqn_dovs_py.model import DuelingQNet
    from dqn_dovs_py.sweep import with_state_flags

    tokens = export_model(DuelingQNet(wall_rays=8, person_tokens=6), tmp_path / "tokens.dqnw", {"v_max": 0.7},
                          "sweep flags", onnx=False)
    plain = export_model(DuelingQNet(), tmp_path / "plain.dqnw", {"v_max": 0.7}, "sweep flags", onnx=False)
    command = ["dqn_dovs_eval", "--methods", "dqn_dovs", "--model", str(tokens), "--generate", "5"]
    assert with_state_flags(command) == ["dqn_dovs_eval", "--methods", "dqn_dovs", "--model", str(tokens), "--dovs",
                                         "wall_rays=8,person_tokens=6", "--generate", "5"]
    assert with_state_flags(command[:3] + ["--model", str(plain)]) == command[:3] + ["--model", str(plain)]
    assert with_state_flags(["dqn_dovs_eval", "--methods", "s_dovs"]) == ["dqn_dovs_eval", "--methods", "s_dovs"]
    own = command + ["--dovs", "previous_action=1"]
    assert with_state_flags(own) == own
