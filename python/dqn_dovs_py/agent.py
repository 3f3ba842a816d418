"""The DQN-DOVS learning agent: masked epsilon-greedy behaviour and the Double-DQN update.

Invalid actions (the goal-line actions 5-7 when the goal line misses the dynamic
window) are excluded twice: when acting, and in the bootstrap of the learning target,
where the online network's argmax over the *next* state's valid actions picks the
action that the target network evaluates (Double DQN). Without the second mask the
target could bootstrap from an action the robot can never take.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

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
        return ""


@dataclass
class LearnResult:
    loss: float  # importance-weighted Huber loss of the batch
    td_errors: np.ndarray  # float32 [B], target - Q(s, a), for the new priorities
    mean_q: float  # mean Q(s, a) of the batch, a divergence indicator for the logs
    demo_loss: float = float("nan")  # large-margin loss on the teacher's batch (nan: none given)
    aux_loss: float = float("nan")  # the auxiliary head's cross-entropy on its batch (nan: none given)


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

    # ---- behaviour -------------------------------------------------------------------

    def q_values(self, state: np.ndarray) -> np.ndarray:
        with torch.inference_mode():
            return self.online(self._tensor(state)).float().cpu().numpy()

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
        q = self.q_values(state)
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

        target = self.compute_targets(reward, discount, next_state, next_mask)
        aux_loss = None
        if aux is not None and aux_weight > 0:
            if self.aux_head is None:
                raise ValueError("DQNAgent.learn: auxiliary labels given but the agent has no auxiliary head")
            a_state, a_label = aux
            # One pass of the network over both batches: the TD batch's rows first, then the labelled states.
            h = self.online.embed(torch.cat([state, self._tensor(a_state)]))
            q_all = self.online.q_from_embedding(h[:state.shape[0]])
            logits = self.aux_head(h[state.shape[0]:]).squeeze(1)
            aux_loss = F.binary_cross_entropy_with_logits(logits, self._tensor(a_label))
        else:
            q_all = self.online(state)
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
            demo_loss = large_margin_loss(self.online(self._tensor(d_state)), d_mask_t, d_action_t, margin).mean()
            loss = loss + float(demo_weight) * demo_loss
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
                           aux_loss=float(aux_loss.item()) if aux_loss is not None else float("nan"))

    def sync_target(self) -> None:
        self.target.load_state_dict(self.online.state_dict())

    # ---- checkpoints -----------------------------------------------------------------

    def state_dict(self) -> dict:
        return {"online": self.online.state_dict(), "target": self.target.state_dict(),
                "optimizer": self.optimizer.state_dict(), "updates": self.updates,
                "rng": self._rng.bit_generator.state,
                "aux_head": self.aux_head.state_dict() if self.aux_head is not None else None}

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

    # ---- helpers ---------------------------------------------------------------------

    def _tensor(self, array: np.ndarray) -> torch.Tensor:
        return torch.from_numpy(np.ascontiguousarray(array, dtype=np.float32)).to(self.device)

    @staticmethod
    def _check_masks(mask: np.ndarray, where: str) -> None:
        empty = np.flatnonzero(~mask.any(axis=1))
        if empty.size:
            raise ValueError(f"DQNAgent.{where}: no valid action in the mask of environment {int(empty[0])}")
