"""Format versions 3 and 4 (wall rays, route points, person tokens pooled by attention, a quantile head with CVaR action choice) against the
planner's Eigen inference and onnxruntime: |dQ| <= 1e-5 on every output, the same greedy actions, permutation
invariance over the tokens and absent slots that change nothing.

Needs the built tool dqn_dovs_qnet_eval in $DQN_DOVS_BIN_DIR (as test_qnet_parity.py); builds nothing.
"""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np
import onnxruntime as ort
import pytest
import torch

from built_tools import built_tool
from dqn_dovs_py.export import (FORMAT_VERSION_ROUTE, FORMAT_VERSION_TOKENS, ONNX_ACTION_VALUES, export_model, load_weights,
                                model_from_weights)
from dqn_dovs_py.model import TOKEN_SIZE, DuelingQNet, masked_argmax, widen_tokens, widened
from dqn_dovs_py.model import widen_quantiles

NORMALIZATION = {"v_max": 0.7, "w_max": 3.14159265}
TOLERANCE = 1e-5
RAYS, TOKENS = 8, 6


def _net(seed: int, quantiles: int = 1, cvar_alpha: float = 1.0) -> DuelingQNet:
    torch.manual_seed(seed)
    net = DuelingQNet(wall_rays=RAYS, person_tokens=TOKENS, quantiles=quantiles, cvar_alpha=cvar_alpha).eval()
    with torch.no_grad():
        for module in net.modules():
            if isinstance(module, torch.nn.Linear):
                module.bias.add_(0.3 * torch.randn_like(module.bias))
    return net


def _states(n: int, seed: int) -> np.ndarray:
    """Grid +-1, features and rays in range, and tokens as the state builder writes them: a random number present
    (0 to all), the present ones first, absent slots all zero."""
    rng = np.random.default_rng(seed)
    grid = np.where(rng.random((n, 400)) < 0.7, 1.0, -1.0)
    features = rng.uniform(-1.0, 1.0, size=(n, 8))
    rays = rng.uniform(0.0, 1.0, size=(n, RAYS))
    tokens = rng.uniform(-2.0, 2.0, size=(n, TOKENS, TOKEN_SIZE))
    tokens[:, :, 0] = 1.0
    present = rng.integers(0, TOKENS + 1, size=n)
    for i, k in enumerate(present):
        tokens[i, k:, :] = 0.0
    return np.concatenate([grid, features, rays, tokens.reshape(n, -1)], axis=1).astype(np.float32)


def _eigen(weights: Path, states: np.ndarray, tmp_path: Path, values: str, width: int) -> np.ndarray:
    states_file, out_file = tmp_path / "states.f32", tmp_path / f"{values}.f32"
    states.astype("<f4").tofile(states_file)
    result = subprocess.run([str(built_tool("dqn_dovs_qnet_eval")), "--values", values, str(weights),
                             str(states_file), str(out_file)], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, f"dqn_dovs_qnet_eval failed: {result.stderr}"
    return np.fromfile(out_file, dtype="<f4").reshape(len(states), width)


def _onnx(model: Path, states: np.ndarray) -> list[np.ndarray]:
    options = ort.SessionOptions()
    options.intra_op_num_threads = 1
    session = ort.InferenceSession(str(model), options, providers=["CPUExecutionProvider"])
    names = [o.name for o in session.get_outputs()]
    return dict(zip(names, session.run(names, {"state": states})))


@pytest.mark.parametrize("quantiles,cvar_alpha", [(1, 1.0), (16, 0.25)])
def test_token_network_matches_eigen_and_onnx(tmp_path: Path, quantiles: int, cvar_alpha: float) -> None:
    net = _net(7 + quantiles, quantiles, cvar_alpha)
    path = export_model(net, tmp_path / "tokens.dqnw", NORMALIZATION, "token parity")
    weights = load_weights(path)
    assert weights.format_version == FORMAT_VERSION_TOKENS
    assert (weights.wall_ray_count, weights.person_token_count, weights.token_size) == (RAYS, TOKENS, TOKEN_SIZE)
    assert (weights.quantile_count, weights.cvar_count) == (quantiles, 4 if quantiles == 16 else 1)
    states = _states(400, quantiles)
    with torch.no_grad():
        x = torch.from_numpy(states)
        q_torch, a_torch = net(x).numpy(), net.action_values(x).numpy()
        z_torch = net.quantile_values(x).numpy().reshape(len(states), -1)
    assert q_torch.std(axis=0).min() > 1e-3  # not degenerate
    q_eigen = _eigen(path, states, tmp_path, "q", 8)
    a_eigen = _eigen(path, states, tmp_path, "action", 8)
    z_eigen = _eigen(path, states, tmp_path, "quantiles", 8 * quantiles)
    assert np.abs(q_eigen - q_torch).max() <= TOLERANCE
    assert np.abs(a_eigen - a_torch).max() <= TOLERANCE
    assert np.abs(z_eigen - z_torch).max() <= TOLERANCE
    onnx_out = _onnx(path.with_suffix(".onnx"), states)
    assert np.abs(onnx_out["q_values"] - q_torch).max() <= TOLERANCE
    if quantiles > 1:
        assert np.abs(onnx_out[ONNX_ACTION_VALUES] - a_torch).max() <= TOLERANCE
        assert np.abs(a_torch - q_torch).max() > 1e-3  # CVaR is not the mean here
    mask = torch.from_numpy(np.random.default_rng(quantiles).random((len(states), 8)) < 0.6)
    best_torch = masked_argmax(torch.from_numpy(a_torch), mask).numpy()
    best_eigen = masked_argmax(torch.from_numpy(a_eigen), mask).numpy()
    ordered = np.sort(np.where(mask.numpy(), a_torch, -np.inf), axis=1)
    clear = ~np.isfinite(ordered[:, -2]) | ((ordered[:, -1] - ordered[:, -2]) > 1e-4)
    assert clear.mean() > 0.95
    assert np.array_equal(best_torch[clear], best_eigen[clear])
    # The file rebuilds the same network.
    rebuilt = model_from_weights(weights).eval()
    with torch.no_grad():
        assert torch.equal(rebuilt.action_values(x), net.action_values(x))


def test_tokens_are_a_set_and_absent_slots_count_for_nothing(tmp_path: Path) -> None:
    net = _net(3)
    path = export_model(net, tmp_path / "set.dqnw", NORMALIZATION, "token set", onnx=False)
    states = _states(50, 11)
    base = 400 + 8 + RAYS
    tokens = states[:, base:].reshape(50, TOKENS, TOKEN_SIZE)
    # Swap the first two slots wherever both are present, and fill absent slots (presence 0) with noise.
    swapped = tokens.copy()
    both = (tokens[:, 0, 0] > 0.5) & (tokens[:, 1, 0] > 0.5)
    swapped[both, 0], swapped[both, 1] = tokens[both, 1], tokens[both, 0]
    absent = swapped[:, :, 0] < 0.5
    noise = np.random.default_rng(5).uniform(-2, 2, size=swapped.shape).astype(np.float32)
    noise[:, :, 0] = 0.0
    swapped[absent] = noise[absent]
    changed = states.copy()
    changed[:, base:] = swapped.reshape(50, -1)
    assert both.any() and absent.any()
    q = _eigen(path, states, tmp_path, "q", 8)
    q_changed = _eigen(path, changed, tmp_path, "q", 8)
    assert np.abs(q - q_changed).max() <= TOLERANCE
    # But a present token does matter.
    moved = states.copy()
    moved[:, base + 1] += 0.5
    present = states[:, base] > 0.5
    assert np.abs(_eigen(path, moved, tmp_path, "q", 8) - q)[present].max() > 1e-4


def test_widened_network_is_the_start_network_until_trained() -> None:
    torch.manual_seed(0)
    start = DuelingQNet().eval()
    wide = widen_quantiles(widen_tokens(start, RAYS, TOKENS), 16, 0.25).eval()
    states = torch.from_numpy(_states(64, 2))
    with torch.no_grad():
        q_start = start(states[:, :408])
        assert torch.allclose(wide(states), q_start, atol=1e-6)
        assert torch.allclose(wide.action_values(states), q_start, atol=1e-6)


ROUTE = 5


def test_route_points_network_matches_eigen_and_onnx(tmp_path: Path) -> None:
    """Format version 4: the route points after the wall rays feed the feature stream; the tokens come after them."""
    torch.manual_seed(21)
    net = DuelingQNet(wall_rays=RAYS, person_tokens=TOKENS, route_points=ROUTE).eval()
    path = export_model(net, tmp_path / "route.dqnw", NORMALIZATION, "route parity")
    weights = load_weights(path)
    assert weights.format_version == FORMAT_VERSION_ROUTE
    assert weights.route_point_count == ROUTE
    base = _states(300, 4)
    route = np.random.default_rng(6).uniform(-1.0, 2.0, size=(300, 2 * ROUTE)).astype(np.float32)
    at = 400 + 8 + RAYS
    states = np.concatenate([base[:, :at], route, base[:, at:]], axis=1)
    assert states.shape[1] == net.state_size
    with torch.no_grad():
        x = torch.from_numpy(states)
        q_torch = net(x).numpy()
    q_eigen = _eigen(path, states, tmp_path, "q", 8)
    assert np.abs(q_eigen - q_torch).max() <= TOLERANCE
    assert np.abs(_onnx(path.with_suffix(".onnx"), states)["q_values"] - q_torch).max() <= TOLERANCE
    # The route points matter, and a network widened to read them starts as the network it was.
    moved = states.copy()
    moved[:, at:at + 2 * ROUTE] = 0.0
    assert np.abs(_eigen(path, moved, tmp_path, "q", 8) - q_eigen).max() > 1e-4
    torch.manual_seed(0)
    start = DuelingQNet(wall_rays=RAYS, person_tokens=TOKENS).eval()
    wide = widened(start, route_points=ROUTE).eval()
    with torch.no_grad():
        assert torch.allclose(wide(x), start(torch.from_numpy(np.concatenate([states[:, :at], states[:, at + 2 * ROUTE:]],
                                                                          axis=1))), atol=1e-6)
