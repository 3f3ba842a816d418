"""Learning from a teacher (docs/training.md, "Learning from a teacher"): the large-margin loss, the buffer of
labelled states, the trainer's use of a teacher (labels, DAgger behaviour, checkpoints) on the corridor task of
chain_env.py, and the C++ environment's teachers (oracle, s_dovs)."""

import copy
import os

import numpy as np
import pytest
import torch

from chain_env import ChainCore
from dqn_dovs_py.agent import large_margin_loss
from dqn_dovs_py.env import EnvContractError, VecEnv
from dqn_dovs_py.replay import DemoBuffer
from dqn_dovs_py.train import ConfigError, Trainer, TrainConfig, load_config

REPO = os.path.join(os.path.dirname(__file__), "..", "..")
STAY = 2  # chain_env: a valid action that never reaches the goal

RAW = {
    "seed": 5, "num_envs": 4, "gamma": 0.97, "n_step": 3,
    "agent": {"lr_start": 1e-3, "lr_end": 3e-4, "target_update_period": 50},
    "replay": {"capacity": 5000, "batch_size": 32, "learning_starts": 200, "transitions_per_update": 2},
    "evaluation": {"every_episodes": 0, "episodes": 8, "num_envs": 4, "seed": 7},
    "checkpoint": {"every_episodes": 40, "save_replay": True},
    "log": {"success_window": 20, "plot_every_episodes": 0},
    "curriculum": {"stages": [{"name": "near", "episodes": 100, "goal_distance_m": [1.0, 3.0], "obstacles": 0,
                               "obstacle_type": "none", "epsilon": 0.1}]},
}


class TaughtChainCore(ChainCore):
    """The corridor with a teacher that always says "stay" (a valid action the TD loss alone learns to avoid)."""

    def __init__(self, num_envs, seed, perfect_info=False):
        super().__init__(num_envs, seed, perfect_info)
        self.asked = []

    def teacher_actions(self, teacher, which):
        self.asked.append(teacher)
        return np.where(which, STAY, -1).astype(np.int64)


def make_trainer(out_dir, teacher=None, resume=False, episodes=100):
    raw = copy.deepcopy(RAW)
    raw["curriculum"]["stages"][0]["episodes"] = episodes
    if teacher is not None:
        raw["teacher"] = teacher
    config = TrainConfig.from_dict(raw)
    return Trainer(config, str(out_dir), device="cpu", threads=1, resume=resume, progress=False, command="test",
                   env_factory=lambda n, seed, perfect: VecEnv(n, seed, perfect, core=TaughtChainCore(n, seed)))


def greedy_stay_share(trainer) -> float:
    core = TaughtChainCore(16, 123)
    state, mask = core.reset()
    return float(np.mean(trainer.agent.greedy(state, mask) == STAY))


def test_large_margin_loss_by_hand():
    q = torch.tensor([[1.0, 2.0, 0.5], [3.0, 1.0, 0.0]])
    everything = torch.ones(2, 3, dtype=torch.bool)
    action = torch.tensor([0, 0])
    # Row 0: max(1, 2 + 0.8, 0.5 + 0.8) - 1 = 1.8; row 1: the teacher's action leads by more than the margin: 0.
    torch.testing.assert_close(large_margin_loss(q, everything, action, 0.8), torch.tensor([1.8, 0.0]))
    # Masked-out actions do not count: without action 1, row 0 is max(1, 1.3) - 1.
    mask = torch.tensor([[True, False, True], [True, True, True]])
    torch.testing.assert_close(large_margin_loss(q, mask, action, 0.8), torch.tensor([0.3, 0.0]))


def test_demo_buffer_keeps_the_latest_labels_and_round_trips():
    buffer = DemoBuffer(3, seed=1)
    state = -np.ones((4, 408), np.float32)
    state[:, 400] = np.arange(4)
    mask = np.ones((4, 8), bool)
    buffer.add(state, mask, np.array([0, 1, 2, 3]))
    assert len(buffer) == 3
    s, m, a = buffer.sample(200)
    assert set(a.tolist()) == {1, 2, 3}, "the oldest label was overwritten"
    np.testing.assert_array_equal(s[:, 400], a.astype(np.float32))
    assert m.all()
    copy_ = DemoBuffer(3, seed=99)
    copy_.load_state_dict(buffer.state_dict())
    np.testing.assert_array_equal(copy_.sample(50)[2], buffer.sample(50)[2])
    masked = mask.copy()
    masked[0, 0] = False
    with pytest.raises(ValueError, match="not allowed by its mask"):
        buffer.add(state, masked, np.array([0, 1, 2, 3]))
    with pytest.raises(ValueError, match="capacity 3 != 5"):
        DemoBuffer(5).load_state_dict(buffer.state_dict())


def test_the_margin_loss_makes_the_agent_follow_its_teacher(tmp_path):
    plain = make_trainer(tmp_path / "plain")
    plain.run()
    taught = make_trainer(tmp_path / "taught", {"kind": "oracle", "label_fraction": 1.0, "loss_weight": 10.0,
                                                "min_labels": 100})
    summary = taught.run()
    t = summary["teacher"]
    assert t["kind"] == "oracle" and t["labels"] == summary["env_steps"] and t["executed"] == 0
    assert greedy_stay_share(plain) < 0.2, "without a teacher the corridor is learnt"
    assert greedy_stay_share(taught) > 0.8, "the teacher's 'stay' wins on the start states"
    assert t["mean_margin_loss"] >= 0.0


def test_behaviour_runs_the_teachers_actions_and_a_resumed_run_keeps_its_labels(tmp_path):
    teacher = {"kind": "s_dovs", "label_fraction": 0.5, "behaviour_start": 1.0, "behaviour_end": 1.0,
               "loss_weight": 0.5, "min_labels": 50}
    stopped = make_trainer(tmp_path / "run", teacher)
    stopped.run(stop_at=40)
    labels, executed = stopped.teacher_counts["labels"], stopped.teacher_counts["executed"]
    assert labels > 0 and executed == labels, "every labelled step ran the teacher's action"
    assert len(stopped.demos) == labels
    resumed = make_trainer(tmp_path / "run", teacher, resume=True)
    assert resumed.teacher_counts["labels"] == labels and len(resumed.demos) == labels
    summary = resumed.run()
    assert summary["teacher"]["labels"] > labels
    with pytest.raises(ConfigError, match="teacher differs"):
        make_trainer(tmp_path / "run", dict(teacher, label_fraction=0.25), resume=True)


@pytest.mark.parametrize("change, message", [
    ({"kind": "expert"}, "teacher.kind must be one of none, oracle, s_dovs, got 'expert'"),
    ({"kind": "oracle", "label_fraction": 0.0}, "teacher.label_fraction is 0"),
    ({"kind": "oracle", "behaviour_end": 1.5}, r"teacher.behaviour_end must be in \[0, 1\], got 1.5"),
    ({"kind": "oracle", "batch_size": 0}, "teacher.batch_size must be >= 1"),
])
def test_bad_teacher_settings_are_named(change, message):
    raw = copy.deepcopy(RAW)
    raw["teacher"] = change
    with pytest.raises(ConfigError, match=message):
        Trainer(TrainConfig.from_dict(raw), "/nonexistent/never-made", device="cpu")


@pytest.mark.parametrize("name, kind", [("finetune_worlds_oracle.yaml", "oracle"),
                                         ("finetune_worlds_sdovs.yaml", "s_dovs")])
def test_the_shipped_teacher_configurations_are_the_worlds_one_with_a_teacher(name, kind):
    taught = load_config(os.path.join(REPO, "config", name))
    plain = load_config(os.path.join(REPO, "config", "finetune_worlds.yaml"))
    assert taught.teacher.kind == kind and not plain.teacher.enabled
    assert taught.to_dict() | {"teacher": None} == plain.to_dict() | {"teacher": None}


@pytest.mark.parametrize("teacher", ["oracle", "s_dovs"])
def test_the_environments_teachers_answer_with_allowed_actions(core, teacher):
    def run():
        env = VecEnv(4, 21, core=core.VecEnv(4, 21, threads=2, action_shield=True,
                                             world_options={"world": "crowd", "sensor": "urg04lx"}))
        env._core.set_stage(4.0, 8.0, 6, 6, "both")
        state, mask = env.reset()
        answers = []
        for k in range(40):
            which = np.array([True, k % 2 == 0, False, True])
            taught = env.teacher_actions(teacher, which, mask)
            assert taught[2] == -1 and (k % 2 == 0 or taught[1] == -1)
            answers.append(taught)
            out = env.step(np.where(taught >= 0, taught, 0))
            mask = out.mask
        return np.array(answers)

    first = run()
    assert (first >= 0).mean() > 0.5, "the teacher answers where asked, except when boxed in"
    assert len(set(first[first >= 0].tolist())) >= 2
    np.testing.assert_array_equal(first, run())  # reproducible by seed


def test_an_unknown_teacher_or_a_wrong_shape_is_named(core):
    env = VecEnv(2, 3, core=core.VecEnv(2, 3, threads=1))
    _, mask = env.reset()
    with pytest.raises(ValueError, match="teacher 'expert' is not one of oracle, s_dovs"):
        env.teacher_actions("expert", np.ones(2, bool), mask)
    with pytest.raises(ValueError, match=r"which has shape \(3,\), expected \(2,\)"):
        env.teacher_actions("oracle", np.ones(3, bool), mask)
    answer = env.teacher_actions("s_dovs", np.ones(2, bool), mask)
    blocked = mask.copy()
    blocked[0, answer[0]] = False  # the environment's own mask allows it: a caller's stale mask is caught
    with pytest.raises(EnvContractError, match="not allowed by its mask"):
        env.teacher_actions("s_dovs", np.ones(2, bool), blocked)
