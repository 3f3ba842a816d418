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


def test_the_trainer_refuses_a_reward_the_environment_cannot_take_before_any_run(core, tmp_path):
    import dataclasses  # noqa: PLC0415

    from dqn_dovs_py.train import ConfigError, Trainer  # noqa: PLC0415 - torch only where it trains
    from test_train_smoke import smoke_config  # noqa: PLC0415

    bad = dataclasses.replace(smoke_config(), reward={"hit_reward": -5.0})
    with pytest.raises(ConfigError, match="reward_parameters: unknown reward parameter 'hit_reward'"):
        Trainer(bad, str(tmp_path / "bad"), device="cpu", threads=1, progress=False)
    assert not (tmp_path / "bad").exists()


def test_the_deployed_curriculum_trains_among_people_who_notice_the_robot(core, monkeypatch):
    """config/curriculum_deployed.yaml: valid; its dynamic stages draw every building family, mostly at the headline
    mix with shares of the oblivious stress test and of all attentive people; its reward prices the yardstick with
    shaping consistent with its discount; and the C++ environments accept every world and the reward as written."""
    import os  # noqa: PLC0415

    from dqn_dovs_py.train import load_config  # noqa: PLC0415 - torch only where it trains

    root = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
    monkeypatch.chdir(root)  # the predictor's path is relative to the repository, where training runs
    config_dir = os.path.join(root, "config")
    config = load_config(os.path.join(config_dir, "curriculum_deployed.yaml"))
    assert config.validate() == ""
    assert config.action_shield and config.decision_config == ""  # the robot's own dovs.yaml and static_safety.yaml
    assert config.reward["shaping_gamma"] == config.gamma
    assert config.reward["hit_at_rest_reward"] < 0
    dynamic = [s for s in config.build_curriculum().stages if s.obstacle_type not in ("none", "static")]
    assert dynamic
    for stage in dynamic:
        people = [w for w in stage.worlds if w.world != "room"]
        assert {w.world for w in people} == {"crowd", "corridor", "doorway", "clutter", "junction"}
        weight = {mix: sum(w.weight for w in people if w.people_mix == mix)
                  for mix in ("headline", "oblivious=1", "attentive=1")}
        assert weight["headline"] > weight["oblivious=1"] > 0 and weight["attentive=1"] > 0
        assert sum(weight.values()) == sum(w.weight for w in people)
        assert {w.sensor for w in people} >= {"sim", "urg04lx", "rplidar_a1"}
        assert all(w.people_predictor for w in people)
        env = core.VecEnv(1, 1, threads=1, reward_parameters={k: str(v) for k, v in config.reward.items()})
        env.set_worlds([w.options() for w in stage.worlds], [w.weight for w in stage.worlds])
