"""PyTorch vs the C++ planner's inference on the same exported network: max |dQ| < 1e-4.

Needs the built tool dqn_dovs_qnet_eval, found in $DQN_DOVS_BIN_DIR (the directory of built
executables, e.g. install/lib/dqn_dovs or a CMake build directory). This test builds nothing.
"""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np
import pytest
import torch

from built_tools import built_tool
from qnet_samples import random_net, random_states
from dqn_dovs_py.export import export_model
from dqn_dovs_py.model import masked_argmax

NORMALIZATION = {"v_max": 0.7, "w_max": 3.14159265, "goal_distance_scale": 8.0}


def _eval_tool() -> Path:
    return built_tool("dqn_dovs_qnet_eval")


def _cpp_q(tool: Path, weights: Path, states: np.ndarray, tmp_path: Path) -> np.ndarray:
    states_file = tmp_path / "states.f32"
    out_file = tmp_path / "q.f32"
    states.astype("<f4").tofile(states_file)
    result = subprocess.run([str(tool), str(weights), str(states_file), str(out_file)], capture_output=True, text=True,
                            timeout=120)
    assert result.returncode == 0, f"dqn_dovs_qnet_eval failed: {result.stderr}"
    return np.fromfile(out_file, dtype="<f4").reshape(-1, 8)


@pytest.mark.parametrize("seed", [0, 1])
def test_cpp_q_values_match_pytorch(tmp_path: Path, seed: int) -> None:
    tool = _eval_tool()
    net = random_net(seed)
    weights = export_model(net, tmp_path / "net.dqnw", NORMALIZATION, f"parity test seed {seed}")
    states = random_states(500, seed + 100)
    with torch.no_grad():
        q_torch = net(torch.from_numpy(states)).numpy()
    q_cpp = _cpp_q(tool, weights, states, tmp_path)
    assert q_cpp.shape == q_torch.shape
    # The network must not be degenerate, or equality would prove little.
    assert q_torch.std(axis=0).min() > 1e-3
    max_diff = float(np.abs(q_cpp - q_torch).max())
    assert max_diff < 1e-4, f"max |dQ| = {max_diff}"
    # Same greedy action wherever the best two actions are not a near tie.
    mask = torch.from_numpy(np.random.default_rng(seed).random((len(states), 8)) < 0.6)
    a_torch = masked_argmax(torch.from_numpy(q_torch), mask).numpy()
    a_cpp = masked_argmax(torch.from_numpy(q_cpp), mask).numpy()
    sorted_q = np.sort(np.where(mask.numpy(), q_torch, -np.inf), axis=1)
    clear = (sorted_q[:, -1] - sorted_q[:, -2]) > 1e-3
    assert np.array_equal(a_torch[clear], a_cpp[clear])


def test_cpp_tool_rejects_corrupt_file(tmp_path: Path) -> None:
    tool = _eval_tool()
    weights = export_model(random_net(3), tmp_path / "net.dqnw", NORMALIZATION, "corrupt")
    data = bytearray(weights.read_bytes())
    data[len(data) // 2] ^= 0x10
    weights.write_bytes(bytes(data))
    states = random_states(2, 0)
    states.astype("<f4").tofile(tmp_path / "s.f32")
    result = subprocess.run([str(tool), str(weights), str(tmp_path / "s.f32"), str(tmp_path / "q.f32")],
                            capture_output=True, text=True, timeout=60)
    assert result.returncode != 0
    assert "checksum" in result.stderr and str(weights) in result.stderr
