"""The trainer runs the action shield the robot runs: decision_config reads config/dovs.yaml and
config/static_safety.yaml as the nodes do, the C++ environment applies them by name, and the C++ defaults
(what dqn_dovs_eval runs without --shield) are the YAML values. Bad files are refused naming file and key.

Needs dqn_dovs_py._core (skipped without it unless DQN_DOVS_REQUIRE_CORE=1, as in scripts/run_tests.sh)."""

import os
import shutil

import pytest

REPO = os.path.join(os.path.dirname(__file__), "..", "..")
REQUIRE_CORE = os.environ.get("DQN_DOVS_REQUIRE_CORE") == "1"


@pytest.fixture
def core():
    try:
        from dqn_dovs_py import _core  # noqa: PLC0415
    except ImportError as error:
        if REQUIRE_CORE:
            pytest.fail(f"dqn_dovs_py._core cannot be imported ({error}) [DQN_DOVS_REQUIRE_CORE=1]")
        pytest.skip(f"dqn_dovs_py._core cannot be imported ({error})")
    return _core


def _same(a: str, b: str) -> bool:
    """Two parameter texts with the same value (numbers compared as numbers)."""
    try:
        return float(a) == float(b)
    except ValueError:
        return a == b


def test_the_repository_config_names_every_shield_parameter(core):
    from dqn_dovs_py.decision_config import load_shield_parameters  # noqa: PLC0415

    params = load_shield_parameters()
    assert set(params) == set(core.shield_parameter_names())
    assert params["passive_escape"] == "true"
    assert float(params["static_safety/margin"]) == 0.05


def test_the_environment_runs_the_yaml_and_the_defaults_are_the_yaml(core, tmp_path):
    from dqn_dovs_py.decision_config import load_shield_parameters  # noqa: PLC0415
    from dqn_dovs_py.env import VecEnv  # noqa: PLC0415

    params = load_shield_parameters()
    # dqn_dovs_eval and the C++ defaults: the same values as the files the robot's launch loads.
    defaults = core.default_shield_parameters()
    different = {k: (defaults[k], v) for k, v in params.items() if not _same(defaults[k], v)}
    assert not different, f"C++ defaults differ from config/*.yaml: {different}"

    # A configuration folder with other values: the environment runs them, not the defaults.
    other = tmp_path / "config"
    shutil.copytree(os.path.join(REPO, "config"), other)
    text = (other / "static_safety.yaml").read_text().replace("margin: 0.05", "margin: 0.12")
    (other / "static_safety.yaml").write_text(text)
    text = (other / "dovs.yaml").read_text().replace("escape_window_samples: 5", "escape_window_samples: 3")
    (other / "dovs.yaml").write_text(text)
    changed = load_shield_parameters(str(other))
    env = VecEnv(2, 7, action_shield=True, shield_parameters=changed)
    running = env._core.shield_parameters()
    assert float(running["static_safety/margin"]) == 0.12
    assert running["escape_window_samples"] == "3"
    assert running["enabled"] == "true"
    assert all(_same(running[k], v) for k, v in changed.items())
    # action_shield=False switches the shield off whatever the file says.
    assert VecEnv(1, 7, action_shield=False, shield_parameters=changed)._core.shield_parameters()["enabled"] == "false"


def test_bad_files_and_values_are_named(core, tmp_path):
    from dqn_dovs_py.decision_config import DecisionConfigError, load_shield_parameters  # noqa: PLC0415
    from dqn_dovs_py.env import VecEnv  # noqa: PLC0415

    other = tmp_path / "config"
    shutil.copytree(os.path.join(REPO, "config"), other)
    dovs = other / "dovs.yaml"
    original = dovs.read_text()
    dovs.write_text(original.replace("passive_escape: true", "passive_escap: true"))
    with pytest.raises(DecisionConfigError, match=r"dovs\.yaml: 'action_shield/passive_escap' is not an action shield"):
        load_shield_parameters(str(other))
    dovs.write_text(original.replace("rest_speed: 0.05", "rest_speed: [0.05]"))
    with pytest.raises(DecisionConfigError, match=r"dovs\.yaml: 'action_shield/rest_speed'"):
        load_shield_parameters(str(other))
    (other / "static_safety.yaml").unlink()
    dovs.write_text(original)
    with pytest.raises(DecisionConfigError, match=r"static_safety\.yaml: cannot be read"):
        load_shield_parameters(str(other))
    # Values the C++ setter or the validation refuses stop the environment with the parameter's name.
    with pytest.raises(ValueError, match="escape_window_samples"):
        VecEnv(1, 7, action_shield=True, shield_parameters={"escape_window_samples": "2.5"})
    with pytest.raises(ValueError, match="margin"):
        VecEnv(1, 7, action_shield=True, shield_parameters={"static_safety/margin": "-1"})


def test_training_runs_the_dovs_model_of_the_robots_dovs_yaml(core, tmp_path):
    """The trainer's environments build their velocity spaces with config/dovs.yaml's dovs: section (the folder of
    decision_config), the configuration's own dovs section over it; every export names the values
    (`state parameters:`)."""
    from dqn_dovs_py.decision_config import DecisionConfigError, load_dovs_parameters  # noqa: PLC0415

    robot = load_dovs_parameters()
    assert robot["safety_factor"] == "1.1" and robot["obstacle_range"] == "4.0"
    other = tmp_path / "config"
    shutil.copytree(os.path.join(REPO, "config"), other)
    text = (other / "dovs.yaml").read_text().replace("safety_factor: 1.1", "safety_factor: 1.3")
    (other / "dovs.yaml").write_text(text)
    assert load_dovs_parameters(str(other))["safety_factor"] == "1.3"
    import yaml  # noqa: PLC0415

    raw = yaml.safe_load(open(os.path.join(REPO, "config", "curriculum.yaml")).read())
    raw["decision_config"] = str(other)
    raw["dovs"] = {"time_horizon": 4.0}
    trainer_config = tmp_path / "run.yaml"
    trainer_config.write_text(yaml.safe_dump(raw))
    from dqn_dovs_py.train import Trainer, load_config  # noqa: PLC0415

    trainer = Trainer(load_config(str(trainer_config)), str(tmp_path / "out"))
    assert trainer.dovs_parameters["safety_factor"] == "1.3"
    env = trainer._env_factory(1, 0, False)
    line = env.state_parameters()
    assert "dovs/safety_factor=1.3 " in line and "dovs/time_horizon=4 " in line, line
    (other / "dovs.yaml").write_text(text.replace("safety_factor: 1.3", "safety_factr: 1.3"))
    with pytest.raises(DecisionConfigError, match="'dovs/safety_factr' is not a DOVS parameter"):
        load_dovs_parameters(str(other))
