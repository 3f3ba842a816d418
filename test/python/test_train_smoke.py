"""Short CPU training run on the real C++ environment (dqn_dovs_py._core), a few minutes.

Skipped when dqn_dovs_py._core cannot be imported, unless DQN_DOVS_REQUIRE_CORE=1 (as in
scripts/run_tests.sh), where its absence is a failure. Checks: the shipped curriculum
runs through every stage type with a stop and a resume; rewards agree with DESIGN
section 7 at episode ends; the learning step lowers the loss on the collected data; the
exported model.dqnw loads and runs in C++ (dqn_dovs_qnet_eval from DQN_DOVS_BIN_DIR)
with the same Q-values and greedy actions as PyTorch.
"""

import copy
import csv
import os
import subprocess

import numpy as np
import pytest
import torch

from dqn_dovs_py.env import OUTCOME_COLLISION, OUTCOME_SUCCESS, OUTCOME_TIMEOUT, VecEnv
from dqn_dovs_py.export import load_weights
from dqn_dovs_py.model import masked_argmax
from dqn_dovs_py.train import Trainer, init_from_factory, load_config
from dqn_dovs_py.train import main as train_main

REPO = os.path.join(os.path.dirname(__file__), "..", "..")
REQUIRE_CORE = os.environ.get("DQN_DOVS_REQUIRE_CORE") == "1"


def _core_or_skip():
    try:
        from dqn_dovs_py import _core  # noqa: PLC0415
    except ImportError as error:
        message = (f"dqn_dovs_py._core cannot be imported ({error}); build the package first (make build links "
                   "the compiled module into python/dqn_dovs_py/)")
        if REQUIRE_CORE:
            pytest.fail(message + " [DQN_DOVS_REQUIRE_CORE=1]")
        pytest.skip(message)
    return _core


def _qnet_eval_tool():
    bin_dir = os.environ.get("DQN_DOVS_BIN_DIR", "")
    tool = os.path.join(bin_dir, "dqn_dovs_qnet_eval")
    if not bin_dir or not os.access(tool, os.X_OK):
        message = f"dqn_dovs_qnet_eval not found in DQN_DOVS_BIN_DIR={bin_dir!r}"
        if REQUIRE_CORE:
            pytest.fail(message)
        pytest.skip(message)
    return tool


def smoke_config():
    config = load_config(os.path.join(REPO, "config", "curriculum.yaml"))
    config.scale = 0.004  # 4 episodes per 1000: 36 episodes over all six stages
    config.num_envs = 4
    config.replay.capacity = 50_000
    config.replay.batch_size = 32
    config.replay.learning_starts = 256
    config.replay.transitions_per_update = 4
    config.evaluation.every_episodes = 0
    config.evaluation.episodes = 4
    config.evaluation.num_envs = 4
    config.checkpoint.every_episodes = 5
    config.log.plot_every_episodes = 0
    return config


def test_action_shield_only_narrows_the_mask():
    """The shielded environment is the same world until it escapes; its masks are non-empty subsets of the
    validity masks; boxed in, it runs the shield's escape instead of the action (and the worlds part)."""
    core = _core_or_skip()
    plain = VecEnv(4, seed=21, core=core.VecEnv(4, 21, False))
    shielded = VecEnv(4, seed=21, core=core.VecEnv(4, 21, False, action_shield=True))
    stage = smoke_config().build_curriculum().stages[-1].settings(1.0)
    plain.set_stage(stage)
    shielded.set_stage(stage)
    state_p, mask_p = plain.reset()
    state_s, mask_s = shielded.reset()
    rng = np.random.default_rng(3)
    narrower = 0
    parted = np.zeros(4, dtype=bool)  # environments whose shielded world has escaped (and so differs) once
    for _ in range(300):
        same = ~parted
        np.testing.assert_array_equal(state_p[same], state_s[same])
        assert not np.any(mask_s[same] & ~mask_p[same]), "the shield allowed an invalid action"
        assert np.all(mask_s.any(axis=1)), "the shield emptied a mask"
        narrower += int(np.sum(mask_s[same].sum(axis=1) < mask_p[same].sum(axis=1)))
        actions = np.array([rng.choice(np.flatnonzero(m)) for m in mask_s])
        out_p, out_s = plain.step(actions), shielded.step(actions)
        assert out_s.escaped is not None and out_p.escaped is not None
        assert not out_p.escaped.any(), "the environment without the shield escaped"
        parted |= out_s.escaped
        same = ~parted
        np.testing.assert_array_equal(out_p.reward[same], out_s.reward[same])
        state_p, mask_p, state_s, mask_s = out_p.state, out_p.mask, out_s.state, out_s.mask
    assert narrower > 0, "300 steps among 12 obstacles and the shield never removed an action"
    assert parted.any(), "300 steps among 12 obstacles and the robot was never boxed in"


@pytest.fixture(scope="module")
def smoke_run(tmp_path_factory):
    _core_or_skip()
    out = str(tmp_path_factory.mktemp("smoke"))
    first = Trainer(smoke_config(), out, device="cpu", threads=1, progress=False, command="smoke test")
    stopped = first.run(stop_at=15)
    assert not stopped["finished"]
    trainer = Trainer(smoke_config(), out, device="cpu", threads=1, progress=False, command="smoke test",
                      resume=True)
    summary = trainer.run()
    return out, trainer, summary


def test_environment_follows_the_contract_and_the_reward_definition():
    core = _core_or_skip()
    env = VecEnv(4, seed=11, core=core.VecEnv(4, 11, False))
    config = smoke_config()
    curriculum = config.build_curriculum()
    env.set_stage(curriculum.stages[-1].settings(1.0))
    state, mask = env.reset()
    assert state.shape == (4, 408) and mask.shape == (4, 8)
    assert np.all(np.abs(state[:, :400]) == 1.0), "grid cells must be +1 or -1"
    assert np.all(mask[:, :5]), "actions 0-4 (dynamic window corners and keep) are always valid"
    norm = env.normalization()
    assert norm and all(np.isfinite(v) for v in norm.values())
    # At rest with no obstacle near, "keep" neither moves the robot nor costs clearance: reward 0.
    env.set_stage(curriculum.stages[0].settings(1.0))
    state, mask = env.reset()
    np.testing.assert_array_equal(env.step(np.full(4, 4)).reward, np.zeros(4, np.float32))
    env.set_stage(curriculum.stages[-1].settings(1.0))
    rng = np.random.default_rng(0)
    seen = set()
    rewards_differ = False
    # Shaping bound: |2.5 * change of goal distance| with |change| <= v_max * dt (0.7 * 0.2 m)
    # plus the clearance penalty (at most 0.1 * 0.2); a margin for the acceleration step.
    shaping_bound = 2.5 * 0.7 * 0.2 + 0.1 * 0.2 + 0.05
    for _ in range(600):
        actions = np.array([rng.choice(np.flatnonzero(m)) for m in mask])
        out = env.step(actions)
        for i, outcome in enumerate(out.outcome):
            seen.add(int(outcome))
            if outcome == OUTCOME_SUCCESS:
                assert out.reward[i] == pytest.approx(15.0) and out.terminated[i]
            elif outcome == OUTCOME_COLLISION:
                assert out.reward[i] == pytest.approx(-15.0) and out.terminated[i]
            elif outcome == OUTCOME_TIMEOUT:
                assert out.truncated[i] and not out.terminated[i] and out.episode_steps[i] == 500
            else:
                assert abs(out.reward[i]) <= shaping_bound, f"shaping reward {out.reward[i]} out of range"
        rewards_differ |= bool(np.any(out.reward != out.reward[0]))
        state, mask = out.state, out.mask
    assert seen - {0}, "no episode ended in 600 random steps of 4 environments"
    assert rewards_differ, "4 environments with different actions always got the same reward"


def test_smoke_run_completes_with_every_file(smoke_run):
    out, trainer, summary = smoke_run
    assert summary["finished"] and summary["episodes"] == 36 and summary["updates"] > 100
    for name in ("train_log.csv", "eval_log.csv", "checkpoint.pt", "model.dqnw", "learning_curves.png",
                 "summary.json"):
        assert os.path.getsize(os.path.join(out, name)) > 0, name
    with open(os.path.join(out, "train_log.csv"), newline="") as f:
        rows = list(csv.DictReader(f))
    assert [int(r["episode"]) for r in rows] == list(range(36))
    assert {int(r["stage"]) for r in rows} == {1, 2, 3, 4, 5, 6}
    losses = np.array([float(r["loss"]) for r in rows if r["loss"]])
    assert losses.size and np.all(np.isfinite(losses))
    print(f"smoke run: {summary['env_steps']} env steps, {summary['updates']} updates, "
          f"{summary['env_steps_per_s']:.0f} env steps/s, env alone {summary['env_only_steps_per_s']:.0f}/s, "
          f"learning alone {summary['learn_only_updates_per_s']:.0f} updates/s")


def test_learning_step_lowers_the_loss_on_collected_data(smoke_run):
    _, trainer, _ = smoke_run
    agent = copy.deepcopy(trainer.agent)
    agent.config.target_update_period = 10 ** 9  # a fixed target: the loss is one objective
    agent.set_learning_rate(1e-3)
    batch = trainer.replay.sample(256, beta=1.0)
    batch.weights[:] = 1.0
    first = agent.learn(batch).loss
    for _ in range(300):
        last = agent.learn(batch).loss
    assert np.isfinite(first) and last < 0.5 * first, (first, last)


def test_exported_model_runs_in_cpp_like_in_pytorch(smoke_run, tmp_path):
    core = _core_or_skip()
    tool = _qnet_eval_tool()
    out, trainer, _ = smoke_run
    env = VecEnv(8, seed=5, core=core.VecEnv(8, 5, False))
    env.set_stage(trainer.curriculum.stages[-1].settings(1.0))
    states, masks = [], []
    state, mask = env.reset()
    for _ in range(25):
        states.append(state)
        masks.append(mask)
        out_step = env.step(trainer.agent.act(state, mask, 0.3))
        state, mask = out_step.state, out_step.mask
    states = np.concatenate(states)
    masks = np.concatenate(masks)
    states.astype("<f4").tofile(tmp_path / "states.f32")
    model_path = os.path.join(out, "model.dqnw")
    result = subprocess.run([tool, model_path, str(tmp_path / "states.f32"), str(tmp_path / "q.f32")],
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    q_cpp = np.fromfile(tmp_path / "q.f32", "<f4").reshape(-1, 8)
    q_torch = trainer.agent.q_values(states)
    assert np.abs(q_cpp - q_torch).max() < 1e-4
    a_cpp = masked_argmax(torch.from_numpy(q_cpp), torch.from_numpy(masks)).numpy()
    sorted_q = np.sort(np.where(masks, q_torch, -np.inf), axis=1)
    clear = sorted_q[:, -1] - sorted_q[:, -2] > 1e-3
    np.testing.assert_array_equal(a_cpp[clear], trainer.agent.greedy(states, masks)[clear])
    assert load_weights(model_path).normalization == env.normalization()


def test_fine_tuning_starts_from_the_weight_file(smoke_run, tmp_path):
    out, trainer, _ = smoke_run
    model_path = os.path.join(out, "model.dqnw")
    tuned = Trainer(smoke_config(), str(tmp_path / "tuned"), device="cpu", threads=1, progress=False,
                    model_factory=init_from_factory(model_path), command="fine-tuning test")
    states = np.random.default_rng(0).normal(size=(16, 408)).astype(np.float32)
    np.testing.assert_allclose(tuned.agent.q_values(states), trainer.agent.q_values(states), atol=1e-5)
    assert tuned.episodes_done == 0 and tuned.agent.updates == 0


def test_fine_tuning_rejects_bad_files_and_resume(tmp_path, capsys):
    bad = tmp_path / "bad.dqnw"
    bad.write_bytes(b"not a weight file")
    assert train_main(["--out", str(tmp_path / "a"), "--init-from", str(bad), "--no-progress"]) == 2
    assert "bad.dqnw" in capsys.readouterr().err
    assert train_main(["--out", str(tmp_path / "b"), "--init-from", str(bad), "--resume", "--no-progress"]) == 2
    assert "--init-from" in capsys.readouterr().err
