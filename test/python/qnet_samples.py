"""Networks and states for the parity tests of our inference against PyTorch and onnxruntime."""
from __future__ import annotations

import numpy as np
import torch

from dqn_dovs_py.model import DuelingQNet


def random_net(seed: int) -> DuelingQNet:
    """A seeded network whose biases are larger than a fresh one's, so every bias add shows in a comparison."""
    torch.manual_seed(seed)
    net = DuelingQNet().eval()
    with torch.no_grad():
        for module in net.modules():
            if isinstance(module, (torch.nn.Conv2d, torch.nn.Linear)):
                module.bias.add_(0.3 * torch.randn_like(module.bias))
    return net


def random_states(n: int, seed: int, edge_rows: bool = False) -> np.ndarray:
    """n states of 408 inputs: a +-1 grid (70 % free) and 8 features in [-1, 1]. With edge_rows the first four are
    every cell free, every cell unsafe, and the features at their upper and lower clip limits."""
    rng = np.random.default_rng(seed)
    grid = np.where(rng.random((n, 400)) < 0.7, 1.0, -1.0)
    features = rng.uniform(-1.0, 1.0, size=(n, 8))
    states = np.concatenate([grid, features], axis=1).astype(np.float32)
    if edge_rows:
        states[0, :400], states[1, :400] = 1.0, -1.0
        states[2, 400:], states[3, 400:] = 1.0, -1.0
    return states
