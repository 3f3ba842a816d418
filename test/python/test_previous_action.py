"""The previous action in the state (docs/dovs.md, "The previous action"): with the DOVS parameter
previous_action = 1 the environment's state carries, after the 8 features, a one-hot of what the previous step ran
(one of the 8 actions, or the shield's escape); the trainer builds and exports such a network (17 feature inputs),
widens an 8-feature network it starts from without changing what it computes, and the evaluation runs such a network
only with the same layout (compare_models gives it)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from built_tools import check_eval_needs_the_state_flags, check_evaluates_like
from dqn_dovs_py.compare_models import state_flags
from dqn_dovs_py.export import load_weights, model_from_weights, widen_previous_action

PLAIN = 408
OTHER = 8  # the slot of anything that is not one of the 8 actions: the shield's escape
ROOT = Path(__file__).resolve().parents[2]
SHIPPED = ROOT / "models" / "dqn_dovs.dqnw"
ACTIONS = (0, 3, 4, 1, 2, 4, 0, 0, 5, 6, 7, 4)


def test_the_state_ends_with_a_one_hot_of_what_the_previous_step_ran(core):
    plain = core.VecEnv(4, 43, threads=1)
    prev = core.VecEnv(4, 43, threads=1, dovs_parameters={"previous_action": "1"})
    assert (prev.state_size, plain.state_size) == (417, 408)
    for env in (plain, prev):
        env.set_stage(1.0, 6.0, 8, 14, "dynamic")
    p, _ = plain.reset()
    s, _ = prev.reset()
    np.testing.assert_array_equal(s[:, :PLAIN], p)
    assert not s[:, PLAIN:].any()  # an episode's first decision: no previous choice
    seen = set()
    for action in ACTIONS:
        actions = np.full(4, action, dtype=np.int64)
        out_p, out = plain.step(actions), prev.step(actions)
        # Same episodes, same decisions: the layout adds inputs and changes nothing else.
        np.testing.assert_array_equal(out["next_state"][:, :PLAIN], out_p["next_state"])
        np.testing.assert_array_equal(out["state"][:, :PLAIN], out_p["state"])
        for i in range(4):
            one_hot = out["next_state"][i, PLAIN:]
            assert one_hot.sum() == 1.0 and set(np.unique(one_hot)) == {0.0, 1.0}
            slot = int(np.argmax(one_hot))
            expected = OTHER if out["escaped"][i] else int(out["executed_action"][i])
            assert slot == expected, (i, action, out["escaped"][i], out["executed_action"][i])
            seen.add(slot)
            if out["outcome"][i] != 0:  # ended: what runs next is a new episode's first state
                assert not out["state"][i, PLAIN:].any()
    assert len(seen) >= 5, seen  # the test drove most of the actions, not one


@pytest.mark.parametrize("value", ["2", "-1", "x"])
def test_bad_values_are_refused_naming_the_parameter(core, value):
    with pytest.raises(ValueError, match="previous_action"):
        core.VecEnv(1, 1, threads=1, dovs_parameters={"previous_action": value})


def test_a_widened_network_computes_what_it_did_whatever_the_previous_choice():
    import torch  # noqa: PLC0415

    net = model_from_weights(load_weights(str(SHIPPED)))
    wide = widen_previous_action(net)
    assert (wide.feature_count, wide.state_size) == (17, 417)
    rng = np.random.default_rng(3)
    states = rng.uniform(-1, 1, size=(16, PLAIN)).astype(np.float32)
    one_hots = np.eye(9, dtype=np.float32)[rng.integers(0, 9, size=16)]
    with torch.no_grad():
        q8 = net(torch.from_numpy(states))
        q17 = wide(torch.from_numpy(np.concatenate([states, one_hots], axis=1)))
        q17_none = wide(torch.from_numpy(np.concatenate([states, np.zeros_like(one_hots)], axis=1)))
    torch.testing.assert_close(q17, q8, rtol=0, atol=1e-5)
    torch.testing.assert_close(q17_none, q8, rtol=0, atol=1e-5)
    with pytest.raises(ValueError, match="widen"):
        widen_previous_action(wide)


def test_a_previous_action_run_exports_17_features_and_the_evaluation_needs_the_layout(core, tmp_path):
    from dqn_dovs_py.train import ConfigError, Trainer, feature_count_of, init_from_factory  # noqa: PLC0415
    from test_train_smoke import smoke_config  # noqa: PLC0415

    assert feature_count_of({}) == 8 and feature_count_of({"previous_action": 1}) == 17
    for bad in (2, "x", 0.5):
        with pytest.raises(ConfigError, match="previous_action"):
            feature_count_of({"previous_action": bad})

    config = smoke_config()
    config.scale = 0.001  # 9 episodes
    config.dovs = {"previous_action": 1}
    trainer = Trainer(config, str(tmp_path / "run"), device="cpu", threads=1, progress=False,
                      model_factory=init_from_factory(str(SHIPPED), 1, 17))
    assert trainer.replay.state_dim == 417 and trainer.replay.grid_cells == 400  # the grid still stored as int8
    trainer.run()
    model = str(tmp_path / "run" / "model.dqnw")
    weights = load_weights(model)
    assert (weights.format_version, weights.grid_channels, weights.feature_count) == (1, 1, 17)
    assert weights.normalization == load_weights(str(SHIPPED)).normalization
    assert state_flags(model) == ["--dovs", "previous_action=1"]

    # A network that reads the previous choice cannot start a run without it.
    with pytest.raises(ConfigError, match="17 feature inputs"):
        init_from_factory(model, 1, 8)

    check_eval_needs_the_state_flags(model, state_flags(model),
                                     "'state layout: feature count' is 17 in the file but 8 here", tmp_path)


def test_a_widened_network_evaluates_exactly_like_its_source(tmp_path):
    """The widened shipped network with --dovs previous_action=1 drives the same episodes the same way as the
    shipped one: the C++ reader, the 417-float state and the planner agree with the widening."""
    from dqn_dovs_py.export import export_model  # noqa: PLC0415

    weights = load_weights(str(SHIPPED))
    wide_path = tmp_path / "wide.dqnw"
    export_model(widen_previous_action(model_from_weights(weights)), wide_path, weights.normalization,
                 "widened shipped network", onnx=False)
    check_evaluates_like(str(SHIPPED), str(wide_path), ["--dovs", "previous_action=1"], tmp_path)
