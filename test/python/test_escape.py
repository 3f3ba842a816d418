"""The action stored where the shield's escape ran instead of the chosen action.

The geometry of the 8 actions (a mirror of computeActions) on hand-made cases and against the C++ environment;
then the trainer on the real environment with the shield: every escaped step is stored with the action whose
velocity the robot executed under a one-action mask, and the targets that bootstrap on that state use that mask.
The C++ parts are skipped when dqn_dovs_py._core is missing, unless DQN_DOVS_REQUIRE_CORE=1.
"""

import copy
import os

import numpy as np
import pytest

from dqn_dovs_py.curriculum import StageSettings
from dqn_dovs_py.env import OUTCOME_COLLISION, VecEnv
from dqn_dovs_py.escape import (RobotLimits, RobotLimitsError, action_velocities, decode_goal, decode_velocity,
                                executed_actions, load_robot_limits, one_action_masks)
from dqn_dovs_py.train import Trainer, TrainConfig

LIMITS = RobotLimits(v_max=0.7, w_max=np.pi, a_v=0.5, a_w=2.0, dt=0.2)  # dv = 0.1 m/s, dw = 0.4 rad/s
NORM = {"v_scale_mps": 0.7, "w_scale_rps": np.pi, "goal_distance_scale_m": 10.0, "goal_angle_scale_rad": np.pi}


def _core():
    try:
        from dqn_dovs_py import _core  # noqa: PLC0415
    except ImportError as error:
        if os.environ.get("DQN_DOVS_REQUIRE_CORE") == "1":
            pytest.fail(f"dqn_dovs_py._core is not built: {error}")
        pytest.skip(f"dqn_dovs_py._core is not built: {error}")
    return _core


def state_with(v, w, goal_distance=5.0, goal_angle=np.pi):
    s = -np.ones(408, np.float32)
    s[400:] = 0.0
    s[400], s[401] = v / NORM["v_scale_mps"], w / NORM["w_scale_rps"]
    s[402], s[403] = goal_distance / 10.0, goal_angle / np.pi
    return s


def test_actions_are_the_window_corners_keep_and_the_goal_line():
    velocities, valid = action_velocities(0.35, 0.0, -3.0, 0.0, LIMITS)  # goal behind: turn in place, out of reach
    np.testing.assert_allclose(velocities[:5], [[0.45, 0.0], [0.25, 0.0], [0.35, -0.4], [0.35, 0.4], [0.35, 0.0]])
    np.testing.assert_array_equal(valid, [True] * 5 + [False] * 3)
    # Goal straight ahead: the goal line is w = 0, crossing the window from v = 0.25 to v = 0.45.
    velocities, valid = action_velocities(0.35, 0.0, 3.0, 0.0, LIMITS)
    assert valid.all()
    np.testing.assert_allclose(velocities[5:], [[0.45, 0.0], [0.25, 0.0], [0.35, 0.0]], atol=1e-12)
    # At top speed the "top" corner is clipped back onto the feasible triangle (here: the current velocity).
    velocities, _ = action_velocities(0.7, 0.0, -3.0, 0.0, LIMITS)
    np.testing.assert_allclose(velocities[0], [0.7, 0.0])


def test_the_executed_escape_maps_to_the_nearest_action_in_window_units():
    state = state_with(0.35, 0.0)
    # A lattice point of the window (0.6 dv slower, 0.3 dw to the left): nearest to the bottom corner.
    escape = state_with(0.35 - 0.06, 0.12)
    assert executed_actions(state[None], escape[None], NORM, LIMITS)[0] == 1
    # Exactly an action's velocity: that action.
    for action, (v, w) in enumerate([(0.45, 0.0), (0.25, 0.0), (0.35, -0.4), (0.35, 0.4), (0.35, 0.0)]):
        assert executed_actions(state[None], state_with(v, w)[None], NORM, LIMITS)[0] == action
    # At rest the bottom corner is "keep": equal distances go to the chosen action, else to the lowest index.
    rest = state_with(0.0, 0.0)
    assert executed_actions(rest[None], rest[None], NORM, LIMITS)[0] == 1
    assert executed_actions(rest[None], rest[None], NORM, LIMITS, chosen=np.array([4]))[0] == 4
    assert executed_actions(rest[None], rest[None], NORM, LIMITS, chosen=np.array([0]))[0] == 1
    np.testing.assert_array_equal(one_action_masks(np.array([1, 7])),
                                  [[False, True] + [False] * 6, [False] * 7 + [True]])


def test_robot_limits_follow_the_environment_and_agree_with_the_robot_file(tmp_path):
    limits = load_robot_limits({"v_scale_mps": 0.7, "w_scale_rps": float(np.float32(np.pi))})
    assert (limits.dv, limits.dw) == pytest.approx((0.1, 0.4))
    with pytest.raises(RobotLimitsError, match="v_max = 0.7 but the environment runs 0.5"):
        load_robot_limits({"v_scale_mps": 0.5, "w_scale_rps": np.pi})
    bad = tmp_path / "robot.yaml"
    bad.write_text("robot: {v_max: 0.7, w_max: 3.14159, a_v: -1, a_w: 2.0, dt: 0.2}\n")
    with pytest.raises(RobotLimitsError, match="robot/a_v must be a positive number"):
        load_robot_limits({"v_scale_mps": 0.7, "w_scale_rps": np.pi}, str(bad))


def test_action_geometry_is_the_environments():
    """On the C++ environment without the shield, the velocity the robot has after each step is the velocity this
    module gives the action taken, and the actions it finds valid are the environment's mask."""
    core = _core()
    env = VecEnv(4, 31, core=core.VecEnv(4, 31, False))
    env.set_stage(StageSettings(1.0, 12.0, 0, 12, "both"))
    norm = env.normalization()
    limits = load_robot_limits(norm)
    state, mask = env.reset()
    rng = np.random.default_rng(5)
    checked = 0
    for _ in range(250):
        actions = np.array([rng.choice(np.flatnonzero(m)) for m in mask])
        out = env.step(actions)
        v, w = decode_velocity(state, norm)
        goal_x, goal_y = decode_goal(state, norm)
        next_v, next_w = decode_velocity(out.next_state, norm)
        for i in range(4):
            velocities, valid = action_velocities(v[i], w[i], goal_x[i], goal_y[i], limits)
            np.testing.assert_array_equal(valid, mask[i])
            if out.outcome[i] == OUTCOME_COLLISION:
                continue  # the robot stops where it touched
            a = actions[i]
            assert abs(velocities[a, 0] - next_v[i]) < 1e-5 * limits.dv, (a, velocities[a], next_v[i], next_w[i])
            assert abs(velocities[a, 1] - next_w[i]) < 1e-5 * limits.dw, (a, velocities[a], next_v[i], next_w[i])
            checked += 1
        state, mask = out.state, out.mask
    assert checked > 900


class RecordingVecEnv(VecEnv):
    """Records (state, successor, chosen action) of every step that ran the shield's escape."""

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
            self.escapes.append((self._state[i].copy(), out.next_state[i].copy(), int(actions[i])))
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


def test_escaped_steps_are_stored_as_the_action_executed(tmp_path):
    core = _core()
    from dqn_dovs_py.decision_config import load_shield_parameters  # noqa: PLC0415

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

    norm = trainer._normalization
    limits = load_robot_limits(norm)
    found = bootstrapped = 0
    for state, successor, chosen in escapes:
        executed = int(executed_actions(state[None], successor[None], norm, limits, chosen=np.array([chosen]))[0])
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
