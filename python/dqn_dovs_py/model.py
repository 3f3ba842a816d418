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

With `quantiles` Nq > 1 (QR-DQN) the heads give Nq values per action: value linear (Nq), advantage linear (8 Nq,
action-major), Z[a, j] = V[j] + A[a, j] - mean_a A[a, j] at the fractions tau_j = (2j + 1) / (2 Nq); forward() is
their mean (Q) and action_values() their CVaR at `cvar_alpha`, which acting maximises. With Nq = 1 the network,
its parameter names and shapes are the ones above.

The C++ planner runs the same function from the exported `.dqnw` file
(src/policy/qnetwork.cpp); export.py maps every module of this class to a record of
that file, so changing the structure here means changing the format too.
"""

from __future__ import annotations

import math
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
        quantiles: int = 1,
        cvar_alpha: float = 1.0,
        wall_rays: int = 0,
        person_tokens: int = 0,
        token_hidden: Sequence[int] = (64, 64),
        attention_hidden: Sequence[int] = (64,),
        route_points: int = 0,
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
        check_quantile_head(quantiles, cvar_alpha)
        if not 0 <= int(wall_rays) <= MAX_WALL_RAYS:
            raise ValueError(f"wall_rays must be in [0, {MAX_WALL_RAYS}], got {wall_rays}")
        if not 0 <= int(person_tokens) <= MAX_PERSON_TOKENS:
            raise ValueError(f"person_tokens must be in [0, {MAX_PERSON_TOKENS}], got {person_tokens}")
        if not 0 <= int(route_points) <= MAX_ROUTE_POINTS:
            raise ValueError(f"route_points must be in [0, {MAX_ROUTE_POINTS}], got {route_points}")
        if int(person_tokens) > 0 and (len(token_hidden) == 0 or min(token_hidden) < 1
                                       or (len(attention_hidden) > 0 and min(attention_hidden) < 1)):
            raise ValueError(f"token_hidden {tuple(token_hidden)} must be non-empty and positive, attention_hidden "
                             f"{tuple(attention_hidden)} positive")
        self.wall_rays = int(wall_rays)
        self.person_tokens = int(person_tokens)
        self.route_points = int(route_points)
        self.token_hidden = tuple(int(h) for h in token_hidden)
        self.attention_hidden = tuple(int(h) for h in attention_hidden)
        self.quantiles = int(quantiles)
        self.cvar_alpha = float(cvar_alpha)
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

        self.features = nn.Sequential(nn.Linear(self.flat_inputs, self.feature_hidden), nn.ReLU())

        # Person tokens (docs/dovs.md "Person tokens"): each present token through the encoder, a score for each from
        # its encoding beside the mean encoding, and the softmax-weighted sum of the encodings joins the trunk's input.
        self.token_embedding = self.token_hidden[-1] if self.person_tokens > 0 else 0
        if self.person_tokens > 0:
            layers_t: list[nn.Module] = []
            width_t = TOKEN_SIZE
            for hidden in self.token_hidden:
                layers_t += [nn.Linear(width_t, hidden), nn.ReLU()]
                width_t = hidden
            self.token_encoder = nn.Sequential(*layers_t)
            layers_a: list[nn.Module] = []
            width_a = 2 * self.token_embedding
            for hidden in self.attention_hidden:
                layers_a += [nn.Linear(width_a, hidden), nn.ReLU()]
                width_a = hidden
            layers_a.append(nn.Linear(width_a, 1))
            self.attention = nn.Sequential(*layers_a)

        trunk: list[nn.Module] = []
        width = self.grid_out + self.feature_hidden + self.token_embedding
        for hidden in self.trunk_hidden:
            trunk += [nn.Linear(width, hidden), nn.ReLU()]
            width = hidden
        self.trunk = nn.Sequential(*trunk)
        self.trunk_width = width
        # With quantiles Nq > 1 (a QR-DQN head): Nq value outputs, and action_count * Nq advantage outputs laid out
        # action-major (output a * Nq + j is quantile j of action a).
        self.value = nn.Linear(width, self.quantiles)
        self.advantage = nn.Linear(width, self.action_count * self.quantiles)

    @property
    def flat_inputs(self) -> int:
        """The feature stream's inputs: the features, the wall rays and the route points' x, y."""
        return self.feature_count + self.wall_rays + ROUTE_POINT_INPUTS * self.route_points

    @property
    def state_size(self) -> int:
        return (self.grid_channels * self.grid_rows * self.grid_cols + self.flat_inputs
                + self.person_tokens * TOKEN_SIZE)

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
            "quantiles": self.quantiles,
            "cvar_alpha": self.cvar_alpha,
            "wall_rays": self.wall_rays,
            "person_tokens": self.person_tokens,
            "route_points": self.route_points,
            "token_hidden": list(self.token_hidden),
            "attention_hidden": list(self.attention_hidden),
        }

    def embed(self, state: torch.Tensor) -> torch.Tensor:
        """state [B, 408] -> the trunk's last hidden layer [B, trunk_width], which both heads read (and the
        trainer's auxiliary head, when one is configured)."""
        if state.dim() != 2 or state.shape[1] != self.state_size:
            raise ValueError(f"DuelingQNet expects a state batch of shape [B, {self.state_size}], got {tuple(state.shape)}")
        n_grid = self.grid_channels * self.grid_rows * self.grid_cols
        grid = state[:, :n_grid].reshape(-1, self.grid_channels, self.grid_rows, self.grid_cols)
        g = self.grid(grid).flatten(1)
        n_features = self.flat_inputs
        f = self.features(state[:, n_grid:n_grid + n_features])
        if self.person_tokens == 0:
            return self.trunk(torch.cat([g, f], dim=1))
        tokens = state[:, n_grid + n_features:].reshape(-1, self.person_tokens, TOKEN_SIZE)
        return self.trunk(torch.cat([g, f, self.pool_tokens(tokens)], dim=1))

    def pool_tokens(self, tokens: torch.Tensor) -> torch.Tensor:
        """tokens [B, K, TOKEN_SIZE] -> the pooled encoding [B, E]: the encodings e_k of the present tokens (entry 0 >
        0.5), their mean m, scores s_k = attention([e_k, m]), and sum_k softmax(s)_k e_k over the present ones; 0
        when none is present. The C++ planner computes the same (src/policy/qnetwork.cpp)."""
        present = tokens[:, :, 0] > 0.5
        weight = present.to(tokens.dtype).unsqueeze(2)
        e = self.token_encoder(tokens) * weight
        count = weight.sum(dim=1).clamp(min=1.0)
        mean = e.sum(dim=1) / count
        scores = self.attention(torch.cat([e, mean.unsqueeze(1).expand_as(e)], dim=2)).squeeze(2)
        scores = scores.masked_fill(~present, float("-inf"))
        any_present = present.any(dim=1, keepdim=True)
        attn = torch.softmax(torch.where(any_present, scores, torch.zeros_like(scores)), dim=1)
        attn = torch.where(present, attn, torch.zeros_like(attn))
        return (attn.unsqueeze(2) * e).sum(dim=1)

    def q_from_embedding(self, h: torch.Tensor) -> torch.Tensor:
        """The dueling heads on an embedding from `embed`: Q [B, 8] (with quantiles, the mean of each action's
        quantile values)."""
        if self.quantiles > 1:
            return self.quantiles_from_embedding(h).mean(dim=2)
        advantage = self.advantage(h)
        return self.value(h) + advantage - advantage.mean(dim=1, keepdim=True)

    def quantiles_from_embedding(self, h: torch.Tensor) -> torch.Tensor:
        """The quantile values Z [B, 8, Nq] on an embedding from `embed`: Z[b, a, j] = V[b, j] + A[b, a, j] -
        mean_a A[b, a, j], at the fractions quantile_fractions() (Nq = 1: Q[..., None])."""
        if self.quantiles == 1:
            return self.q_from_embedding(h).unsqueeze(2)
        advantage = self.advantage(h).reshape(-1, self.action_count, self.quantiles)
        return self.value(h).unsqueeze(1) + advantage - advantage.mean(dim=1, keepdim=True)

    def quantile_values(self, state: torch.Tensor) -> torch.Tensor:
        """state [B, 408] -> Z [B, 8, Nq], the return distribution of every action as Nq quantile values."""
        return self.quantiles_from_embedding(self.embed(state))

    def quantile_fractions(self) -> torch.Tensor:
        """tau_j = (2j + 1) / (2 Nq), j = 0 .. Nq-1: the fractions the quantile values stand for (float32 [Nq])."""
        return (2 * torch.arange(self.quantiles, dtype=torch.float32) + 1) / (2 * self.quantiles)

    def action_values(self, state: torch.Tensor) -> torch.Tensor:
        """state [B, 408] -> [B, 8]: what acting greedily maximises, CVaR_alpha of each action's quantile values
        (cvar_of_quantiles). With one quantile, or cvar_alpha 1 and no rounding, it is Q; with one quantile it is
        exactly forward()."""
        if self.quantiles == 1:
            return self.forward(state)
        return cvar_of_quantiles(self.quantile_values(state), self.cvar_alpha)

    def forward(self, state: torch.Tensor) -> torch.Tensor:
        """state [B, 408] -> Q [B, 8] (with quantiles, the mean of each action's quantile values)."""
        return self.q_from_embedding(self.embed(state))


# Floats of one person token, and the most tokens and wall rays a state carries (include/dqn_dovs/dovs/state.h).
TOKEN_SIZE = 14
MAX_PERSON_TOKENS = 16
MAX_WALL_RAYS = 32
# The most route points, and the inputs of each (x, y) (include/dqn_dovs/dovs/state.h).
MAX_ROUTE_POINTS = 16
ROUTE_POINT_INPUTS = 2


def widen_tokens(model: DuelingQNet, wall_rays: int, person_tokens: int, **token_arch) -> DuelingQNet:
    """The network `model` (no wall rays, no person tokens) reading `wall_rays` rays and `person_tokens` tokens: the
    feature stream's first layer gets zero weights for the rays and the trunk's first layer zero weights for the
    pooled encoding; the token encoder and the attention are newly initialised. Its Q-values are the start's on every
    state, whatever the rays and tokens hold, until training moves those zeros."""
    if model.wall_rays != 0 or model.person_tokens != 0:
        raise ValueError("widen_tokens: widens a network without wall rays or person tokens")
    return widened(model, wall_rays=int(wall_rays), person_tokens=int(person_tokens), **token_arch)


def widened(model: DuelingQNet, **changes) -> DuelingQNet:
    """`model` rebuilt with its constructor arguments updated by `changes`, for more inputs: a tensor of the same
    shape is copied; one that reads more inputs ([out, old inputs, ...] -> [out, new inputs, ...]) keeps its weights
    for the old inputs, which come first, and gets zeros for the new ones; a tensor `model` does not have keeps its
    fresh initialisation. So the wider network computes what `model` did whatever the new inputs hold."""
    config = model.config()
    config.update(changes)
    wide = DuelingQNet(**config)
    source = model.state_dict()
    with torch.no_grad():
        for name, tensor in wide.state_dict().items():
            if name not in source:
                continue
            old = source[name]
            if old.shape == tensor.shape:
                tensor.copy_(old)
            else:
                tensor.zero_()
                tensor[:, :old.shape[1]].copy_(old)
    return wide


def check_quantile_head(quantiles: int, cvar_alpha: float) -> None:
    """ValueError naming the argument unless quantiles is an integer in [1, MAX_QUANTILES] and cvar_alpha in (0, 1]."""
    if isinstance(quantiles, bool) or int(quantiles) != quantiles or not 1 <= int(quantiles) <= MAX_QUANTILES:
        raise ValueError(f"quantiles must be an integer in [1, {MAX_QUANTILES}], got {quantiles!r}")
    if isinstance(cvar_alpha, bool) or not (math.isfinite(float(cvar_alpha)) and 0.0 < float(cvar_alpha) <= 1.0):
        raise ValueError(f"cvar_alpha must be in (0, 1], got {cvar_alpha!r}")


MAX_QUANTILES = 256
# alpha * Nq is taken this much lower before rounding up, so that a product that is an integer in exact arithmetic
# (0.3 * 10, or 0.6 * 5 with alpha stored as float32) is not pushed to the next integer by alpha's rounding.
CVAR_COUNT_TOLERANCE = 1e-4


def cvar_quantile_count(quantiles: int, cvar_alpha: float) -> int:
    """m = ceil(cvar_alpha * quantiles), the number of lowest quantile values CVaR averages (at least 1, at most
    quantiles); alpha * Nq is lowered by CVAR_COUNT_TOLERANCE first (above)."""
    return min(int(quantiles), max(1, math.ceil(float(cvar_alpha) * int(quantiles) - CVAR_COUNT_TOLERANCE)))


def cvar_of_quantiles(z: torch.Tensor, cvar_alpha: float) -> torch.Tensor:
    """CVaR_alpha along the last dimension of quantile values z [..., Nq]: sort ascending, then the mean of the first
    m = cvar_quantile_count(Nq, alpha). alpha = 1 is the mean of all of them."""
    m = cvar_quantile_count(z.shape[-1], cvar_alpha)
    return torch.sort(z, dim=-1).values[..., :m].mean(dim=-1)


def widen_quantiles(model: DuelingQNet, quantiles: int, cvar_alpha: float = 1.0) -> DuelingQNet:
    """The network `model` (one quantile) with a head of `quantiles` quantile values: the value head's last layer
    replicated Nq times and each action's advantage row replicated Nq times (action-major), every other tensor
    copied. Every quantile of action a then starts equal to Q(a): the same Q (forward) and, whatever cvar_alpha,
    the same action_values as `model`, on every state."""
    if model.quantiles != 1:
        raise ValueError(f"widen_quantiles: widens a network of 1 quantile, not {model.quantiles}")
    config = model.config()
    config.update(quantiles=int(quantiles), cvar_alpha=float(cvar_alpha))
    wide = DuelingQNet(**config)
    source = model.state_dict()
    with torch.no_grad():
        for name, tensor in wide.state_dict().items():
            old = source[name]
            if old.shape == tensor.shape:
                tensor.copy_(old)
            elif name.startswith("value."):  # [1, ...] -> [Nq, ...]
                tensor.copy_(old.expand_as(tensor))
            elif name.startswith("advantage."):  # [A, ...] -> [A * Nq, ...], row a * Nq + j = old row a
                tensor.copy_(old.repeat_interleave(int(quantiles), dim=0))
            else:
                raise ValueError(f"widen_quantiles: {name} changes shape {tuple(old.shape)} -> "
                                 f"{tuple(tensor.shape)}, which a quantile head does not explain")
    return wide


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
