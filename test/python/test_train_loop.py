"""The trainer end to end on the corridor task of chain_env.py (no C++ needed): it learns,
writes every file, is deterministic by seed, and resumes from its checkpoint."""

import copy
import csv
import os
import subprocess
import sys

import numpy as np
import pytest
import torch
import yaml

from chain_env import ChainCore
from dqn_dovs_py.env import VecEnv
from dqn_dovs_py.export import load_weights, model_from_weights
from dqn_dovs_py.train import ConfigError, Trainer, TrainConfig, load_config, main

REPO = os.path.join(os.path.dirname(__file__), "..", "..")

RAW = {
    "seed": 3, "num_envs": 4, "gamma": 0.97, "n_step": 3,
    "agent": {"lr_start": 1e-3, "lr_end": 3e-4, "target_update_period": 50},
    "replay": {"capacity": 5000, "batch_size": 32, "learning_starts": 200, "transitions_per_update": 2},
    "evaluation": {"every_episodes": 50, "episodes": 12, "num_envs": 4, "seed": 7, "keep_snapshots": True},
    "checkpoint": {"every_episodes": 50, "save_replay": True},
    "log": {"success_window": 20, "plot_every_episodes": 100},
    "curriculum": {
        "epsilon_decay": {"start": 1.0, "end": 0.05, "fraction": 0.8},
        "stages": [
            {"name": "near", "episodes": 120, "goal_distance_start_m": [1.0, 1.0], "goal_distance_m": [1.0, 3.0],
             "obstacles": 0, "obstacle_type": "none", "epsilon": "decay"},
            {"name": "far", "episodes": 80, "goal_distance_m": [2.0, 4.0], "obstacles": [0, 3],
             "obstacle_type": "static", "epsilon": 0.05},
        ]},
}


def chain_env(num_envs, seed, perfect_info):
    return VecEnv(num_envs, seed, perfect_info, core=ChainCore(num_envs, seed))


def make_trainer(out_dir, raw=None, resume=False):
    config = TrainConfig.from_dict(copy.deepcopy(raw or RAW))
    return Trainer(config, str(out_dir), device="cpu", threads=1, resume=resume, env_factory=chain_env,
                   progress=False, command="test")


def read_rows(path, drop=("wall_s",)):
    with open(path, newline="") as f:
        return [{k: v for k, v in row.items() if k not in drop} for row in csv.DictReader(f)]


@pytest.fixture(scope="module")
def full_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("full")
    summary = make_trainer(out).run()
    return out, summary


def test_training_learns_the_task_and_writes_every_file(full_run):
    out, summary = full_run
    assert summary["finished"] and summary["episodes"] == 200
    assert summary["final_eval"]["success_rate"] >= 0.9, summary["final_eval"]
    for name in ("train_log.csv", "eval_log.csv", "checkpoint.pt", "replay.pt", "config.yaml", "summary.json",
                 "model.dqnw", "learning_curves.png"):
        assert os.path.getsize(out / name) > 0, name
    rows = read_rows(out / "train_log.csv")
    assert [int(r["episode"]) for r in rows] == list(range(200))
    assert {r["stage_name"] for r in rows[:100]} == {"near"} and rows[-1]["stage_name"] == "far"
    eps = [float(r["epsilon"]) for r in rows]
    assert eps[0] == pytest.approx(1.0) and eps[-1] == pytest.approx(0.05)
    lr = [float(r["lr"]) for r in rows]
    assert lr[0] == pytest.approx(1e-3, rel=0.02) and lr[-1] == pytest.approx(3e-4, rel=0.05)
    losses = np.array([float(r["loss"]) for r in rows if r["loss"]])
    assert losses.size > 30 and np.all(np.isfinite(losses))
    assert losses[-10:].mean() < 0.5 * losses[:5].mean()
    evals = read_rows(out / "eval_log.csv")
    # Every 50 episodes (50, 100, 150) plus the final evaluation on the last stage.
    assert [int(r["episode"]) for r in evals] == [50, 100, 150, 200]
    assert evals[-1]["stage_name"] == "far"
    assert float(evals[-1]["success_rate"]) > float(evals[0]["success_rate"])
    # Snapshots: every network evaluated in the last stage ("far" starts at episode 120).
    # Each .dqnw with its .onnx beside it (the exporter's default).
    assert sorted(os.listdir(out / "snapshots")) == ["ep000150.dqnw", "ep000150.onnx", "ep000200.dqnw",
                                                     "ep000200.onnx"]
    assert os.path.getsize(out / "model.onnx") > 0 and os.path.getsize(out / "best.onnx") > 0
    last = load_weights(out / "snapshots" / "ep000200.dqnw")
    final = load_weights(out / "model.dqnw")
    assert len(last.layers) == len(final.layers)
    for a, b in zip(last.layers, final.layers):
        assert np.array_equal(a.weight, b.weight) and np.array_equal(a.bias, b.bias)


def test_exported_model_matches_the_trained_network(full_run):
    out, _ = full_run
    weights = load_weights(out / "model.dqnw")
    assert weights.normalization == {"cells": 20.0, "max_steps": 40.0}
    assert "python -m dqn_dovs_py.train" in weights.metadata or "test" in weights.metadata
    exported = model_from_weights(weights).eval()
    checkpoint = torch.load(out / "checkpoint.pt", weights_only=True)
    trained = type(exported)(**checkpoint["model_config"])
    trained.load_state_dict(checkpoint["model"])
    states = torch.from_numpy(ChainCore(6, 1).reset()[0])
    with torch.no_grad():
        torch.testing.assert_close(exported(states), trained(states))


def test_exported_model_runs_in_cpp_like_in_pytorch(full_run, tmp_path):
    bin_dir = os.environ.get("DQN_DOVS_BIN_DIR")
    tool = os.path.join(bin_dir or "", "dqn_dovs_qnet_eval")
    if not bin_dir or not os.access(tool, os.X_OK):
        pytest.skip("DQN_DOVS_BIN_DIR does not hold dqn_dovs_qnet_eval (the C++ parity test covers its absence)")
    out, _ = full_run
    states = ChainCore(16, 2).reset()[0]
    states.astype("<f4").tofile(tmp_path / "s.f32")
    result = subprocess.run([tool, str(out / "model.dqnw"), str(tmp_path / "s.f32"), str(tmp_path / "q.f32")],
                            capture_output=True, text=True, timeout=60)
    assert result.returncode == 0, result.stderr
    q_cpp = np.fromfile(tmp_path / "q.f32", "<f4").reshape(-1, 8)
    with torch.no_grad():
        q_torch = model_from_weights(load_weights(out / "model.dqnw"))(torch.from_numpy(states)).numpy()
    assert np.abs(q_cpp - q_torch).max() < 1e-4


def test_same_seed_gives_the_same_run(tmp_path):
    raw = copy.deepcopy(RAW)
    raw["curriculum"]["stages"][0]["episodes"] = 40
    raw["curriculum"]["stages"][1]["episodes"] = 20
    raw["evaluation"]["every_episodes"] = 0
    make_trainer(tmp_path / "a", raw).run()
    make_trainer(tmp_path / "b", raw).run()
    assert read_rows(tmp_path / "a" / "train_log.csv") == read_rows(tmp_path / "b" / "train_log.csv")
    a, b = load_weights(tmp_path / "a" / "model.dqnw"), load_weights(tmp_path / "b" / "model.dqnw")
    for la, lb in zip(a.layers, b.layers):
        if la.weight is not None:
            np.testing.assert_array_equal(la.weight, lb.weight)
    raw["seed"] = 4
    make_trainer(tmp_path / "c", raw).run()
    assert read_rows(tmp_path / "a" / "train_log.csv") != read_rows(tmp_path / "c" / "train_log.csv")


def test_resume_continues_from_the_checkpoint(tmp_path, full_run):
    full_out, _ = full_run
    out = tmp_path / "run"
    stopped = make_trainer(out).run(stop_at=100)
    assert not stopped["finished"] and stopped["episodes"] == 100 and stopped["model"] is None
    with pytest.raises(FileExistsError, match="--resume"):
        make_trainer(out)
    other_seed = copy.deepcopy(RAW)
    other_seed["seed"] = 9
    with pytest.raises(ConfigError, match="seed differs"):
        make_trainer(out, other_seed, resume=True)
    resumed = make_trainer(out, resume=True)
    assert resumed.episodes_done == 100 and len(resumed.replay) > 0
    updates_at_resume = resumed.agent.updates
    summary = resumed.run()
    assert summary["finished"] and summary["episodes"] == 200 and summary["updates"] > updates_at_resume
    rows = read_rows(out / "train_log.csv")
    assert [int(r["episode"]) for r in rows] == list(range(200))
    # Up to the stop, the run is the uninterrupted one with the same seed.
    assert rows[:100] == read_rows(full_out / "train_log.csv")[:100]
    assert summary["final_eval"]["success_rate"] >= 0.75
    with pytest.raises(FileNotFoundError, match="does not exist"):
        make_trainer(tmp_path / "nothing", resume=True)


@pytest.mark.parametrize("name,episodes", [("curriculum.yaml", 9000), ("curriculum_paper.yaml", 7500)])
def test_shipped_configuration_is_valid(name, episodes):
    config = load_config(os.path.join(REPO, "config", name))
    assert config.gamma == 0.97 and config.n_step == 5
    assert config.agent.lr_start == 3e-4 and config.agent.lr_end == 1e-4
    assert config.agent.target_update_period == 100 and config.agent.double_dqn
    assert config.replay.alpha == 0.6 and config.replay.beta_start == 0.4 and config.replay.beta_end == 1.0
    assert config.build_curriculum().total_episodes == episodes


@pytest.mark.parametrize("path,value,message", [
    (("replay", "alpha"), 2.0, "replay.alpha must be in"),
    (("agent", "lr_start"), "fast", "agent.lr_start: expected a finite float"),
    (("n_step",), 0, "n_step must be >= 1"),
    (("evaluation", "episodes"), 0, "evaluation.episodes must be >= 1"),
    (("replay", "colour"), 1, r"replay: unknown field\(s\) \['colour'\]"),
])
def test_bad_configuration_is_named(tmp_path, path, value, message):
    with open(os.path.join(REPO, "config", "curriculum.yaml")) as f:
        raw = yaml.safe_load(f)
    node = raw
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = value
    bad = tmp_path / "bad.yaml"
    bad.write_text(yaml.safe_dump(raw))
    with pytest.raises(ConfigError, match=message):
        load_config(str(bad))


def test_command_line_reports_errors_clearly(tmp_path, capsys):
    assert main(["--config", str(tmp_path / "missing.yaml"), "--out", str(tmp_path / "r")]) == 2
    assert "missing.yaml: cannot read the configuration" in capsys.readouterr().err
    try:
        import dqn_dovs_py._core  # noqa: F401
    except ImportError:
        code = main(["--config", os.path.join(REPO, "config", "curriculum.yaml"), "--out", str(tmp_path / "r"),
                     "--scale", "0.001", "--device", "cpu", "--no-progress"])
        assert code == 2
        assert "dqn_dovs_py._core" in capsys.readouterr().err


def test_help_runs_as_a_module():
    result = subprocess.run([sys.executable, "-m", "dqn_dovs_py.train", "--help"], capture_output=True, text=True,
                            env={**os.environ, "PYTHONPATH": os.path.join(REPO, "python")}, timeout=60)
    assert result.returncode == 0 and "--resume" in result.stdout and "--scale" in result.stdout
