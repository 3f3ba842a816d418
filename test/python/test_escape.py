"""The action stored where the shield's escape ran instead of the chosen action.

The environment reports the action that stands for what ran (`executed_action`): the chosen one when no escape
ran, otherwise the action whose velocity is nearest to the escape's. The trainer on the real environment with the
shield stores every escaped step with that action under a one-action mask, and the targets that bootstrap on that
state use that mask. The C++ parts are skipped when dqn_dovs_py._core is missing, unless DQN_DOVS_REQUIRE_CORE=1.
"""

import copy

import numpy as np
import pytest

from dqn_dovs_py.decision_config import load_shield_parameters
from dqn_dovs_py.env import VecEnv
from dqn_dovs_py.escape import one_action_masks
from dqn_dovs_py.train import Trainer, TrainConfig


def test_one_action_masks():
    m = one_action_masks(np.array([0, 7, 3]))
    assert m.shape == (3, 8) and m.sum() == 3
    assert m[0, 0] and m[1, 7] and m[2, 3]
    with pytest.raises(ValueError, match="actions must lie in"):
        one_action_masks(np.array([8]))


def test_the_environment_says_which_action_ran(core):
    # Crowded episodes with the shield. Where no escape ran, the executed action is the chosen one ("keep" for a
    # masked one). Where the escape ran, the robot ends the period at the escape velocity (it lies inside the
    # window), and the executed action is the one nearest to that velocity in the window's units.
    raw = core.VecEnv(8, 5, action_shield=True, shield_parameters=load_shield_parameters())
    env = VecEnv(8, 5, core=raw)
    env.set_stage(_stage())
    norm = env.normalization()
    dv, dw = 0.5 * 0.2, 2.0 * 0.2  # a_v dt, a_w dt (config/robot.yaml)
    state, mask = env.reset()
    rng = np.random.default_rng(2)
    escaped_steps = plain_steps = 0
    for _ in range(150):
        velocities = raw.action_velocities()
        actions = np.array([rng.choice(np.flatnonzero(m)) if m.any() else 3 for m in mask], np.int64)
        out = env.step(actions)
        assert out.executed_action is not None and out.escaped is not None
        for i in range(8):
            if out.escaped[i]:
                escaped_steps += 1
                if out.terminated[i] or out.truncated[i]:
                    continue  # a collision stops the robot: its velocity says nothing about the escape
                v = out.next_state[i, 400] * norm["v_scale_mps"]
                w = out.next_state[i, 401] * norm["w_scale_rps"]
                d = np.hypot((velocities[i, :, 0] - v) / dv, (velocities[i, :, 1] - w) / dw)
                assert d[out.executed_action[i]] <= d.min() + 1e-3, (d, out.executed_action[i])
            else:
                plain_steps += 1
                assert out.executed_action[i] == (actions[i] if mask[i, actions[i]] else 3)
        state, mask = out.state, out.mask
    assert plain_steps > 500 and escaped_steps > 0


def _stage():
    from dqn_dovs_py.curriculum import StageSettings  # noqa: PLC0415

    return StageSettings(goal_distance_min=4.0, goal_distance_max=12.0, obstacles_min=10, obstacles_max=12,
                         obstacle_type="both")


class RecordingVecEnv(VecEnv):
    """Records (state, executed action) of every step that ran the shield's escape."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.escapes = []
        self._state = None

    def reset(self):
        self._state, mask = super().reset()
        return self._state, mask

    def step(self, actions):
        out = super().step(actions)
        for i in np.flatnonzero(out.escaped):
            self.escapes.append((self._state[i].copy(), int(out.executed_action[i])))
        self._state = out.state
        return out


RAW = {
    "seed": 4, "num_envs": 4, "n_step": 3, "action_shield": True,
    # No learning: only what goes into replay matters here.
    "replay": {"capacity": 20000, "batch_size": 32, "learning_starts": 20000},
    "evaluation": {"every_episodes": 0, "episodes": 1, "num_envs": 1},
    "checkpoint": {"every_episodes": 0, "save_replay": False},
    "log": {"plot_every_episodes": 0},
    "curriculum": {"stages": [
        {"name": "crowded", "episodes": 24, "goal_distance_m": [4.0, 12.0], "obstacles": [10, 12],
         "obstacle_type": "both", "epsilon": 1.0}]},
}


def test_escaped_steps_are_stored_as_the_action_executed(core, tmp_path):
    shield = load_shield_parameters()
    envs = []

    def factory(num_envs, seed, perfect_info):
        env = RecordingVecEnv(num_envs, seed, perfect_info,
                              core=core.VecEnv(num_envs, seed, perfect_info, action_shield=True,
                                               shield_parameters=shield))
        envs.append(env)
        return env

    trainer = Trainer(TrainConfig.from_dict(copy.deepcopy(RAW)), str(tmp_path), device="cpu", threads=1,
                      env_factory=factory, progress=False)
    trainer.run()
    escapes = envs[0].escapes  # the training environments (the evaluation's come later)
    assert len(escapes) >= 5, "24 random episodes among 10-12 obstacles and hardly any escape"

    stored = trainer.replay.gather(np.arange(len(trainer.replay)))
    rows_of = {}
    for i in range(len(stored)):
        rows_of.setdefault(stored.state[i].tobytes(), []).append(i)
    bootstraps_on = {}
    for i in range(len(stored)):
        if stored.discount[i] > 0:
            bootstraps_on.setdefault(stored.next_state[i].tobytes(), []).append(i)

    found = bootstrapped = 0
    for state, executed in escapes:
        expected_mask = one_action_masks(np.array([executed]))[0]
        for i in rows_of.get(state.tobytes(), []):
            found += 1
            assert stored.action[i] == executed, f"stored {stored.action[i]}, the escape executed {executed}"
            np.testing.assert_array_equal(stored.mask[i], expected_mask)
        for i in bootstraps_on.get(state.tobytes(), []):
            bootstrapped += 1
            np.testing.assert_array_equal(stored.next_mask[i], expected_mask)
    # Steps still in the n-step windows when training stopped are not in replay; the rest must be.
    assert found >= len(escapes) - 4 * 4 and found > 0
    assert bootstrapped > 0
