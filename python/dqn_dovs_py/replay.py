"""Experience replay for the DQN-DOVS trainer: a vectorised sum tree, prioritized replay
with stored action masks, the per-environment n-step transition builder, and the
labelled-state buffers of the teacher and of the auxiliary head.

Everything works on numpy batches (one call per environment step or per learning
step), never on per-transition Python objects, so the trainer's overhead stays small
next to the simulator and the network.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

STATE_DIM = 408
GRID_CELLS = 400
NUM_ACTIONS = 8


def split_compact(states: np.ndarray, grid_cells: int, where: str, hint: str = "") -> tuple[np.ndarray, np.ndarray]:
    """States [B, D] as (grid int8 [B, grid_cells], features [B, D - grid_cells]); the grid cells must be exactly +1
    or -1 (ValueError naming `where` otherwise). grid_cells = 0 keeps everything as features."""
    grid = states[:, :grid_cells]
    if grid_cells and not np.all(np.abs(grid) == 1.0):
        bad = grid[np.abs(grid) != 1.0][0]
        raise ValueError(f"{where} grid cells must be exactly +1 or -1 for compact storage, found {bad}{hint}")
    return grid.astype(np.int8), states[:, grid_cells:]


def join_compact(grid: np.ndarray, features: np.ndarray) -> np.ndarray:
    """Inverse of split_compact: float32 [B, grid + features]."""
    return np.concatenate([grid.astype(np.float32), features.astype(np.float32, copy=False)], axis=1)


@dataclass
class Transitions:
    """A batch of n-step transitions (row i of every array belongs to transition i).

    `discount` already holds gamma**k for a transition that bootstraps after k rewards,
    and 0 for one that ends in a terminal state, so the learning target is simply
    reward + discount * Q(next_state, .).
    """

    state: np.ndarray  # float32 [B, 408]
    mask: np.ndarray  # bool [B, 8], valid actions in `state`
    action: np.ndarray  # int64 [B]
    reward: np.ndarray  # float32 [B], discounted sum of the k <= n rewards
    discount: np.ndarray  # float32 [B], gamma**k, or 0 after a terminal state
    next_state: np.ndarray  # float32 [B, 408], state after the k steps
    next_mask: np.ndarray  # bool [B, 8], valid actions in `next_state`

    def __len__(self) -> int:
        return int(self.action.shape[0])

    @staticmethod
    def empty(state_dim: int = STATE_DIM, num_actions: int = NUM_ACTIONS) -> "Transitions":
        return Transitions(
            state=np.zeros((0, state_dim), np.float32),
            mask=np.zeros((0, num_actions), bool),
            action=np.zeros(0, np.int64),
            reward=np.zeros(0, np.float32),
            discount=np.zeros(0, np.float32),
            next_state=np.zeros((0, state_dim), np.float32),
            next_mask=np.zeros((0, num_actions), bool),
        )

    @staticmethod
    def concatenate(parts: list["Transitions"]) -> "Transitions":
        if len(parts) == 1:
            return parts[0]
        return Transitions(**{f.name: np.concatenate([getattr(p, f.name) for p in parts]) for f in fields(Transitions)})


class SumTree:
    """Binary tree whose internal nodes hold the sum (and the minimum) of their leaves.

    Leaves are padded to a power of two and stored in flat arrays, so a batch of
    updates or look-ups walks the tree level by level with numpy instead of one
    Python loop per element. The minimum over the leaves is kept as well (min_priority).
    """

    def __init__(self, capacity: int):
        if int(capacity) < 1:
            raise ValueError(f"SumTree: capacity must be >= 1, got {capacity}")
        self.capacity = int(capacity)
        size = 1
        while size < self.capacity:
            size *= 2
        self._first_leaf = size
        self._depth = size.bit_length() - 1
        self._sum = np.zeros(2 * size, np.float64)
        self._min = np.full(2 * size, np.inf, np.float64)

    @property
    def total(self) -> float:
        return float(self._sum[1])

    @property
    def min_priority(self) -> float:
        """Smallest priority among the leaves set so far (inf when none is)."""
        return float(self._min[1])

    def get(self, indices: np.ndarray) -> np.ndarray:
        indices = self._check_indices(indices)
        return self._sum[indices + self._first_leaf].copy()

    def update(self, indices: np.ndarray, priorities: np.ndarray) -> None:
        indices = self._check_indices(indices)
        priorities = np.asarray(priorities, np.float64).reshape(-1)
        if priorities.shape != indices.shape:
            raise ValueError(
                f"SumTree.update: {indices.size} indices but {priorities.size} priorities")
        if not np.all(np.isfinite(priorities)) or np.any(priorities < 0.0):
            bad = priorities[~np.isfinite(priorities) | (priorities < 0.0)][0]
            raise ValueError(f"SumTree.update: priorities must be finite and >= 0, got {bad}")
        if indices.size == 0:
            return
        # With repeated indices the last write must win; keep only each index's last occurrence.
        _, last = np.unique(indices[::-1], return_index=True)
        keep = indices.size - 1 - last
        nodes = indices[keep] + self._first_leaf
        self._sum[nodes] = priorities[keep]
        self._min[nodes] = priorities[keep]
        for _ in range(self._depth):
            nodes = np.unique(nodes >> 1)
            left = 2 * nodes
            self._sum[nodes] = self._sum[left] + self._sum[left + 1]
            self._min[nodes] = np.minimum(self._min[left], self._min[left + 1])

    def find(self, values: np.ndarray) -> np.ndarray:
        """Leaf index whose cumulative-priority interval contains each value in [0, total)."""
        values = np.asarray(values, np.float64).reshape(-1).copy()
        nodes = np.ones(values.shape, np.int64)
        for _ in range(self._depth):
            left = 2 * nodes
            left_sum = self._sum[left]
            # Rounding can leave a value just past the left sum while the right subtree is
            # empty; staying left then keeps every sample on a leaf with non-zero priority.
            go_right = (values >= left_sum) & (self._sum[left + 1] > 0.0)
            values = np.where(go_right, values - left_sum, values)
            nodes = left + go_right
        return nodes - self._first_leaf

    def state_dict(self) -> dict:
        return {"capacity": self.capacity, "leaves": self._sum[self._first_leaf:self._first_leaf + self.capacity].copy(),
                "set": np.isfinite(self._min[self._first_leaf:self._first_leaf + self.capacity])}

    def load_state_dict(self, state: dict) -> None:
        if int(state["capacity"]) != self.capacity:
            raise ValueError(f"SumTree: checkpoint capacity {state['capacity']} != {self.capacity}")
        self._sum[:] = 0.0
        self._min[:] = np.inf
        idx = np.flatnonzero(state["set"])
        self.update(idx, np.asarray(state["leaves"])[idx])

    def _check_indices(self, indices: np.ndarray) -> np.ndarray:
        indices = np.asarray(indices).reshape(-1).astype(np.int64, copy=False)
        if indices.size and (indices.min() < 0 or indices.max() >= self.capacity):
            raise IndexError(f"SumTree: leaf index out of range [0, {self.capacity}): "
                             f"{indices.min()}..{indices.max()}")
        return indices


@dataclass
class SampledBatch:
    """A prioritized sample: the transitions, their buffer slots and IS weights."""

    indices: np.ndarray  # int64 [B], slots to pass back to update_priorities
    weights: np.ndarray  # float32 [B], importance-sampling weights, max over the batch = 1
    transitions: Transitions


class PrioritizedReplay:
    """Proportional prioritized replay (Schaul et al. 2016) with stored action masks.

    A transition is sampled with probability p_i / sum_j p_j, where p_i =
    (|td_i| + priority_eps) ** alpha; new transitions get the largest priority seen so
    far so that each is replayed at least once soon. Sampling is stratified (one
    uniform draw per equal slice of the total priority), and the importance weights
    (N P(i)) ** -beta are divided by the largest weight in the sampled batch (Schaul et
    al.'s normalisation), so they lie in (0, 1] and only ever scale updates down. A single
    tiny priority elsewhere in the buffer does not shrink them: normalising by the weight
    of the smallest priority in the whole buffer would scale every batch by that outlier.

    States are stored compactly: the 400 grid cells as int8 (they are exactly +1 or -1)
    and the 8 features as float32, i.e. 432 bytes instead of 1632 per state.
    """

    def __init__(self, capacity: int, alpha: float = 0.6, priority_eps: float = 1e-3, seed: int = 0,
                 state_dim: int = STATE_DIM, grid_cells: int = GRID_CELLS, num_actions: int = NUM_ACTIONS,
                 compact_states: bool = True):
        if int(capacity) < 1:
            raise ValueError(f"PrioritizedReplay: capacity must be >= 1, got {capacity}")
        if not (0.0 <= alpha <= 1.0):
            raise ValueError(f"PrioritizedReplay: alpha must be in [0, 1], got {alpha}")
        if not (priority_eps > 0.0 and np.isfinite(priority_eps)):
            raise ValueError(f"PrioritizedReplay: priority_eps must be > 0, got {priority_eps}")
        if not (0 <= grid_cells <= state_dim):
            raise ValueError(f"PrioritizedReplay: grid_cells must be in [0, state_dim], got {grid_cells}")
        self.capacity = int(capacity)
        self.alpha = float(alpha)
        self.priority_eps = float(priority_eps)
        self.state_dim = int(state_dim)
        self.grid_cells = int(grid_cells) if compact_states else 0
        self.num_actions = int(num_actions)
        self._tree = SumTree(self.capacity)
        self._rng = np.random.default_rng(seed)
        self._size = 0
        self._next = 0
        self._max_priority = 1.0
        cap, g, f = self.capacity, self.grid_cells, self.state_dim - self.grid_cells
        self._grid = np.zeros((cap, g), np.int8)
        self._features = np.zeros((cap, f), np.float32)
        self._next_grid = np.zeros((cap, g), np.int8)
        self._next_features = np.zeros((cap, f), np.float32)
        self._mask = np.zeros((cap, num_actions), bool)
        self._next_mask = np.zeros((cap, num_actions), bool)
        self._action = np.zeros(cap, np.int64)
        self._reward = np.zeros(cap, np.float32)
        self._discount = np.zeros(cap, np.float32)

    def __len__(self) -> int:
        return self._size

    @property
    def max_priority(self) -> float:
        return self._max_priority

    def add(self, batch: Transitions) -> np.ndarray:
        """Stores a batch (overwriting the oldest slots when full); returns the slots used."""
        n = len(batch)
        if n == 0:
            return np.zeros(0, np.int64)
        self._check_batch(batch)
        if n > self.capacity:
            raise ValueError(f"PrioritizedReplay.add: batch of {n} exceeds capacity {self.capacity}")
        slots = (self._next + np.arange(n)) % self.capacity
        self._grid[slots], self._features[slots] = self._split(batch.state, "state")
        self._next_grid[slots], self._next_features[slots] = self._split(batch.next_state, "next_state")
        self._mask[slots] = batch.mask
        self._next_mask[slots] = batch.next_mask
        self._action[slots] = batch.action
        self._reward[slots] = batch.reward
        self._discount[slots] = batch.discount
        self._tree.update(slots, np.full(n, self._max_priority))
        self._next = int((self._next + n) % self.capacity)
        self._size = min(self._size + n, self.capacity)
        return slots

    def sample(self, batch_size: int, beta: float) -> SampledBatch:
        if self._size == 0:
            raise RuntimeError("PrioritizedReplay.sample: the buffer is empty")
        if batch_size < 1:
            raise ValueError(f"PrioritizedReplay.sample: batch_size must be >= 1, got {batch_size}")
        if not (0.0 <= beta <= 1.0):
            raise ValueError(f"PrioritizedReplay.sample: beta must be in [0, 1], got {beta}")
        total = self._tree.total
        segment = total / batch_size
        values = (np.arange(batch_size) + self._rng.random(batch_size)) * segment
        indices = self._tree.find(np.minimum(values, np.nextafter(total, 0.0)))
        # find() never lands on an empty leaf; the guard keeps a corrupted tree from
        # returning slots that were never written.
        indices = np.minimum(indices, self._size - 1)
        probs = self._tree.get(indices) / total
        # (N P(i))^-beta / max_j (N P(j))^-beta over the batch: N cancels, and the largest weight
        # is that of the batch's smallest probability.
        weights = (probs / probs.min()) ** (-beta)
        return SampledBatch(indices=indices, weights=weights.astype(np.float32), transitions=self.gather(indices))

    def gather(self, indices: np.ndarray) -> Transitions:
        return Transitions(
            state=self._join(self._grid[indices], self._features[indices]),
            mask=self._mask[indices],
            action=self._action[indices],
            reward=self._reward[indices],
            discount=self._discount[indices],
            next_state=self._join(self._next_grid[indices], self._next_features[indices]),
            next_mask=self._next_mask[indices],
        )

    def priorities(self, indices: np.ndarray) -> np.ndarray:
        return self._tree.get(indices)

    def update_priorities(self, indices: np.ndarray, td_errors: np.ndarray) -> None:
        td = np.abs(np.asarray(td_errors, np.float64).reshape(-1))
        if not np.all(np.isfinite(td)):
            raise FloatingPointError("PrioritizedReplay.update_priorities: non-finite TD error "
                                     "(the Q-network has diverged)")
        priorities = (td + self.priority_eps) ** self.alpha
        self._tree.update(indices, priorities)
        self._max_priority = max(self._max_priority, float(priorities.max(initial=0.0)))

    def state_dict(self) -> dict:
        n = self._size
        return {
            "capacity": self.capacity, "size": n, "next": self._next, "max_priority": self._max_priority,
            "alpha": self.alpha, "grid_cells": self.grid_cells, "state_dim": self.state_dim,
            "grid": self._grid[:n].copy(), "features": self._features[:n].copy(),
            "next_grid": self._next_grid[:n].copy(), "next_features": self._next_features[:n].copy(),
            "mask": self._mask[:n].copy(), "next_mask": self._next_mask[:n].copy(),
            "action": self._action[:n].copy(), "reward": self._reward[:n].copy(),
            "discount": self._discount[:n].copy(), "tree": self._tree.state_dict(),
            "rng": self._rng.bit_generator.state,
        }

    def load_state_dict(self, state: dict) -> None:
        for key, mine in (("capacity", self.capacity), ("grid_cells", self.grid_cells), ("state_dim", self.state_dim)):
            if int(state[key]) != mine:
                raise ValueError(f"PrioritizedReplay: checkpoint {key} {state[key]} != configured {mine}")
        n = int(state["size"])
        for name in ("grid", "features", "next_grid", "next_features", "mask", "next_mask",
                     "action", "reward", "discount"):
            getattr(self, "_" + name)[:n] = state[name]
        self._size = n
        self._next = int(state["next"])
        self._max_priority = float(state["max_priority"])
        self._tree.load_state_dict(state["tree"])
        self._rng.bit_generator.state = state["rng"]

    def _split(self, states: np.ndarray, name: str) -> tuple[np.ndarray, np.ndarray]:
        return split_compact(states, self.grid_cells, f"PrioritizedReplay.add: {name}",
                             " (set replay.compact_states: false)")

    def _join(self, grid: np.ndarray, features: np.ndarray) -> np.ndarray:
        return join_compact(grid, features)

    def _check_batch(self, batch: Transitions) -> None:
        n, d, a = len(batch), self.state_dim, self.num_actions
        expected = {"state": (n, d), "next_state": (n, d), "mask": (n, a), "next_mask": (n, a),
                    "reward": (n,), "discount": (n,)}
        for name, shape in expected.items():
            if getattr(batch, name).shape != shape:
                raise ValueError(f"PrioritizedReplay.add: {name} has shape {getattr(batch, name).shape}, "
                                 f"expected {shape}")
        for name in ("state", "next_state", "reward", "discount"):
            if not np.all(np.isfinite(getattr(batch, name))):
                raise ValueError(f"PrioritizedReplay.add: {name} contains NaN or inf")
        if np.any((batch.action < 0) | (batch.action >= a)):
            raise ValueError(f"PrioritizedReplay.add: action outside [0, {a})")
        if not np.all(batch.mask[np.arange(n), batch.action]):
            raise ValueError("PrioritizedReplay.add: a stored action is invalid under its own mask")
        if np.any(~batch.next_mask.any(axis=1) & (batch.discount > 0)):
            raise ValueError("PrioritizedReplay.add: a bootstrapped transition has no valid action in next_mask")


class LabelledStates:
    """A ring buffer of states, each with named per-state arrays (its labels), sampled uniformly with replacement.
    Grid cells are stored as int8 (they are +1/-1). The teacher's DemoBuffer and the auxiliary head's LabelBuffer
    are its two uses; `name` prefixes their error messages."""

    name = "LabelledStates"

    def __init__(self, capacity: int, labels: dict[str, tuple[tuple[int, ...], type]], seed: int = 0,
                 state_dim: int = STATE_DIM, grid_cells: int = GRID_CELLS):
        if capacity < 1:
            raise ValueError(f"{self.name}: capacity must be >= 1, got {capacity}")
        self.capacity = int(capacity)
        self.state_dim, self.grid_cells = state_dim, grid_cells
        self._grid = np.zeros((self.capacity, grid_cells), np.int8)
        self._features = np.zeros((self.capacity, state_dim - grid_cells), np.float32)
        self._labels = {key: np.zeros((self.capacity, *shape), dtype) for key, (shape, dtype) in labels.items()}
        self._size = 0
        self._next = 0
        self._rng = np.random.default_rng(seed)

    def __len__(self) -> int:
        return self._size

    def _store(self, state: np.ndarray, labels: dict[str, np.ndarray]) -> None:
        """Appends states [n, state_dim] with their labels (checked by the caller); beyond the capacity at once,
        the latest ones stay."""
        state = np.asarray(state, np.float32)
        n = state.shape[0]
        if state.shape != (n, self.state_dim):
            raise ValueError(f"{self.name}.add: state has shape {state.shape}, expected ({n}, {self.state_dim})")
        if not np.all(np.isfinite(state)):
            raise ValueError(f"{self.name}.add: state contains NaN or inf")
        grid, features = split_compact(state, self.grid_cells, f"{self.name}.add: state")
        keep = slice(max(0, n - self.capacity), n)
        slots = (self._next + np.arange(keep.stop - keep.start)) % self.capacity
        self._grid[slots], self._features[slots] = grid[keep], features[keep]
        for key, value in labels.items():
            self._labels[key][slots] = value[keep]
        self._next = int((self._next + slots.size) % self.capacity)
        self._size = min(self._size + int(slots.size), self.capacity)

    def _draw(self, batch_size: int) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        if self._size == 0:
            raise ValueError(f"{self.name}.sample: the buffer is empty")
        idx = self._rng.integers(0, self._size, size=batch_size)
        return (join_compact(self._grid[idx], self._features[idx]),
                {key: value[idx].copy() for key, value in self._labels.items()})

    def state_dict(self) -> dict:
        n = self._size
        return {"capacity": self.capacity, "size": n, "next": self._next, "grid": self._grid[:n].copy(),
                "features": self._features[:n].copy(), "rng": self._rng.bit_generator.state,
                **{key: value[:n].copy() for key, value in self._labels.items()}}

    def load_state_dict(self, state: dict) -> None:
        if int(state["capacity"]) != self.capacity:
            raise ValueError(f"{self.name}.load_state_dict: capacity {state['capacity']} != {self.capacity}")
        n = int(state["size"])
        self._size, self._next = n, int(state["next"])
        self._grid[:n] = state["grid"]
        self._features[:n] = state["features"]
        for key, value in self._labels.items():
            value[:n] = state[key]
        self._rng.bit_generator.state = state["rng"]


class DemoBuffer(LabelledStates):
    """Teacher-labelled states for the large-margin loss (docs/training.md, "Learning from a teacher"):
    (state, mask, teacher action)."""

    name = "DemoBuffer"

    def __init__(self, capacity: int, seed: int = 0, state_dim: int = STATE_DIM, grid_cells: int = GRID_CELLS,
                 num_actions: int = NUM_ACTIONS):
        super().__init__(capacity, {"mask": ((num_actions,), bool), "action": ((), np.int64)}, seed=seed,
                         state_dim=state_dim, grid_cells=grid_cells)
        self.num_actions = num_actions

    def add(self, state: np.ndarray, mask: np.ndarray, action: np.ndarray) -> None:
        mask = np.asarray(mask, bool)
        action = np.asarray(action, np.int64)
        n = action.shape[0]
        if np.shape(state) != (n, self.state_dim) or mask.shape != (n, self.num_actions):
            raise ValueError(f"DemoBuffer.add: state {np.shape(state)} / mask {mask.shape} do not match {n} actions")
        if np.any((action < 0) | (action >= self.num_actions)) or not np.all(mask[np.arange(n), action]):
            raise ValueError("DemoBuffer.add: a teacher action is outside [0, 8) or not allowed by its mask")
        self._store(state, {"mask": mask, "action": action})

    def sample(self, batch_size: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(state float32 [B, 408], mask bool [B, 8], action int64 [B]), drawn uniformly with replacement."""
        state, labels = self._draw(batch_size)
        return state, labels["mask"], labels["action"]


class LabelBuffer(LabelledStates):
    """States with a binary label for the auxiliary head (docs/training.md, "An auxiliary head"): (state, label)."""

    name = "LabelBuffer"

    def __init__(self, capacity: int, seed: int = 0, state_dim: int = STATE_DIM, grid_cells: int = GRID_CELLS):
        super().__init__(capacity, {"label": ((), np.float32)}, seed=seed, state_dim=state_dim,
                         grid_cells=grid_cells)
        self.positives = 0  # positive labels ever added (their share is the base rate of the head's task)
        self.added = 0

    def add(self, state: np.ndarray, label: np.ndarray) -> None:
        label = np.asarray(label, np.float32).reshape(-1)
        if np.shape(state)[0] != label.shape[0]:
            raise ValueError(f"LabelBuffer.add: {np.shape(state)[0]} states but {label.shape[0]} labels")
        if not np.all((label == 0.0) | (label == 1.0)):
            raise ValueError("LabelBuffer.add: labels must be 0 or 1")
        self._store(state, {"label": label})
        self.positives += int(label.sum())
        self.added += int(label.size)

    def sample(self, batch_size: int) -> tuple[np.ndarray, np.ndarray]:
        """(state float32 [B, 408], label float32 [B]), drawn uniformly with replacement."""
        state, labels = self._draw(batch_size)
        return state, labels["label"]

    def latest(self, count: int) -> tuple[np.ndarray, np.ndarray]:
        """The newest `count` (or fewer) states and labels, oldest first."""
        n = min(int(count), self._size)
        idx = (self._next - n + np.arange(n)) % self.capacity
        return join_compact(self._grid[idx], self._features[idx]), self._labels["label"][idx].copy()

    def state_dict(self) -> dict:
        return {**super().state_dict(), "positives": self.positives, "added": self.added}

    def load_state_dict(self, state: dict) -> None:
        super().load_state_dict(state)
        self.positives, self.added = int(state["positives"]), int(state["added"])


class HorizonLabeller:
    """Labels each environment's states with whether an event (the robot boxed in: the shield's escape ran, or a
    collision) happens within the next `horizon` decisions, the one taken in that state included.

    `push` takes every environment's state together with whether the step taken from it was such an event and
    whether the episode ended there; it returns the states whose label is now known: the oldest of a full window
    (positive if any of its `horizon` steps was an event), and at an episode's end every state still waiting.
    There the window is cut: a state counts as positive if an event happened before the end; after a
    collision every state left is positive (the collision is within its horizon); after a success or a timeout the
    unfinished ones are labelled with what happened before the end (a success ends with no event to come; a
    timeout's unseen future is taken as free, which it is for the robot at rest or driving clear).
    """

    def __init__(self, num_envs: int, horizon: int, state_dim: int = STATE_DIM):
        if num_envs < 1 or horizon < 1:
            raise ValueError(f"HorizonLabeller: num_envs ({num_envs}) and horizon ({horizon}) must be >= 1")
        self.num_envs, self.horizon, self.state_dim = int(num_envs), int(horizon), int(state_dim)
        self._state = np.zeros((num_envs, horizon, state_dim), np.float32)
        self._event = np.zeros((num_envs, horizon), bool)
        self._count = np.zeros(num_envs, np.int64)  # steps of the current episode pushed so far

    def reset(self) -> None:
        self._count[:] = 0

    def push(self, state: np.ndarray, event: np.ndarray, done: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        e, h = self.num_envs, self.horizon
        if np.shape(state) != (e, self.state_dim) or np.shape(event) != (e,) or np.shape(done) != (e,):
            raise ValueError(f"HorizonLabeller.push: state {np.shape(state)}, event {np.shape(event)}, done "
                             f"{np.shape(done)}; expected ({e}, {self.state_dim}), ({e},), ({e},)")
        event, done = np.asarray(event, bool), np.asarray(done, bool)
        envs = np.arange(e)
        slot = self._count % h
        self._state[envs, slot] = state
        self._event[envs, slot] = event
        self._count += 1
        states, labels = [], []
        full = np.flatnonzero(~done & (self._count >= h))
        if full.size:
            oldest = self._count[full] % h  # the slot to be written next holds the oldest step
            states.append(self._state[full, oldest])
            labels.append(self._event[full].any(axis=1))
        for env in np.flatnonzero(done):
            length = int(min(self._count[env], h))
            order = (self._count[env] - length + np.arange(length)) % h
            events = self._event[env, order]
            # Positive where an event lies at or after the state, within the window (the last step included).
            later = np.logical_or.accumulate(events[::-1])[::-1]
            states.append(self._state[env, order])
            labels.append(later)
            self._count[env] = 0
        if not states:
            return np.zeros((0, self.state_dim), np.float32), np.zeros(0, np.float32)
        return np.concatenate(states), np.concatenate(labels).astype(np.float32)


class NStepAccumulator:
    """Builds n-step transitions for `num_envs` environments, each with its own window.

    Each step pushes (state, mask, action, reward) of every environment together with
    the true successor and how the step ended. A full window of n steps emits the
    transition of its oldest step, bootstrapping with gamma**n from the newest
    successor. When an episode ends, every step still in that environment's window is
    emitted with the rewards up to the end only: after a terminal state (goal or
    collision) with no bootstrap (discount 0); after a truncation (timeout) with
    gamma**k from the final successor, since the state itself is not terminal. The
    window is then cleared, so no return ever mixes two episodes.

    With `defer_bootstrap`, a running episode's transition waits one more step, until its
    bootstrap state has itself been pushed, and bootstraps under the mask pushed with that
    state (the mask it was really acted on under) instead of the `next_mask` of the step
    that reached it. The trainer pushes a one-action mask where the environment ran the
    action shield's escape instead of the chosen action, so a target never takes the
    maximum over choices that state did not have. The transitions are otherwise the same;
    ends of episodes flush as above (a final successor is never acted on).
    """

    def __init__(self, num_envs: int, n: int, gamma: float, state_dim: int = STATE_DIM,
                 num_actions: int = NUM_ACTIONS, defer_bootstrap: bool = False):
        if num_envs < 1:
            raise ValueError(f"NStepAccumulator: num_envs must be >= 1, got {num_envs}")
        if n < 1:
            raise ValueError(f"NStepAccumulator: n must be >= 1, got {n}")
        if not (0.0 <= gamma <= 1.0):
            raise ValueError(f"NStepAccumulator: gamma must be in [0, 1], got {gamma}")
        self.num_envs, self.n, self.gamma = int(num_envs), int(n), float(gamma)
        self.state_dim, self.num_actions = int(state_dim), int(num_actions)
        self.defer_bootstrap = bool(defer_bootstrap)
        e = self.num_envs
        # Ring buffers: step t of env e lives in slot t % slots (one more slot when deferring:
        # the oldest step waits until the step n after it has been pushed).
        self._slots = n + 1 if self.defer_bootstrap else n
        self._state = np.zeros((e, self._slots, state_dim), np.float32)
        self._mask = np.zeros((e, self._slots, num_actions), bool)
        self._action = np.zeros((e, self._slots), np.int64)
        self._reward = np.zeros((e, self._slots), np.float64)
        self._count = np.zeros(e, np.int64)  # steps of the current episode pushed so far
        self._powers = self.gamma ** np.arange(n + 1)

    def pending(self) -> np.ndarray:
        """Steps per environment waiting in the window (not emitted yet)."""
        return np.minimum(self._count, self._slots - 1)

    def reset(self) -> None:
        """Drops every window (e.g. when the environments are recreated)."""
        self._count[:] = 0

    def push(self, state: np.ndarray, mask: np.ndarray, action: np.ndarray, reward: np.ndarray,
             next_state: np.ndarray, next_mask: np.ndarray, terminated: np.ndarray,
             truncated: np.ndarray) -> Transitions:
        e, n, slots = self.num_envs, self.n, self._slots
        for name, value, shape in (("state", state, (e, self.state_dim)), ("mask", mask, (e, self.num_actions)),
                                   ("action", action, (e,)), ("reward", reward, (e,)),
                                   ("next_state", next_state, (e, self.state_dim)),
                                   ("next_mask", next_mask, (e, self.num_actions)),
                                   ("terminated", terminated, (e,)), ("truncated", truncated, (e,))):
            if np.shape(value) != shape:
                raise ValueError(f"NStepAccumulator.push: {name} has shape {np.shape(value)}, expected {shape}")
        terminated = np.asarray(terminated, bool)
        done = terminated | np.asarray(truncated, bool)
        envs = np.arange(e)
        slot = self._count % slots
        self._state[envs, slot] = state
        self._mask[envs, slot] = mask
        self._action[envs, slot] = action
        self._reward[envs, slot] = reward
        self._count += 1

        parts = []
        # Full windows: one transition each, from the oldest step, bootstrapping with gamma**n.
        if self.defer_bootstrap:
            # The step n before the one just pushed, bootstrapping on the state just pushed (acted on,
            # so not yet flushed below even when its step ended the episode) under its pushed mask.
            full = np.flatnonzero(self._count > n)
            oldest = (self._count[full] - 1 - n) % slots
            bootstrap_state, bootstrap_mask = state, mask
        else:
            full = np.flatnonzero(~done & (self._count >= n))
            oldest = (self._count[full] - n) % slots
            bootstrap_state, bootstrap_mask = next_state, next_mask
        if full.size:
            order = (oldest[:, None] + np.arange(n)[None, :]) % slots
            rewards = self._reward[full[:, None], order]
            parts.append(Transitions(
                state=self._state[full, oldest],
                mask=self._mask[full, oldest],
                action=self._action[full, oldest],
                reward=(rewards @ self._powers[:n]).astype(np.float32),
                discount=np.full(full.size, self._powers[n], np.float32),
                next_state=np.asarray(bootstrap_state[full], np.float32),
                next_mask=np.asarray(bootstrap_mask[full], bool),
            ))
        # Ended episodes: flush the whole window with returns cut at the episode end.
        for env in np.flatnonzero(done):
            length = int(min(self._count[env], n))
            first = int(self._count[env] - length)
            order = (first + np.arange(length)) % slots
            rewards = self._reward[env, order]
            # returns[j] = sum_{k >= j} gamma**(k - j) * rewards[k]
            returns = np.zeros(length, np.float64)
            acc = 0.0
            for j in range(length - 1, -1, -1):
                acc = rewards[j] + self.gamma * acc
                returns[j] = acc
            steps_left = length - np.arange(length)
            discount = np.zeros(length) if terminated[env] else self._powers[steps_left]
            parts.append(Transitions(
                state=self._state[env, order],
                mask=self._mask[env, order],
                action=self._action[env, order],
                reward=returns.astype(np.float32),
                discount=discount.astype(np.float32),
                next_state=np.repeat(np.asarray(next_state[env:env + 1], np.float32), length, axis=0),
                next_mask=np.repeat(np.asarray(next_mask[env:env + 1], bool), length, axis=0),
            ))
            self._count[env] = 0
        if not parts:
            return Transitions.empty(self.state_dim, self.num_actions)
        return Transitions.concatenate(parts)
