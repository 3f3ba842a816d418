"""The training reward's parameters (docs/training.md, "Reward"): the trainer config's `reward:` section reaches the
C++ environments by name, a collision the robot was walked into at rest is priced by hit_at_rest_reward there, and
bad names, values and a shaping discount other than the paper's or the trainer's are refused, naming them."""

from __future__ import annotations

import numpy as np
import pytest

KEEP = 4  # the action that keeps the current velocity


def _walked_into(core, **kwargs) -> float:
    """The terminal reward of the first episode that ends in a collision, the robot keeping still throughout (only
    moving discs can reach it, so every contact is one it was walked into at rest)."""
    env = core.VecEnv(4, 17, threads=1, **kwargs)
    env.set_stage(3.0, 6.0, 12, 12, "dynamic")
    env.reset()
    for _ in range(400):
        out = env.step(np.full(4, KEEP, dtype=np.int64))
        for i, outcome in enumerate(out["outcome"]):
            if int(outcome) == 2:  # collision
                return float(out["reward"][i])
    pytest.fail("no disc walked into the resting robot in 400 steps")


def test_the_reward_section_reaches_the_environment(core):
    assert "hit_at_rest_reward" in core.reward_parameter_names()
    assert _walked_into(core) == pytest.approx(-15.0)  # the paper's: a contact is a contact
    assert _walked_into(core, reward_parameters={"hit_at_rest_reward": "-4"}) == pytest.approx(-4.0)


@pytest.mark.parametrize("parameters, message", [
    ({"hit_reward": "1"}, "unknown reward parameter 'hit_reward'"),
    ({"hit_at_rest_reward": "-30"}, "hit_at_rest_reward"),
    ({"intimate_weight": "much"}, "intimate_weight"),
])
def test_bad_reward_parameters_are_refused_naming_them(core, parameters, message):
    with pytest.raises(ValueError, match=message):
        core.VecEnv(1, 1, threads=1, reward_parameters=parameters)


def test_the_trainer_config_checks_its_reward_section():
    import dataclasses  # noqa: PLC0415

    from dqn_dovs_py.train import ConfigError, TrainConfig  # noqa: PLC0415 - torch only where it trains
    from test_train_smoke import smoke_config  # noqa: PLC0415

    base = smoke_config()
    assert base.reward == {}  # the shipped curriculum trains on the paper's reward
    assert dataclasses.replace(base, reward={"shaping_gamma": 0.97, "intimate_weight": 0.5}).validate() == ""
    assert dataclasses.replace(base, reward={"shaping_gamma": 1.0}).validate() == ""
    message = dataclasses.replace(base, reward={"shaping_gamma": 0.9}).validate()
    assert "shaping_gamma 0.9 is neither 1" in message
    assert "must map to a finite number" in dataclasses.replace(base, reward={"goal_reward": "big"}).validate()
    assert TrainConfig.from_dict({"reward": {"blocking_weight": 1}}).reward == {"blocking_weight": 1}
    with pytest.raises(ConfigError, match="reward: expected a mapping"):
        TrainConfig.from_dict({"reward": [1]})
