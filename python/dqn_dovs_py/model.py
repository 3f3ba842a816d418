"""The DQN-DOVS Q-network: a two-stream dueling network over the 408-float state.

State layout (DESIGN section 5): 400 grid values (20 x 20, row-major: rows are linear
speeds v, columns turn rates w; +1 free, -1 unsafe) followed by 8 normalised features.
With `grid_channels` = 3 (docs/dovs.md "Grid channels") the grid is a 3 x 20 x 20 image, channel-major
(the DOVS grid, the dynamic window, the goal line: 1,200 values), then the 8 features.

    grid (1 x 20 x 20) -> conv3x3 s1 (8) ReLU -> conv3x3 s2 (16) ReLU -> conv3x3 s2 (16) ReLU
                       -> flatten channel-major (16 x 5 x 5 = 400)
    features (8)       -> linear (64) ReLU
    concat (464)       -> linear (256) ReLU -> linear (128) ReLU
    heads              -> value linear (1), advantage linear (8);  Q = V + A - mean(A)

The C++ planner runs the same function from the exported `.dqnw` file
(src/policy/qnetwork.cpp); export.py maps every module of this class to a record of
that file, so changing the structure here means changing the format too.
"""

from __future__ import annotations

from typing import Sequence

import torch
from torch import nn


class DuelingQNet(nn.Module):
    """Dueling Q-network. The defaults are the project's fixed architecture; the arguments exist so
    that the exporter and tests can name and rebuild every shape, not for tuning."""

    def __init__(
        self,
        grid_rows: int = 20,
        grid_cols: int = 20,
        feature_count: int = 8,
        action_count: int = 8,
        conv_channels: Sequence[int] = (8, 16, 16),
        conv_strides: Sequence[int] = (1, 2, 2),
        conv_kernel: int = 3,
        feature_hidden: int = 64,
        trunk_hidden: Sequence[int] = (256, 128),
        grid_channels: int = 1,
    ) -> None:
        super().__init__()
        if len(conv_channels) == 0 or len(conv_channels) != len(conv_strides):
            raise ValueError(
                f"conv_channels ({len(conv_channels)} entries) and conv_strides ({len(conv_strides)}) "
                "must be non-empty and of equal length"
            )
        if conv_kernel < 1 or conv_kernel % 2 == 0:
            raise ValueError(f"conv_kernel must be odd and positive, got {conv_kernel}")
        for name, value in (("grid_rows", grid_rows), ("grid_cols", grid_cols), ("grid_channels", grid_channels),
                            ("feature_count", feature_count),
                            ("action_count", action_count), ("feature_hidden", feature_hidden)):
            if int(value) < 1:
                raise ValueError(f"{name} must be positive, got {value}")
        self.grid_rows = int(grid_rows)
        self.grid_cols = int(grid_cols)
        self.grid_channels = int(grid_channels)
        self.feature_count = int(feature_count)
        self.action_count = int(action_count)
        self.conv_channels = tuple(int(c) for c in conv_channels)
        self.conv_strides = tuple(int(s) for s in conv_strides)
        self.conv_kernel = int(conv_kernel)
        self.feature_hidden = int(feature_hidden)
        self.trunk_hidden = tuple(int(h) for h in trunk_hidden)

        pad = self.conv_kernel // 2
        layers: list[nn.Module] = []
        channels, h, w = self.grid_channels, self.grid_rows, self.grid_cols
        for out_channels, stride in zip(self.conv_channels, self.conv_strides):
            layers += [nn.Conv2d(channels, out_channels, self.conv_kernel, stride=stride, padding=pad), nn.ReLU()]
            channels = out_channels
            h = (h + 2 * pad - self.conv_kernel) // stride + 1
            w = (w + 2 * pad - self.conv_kernel) // stride + 1
        self.grid = nn.Sequential(*layers)
        self.grid_out = channels * h * w

        self.features = nn.Sequential(nn.Linear(self.feature_count, self.feature_hidden), nn.ReLU())

        trunk: list[nn.Module] = []
        width = self.grid_out + self.feature_hidden
        for hidden in self.trunk_hidden:
            trunk += [nn.Linear(width, hidden), nn.ReLU()]
            width = hidden
        self.trunk = nn.Sequential(*trunk)
        self.trunk_width = width
        self.value = nn.Linear(width, 1)
        self.advantage = nn.Linear(width, self.action_count)

    @property
    def state_size(self) -> int:
        return self.grid_channels * self.grid_rows * self.grid_cols + self.feature_count

    def config(self) -> dict:
        """Constructor arguments that rebuild this architecture (stored in checkpoints)."""
        return {
            "grid_rows": self.grid_rows,
            "grid_cols": self.grid_cols,
            "feature_count": self.feature_count,
            "action_count": self.action_count,
            "conv_channels": list(self.conv_channels),
            "conv_strides": list(self.conv_strides),
            "conv_kernel": self.conv_kernel,
            "feature_hidden": self.feature_hidden,
            "trunk_hidden": list(self.trunk_hidden),
            "grid_channels": self.grid_channels,
        }

    def embed(self, state: torch.Tensor) -> torch.Tensor:
        """state [B, 408] -> the trunk's last hidden layer [B, trunk_width], which both heads read (and the
        trainer's auxiliary head, when one is configured)."""
        if state.dim() != 2 or state.shape[1] != self.state_size:
            raise ValueError(f"DuelingQNet expects a state batch of shape [B, {self.state_size}], got {tuple(state.shape)}")
        n_grid = self.grid_channels * self.grid_rows * self.grid_cols
        grid = state[:, :n_grid].reshape(-1, self.grid_channels, self.grid_rows, self.grid_cols)
        g = self.grid(grid).flatten(1)
        f = self.features(state[:, n_grid:])
        return self.trunk(torch.cat([g, f], dim=1))

    def q_from_embedding(self, h: torch.Tensor) -> torch.Tensor:
        """The dueling heads on an embedding from `embed`: Q [B, 8]."""
        advantage = self.advantage(h)
        return self.value(h) + advantage - advantage.mean(dim=1, keepdim=True)

    def forward(self, state: torch.Tensor) -> torch.Tensor:
        """state [B, 408] -> Q [B, 8]."""
        return self.q_from_embedding(self.embed(state))


def masked_argmax(q: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
    """Index of the highest Q among valid actions along the last dimension (lowest index on ties),
    -1 where no action is valid. q: float [..., A]; mask: bool [..., A] (True = valid).
    NaN Q-values are never chosen while a valid non-NaN action exists (the C++ planner agrees)."""
    if q.shape != mask.shape:
        raise ValueError(f"masked_argmax: q {tuple(q.shape)} and mask {tuple(mask.shape)} differ in shape")
    mask = mask.to(torch.bool)
    usable = mask & ~torch.isnan(q)
    masked = q.masked_fill(~usable, float("-inf"))
    best = masked.argmax(dim=-1)
    # When every usable Q is -inf, argmax may land on an unusable slot: fall back to the first usable one.
    first_usable = usable.to(torch.int8).argmax(dim=-1)
    best = torch.where(usable.gather(-1, best.unsqueeze(-1)).squeeze(-1), best, first_usable)
    return torch.where(usable.any(dim=-1), best, torch.full_like(best, -1))
