"""The DQN-DOVS learning agent: masked epsilon-greedy behaviour and the Double-DQN update.

Invalid actions (the goal-line actions 5-7 when the goal line misses the dynamic
window) are excluded twice: when acting, and in the bootstrap of the learning target,
where the online network's argmax over the *next* state's valid actions picks the
action that the target network evaluates (Double DQN). Without the second mask the
target could bootstrap from an action the robot can never take.

A network with a quantile head (DuelingQNet quantiles Nq > 1, QR-DQN) acts on, and bootstraps through, the CVaR of
each action's quantile values (`action_values`) and learns with the quantile Huber loss (`quantile_huber_loss`);
with one quantile everything is the plain Double-DQN step above. With `l2_sp_weight` > 0 and a start network
(`set_anchor`), the loss also pulls the parameters towards the start network's (L2-SP).
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from typing import Mapping

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

from .model import cvar_of_quantiles
from .replay import SampledBatch


@dataclass
class AgentConfig:
    """Hyper-parameters of the learning step (defaults: DESIGN section 8)."""

    # Adam step size at the start of training; the trainer lowers it linearly to lr_end.
    lr_start: float = 3e-4
    # Adam step size at the end of training.
    lr_end: float = 1e-4
    # Adam epsilon; larger than PyTorch's default to damp steps on rarely-seen states.
    adam_eps: float = 1e-5
    # Learning steps between hard copies of the online network into the target network.
    target_update_period: int = 100
    # Huber loss: quadratic for |TD error| below this, linear above.
    huber_delta: float = 1.0
    # Gradient norm clip (0 disables); guards against the +-15 terminal rewards' spikes.
    grad_clip_norm: float = 10.0
    # Double DQN (online argmax, target evaluation); False gives the plain max of the target net.
    double_dqn: bool = True
    # L2-SP: weight of the squared distance ||theta - theta_0||^2 of the parameters from those of the start network
    # (DQNAgent.set_anchor; the trainer's --init-from), added to the loss. 0 disables it.
    l2_sp_weight: float = 0.0

    def validate(self) -> str:
        """Returns an empty string when consistent, else a message naming the field."""
        for name in ("lr_start", "lr_end", "adam_eps", "huber_delta"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                return f"agent.{name} must be a positive number, got {value}"
        if self.target_update_period < 1:
            return f"agent.target_update_period must be >= 1, got {self.target_update_period}"
        if not (np.isfinite(self.grad_clip_norm) and self.grad_clip_norm >= 0):
            return f"agent.grad_clip_norm must be >= 0, got {self.grad_clip_norm}"
        if not (np.isfinite(self.l2_sp_weight) and self.l2_sp_weight >= 0):
            return f"agent.l2_sp_weight must be >= 0, got {self.l2_sp_weight}"
        return ""


@dataclass
class LearnResult:
    loss: float  # importance-weighted Huber (quantile Huber) loss of the batch, plus the weighted extra losses
    # float32 [B], target - Q(s, a), for the new priorities; with quantiles, the mean of the target's quantile values
    # minus the mean of the prediction's (the TD error of the Q each distribution stands for)
    td_errors: np.ndarray
    mean_q: float  # mean Q(s, a) of the batch, a divergence indicator for the logs
    demo_loss: float = float("nan")  # large-margin loss on the teacher's batch (nan: none given)
    aux_loss: float = float("nan")  # the auxiliary head's cross-entropy on its batch (nan: none given)
    # ||theta - theta_0||^2 from the start network before this step, before l2_sp_weight (nan: no start network)
    sp_loss: float = float("nan")


def quantile_huber_loss(z: torch.Tensor, target: torch.Tensor, tau: torch.Tensor, kappa: float) -> torch.Tensor:
    """QR-DQN's loss (Dabney et al. 2018) per sample: z [B, N] the predicted quantile values at the fractions tau [N],
    target [B, N'] samples of the target distribution. With u_ij = target_j - z_i, the sum over i and the mean over j
    of |tau_i - 1{u_ij < 0}| * Huber_kappa(u_ij) / kappa. Returns [B]."""
    u = target[:, None, :] - z[:, :, None]  # [B, N (i), N' (j)]
    abs_u = u.abs()
    huber = torch.where(abs_u <= kappa, 0.5 * u * u, kappa * (abs_u - 0.5 * kappa))
    weight = (tau.to(z)[None, :, None] - (u.detach() < 0).to(z.dtype)).abs()
    return (weight * huber / kappa).sum(dim=1).mean(dim=1)


def large_margin_loss(q: torch.Tensor, mask: torch.Tensor, action: torch.Tensor, margin: float) -> torch.Tensor:
    """Per-sample max over the allowed actions a of Q(s, a) + margin * [a != a_E], minus Q(s, a_E): zero once the
    teacher's action a_E beats every other allowed action by the margin (the supervised loss of learning from
    demonstrations, restricted to the mask the agent chooses under)."""
    bonus = torch.full_like(q, float(margin))
    bonus.scatter_(1, action[:, None], 0.0)
    best = (q + bonus).masked_fill(~mask, float("-inf")).max(dim=1).values
    return best - q.gather(1, action[:, None]).squeeze(1)


def masked_argmax_torch(q: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
    """Argmax over the valid entries of each row; rows must have at least one valid entry."""
    return q.masked_fill(~mask, float("-inf")).argmax(dim=1)


class DQNAgent:
    """Online and target Q-networks, Adam, and the behaviour policy."""

    def __init__(self, model: nn.Module, config: AgentConfig | None = None, device: str | torch.device = "cpu",
                 seed: int = 0, aux_head: nn.Module | None = None):
        """`aux_head`: an optional training-only head on the online network's embedding (`model.embed`), trained
        by `learn`'s auxiliary loss; it is never exported and never acts."""
        self.config = config or AgentConfig()
        error = self.config.validate()
        if error:
            raise ValueError(error)
        self.device = torch.device(device)
        self.online = model.to(self.device)
        self.target = copy.deepcopy(self.online)
        for p in self.target.parameters():
            p.requires_grad_(False)
        if aux_head is not None and not hasattr(self.online, "embed"):
            raise ValueError(f"DQNAgent: an auxiliary head needs a network with embed(); "
                             f"{type(self.online).__name__} has none")
        self.aux_head = aux_head.to(self.device) if aux_head is not None else None
        parameters = list(self.online.parameters())
        if self.aux_head is not None:
            parameters += list(self.aux_head.parameters())
        self.optimizer = torch.optim.Adam(parameters, lr=self.config.lr_start, eps=self.config.adam_eps)
        self.updates = 0
        self._rng = np.random.default_rng(seed)
        # Quantile values per action (DuelingQNet quantiles): 1 is the plain Q-network.
        self.quantiles = int(getattr(self.online, "quantiles", 1))
        # L2-SP: the start network's parameters as given (set_anchor), and (parameter, theta_0, old input width or
        # None for the whole tensor) for each online parameter they anchor.
        self._anchor_source: dict[str, torch.Tensor] | None = None
        self._anchor: list[tuple[nn.Parameter, torch.Tensor, int | None]] = []
        self.anchor_excluded: list[str] = []  # online parameters the start network does not anchor (new, or widened)

    # ---- behaviour -------------------------------------------------------------------

    def q_values(self, state: np.ndarray) -> np.ndarray:
        with torch.inference_mode():
            return self.online(self._tensor(state)).float().cpu().numpy()

    def action_scores(self, state: np.ndarray) -> np.ndarray:
        """What greedy acting maximises per action: the network's action_values (CVaR of the quantile values; Q
        itself with one quantile), or its Q for a network without them."""
        with torch.inference_mode():
            return self._action_values(self.online, self._tensor(state)).float().cpu().numpy()

    def act(self, state: np.ndarray, mask: np.ndarray, epsilon: float | np.ndarray) -> np.ndarray:
        """Masked epsilon-greedy: with probability epsilon a uniformly random valid action,
        otherwise the valid action of highest Q. One network call for all environments."""
        mask = np.asarray(mask, bool)
        self._check_masks(mask, "act")
        n = mask.shape[0]
        epsilon = np.broadcast_to(np.asarray(epsilon, np.float64), (n,))
        # The draws are made for every row whatever epsilon is, so the random stream (and
        # with it every later episode) does not depend on the values of epsilon.
        explore = self._rng.random(n) < epsilon
        random_scores = np.where(mask, self._rng.random(mask.shape), -1.0)
        actions = random_scores.argmax(axis=1)
        if not np.all(explore):
            greedy = self.greedy(state, mask)
            actions = np.where(explore, actions, greedy)
        return actions.astype(np.int64)

    def greedy(self, state: np.ndarray, mask: np.ndarray) -> np.ndarray:
        mask = np.asarray(mask, bool)
        self._check_masks(mask, "greedy")
        q = self.action_scores(state)
        if not np.all(np.isfinite(q)):
            raise FloatingPointError("DQNAgent.greedy: the Q-network returned NaN/inf (non-finite state or "
                                     "diverged weights)")
        return np.where(mask, q, -np.inf).argmax(axis=1).astype(np.int64)

    # ---- learning --------------------------------------------------------------------

    def set_learning_rate(self, lr: float) -> None:
        for group in self.optimizer.param_groups:
            group["lr"] = float(lr)

    @property
    def learning_rate(self) -> float:
        return float(self.optimizer.param_groups[0]["lr"])

    def compute_targets(self, reward: torch.Tensor, discount: torch.Tensor, next_state: torch.Tensor,
                        next_mask: torch.Tensor) -> torch.Tensor:
        """reward + discount * Q_target(s', argmax_{valid a'} Q_online(s', a')).

        The bootstrap is taken only where discount > 0, so a terminal transition's target
        is its reward even if the next-state values were NaN or every action were masked.
        """
        with torch.no_grad():
            q_target_next = self.target(next_state)
            if self.config.double_dqn:
                best = masked_argmax_torch(self.online(next_state), next_mask)
            else:
                best = masked_argmax_torch(q_target_next, next_mask)
            bootstrap = q_target_next.gather(1, best[:, None]).squeeze(1)
            return reward + torch.where(discount > 0, discount * bootstrap, torch.zeros_like(bootstrap))

    def compute_quantile_targets(self, reward: torch.Tensor, discount: torch.Tensor, next_state: torch.Tensor,
                                 next_mask: torch.Tensor) -> torch.Tensor:
        """The target distribution of a quantile head, [B, Nq]: T_j = reward + discount * Z_target(s', a*)_j with
        a* the valid action of highest action_values (CVaR) of the online network at s' (Double DQN; of the target
        network with double_dqn false). As in compute_targets, a terminal transition's T_j is its reward exactly."""
        with torch.no_grad():
            z_next = self.target.quantile_values(next_state)
            if self.config.double_dqn:
                best = masked_argmax_torch(self.online.action_values(next_state), next_mask)
            else:
                best = masked_argmax_torch(cvar_of_quantiles(z_next, self.target.cvar_alpha), next_mask)
            bootstrap = z_next.gather(1, best[:, None, None].expand(-1, 1, z_next.shape[2])).squeeze(1)
            discount = discount[:, None]
            return reward[:, None] + torch.where(discount > 0, discount * bootstrap, torch.zeros_like(bootstrap))

    def set_anchor(self, parameters: Mapping[str, torch.Tensor]) -> None:
        """The start network's parameters by name (theta_0 of L2-SP; a frozen copy is kept). An online parameter of
        the same name and shape is pulled towards it whole. One whose inputs were widened (same shape but a wider
        second dimension: the grid channels, the previous action) is pulled over the inputs that existed, its
        leading columns. Any other (new, or with more outputs such as a widened quantile head) is not pulled: it is
        listed in anchor_excluded."""
        anchor: list[tuple[nn.Parameter, torch.Tensor, int | None]] = []
        excluded: list[str] = []
        for name, p in self.online.named_parameters():
            start = parameters.get(name)
            if start is None:
                excluded.append(name)
                continue
            start = start.detach().to(device=p.device, dtype=p.dtype).clone()
            if start.shape == p.shape:
                anchor.append((p, start, None))
            elif (start.dim() == p.dim() >= 2 and start.shape[0] == p.shape[0] and start.shape[2:] == p.shape[2:]
                  and start.shape[1] < p.shape[1]):
                anchor.append((p, start, int(start.shape[1])))
            else:
                excluded.append(name)
        if not anchor:
            raise ValueError("DQNAgent.set_anchor: no parameter of the start network matches one of the online "
                             f"network ({type(self.online).__name__}) by name and shape")
        self._anchor_source = {name: t.detach().cpu().clone() for name, t in parameters.items()}
        self._anchor = anchor
        self.anchor_excluded = excluded

    @property
    def has_anchor(self) -> bool:
        return bool(self._anchor)

    def l2_sp_distance(self) -> torch.Tensor:
        """||theta - theta_0||^2 summed over the anchored parameters (set_anchor), differentiable."""
        if not self._anchor:
            raise ValueError("DQNAgent.l2_sp_distance: no start network was given (set_anchor)")
        total = None
        for p, start, width in self._anchor:
            part = ((p if width is None else p[:, :width]) - start).pow(2).sum()
            total = part if total is None else total + part
        return total

    def learn(self, batch: SampledBatch, demo: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
              demo_weight: float = 0.0, margin: float = 0.8, aux: tuple[np.ndarray, np.ndarray] | None = None,
              aux_weight: float = 0.0) -> LearnResult:
        """One Double-DQN step on `batch`; with `demo` = (state, mask, teacher action) the large-margin loss of
        those states, times `demo_weight`, is added to the TD loss; with `aux` = (state, 0/1 label) and an
        auxiliary head, the head's binary cross-entropy on those states, times `aux_weight`."""
        t = batch.transitions
        state = self._tensor(t.state)
        action = torch.from_numpy(np.ascontiguousarray(t.action)).to(self.device)
        reward = self._tensor(t.reward)
        discount = self._tensor(t.discount)
        weights = self._tensor(batch.weights)
        next_state = self._tensor(t.next_state)
        next_mask = torch.from_numpy(np.ascontiguousarray(t.next_mask)).to(self.device)

        quantile = self.quantiles > 1
        if quantile:
            target_z = self.compute_quantile_targets(reward, discount, next_state, next_mask)
        else:
            target = self.compute_targets(reward, discount, next_state, next_mask)
        aux_loss = None
        if aux is not None and aux_weight > 0:
            if self.aux_head is None:
                raise ValueError("DQNAgent.learn: auxiliary labels given but the agent has no auxiliary head")
            a_state, a_label = aux
            # One pass of the network over both batches: the TD batch's rows first, then the labelled states.
            h = self.online.embed(torch.cat([state, self._tensor(a_state)]))
            if quantile:
                z_all = self.online.quantiles_from_embedding(h[:state.shape[0]])
            else:
                q_all = self.online.q_from_embedding(h[:state.shape[0]])
            logits = self.aux_head(h[state.shape[0]:]).squeeze(1)
            aux_loss = F.binary_cross_entropy_with_logits(logits, self._tensor(a_label))
        elif quantile:
            z_all = self.online.quantile_values(state)
        else:
            q_all = self.online(state)
        if quantile:
            z = z_all.gather(1, action[:, None, None].expand(-1, 1, z_all.shape[2])).squeeze(1)  # [B, Nq]
            per_sample = quantile_huber_loss(z, target_z, self.online.quantile_fractions(), self.config.huber_delta)
            # The TD error of the means (the Q each distribution stands for) sets the priorities and mean_q.
            q, target = z.mean(dim=1), target_z.mean(dim=1)
        else:
            q = q_all.gather(1, action[:, None]).squeeze(1)
            per_sample = F.huber_loss(q, target, reduction="none", delta=self.config.huber_delta)
        loss = (weights * per_sample).mean()
        if aux_loss is not None:
            loss = loss + float(aux_weight) * aux_loss
        demo_loss = None
        if demo is not None and demo_weight > 0:
            d_state, d_mask, d_action = demo
            d_action_t = torch.from_numpy(np.ascontiguousarray(d_action, dtype=np.int64)).to(self.device)
            d_mask_t = torch.from_numpy(np.ascontiguousarray(d_mask, dtype=bool)).to(self.device)
            # The margin is on what acting maximises (action_values: Q itself with one quantile).
            demo_loss = large_margin_loss(self._action_values(self.online, self._tensor(d_state)), d_mask_t,
                                          d_action_t, margin).mean()
            loss = loss + float(demo_weight) * demo_loss
        sp_loss = None
        if self.config.l2_sp_weight > 0:
            if not self._anchor:
                raise ValueError(f"DQNAgent.learn: agent.l2_sp_weight is {self.config.l2_sp_weight} but no start "
                                 "network was given (set_anchor; the trainer's --init-from)")
            sp_loss = self.l2_sp_distance()
            loss = loss + float(self.config.l2_sp_weight) * sp_loss
        elif self._anchor:
            with torch.no_grad():
                sp_loss = self.l2_sp_distance()  # recorded only: the weight is 0
        if not torch.isfinite(loss):
            raise FloatingPointError(f"DQNAgent.learn: non-finite loss at update {self.updates} "
                                     "(the Q-network has diverged; lower the learning rate)")
        self.optimizer.zero_grad(set_to_none=True)
        loss.backward()
        if self.config.grad_clip_norm > 0:
            nn.utils.clip_grad_norm_([p for group in self.optimizer.param_groups for p in group["params"]],
                                     self.config.grad_clip_norm)
        self.optimizer.step()
        self.updates += 1
        if self.updates % self.config.target_update_period == 0:
            self.sync_target()
        td = (target - q).detach()
        return LearnResult(loss=float(loss.item()), td_errors=td.float().cpu().numpy(),
                           mean_q=float(q.detach().mean().item()),
                           demo_loss=float(demo_loss.item()) if demo_loss is not None else float("nan"),
                           aux_loss=float(aux_loss.item()) if aux_loss is not None else float("nan"),
                           sp_loss=float(sp_loss.item()) if sp_loss is not None else float("nan"))

    def sync_target(self) -> None:
        self.target.load_state_dict(self.online.state_dict())

    # ---- checkpoints -----------------------------------------------------------------

    def state_dict(self) -> dict:
        return {"online": self.online.state_dict(), "target": self.target.state_dict(),
                "optimizer": self.optimizer.state_dict(), "updates": self.updates,
                "rng": self._rng.bit_generator.state,
                "aux_head": self.aux_head.state_dict() if self.aux_head is not None else None,
                "anchor": self._anchor_source}

    def load_state_dict(self, state: dict) -> None:
        saved_aux = state.get("aux_head")
        if (saved_aux is None) != (self.aux_head is None):
            raise ValueError("DQNAgent.load_state_dict: the checkpoint was made " +
                             ("without" if saved_aux is None else "with") + " an auxiliary head and this agent has " +
                             ("one" if saved_aux is None else "none"))
        if self.aux_head is not None:
            self.aux_head.load_state_dict(saved_aux)
        self.online.load_state_dict(state["online"])
        self.target.load_state_dict(state["target"])
        self.optimizer.load_state_dict(state["optimizer"])
        self.updates = int(state["updates"])
        self._rng.bit_generator.state = state["rng"]
        if state.get("anchor") is not None:
            self.set_anchor(state["anchor"])

    # ---- helpers ---------------------------------------------------------------------

    @staticmethod
    def _action_values(net: nn.Module, state: torch.Tensor) -> torch.Tensor:
        return net.action_values(state) if hasattr(net, "action_values") else net(state)

    def _tensor(self, array: np.ndarray) -> torch.Tensor:
        return torch.from_numpy(np.ascontiguousarray(array, dtype=np.float32)).to(self.device)

    @staticmethod
    def _check_masks(mask: np.ndarray, where: str) -> None:
        empty = np.flatnonzero(~mask.any(axis=1))
        if empty.size:
            raise ValueError(f"DQNAgent.{where}: no valid action in the mask of environment {int(empty[0])}")
