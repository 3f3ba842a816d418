"""Typed wrapper of the vectorised training environment implemented in C++ (`dqn_dovs_py._core`).

The compiled module runs the same core as the robot: simulator -> LIDAR -> obstacle
tracker -> DOVS -> 408-float state (1,208 with the grid channels of docs/dovs.md), with the 8 actions of DESIGN section 6 and the
reward of section 7. This module only checks and types what crosses the boundary; it
holds no simulation of its own.

Contract of `dqn_dovs_py._core.VecEnv` (n = num_envs, all arrays numpy):

    core = dqn_dovs_py._core.VecEnv(num_envs: int, seed: int, perfect_info: bool = False,
                                 threads: int = 0, action_shield: bool = False,
                                 shield_parameters: dict[str, str] = {})
        Deterministic given the seed. perfect_info=True feeds the DOVS with ground-truth
        obstacles instead of the tracker (for comparisons only). action_shield=True
        narrows every returned mask to the actions the DOVS finds safe whenever any
        valid one is (the planner's action shield, docs/planners.md). shield_parameters:
        the shield's named parameters (decision_config.load_shield_parameters reads them
        from config/dovs.yaml and config/static_safety.yaml as the nodes do); a bad one
        raises ValueError naming it.
    core.shield_parameters() -> dict[str, str]
        The shield's parameters as the environments run them.
    core.set_stage(goal_distance_min: float, goal_distance_max: float,
                   obstacles_min: int, obstacles_max: int, obstacle_type: str) -> None
        obstacle_type in {'none', 'static', 'dynamic', 'both'}. Applies to every episode
        reset from now on; each episode draws its goal distance and obstacle count
        uniformly in the given ranges.
    state, mask = core.reset()      # float32 [n, 408], bool [n, 8]
    out = core.step(actions)        # actions: int64 [n]; returns a dict:
        'next_state'    float32 [n, 408]  true successor (the final state for ended episodes)
        'next_mask'     bool    [n, 8]    valid actions in next_state
        'reward'        float32 [n]       DESIGN section 7
        'terminated'    bool    [n]       goal reached and stopped, or collision
        'truncated'     bool    [n]       500-step timeout (not a terminal state)
        'outcome'       int8    [n]       0 running, 1 success, 2 collision, 3 timeout
        'state'         float32 [n, 408]  what to act on next: the first state of a new
                                          episode where one ended (automatic reset)
        'mask'          bool    [n, 8]    valid actions in 'state'
        'episode_steps' int32   [n]       steps of the episode that this step belongs to
        'executed_action' int64 [n]       (optional) the action that stands for what ran: the chosen one (or
                                          "keep" for a masked one); after an escape, the action whose velocity
                                          is nearest to the escape's in the window's units (dv, dw)
        'escaped'       bool    [n]       (optional) boxed in, the step ran the shield's escape
                                          velocity instead of the action (as the robot does)
        'world'         int32   [n]       (optional) the step's world: its index in the mixture
                                          (set_worlds) in force when its episode began
    core.set_worlds(worlds: list[dict[str, str]], weights: list[float]) -> None
        (optional) The mixture of worlds for the episodes reset from now on: each a
        world_options mapping (world, sensor, people_model, people_see_robot, odom_noise, route,
        people_predictor: a people predictor file whose predicted arcs the DOVS takes, as --predict-people),
        drawn with probability weight / sum; a bad one raises ValueError naming it.
    core.normalization() -> dict[str, float]
        The state normaliser's named constants; the weight file stores them so that the
        planner can check that it builds states the same way.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .curriculum import OBSTACLE_TYPES, ROOM_ONLY, StageSettings

STATE_DIM = 408
NUM_ACTIONS = 8

OUTCOME_RUNNING = 0
OUTCOME_SUCCESS = 1
OUTCOME_COLLISION = 2
OUTCOME_TIMEOUT = 3
OUTCOME_NAMES = {OUTCOME_RUNNING: "running", OUTCOME_SUCCESS: "success", OUTCOME_COLLISION: "collision",
                 OUTCOME_TIMEOUT: "timeout"}


class CoreUnavailableError(ImportError):
    """The compiled module dqn_dovs_py._core is missing (the C++ package has not been built)."""


class EnvContractError(RuntimeError):
    """The environment returned something outside the contract above; the message names it."""


def import_core():
    """Imports dqn_dovs_py._core, or raises CoreUnavailableError saying how to build it."""
    try:
        from . import _core  # noqa: PLC0415 - imported lazily: most of the package works without it
    except ImportError as error:
        raise CoreUnavailableError(
            "dqn_dovs_py._core (the C++ training environment) cannot be imported: "
            f"{error}. Build it with `make build` (scripts/build.sh links the compiled module "
            "into python/dqn_dovs_py/)") from error
    return _core


@dataclass
class StepResult:
    next_state: np.ndarray
    next_mask: np.ndarray
    reward: np.ndarray
    terminated: np.ndarray
    truncated: np.ndarray
    outcome: np.ndarray
    state: np.ndarray
    mask: np.ndarray
    episode_steps: np.ndarray
    # Optional in the contract: which environments ran the shield's escape instead of the action (None: not said).
    escaped: np.ndarray | None = None
    # Optional: the action standing for what ran (the escape's nearest action where escaped; None: not said).
    executed_action: np.ndarray | None = None
    # Optional: each step's world, an index into the mixture in force when its episode began (None: not said).
    world: np.ndarray | None = None


_STEP_FIELDS = {
    # name: (dtype the trainer uses, trailing shape)
    "next_state": (np.float32, (STATE_DIM,)),
    "next_mask": (np.bool_, (NUM_ACTIONS,)),
    "reward": (np.float32, ()),
    "terminated": (np.bool_, ()),
    "truncated": (np.bool_, ()),
    "outcome": (np.int8, ()),
    "state": (np.float32, (STATE_DIM,)),
    "mask": (np.bool_, (NUM_ACTIONS,)),
    "episode_steps": (np.int32, ()),
}


class VecEnv:
    """`num_envs` training environments stepped together.

    `core` is an object with the contract above; by default a new
    dqn_dovs_py._core.VecEnv. Every array that comes back is checked for shape and
    finiteness, so a broken environment stops training with a message naming the field
    instead of poisoning the replay buffer.
    """

    def __init__(self, num_envs: int, seed: int, perfect_info: bool = False, core: Any = None,
                 action_shield: bool = False, shield_parameters: dict[str, str] | None = None,
                 dovs_parameters: dict[str, str] | None = None, reward_parameters: dict[str, str] | None = None):
        if num_envs < 1:
            raise ValueError(f"VecEnv: num_envs must be >= 1, got {num_envs}")
        self.num_envs = int(num_envs)
        self.seed = int(seed)
        if core is None:
            core = import_core().VecEnv(self.num_envs, self.seed, bool(perfect_info),
                                        action_shield=bool(action_shield),
                                        shield_parameters=dict(shield_parameters or {}),
                                        dovs_parameters=dict(dovs_parameters or {}),
                                        reward_parameters=dict(reward_parameters or {}))
        self._core = core
        self._worlds = ROOM_ONLY
        # Floats per state: 408, or 1,208 with the dynamic window and the goal line as grid channels
        # (dovs_parameters grid_channels = 3, docs/dovs.md "Grid channels").
        self.state_dim = int(getattr(core, "state_size", STATE_DIM))

    def set_stage(self, settings: StageSettings) -> None:
        if settings.obstacle_type not in OBSTACLE_TYPES:
            raise ValueError(f"VecEnv.set_stage: obstacle_type {settings.obstacle_type!r} not in {OBSTACLE_TYPES}")
        self._core.set_stage(float(settings.goal_distance_min), float(settings.goal_distance_max),
                             int(settings.obstacles_min), int(settings.obstacles_max), settings.obstacle_type)
        if settings.worlds != self._worlds:
            if not hasattr(self._core, "set_worlds"):
                raise ValueError("VecEnv.set_stage: this environment has no set_worlds; it runs the room only")
            try:
                self._core.set_worlds([w.options() for w in settings.worlds], [w.weight for w in settings.worlds])
            except ValueError as error:
                raise ValueError(f"VecEnv.set_stage: {error}") from None
            self._worlds = settings.worlds

    @property
    def worlds(self):
        """The mixture of worlds in force (step()'s `world` indexes it for episodes begun under it)."""
        return self._worlds

    def reset(self) -> tuple[np.ndarray, np.ndarray]:
        result = self._core.reset()
        if not isinstance(result, tuple) or len(result) != 2:
            raise EnvContractError("VecEnv.reset: expected (state, mask)")
        state = self._checked("reset", "state", result[0])
        mask = self._checked("reset", "mask", result[1])
        self._check_masks("reset", "mask", mask)
        return state, mask

    def step(self, actions: np.ndarray) -> StepResult:
        actions = np.ascontiguousarray(actions, dtype=np.int64)
        if actions.shape != (self.num_envs,):
            raise ValueError(f"VecEnv.step: actions has shape {actions.shape}, expected ({self.num_envs},)")
        out = self._core.step(actions)
        missing = [k for k in _STEP_FIELDS if k not in out]
        if missing:
            raise EnvContractError(f"VecEnv.step: result lacks {missing}")
        values = {k: self._checked("step", k, out[k]) for k in _STEP_FIELDS}
        self._check_masks("step", "mask", values["mask"])
        outcome = values["outcome"]
        done = values["terminated"] | values["truncated"]
        if np.any((outcome != OUTCOME_RUNNING) != done):
            i = int(np.flatnonzero((outcome != OUTCOME_RUNNING) != done)[0])
            raise EnvContractError(f"VecEnv.step: environment {i} has outcome {int(outcome[i])} but "
                                   f"terminated={bool(values['terminated'][i])}, "
                                   f"truncated={bool(values['truncated'][i])}")
        escaped = None
        if "escaped" in out:
            escaped = np.asarray(out["escaped"], dtype=np.bool_)
            if escaped.shape != (self.num_envs,):
                raise EnvContractError(f"VecEnv.step: escaped has shape {escaped.shape}, expected ({self.num_envs},)")
        executed = None
        if "executed_action" in out:
            executed = np.asarray(out["executed_action"], dtype=np.int64)
            if executed.shape != (self.num_envs,) or np.any((executed < 0) | (executed >= NUM_ACTIONS)):
                raise EnvContractError(f"VecEnv.step: executed_action must be {self.num_envs} actions in "
                                       f"[0, {NUM_ACTIONS})")
        world = None
        if "world" in out:
            world = np.asarray(out["world"], dtype=np.int64)
            if world.shape != (self.num_envs,) or np.any(world < 0):
                raise EnvContractError(f"VecEnv.step: world must be {self.num_envs} non-negative indices")
        return StepResult(**values, escaped=escaped, executed_action=executed, world=world)

    def teacher_actions(self, teacher: str, which: np.ndarray, mask: np.ndarray) -> np.ndarray:
        """A teacher's action for each environment's current state where `which` is true (docs/training.md,
        "Learning from a teacher"): `oracle` (reads the simulator's future) or `s_dovs`. -1 where not asked and
        where the shield's escape runs. `mask` is the current mask (what reset/step returned): every action
        given must be allowed by it."""
        which = np.ascontiguousarray(which, dtype=np.bool_)
        if which.shape != (self.num_envs,):
            raise ValueError(f"VecEnv.teacher_actions: which has shape {which.shape}, expected ({self.num_envs},)")
        if not hasattr(self._core, "teacher_actions"):
            raise EnvContractError("VecEnv.teacher_actions: this environment has no teacher")
        try:
            out = np.asarray(self._core.teacher_actions(teacher, which), dtype=np.int64)
        except ValueError as error:
            raise ValueError(f"VecEnv.teacher_actions: {error}") from None
        if out.shape != (self.num_envs,) or np.any((out < -1) | (out >= NUM_ACTIONS)):
            raise EnvContractError(f"VecEnv.teacher_actions: expected {self.num_envs} actions in [-1, {NUM_ACTIONS})")
        if np.any((out >= 0) & ~which):
            raise EnvContractError("VecEnv.teacher_actions: an action was given where none was asked for")
        given = np.flatnonzero(out >= 0)
        if given.size and not np.all(mask[given, out[given]]):
            i = int(given[~mask[given, out[given]]][0])
            raise EnvContractError(f"VecEnv.teacher_actions: action {int(out[i])} of environment {i} is not allowed "
                                   "by its mask")
        return out

    def state_parameters(self) -> str | None:
        """The `state parameters:` metadata line's text: the dovs/* and robot/* values the states are built with
        (beyond the normalisation), which planner_node holds its own against; None from a core without a DOVS (the
        small chain environments of the trainer's tests)."""
        get = getattr(self._core, "state_parameters", None)
        return str(get()) if get is not None else None

    def normalization(self) -> dict[str, float]:
        norm = self._core.normalization()
        try:
            result = {str(k): float(v) for k, v in dict(norm).items()}
        except (TypeError, ValueError) as error:
            raise EnvContractError(f"VecEnv.normalization: expected a dict of str -> float ({error})") from None
        bad = [k for k, v in result.items() if not np.isfinite(v)]
        if bad:
            raise EnvContractError(f"VecEnv.normalization: non-finite value for {bad[0]!r}")
        return result

    def _checked(self, where: str, name: str, value: Any) -> np.ndarray:
        dtype, tail = _STEP_FIELDS[name]
        if name in ("state", "next_state"):
            tail = (self.state_dim,)
        array = np.asarray(value)
        if array.shape != (self.num_envs, *tail):
            raise EnvContractError(f"VecEnv.{where}: {name} has shape {array.shape}, "
                                   f"expected {(self.num_envs, *tail)}")
        if any(stride == 0 and size > 1 for stride, size in zip(array.strides, array.shape)):
            # A zero stride means one element seen n times: every environment would share it.
            raise EnvContractError(f"VecEnv.{where}: {name} is a broadcast view (stride 0): the environments "
                                   "share one value instead of having one each")
        array = np.ascontiguousarray(array, dtype=dtype)
        if dtype is np.float32 and not np.all(np.isfinite(array)):
            i = int(np.flatnonzero(~np.isfinite(array).reshape(self.num_envs, -1).all(axis=1))[0])
            raise EnvContractError(f"VecEnv.{where}: {name} of environment {i} contains NaN or inf")
        return array

    def _check_masks(self, where: str, name: str, mask: np.ndarray) -> None:
        empty = np.flatnonzero(~mask.any(axis=1))
        if empty.size:
            raise EnvContractError(f"VecEnv.{where}: {name} of environment {int(empty[0])} has no valid action")
