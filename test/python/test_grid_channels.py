"""Grid channels (docs/dovs.md, "Grid channels"): with the DOVS parameter grid_channels = 3 the environment's state
holds the dynamic window and the goal line as two more 20 x 20 images between the DOVS grid and the features; the
trainer builds and exports such a network (format version 2), widens a one-channel network it starts from without
changing what it computes, and the evaluation runs such a network only with the same layout (compare_models gives
it)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from built_tools import check_eval_needs_the_state_flags, check_evaluates_like
from dqn_dovs_py.compare_models import state_flags
from dqn_dovs_py.export import load_weights, model_from_weights, widen_grid_channels

GRID = 400
ROOT = Path(__file__).resolve().parents[2]
SHIPPED = ROOT / "models" / "dqn_dovs.dqnw"


def _states(core, **kwargs) -> np.ndarray:
    env = core.VecEnv(3, 43, threads=1, **kwargs)
    env.set_stage(2.0, 6.0, 6, 10, "dynamic")
    states, _ = env.reset()
    out = [states]
    for action in (0, 3, 4, 1, 2, 4):
        out.append(env.step(np.full(3, action, dtype=np.int64))["state"])
    return np.concatenate(out)


def test_the_environment_puts_the_window_and_the_goal_line_between_grid_and_features(core):
    plain = _states(core)
    wide = _states(core, dovs_parameters={"grid_channels": "3"})
    env = core.VecEnv(1, 1, threads=1, dovs_parameters={"grid_channels": "3"})
    assert (env.state_size, env.grid_channels) == (1208, 3)
    assert (core.VecEnv(1, 1, threads=1).state_size, core.VecEnv(1, 1, threads=1).grid_channels) == (408, 1)
    assert plain.shape[1] == 408 and wide.shape == (plain.shape[0], 1208)
    np.testing.assert_array_equal(wide[:, :GRID], plain[:, :GRID])  # same episodes, same DOVS grid
    np.testing.assert_array_equal(wide[:, 3 * GRID:], plain[:, GRID:])  # same features
    window, line = wide[:, GRID:2 * GRID], wide[:, 2 * GRID:3 * GRID]
    assert set(np.unique(window)) <= {-1.0, 1.0} and set(np.unique(line)) <= {-1.0, 1.0}
    # The window is a small patch around the robot's velocity: from a few cells up to a few dozen.
    marked = (window > 0).sum(axis=1)
    assert marked.min() >= 2 and marked.max() <= 60, marked
    # The goal line runs from the bottom row (v = 0) upwards unless the goal is behind.
    rows = (line.reshape(-1, 20, 20) > 0).any(axis=2)
    assert rows[:, 19].all()
    assert rows.sum(axis=1).max() >= 10
    # It moves with the robot: the images are not the same in every state.
    assert len({w.tobytes() for w in window}) >= 3
    # The normalisation entries are the paper's: the layout is the state's size, not an entry.
    assert env.normalization() == core.VecEnv(1, 1, threads=1).normalization()


def test_the_history_channel_is_the_previous_decisions_grid(core):
    """grid_channels = 2 (one step of history): each state's second channel is the first channel of the state the
    agent acted on one step before, its own grid at an episode's first decision; the rest is the one-channel state."""
    plain = core.VecEnv(3, 43, threads=1)
    hist = core.VecEnv(3, 43, threads=1, dovs_parameters={"grid_channels": "2"})
    assert (hist.state_size, hist.grid_channels) == (808, 2)
    for env in (plain, hist):
        env.set_stage(2.0, 6.0, 6, 10, "dynamic")
    p, _ = plain.reset()
    h, _ = hist.reset()
    np.testing.assert_array_equal(h[:, GRID:2 * GRID], h[:, :GRID])  # first decision: its own grid
    changed = 0
    for action in (0, 3, 4, 1, 2, 4, 0, 0):
        actions = np.full(3, action, dtype=np.int64)
        out_p, out_h = plain.step(actions), hist.step(actions)
        np.testing.assert_array_equal(out_h["next_state"][:, :GRID], out_p["next_state"][:, :GRID])
        np.testing.assert_array_equal(out_h["next_state"][:, 2 * GRID:], out_p["next_state"][:, GRID:])
        for i in range(3):
            if out_h["episode_steps"][i] > 0 and out_h["outcome"][i] == 0:  # the episode goes on
                np.testing.assert_array_equal(out_h["next_state"][i, GRID:2 * GRID], h[i, :GRID])
                changed += int(np.any(out_h["next_state"][i, GRID:2 * GRID] != out_h["next_state"][i, :GRID]))
        h = out_h["state"]
    assert changed > 3, "the grid never moved between decisions"


@pytest.mark.parametrize("value", ["4", "0", "three"])
def test_bad_channel_counts_are_refused_naming_the_parameter(core, value):
    with pytest.raises(ValueError, match="grid_channels"):
        core.VecEnv(1, 1, threads=1, dovs_parameters={"grid_channels": value})


def test_a_widened_network_computes_what_it_did(core, tmp_path):
    import torch  # noqa: PLC0415

    plain = _states(core)
    wide_states = _states(core, dovs_parameters={"grid_channels": "3"})
    net = model_from_weights(load_weights(str(SHIPPED)))
    wide = widen_grid_channels(net, 3)
    assert wide.grid_channels == 3 and wide.state_size == 1208
    with torch.no_grad():
        q1 = net(torch.from_numpy(plain))
        q3 = wide(torch.from_numpy(wide_states))
        # Whatever the new channels hold, the widened network reads only the first.
        q3_noise = wide(torch.from_numpy(np.concatenate(
            [wide_states[:, :GRID], -wide_states[:, GRID:3 * GRID], wide_states[:, 3 * GRID:]], axis=1)))
    torch.testing.assert_close(q3, q1, rtol=0, atol=1e-5)
    torch.testing.assert_close(q3_noise, q1, rtol=0, atol=1e-5)
    with pytest.raises(ValueError, match="widen"):
        widen_grid_channels(wide, 1)


def test_a_channels_run_exports_version_two_and_the_evaluation_needs_the_layout(core, tmp_path):
    from dqn_dovs_py.train import ConfigError, Trainer, grid_channels_of, init_from_factory  # noqa: PLC0415
    from test_train_smoke import smoke_config  # noqa: PLC0415

    assert grid_channels_of({}) == 1 and grid_channels_of({"grid_channels": 3}) == 3
    for bad in (4, "x", 3.5):
        with pytest.raises(ConfigError, match="grid_channels"):
            grid_channels_of({"grid_channels": bad})

    config = smoke_config()
    config.scale = 0.001  # 9 episodes
    config.dovs = {"grid_channels": 3}
    trainer = Trainer(config, str(tmp_path / "run"), device="cpu", threads=1, progress=False,
                      model_factory=init_from_factory(str(SHIPPED), 3))
    assert trainer.replay.state_dim == 1208 and trainer.replay.grid_cells == 1200  # still int8 + float32
    trainer.run()
    model = str(tmp_path / "run" / "model.dqnw")
    weights = load_weights(model)
    assert (weights.format_version, weights.grid_channels) == (2, 3)
    assert weights.normalization == load_weights(str(SHIPPED)).normalization
    assert state_flags(model) == ["--dovs", "grid_channels=3"]
    assert state_flags(str(SHIPPED)) == []

    # A network of 3 channels cannot start a run of one.
    with pytest.raises(ConfigError, match="3 grid channels"):
        init_from_factory(model, 1)

    check_eval_needs_the_state_flags(model, state_flags(model),
                                     "'state layout: grid channels' is 3 in the file but 1 here", tmp_path)


def test_a_widened_network_evaluates_exactly_like_its_source(tmp_path):
    """The widened shipped network with --dovs grid_channels=3 drives the same episodes the same way as the shipped
    one: the C++ reader, the 3-channel state and the planner agree with the widening."""
    from dqn_dovs_py.export import export_model  # noqa: PLC0415

    weights = load_weights(str(SHIPPED))
    wide_path = tmp_path / "wide.dqnw"
    export_model(widen_grid_channels(model_from_weights(weights), 3), wide_path, weights.normalization,
                 "widened shipped network", onnx=False)
    check_evaluates_like(str(SHIPPED), str(wide_path), ["--dovs", "grid_channels=3"], tmp_path)
