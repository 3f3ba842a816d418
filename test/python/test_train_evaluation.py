"""The trainer's periodic evaluation plays a fixed set of episodes per environment, each to its end.

A scripted environment makes the bias of "the first episodes to finish" visible: environment 0's episodes
are short collisions, environment 1's long successes. A fixed set counts as many of each as the split
says, whatever their lengths, and every evaluation counts the same ones.
"""

import copy

import numpy as np
import pytest

from dqn_dovs_py.env import OUTCOME_COLLISION, OUTCOME_RUNNING, OUTCOME_SUCCESS, VecEnv
from dqn_dovs_py import train
from dqn_dovs_py.train import Trainer, TrainConfig

RAW = {
    "seed": 5, "num_envs": 2, "n_step": 3,
    "replay": {"capacity": 1000, "batch_size": 16, "learning_starts": 16},
    "evaluation": {"every_episodes": 0, "episodes": 8, "num_envs": 2, "seed": 9},
    "curriculum": {"stages": [
        {"name": "a", "episodes": 10, "goal_distance_m": [1.0, 2.0], "obstacles": 0, "obstacle_type": "none",
         "epsilon": 0.1},
        {"name": "b", "episodes": 10, "goal_distance_m": [1.0, 2.0], "obstacles": 0, "obstacle_type": "none",
         "epsilon": 0.1}]},
}


class ScriptedCore:
    """Environment i's k-th episode lasts length(i, k) steps whatever the actions and ends with the outcome
    ends(i, k) (terminated); its last reward is 100 i + k, so that a return names its episode."""

    def __init__(self, num_envs, length, ends):
        self.n = num_envs
        self.length = length
        self.ends = ends
        self.episode = np.zeros(num_envs, int)
        self.steps = np.zeros(num_envs, np.int32)

    def set_stage(self, *args):
        pass

    def normalization(self):
        return {"scale": 1.0}

    def _observe(self):
        state = -np.ones((self.n, 408), np.float32)
        state[:, 400:] = 0.0
        return state, np.ones((self.n, 8), bool)

    def reset(self):
        self.episode[:] = 0
        self.steps[:] = 0
        return self._observe()

    def step(self, actions):
        self.steps += 1
        ended = np.array([self.steps[i] >= self.length(i, self.episode[i]) for i in range(self.n)])
        outcome = np.where(ended, [self.ends(i, self.episode[i]) for i in range(self.n)], OUTCOME_RUNNING)
        reward = np.where(ended, 100.0 * np.arange(self.n) + self.episode, 0.0).astype(np.float32)
        next_state, next_mask = self._observe()
        episode_steps = self.steps.copy()
        self.episode[ended] += 1
        self.steps[ended] = 0
        state, mask = self._observe()
        return {"next_state": next_state, "next_mask": next_mask, "reward": reward, "terminated": ended,
                "truncated": np.zeros(self.n, bool), "outcome": outcome.astype(np.int8), "state": state,
                "mask": mask, "episode_steps": episode_steps}


def short_collisions_and_long_successes(num_envs, seed, perfect_info):
    # Environment 0: 2-step collisions; environment 1: 20-step successes.
    return VecEnv(num_envs, seed, perfect_info, core=ScriptedCore(
        num_envs, length=lambda i, k: 2 if i == 0 else 20,
        ends=lambda i, k: OUTCOME_COLLISION if i == 0 else OUTCOME_SUCCESS))


class _Log:
    def __init__(self):
        self.rows = []

    def write(self, row):
        self.rows.append(row)

    def flush(self):
        pass


def test_evaluation_counts_each_environments_share_not_the_first_to_finish(tmp_path):
    config = TrainConfig.from_dict(copy.deepcopy(RAW))
    trainer = Trainer(config, str(tmp_path), device="cpu", threads=1, env_factory=short_collisions_and_long_successes,
                      progress=False)
    log = _Log()
    first = trainer._evaluate(log, force_stage=0)
    # 8 episodes over 2 environments: 4 short collisions and 4 long successes. The first 8 episodes to finish
    # would be 8 collisions (environment 0 ends 10 episodes before environment 1 ends one).
    assert first["episodes"] == 8
    assert first["success_rate"] == 0.5 and first["collision_rate"] == 0.5
    assert first["mean_steps"] == pytest.approx((4 * 2 + 4 * 20) / 8)
    assert first["mean_return"] == pytest.approx(np.mean([0, 1, 2, 3, 100, 101, 102, 103]))
    assert first["mean_success_time_s"] == pytest.approx(20 * 0.2)
    second = trainer._evaluate(log, force_stage=0)
    assert {k: v for k, v in second.items() if k != "wall_s"} == {k: v for k, v in first.items() if k != "wall_s"}


def test_fixed_episodes_are_each_environments_first_ones_played_to_their_end():
    # Lengths vary with the environment and the episode; environment 2's first episode is the longest of all.
    def length(i, k):
        return 50 if (i, k) == (2, 0) else 1 + (3 * i + k) % 4

    env = VecEnv(3, 0, core=ScriptedCore(3, length=length, ends=lambda i, k: OUTCOME_SUCCESS))
    quota = train.evaluation_quota(7, 3)
    np.testing.assert_array_equal(quota, [3, 2, 2])
    results = train.play_fixed_episodes(env, lambda state, mask: np.zeros(len(state), np.int64), quota)
    # (outcome, return, steps): the return names the episode (100 environment + episode index).
    assert [r[1] for r in results] == [0, 1, 2, 100, 101, 200, 201]
    assert [r[2] for r in results] == [length(0, 0), length(0, 1), length(0, 2), length(1, 0), length(1, 1), 50,
                                       length(2, 1)]
    assert all(r[0] == OUTCOME_SUCCESS for r in results)


def test_evaluation_quota_splits_evenly_and_never_creates_idle_environments():
    np.testing.assert_array_equal(train.evaluation_quota(32, 8), [4] * 8)
    np.testing.assert_array_equal(train.evaluation_quota(10, 4), [3, 3, 2, 2])
    np.testing.assert_array_equal(train.evaluation_quota(3, 8), [1, 1, 1])
    assert train.evaluation_quota(32, 8).sum() == 32
