"""The graded grid (docs/dovs.md, "The graded grid"): the environment builds it when the DOVS parameter
grid_contact_horizon asks, the trainer passes its `dovs` section on, the exported weight file names the encoding, and
the evaluation runs such a network only with the same encoding (compare_models gives it)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from built_tools import check_eval_needs_the_state_flags
from dqn_dovs_py.compare_models import state_flags
from dqn_dovs_py.export import load_weights

GRID = 400
ROOT = Path(__file__).resolve().parents[2]


def _states(core, **kwargs) -> np.ndarray:
    env = core.VecEnv(3, 41, threads=1, **kwargs)
    env.set_stage(3.0, 6.0, 8, 12, "dynamic")
    states, _ = env.reset()
    out = [states]
    for _ in range(5):
        out.append(env.step(np.full(3, 4, dtype=np.int64))["state"])  # keep
    return np.concatenate(out)


def test_the_environment_grades_the_grid_keeping_its_signs_and_the_features(core):
    plain = _states(core)
    graded = _states(core, dovs_parameters={"grid_contact_horizon": "5"})
    assert plain.shape == graded.shape
    np.testing.assert_array_equal(graded[:, GRID:], plain[:, GRID:])  # same episodes, same features
    np.testing.assert_array_equal(graded[:, :GRID] > 0, plain[:, :GRID] > 0)  # free stays free
    assert set(np.unique(plain[:, :GRID])) <= {-1.0, 1.0}
    inside = (np.abs(graded[:, :GRID]) < 1.0).sum()
    assert inside > 100, f"only {inside} graded cells strictly inside (-1, 1) among 8-12 moving obstacles"
    env = core.VecEnv(1, 1, threads=1, dovs_parameters={"grid_contact_horizon": "5"})
    assert env.normalization()["grid_contact_horizon_s"] == pytest.approx(5.0)
    assert "grid_contact_horizon_s" not in core.VecEnv(1, 1, threads=1).normalization()


@pytest.mark.parametrize("parameters, message", [
    ({"grid_horizon": "5"}, "grid_horizon"),
    ({"grid_contact_horizon": "0.2"}, "grid_contact_horizon_s"),
    ({"grid_contact_horizon": "soon"}, "grid_contact_horizon"),
])
def test_bad_dovs_parameters_are_refused_naming_them(core, parameters, message):
    with pytest.raises(ValueError, match=message):
        core.VecEnv(1, 1, threads=1, dovs_parameters=parameters)


def test_a_graded_run_exports_its_encoding_and_the_evaluation_needs_it(core, tmp_path):
    from dqn_dovs_py.train import (  # noqa: PLC0415 - torch only where it trains
        ConfigError, TrainConfig, Trainer, parse_dovs_option)
    from test_train_smoke import smoke_config  # noqa: PLC0415

    with pytest.raises(ConfigError, match="dovs"):
        TrainConfig.from_dict({"dovs": [5]})
    bad = smoke_config()
    bad.dovs = {"grid_contact_horizon": "5"}
    assert "grid_contact_horizon" in bad.validate()
    for wrong, message in (({"grid_horizon": 5.0}, "grid_horizon"), ({"grid_contact_horizon": 0.2}, "0.5, 30")):
        bad.dovs = wrong
        with pytest.raises(ConfigError, match=message):
            Trainer(bad, str(tmp_path / "bad"), device="cpu", threads=1, progress=False)
    assert parse_dovs_option("grid_contact_horizon=5, prediction_growth=0.1") == {
        "grid_contact_horizon": 5.0, "prediction_growth": 0.1}
    for text in ("grid_contact_horizon", "=5", "grid_contact_horizon=soon", "grid_contact_horizon=inf"):
        with pytest.raises(ConfigError, match="--dovs"):
            parse_dovs_option(text)

    config = smoke_config()
    config.scale = 0.001  # 9 episodes
    config.dovs = {"grid_contact_horizon": 5.0}
    assert config.replay.compact_states  # graded states cannot be compact: the trainer stores them as float32
    trainer = Trainer(config, str(tmp_path / "run"), device="cpu", threads=1, progress=False)
    assert trainer.replay.grid_cells == 0
    trainer.run()
    model = str(tmp_path / "run" / "model.dqnw")
    assert load_weights(model).normalization["grid_contact_horizon_s"] == pytest.approx(5.0)
    assert state_flags(model) == ["--dovs", "grid_contact_horizon=5"]

    check_eval_needs_the_state_flags(model, state_flags(model), "grid_contact_horizon_s", tmp_path)
    assert state_flags(str(ROOT / "models" / "dqn_dovs.dqnw")) == []  # a +1 / -1 network needs none
