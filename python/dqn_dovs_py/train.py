"""DQN-DOVS trainer: `python -m dqn_dovs_py.train --config config/curriculum.yaml --out runs/NAME`.

Double DQN with a dueling network, prioritized replay, 5-step returns and invalid-action
masks, trained through the paper's curriculum on the vectorised C++ environment. See
docs/training.md for the algorithm, every configuration field and the files written.
"""

from __future__ import annotations

import argparse
import copy
import csv
import json
import math
import os
import random
import shlex
import sys
import time
from collections import deque
from dataclasses import asdict, dataclass, field, fields
from typing import Any, Callable, Mapping

import numpy as np
import torch
import yaml

from .agent import AgentConfig, DQNAgent
from .curriculum import Curriculum, CurriculumError
from .decision_config import DecisionConfigError, load_dovs_parameters, load_shield_parameters
from .env import (OUTCOME_COLLISION, OUTCOME_NAMES, OUTCOME_SUCCESS, OUTCOME_TIMEOUT, EnvContractError, StepResult,
                  VecEnv, import_core)
from .escape import one_action_masks
from .export import FEATURE_COUNT, FEATURE_COUNT_WITH_PREVIOUS_CHOICE, WeightFileError
from .provenance import ProvenanceError, repo_path, source_commit
from .provenance import make as make_provenance
from .replay import (GRID_CELLS, STATE_DIM, DemoBuffer, HorizonLabeller, LabelBuffer, NStepAccumulator,
                     PrioritizedReplay)

TRAIN_LOG = "train_log.csv"
EVAL_LOG = "eval_log.csv"
CHECKPOINT = "checkpoint.pt"
REPLAY_FILE = "replay.pt"
CONFIG_COPY = "config.yaml"
SUMMARY = "summary.json"
MODEL_FILE = "model.dqnw"
BEST_MODEL_FILE = "best.dqnw"
SNAPSHOT_DIR = "snapshots"

TRAIN_COLUMNS = ["episode", "stage", "stage_name", "steps", "env_steps", "return", "outcome", "epsilon", "loss",
                 "mean_q", "lr", "beta", "updates", "wall_s", "world", "sp_loss"]
EVAL_COLUMNS = ["episode", "stage", "stage_name", "episodes", "success_rate", "collision_rate", "timeout_rate",
                "mean_return", "mean_steps", "mean_success_time_s", "wall_s"]

CONTROL_PERIOD_S = 0.2


class ConfigError(ValueError):
    """A malformed training configuration; the message names the field."""


# ---- configuration ---------------------------------------------------------------------


@dataclass
class ReplayConfig:
    """Prioritized replay and the learning schedule."""

    # Transitions kept.
    capacity: int = 200_000
    # Transitions per learning step.
    batch_size: int = 64
    # Prioritization exponent.
    alpha: float = 0.6
    # Importance-sampling exponent at the start and at the end of the curriculum (linear).
    beta_start: float = 0.4
    beta_end: float = 1.0
    # Added to |TD error| before the exponent.
    priority_eps: float = 1e-3
    # Transitions stored before the first learning step.
    learning_starts: int = 2000
    # Environment transitions per learning step.
    transitions_per_update: float = 8.0
    # Grid cells stored as int8.
    compact_states: bool = True

    def validate(self) -> str:
        if self.capacity < 1:
            return f"replay.capacity must be >= 1, got {self.capacity}"
        if not (1 <= self.batch_size <= self.capacity):
            return f"replay.batch_size must be in [1, capacity], got {self.batch_size}"
        if not (0.0 <= self.alpha <= 1.0):
            return f"replay.alpha must be in [0, 1], got {self.alpha}"
        for name in ("beta_start", "beta_end"):
            if not (0.0 <= getattr(self, name) <= 1.0):
                return f"replay.{name} must be in [0, 1], got {getattr(self, name)}"
        if not (self.priority_eps > 0):
            return f"replay.priority_eps must be > 0, got {self.priority_eps}"
        if self.learning_starts < self.batch_size:
            return f"replay.learning_starts ({self.learning_starts}) must be >= batch_size ({self.batch_size})"
        if not (self.transitions_per_update > 0 and math.isfinite(self.transitions_per_update)):
            return f"replay.transitions_per_update must be > 0, got {self.transitions_per_update}"
        return ""


@dataclass
class EvalConfig:
    """Periodic greedy evaluation on a fixed set of episodes."""

    # Training episodes between evaluations (0: only the final one).
    every_episodes: int = 250
    # Episodes per evaluation, split evenly over the environments: environment i plays the first
    # episodes of its own fixed scenario sequence, each to its end (evaluation_quota).
    episodes: int = 32
    # Environments used by the evaluation (at most `episodes` of them are created).
    num_envs: int = 8
    # Seed of the evaluation environments; the same for every evaluation.
    seed: int = 100003
    # Also export every network evaluated in the last stage to snapshots/ep<EPISODE>.dqnw, for model
    # selection on held-out scenarios (scripts/select_model.sh); 630 KB each.
    keep_snapshots: bool = False

    def validate(self) -> str:
        if self.every_episodes < 0:
            return f"evaluation.every_episodes must be >= 0, got {self.every_episodes}"
        if self.episodes < 1:
            return f"evaluation.episodes must be >= 1, got {self.episodes}"
        if self.num_envs < 1:
            return f"evaluation.num_envs must be >= 1, got {self.num_envs}"
        return ""


@dataclass
class CheckpointConfig:
    # Episodes between checkpoints (0: only at the end).
    every_episodes: int = 250
    # Store the replay buffer too, so that a resumed run continues exactly where it stopped.
    save_replay: bool = True

    def validate(self) -> str:
        if self.every_episodes < 0:
            return f"checkpoint.every_episodes must be >= 0, got {self.every_episodes}"
        return ""


@dataclass
class LogConfig:
    # Episodes in the moving success rate of the progress bar.
    success_window: int = 100
    # Episodes between redraws of the PNG learning curves (0: only at the end).
    plot_every_episodes: int = 500

    def validate(self) -> str:
        if self.success_window < 1:
            return f"log.success_window must be >= 1, got {self.success_window}"
        if self.plot_every_episodes < 0:
            return f"log.plot_every_episodes must be >= 0, got {self.plot_every_episodes}"
        return ""


TEACHERS = ("none", "oracle", "s_dovs")


@dataclass
class LabelBufferFields:
    """The buffer of labelled states the teacher's and the auxiliary head's losses draw from."""

    # Labelled states kept, labelled states per learning step, and labels needed before the loss starts.
    buffer_capacity: int = 50000
    batch_size: int = 64
    min_labels: int = 1000

    def buffer_problem(self, section: str) -> str:
        for name in ("buffer_capacity", "batch_size", "min_labels"):
            if getattr(self, name) < 1:
                return f"{section}.{name} must be >= 1, got {getattr(self, name)}"
        return ""


@dataclass
class TeacherConfig(LabelBufferFields):
    """Learning from a teacher (docs/training.md, "Learning from a teacher"): a share of the states the agent
    visits is labelled with the teacher's action (DAgger: the learner's own states), the labels train a
    large-margin loss beside the TD loss, and some labelled steps run the teacher's action instead of the agent's.
    The robot never runs the teacher: `oracle` reads the simulator's future."""

    # none (off), oracle (privileged: knows the future) or s_dovs (the heuristic, same observation as the agent).
    kind: str = "none"
    # Probability that a state is labelled (each environment, each step).
    label_fraction: float = 0.2
    # Probability that a labelled step runs the teacher's action instead of the agent's, linear from start to end
    # over the run.
    behaviour_start: float = 0.0
    behaviour_end: float = 0.0
    # Weight of the large-margin loss beside the TD loss, and its margin.
    loss_weight: float = 1.0
    margin: float = 0.8

    def validate(self) -> str:
        if self.kind not in TEACHERS:
            return f"teacher.kind must be one of {', '.join(TEACHERS)}, got {self.kind!r}"
        for name in ("label_fraction", "behaviour_start", "behaviour_end"):
            value = getattr(self, name)
            if not 0.0 <= value <= 1.0:
                return f"teacher.{name} must be in [0, 1], got {value}"
        for name in ("loss_weight", "margin"):
            if getattr(self, name) < 0:
                return f"teacher.{name} must be >= 0, got {getattr(self, name)}"
        error = self.buffer_problem("teacher")
        if error:
            return error
        if self.kind != "none" and self.label_fraction == 0:
            return "teacher.label_fraction is 0, so the teacher is never asked; set teacher.kind: none"
        return ""

    @property
    def enabled(self) -> bool:
        return self.kind != "none"


@dataclass
class AuxiliaryConfig(LabelBufferFields):
    """An auxiliary head (docs/training.md, "An auxiliary head"): a linear layer on the network's last hidden layer
    predicts whether the robot will be boxed in (the shield's escape runs, or it collides) within the next
    `horizon` decisions; its cross-entropy is added to the TD loss. It shapes the shared layers only: it is not
    exported and never chooses an action."""

    # Decisions ahead the label looks (0: no auxiliary head).
    horizon: int = 0
    # Weight of its cross-entropy beside the TD loss.
    loss_weight: float = 0.5

    def validate(self) -> str:
        if self.horizon < 0:
            return f"auxiliary.horizon must be >= 0 (0: off), got {self.horizon}"
        if not (math.isfinite(self.loss_weight) and self.loss_weight >= 0):
            return f"auxiliary.loss_weight must be >= 0, got {self.loss_weight}"
        return self.buffer_problem("auxiliary")

    @property
    def enabled(self) -> bool:
        return self.horizon > 0


@dataclass
class ModelConfig:
    """The network's head (docs/training.md, "A quantile head"): `quantiles` > 1 makes the dueling heads give that
    many quantile values of each action's return (QR-DQN), and acting maximises their CVaR at `cvar_alpha`."""

    # Quantile values per action (1: the plain Q-network).
    quantiles: int = 1
    # CVaR level: acting maximises the mean of each action's lowest ceil(cvar_alpha * quantiles) quantile values
    # (1: their mean, Q).
    cvar_alpha: float = 1.0

    def validate(self) -> str:
        from .model import MAX_QUANTILES  # noqa: PLC0415 - keeps config checks free of model imports until here

        if not 1 <= self.quantiles <= MAX_QUANTILES:
            return f"model.quantiles must be in [1, {MAX_QUANTILES}], got {self.quantiles}"
        if not 0.0 < self.cvar_alpha <= 1.0:
            return f"model.cvar_alpha must be in (0, 1], got {self.cvar_alpha}"
        if self.quantiles == 1 and self.cvar_alpha != 1.0:
            return (f"model.cvar_alpha is {self.cvar_alpha} but model.quantiles is 1: the CVaR of one value per action "
                    "is that value; set model.quantiles > 1 or leave cvar_alpha at 1")
        return ""


@dataclass
class TrainConfig:
    """Everything a training run depends on (config/curriculum.yaml, docs/training.md)."""

    # Seed of the environments, exploration, replay sampling and network initialisation.
    seed: int = 1
    # Environments stepped together.
    num_envs: int = 8
    # Ground-truth obstacles for the DOVS instead of the tracker (comparison runs only).
    perfect_info: bool = False
    # The action shield (docs/planners.md): the agent chooses only among the actions the DOVS finds
    # safe whenever there are any; the narrowed mask is stored in replay and applied in the target,
    # exactly as the planner applies it on the robot. false = the paper's validity mask only.
    action_shield: bool = False
    # Folder of the dovs.yaml and static_safety.yaml whose action shield the environments run ("": the
    # repository's config/, what the robot's launch files load; python/dqn_dovs_py/decision_config.py).
    decision_config: str = ""
    # The DOVS model's parameters by name (config/dovs.yaml's dovs/* names, docs/dovs.md) on top of its defaults,
    # in every world: e.g. {grid_contact_horizon: 5.0} for the graded grid. The exported weight file records
    # the state encoding they give (its normalisation), and the robot's dovs.yaml must then say the same.
    dovs: dict = field(default_factory=dict)
    # The reward's parameters by name (RewardConfig, docs/training.md "Reward") on top of the paper's: e.g.
    # {hit_at_rest_reward: -5, intimate_weight: 0.5, blocking_weight: 0.5, shaping_gamma: 0.97}. shaping_gamma, when
    # given, must be 1 (the paper's progress term) or this config's gamma (potential-based shaping that leaves the
    # optimal policy unchanged).
    reward: dict = field(default_factory=dict)
    # Discount per control period.
    gamma: float = 0.97
    # Rewards summed before bootstrapping.
    n_step: int = 5
    agent: AgentConfig = field(default_factory=AgentConfig)
    replay: ReplayConfig = field(default_factory=ReplayConfig)
    evaluation: EvalConfig = field(default_factory=EvalConfig)
    checkpoint: CheckpointConfig = field(default_factory=CheckpointConfig)
    log: LogConfig = field(default_factory=LogConfig)
    teacher: TeacherConfig = field(default_factory=TeacherConfig)
    auxiliary: AuxiliaryConfig = field(default_factory=AuxiliaryConfig)
    model: ModelConfig = field(default_factory=ModelConfig)
    # The raw `curriculum` section (parsed by Curriculum.from_dict); kept raw so that it
    # can be written back verbatim into the run directory.
    curriculum: dict = field(default_factory=dict)
    # Factor applied to every stage's episode count (--scale; 1 = the paper's curriculum).
    scale: float = 1.0

    def validate(self) -> str:
        if self.num_envs < 1:
            return f"num_envs must be >= 1, got {self.num_envs}"
        if not (0.0 < self.gamma <= 1.0):
            return f"gamma must be in (0, 1], got {self.gamma}"
        if self.n_step < 1:
            return f"n_step must be >= 1, got {self.n_step}"
        for section, values in (("dovs", self.dovs), ("reward", self.reward)):
            for name, value in values.items():
                if not isinstance(name, str) or isinstance(value, bool) or not isinstance(value, (int, float)) \
                        or not math.isfinite(value):
                    return f"{section}: {name!r} must map to a finite number, got {value!r}"
        shaping = self.reward.get("shaping_gamma")
        if shaping is not None and shaping != 1.0 and not math.isclose(shaping, self.gamma):
            return (f"reward: shaping_gamma {shaping} is neither 1 (the paper's progress term) nor gamma {self.gamma} "
                    "(shaping that leaves the optimal policy unchanged)")
        for part in (self.agent, self.replay, self.evaluation, self.checkpoint, self.log, self.teacher,
                     self.auxiliary, self.model):
            error = part.validate()
            if error:
                return error
        try:
            self.build_curriculum()
        except CurriculumError as error:
            return str(error)
        return ""

    def build_curriculum(self) -> Curriculum:
        return Curriculum.from_dict(self.curriculum).scaled(self.scale)

    def to_dict(self) -> dict:
        return asdict(self)

    @staticmethod
    def from_dict(raw: dict) -> "TrainConfig":
        if not isinstance(raw, dict):
            raise ConfigError("configuration: expected a mapping at the top level")
        sections = {"agent": AgentConfig, "replay": ReplayConfig, "evaluation": EvalConfig,
                    "checkpoint": CheckpointConfig, "log": LogConfig, "teacher": TeacherConfig,
                    "auxiliary": AuxiliaryConfig, "model": ModelConfig}
        known = {f.name for f in fields(TrainConfig)}
        unknown = set(raw) - known
        if unknown:
            raise ConfigError(f"configuration: unknown field(s) {sorted(unknown)}")
        kwargs: dict[str, Any] = {}
        for name, value in raw.items():
            if name in sections:
                kwargs[name] = _build_section(name, sections[name], value or {})
            elif name == "curriculum":
                kwargs[name] = copy.deepcopy(value)
            elif name in ("dovs", "reward"):
                if not isinstance(value or {}, dict):
                    raise ConfigError(f"{name}: expected a mapping of {name} parameter names to numbers")
                kwargs[name] = dict(value or {})
            else:
                kwargs[name] = _coerce(name, TrainConfig.__dataclass_fields__[name].default, value)
        return TrainConfig(**kwargs)


def _build_section(name: str, cls: type, raw: dict):
    if not isinstance(raw, dict):
        raise ConfigError(f"{name}: expected a mapping")
    known = {f.name: f for f in fields(cls)}
    unknown = set(raw) - set(known)
    if unknown:
        raise ConfigError(f"{name}: unknown field(s) {sorted(unknown)}")
    defaults = cls()
    return cls(**{k: _coerce(f"{name}.{k}", getattr(defaults, k), v) for k, v in raw.items()})


def _coerce(where: str, default: Any, value: Any) -> Any:
    """Converts a YAML value to the default's type, with an error naming the field."""
    try:
        if isinstance(default, bool):
            if not isinstance(value, bool):
                raise TypeError
            return value
        if isinstance(default, int):
            if isinstance(value, bool) or int(value) != value:
                raise TypeError
            return int(value)
        if isinstance(default, float):
            if isinstance(value, bool):
                raise TypeError
            result = float(value)
            if not math.isfinite(result):
                raise TypeError
            return result
    except (TypeError, ValueError):
        raise ConfigError(f"{where}: expected a finite {type(default).__name__}, got {value!r}") from None
    return value


def load_config(path: str) -> TrainConfig:
    try:
        with open(path) as f:
            raw = yaml.safe_load(f)
    except OSError as error:
        raise ConfigError(f"{path}: cannot read the configuration ({error.strerror})") from None
    except yaml.YAMLError as error:
        raise ConfigError(f"{path}: not valid YAML ({error})") from None
    try:
        config = TrainConfig.from_dict(raw)
    except ConfigError as error:
        raise ConfigError(f"{path}: {error}") from None
    message = config.validate()
    if message:
        raise ConfigError(f"{path}: {message}")
    return config


# ---- helpers -------------------------------------------------------------------------------


def boxed_in_events(out: StepResult) -> np.ndarray:
    """Per environment, whether its step boxed the robot in: the shield's escape ran, or the step collided."""
    event = (np.asarray(out.terminated, bool) & (np.asarray(out.outcome) == OUTCOME_COLLISION))
    if out.escaped is not None:
        event |= np.asarray(out.escaped, bool)
    return event


def env_seed(seed: int, episodes_done: int) -> int:
    """Seed of the training environments created after `episodes_done` episodes (a resumed
    run gets fresh, but still reproducible, episodes)."""
    return int(np.random.SeedSequence([int(seed), int(episodes_done)]).generate_state(1)[0] & 0x7FFFFFFF)


def resolve_device(name: str) -> torch.device:
    if name == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    if name == "cuda" and not torch.cuda.is_available():
        raise ConfigError("--device cuda: no CUDA device is available to PyTorch")
    if name not in ("cpu", "cuda"):
        raise ConfigError(f"--device must be auto, cpu or cuda, got {name!r}")
    return torch.device(name)


def default_model_factory(grid_channels: int = 1, feature_count: int = FEATURE_COUNT, quantiles: int = 1,
                          cvar_alpha: float = 1.0, wall_rays: int = 0, person_tokens: int = 0,
                          route_points: int = 0) -> torch.nn.Module:
    from .model import DuelingQNet  # noqa: PLC0415 - keeps `--help` and config checks free of model imports

    if quantiles == 1 and cvar_alpha == 1.0 and wall_rays == 0 and person_tokens == 0 and route_points == 0:
        return DuelingQNet(grid_channels=grid_channels, feature_count=feature_count)  # built exactly as before
    return DuelingQNet(grid_channels=grid_channels, feature_count=feature_count, quantiles=quantiles,
                       cvar_alpha=cvar_alpha, wall_rays=wall_rays, person_tokens=person_tokens,
                       route_points=route_points)


def _dovs_choice(dovs: dict, name: str, default: int, allowed: tuple[int, ...], rule: str) -> int:
    """The integer `name` of a `dovs` section (`default` when absent), one of `allowed`; ConfigError stating `rule`
    otherwise."""
    value = dovs.get(name, default)
    try:
        number = int(value)
    except (TypeError, ValueError):
        raise ConfigError(f"dovs: {name} must be {rule}, got {value!r}") from None
    if number != float(value) or number not in allowed:
        raise ConfigError(f"dovs: {name} must be {rule}, got {value!r}")
    return number


def grid_channels_of(dovs: dict) -> int:
    """The state's grid channels a `dovs` section gives (its grid_channels, 1 by default; docs/dovs.md "Grid
    channels")."""
    return _dovs_choice(dovs, "grid_channels", 1, (1, 2, 3), "1, 2 or 3")


def feature_count_of(dovs: dict) -> int:
    """The network's feature inputs a `dovs` section gives: 8, or 17 with previous_action = 1 (the previous choice
    after the features; docs/dovs.md "The previous action")."""
    on = _dovs_choice(dovs, "previous_action", 0, (0, 1), "0 or 1")
    return FEATURE_COUNT_WITH_PREVIOUS_CHOICE if on else FEATURE_COUNT


def tokens_of(dovs: dict) -> tuple[int, int, int]:
    """(wall rays, person tokens, route points) of a `dovs` section (0, 0, 0 by default; docs/dovs.md "Person
    tokens", "The route ahead")."""
    return (_dovs_choice(dovs, "wall_rays", 0, tuple(range(33)), "an integer in [0, 32]"),
            _dovs_choice(dovs, "person_tokens", 0, tuple(range(17)), "an integer in [0, 16]"),
            _dovs_choice(dovs, "route_points", 0, tuple(range(17)), "an integer in [0, 16]"))


def _atomic_torch_save(obj: Any, path: str) -> None:
    tmp = path + ".tmp"
    torch.save(obj, tmp)
    os.replace(tmp, path)


def _numpy_global_state() -> tuple:
    """numpy's legacy global state with plain lists, so that checkpoints load with weights_only=True."""
    name, keys, pos, has_gauss, cached = np.random.get_state()
    return name, keys.tolist(), int(pos), int(has_gauss), float(cached)


def _set_numpy_global_state(state) -> None:
    name, keys, pos, has_gauss, cached = state
    np.random.set_state((name, np.asarray(keys, np.uint32), pos, has_gauss, cached))


def _truncate_csv(path: str, columns: list[str], keep: Callable[[dict], bool]) -> None:
    """Drops the rows written after the checkpoint being resumed (they will be redone)."""
    if not os.path.exists(path):
        return
    with open(path, newline="") as f:
        rows = [r for r in csv.DictReader(f) if keep(r)]
    with open(path + ".tmp", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=columns)
        writer.writeheader()
        writer.writerows(rows)
    os.replace(path + ".tmp", path)


class _CsvLog:
    def __init__(self, path: str, columns: list[str]):
        new = not os.path.exists(path) or os.path.getsize(path) == 0
        self._file = open(path, "a", newline="")
        self._writer = csv.DictWriter(self._file, fieldnames=columns)
        if new:
            self._writer.writeheader()

    def write(self, row: dict) -> None:
        self._writer.writerow({k: _fmt(v) for k, v in row.items()})
        # One short row per episode: flushing keeps the log current for plots and `tail -f`.
        self._file.flush()

    def flush(self) -> None:
        self._file.flush()

    def close(self) -> None:
        self._file.close()


def _fmt(value: Any) -> Any:
    if isinstance(value, float):
        return "" if math.isnan(value) else f"{value:.6g}"
    return value


# ---- evaluation ----------------------------------------------------------------------------


def evaluation_quota(episodes: int, num_envs: int) -> np.ndarray:
    """Episodes each evaluation environment plays: `episodes` split as evenly as possible over
    min(num_envs, episodes) environments, the first ones taking one more where it does not divide."""
    n = max(1, min(int(num_envs), int(episodes)))
    quota = np.full(n, int(episodes) // n, np.int64)
    quota[:int(episodes) % n] += 1
    return quota


def play_fixed_episodes(env: VecEnv, policy: Callable[[np.ndarray, np.ndarray], np.ndarray],
                        quota: np.ndarray) -> list[tuple[int, float, int]]:
    """Plays the first quota[i] episodes of environment i, each to its end, acting with
    `policy(state, mask)`; returns (outcome, return, steps) per episode, environment by environment.

    Each environment draws its scenarios from a fixed sequence (its seed, its index and its episode
    count), so this is the same set of episodes whatever the policy does: successive evaluations are
    comparable. Counting the first episodes to finish over all environments instead would favour short
    episodes (quick collisions, near goals). Environments done with their share keep stepping (they are
    stepped together) but their further episodes are not counted."""
    quota = np.asarray(quota, np.int64)
    if quota.shape != (env.num_envs,):
        raise ValueError(f"play_fixed_episodes: quota has shape {quota.shape}, expected ({env.num_envs},)")
    state, mask = env.reset()
    returns = np.zeros(env.num_envs)
    played = np.zeros(env.num_envs, np.int64)
    results: list[list[tuple[int, float, int]]] = [[] for _ in range(env.num_envs)]
    while np.any(played < quota):
        out = env.step(policy(state, mask))
        returns += out.reward
        for i in np.flatnonzero(out.terminated | out.truncated):
            if played[i] < quota[i]:
                results[i].append((int(out.outcome[i]), float(returns[i]), int(out.episode_steps[i])))
                played[i] += 1
            returns[i] = 0.0
        state, mask = out.state, out.mask
    return [r for per_env in results for r in per_env]


# ---- the trainer -------------------------------------------------------------------------


EnvFactory = Callable[[int, int, bool], VecEnv]


class Trainer:
    """One training run in `out_dir` (fresh, or resumed from its checkpoint)."""

    def __init__(self, config: TrainConfig, out_dir: str, device: str = "auto", threads: int = 0,
                 resume: bool = False, env_factory: EnvFactory | None = None,
                 model_factory: Callable[[], torch.nn.Module] | None = None, progress: bool = True,
                 command: str = "", provenance: dict[str, str] | None = None,
                 start_parameters: Mapping[str, torch.Tensor] | None = None):
        """`start_parameters`: the parameters of the network the run starts from (--init-from), as the weight file
        holds them (before any widening); with agent.l2_sp_weight > 0 the loss pulls the network towards them
        (L2-SP), and a fresh run then needs them."""
        message = config.validate()
        if message:
            raise ConfigError(message)
        if config.agent.l2_sp_weight > 0 and not resume and start_parameters is None:
            raise ConfigError(f"agent.l2_sp_weight is {config.agent.l2_sp_weight} but the run does not start from a "
                              "network (--init-from): L2-SP pulls the parameters towards the start network's; set it "
                              "to 0 or give --init-from")
        self.config = config
        self.out_dir = out_dir
        self.curriculum = config.build_curriculum()
        self.total_episodes = self.curriculum.total_episodes
        self.device = resolve_device(device)
        self.progress = progress
        self.command = command
        # Written into every exported file (provenance.KEYS); a run resumed keeps the one it started with.
        self.provenance = dict(provenance) if provenance else {
            "config": "none (a TrainConfig built in code)", "seed": str(config.seed), "source commit": source_commit(),
            "init from": "none" if model_factory is None else "unknown (a model factory given in code)"}
        if threads > 0:
            torch.set_num_threads(threads)
        shield = config.action_shield
        # The shield the robot runs, read from the same YAML files as the nodes (never the C++ defaults).
        self.shield_parameters = load_shield_parameters(config.decision_config or None) if env_factory is None else {}
        shield_parameters = self.shield_parameters
        # The DOVS model the robot runs (config/dovs.yaml's dovs: section, decision_config's folder), with the
        # configuration's own `dovs` section over it (experiments on the state).
        self.dovs_parameters = load_dovs_parameters(config.decision_config or None) if env_factory is None else {}
        dovs_parameters = dict(self.dovs_parameters)
        dovs_parameters.update({name: repr(float(value)) if isinstance(value, float) else str(value)
                                for name, value in config.dovs.items()})
        reward_parameters = {name: repr(float(value)) if isinstance(value, float) else str(value)
                             for name, value in config.reward.items()}
        if (dovs_parameters or reward_parameters) and env_factory is None:
            try:  # names and ranges are the C++ side's: one environment built now says what is wrong, naming the
                # section (dovs_parameters: ..., reward_parameters: ...), before any run
                import_core().VecEnv(1, 0, threads=1, dovs_parameters=dovs_parameters,
                                     reward_parameters=reward_parameters)
            except ValueError as error:
                raise ConfigError(str(error)) from None
        self._env_factory = env_factory or (
            lambda n, seed, perfect: VecEnv(n, seed, perfect, action_shield=shield,
                                            shield_parameters=shield_parameters, dovs_parameters=dovs_parameters,
                                            reward_parameters=reward_parameters))
        layout = {**self.dovs_parameters, **config.dovs}  # the state's layout, as the environments build it
        grid_channels = grid_channels_of(layout)
        feature_count = feature_count_of(layout)
        mc = config.model
        wall_rays, person_tokens, route_points = tokens_of(layout)
        self._model_factory = model_factory or (
            lambda: default_model_factory(grid_channels, feature_count, mc.quantiles, mc.cvar_alpha, wall_rays,
                                          person_tokens, route_points))

        os.makedirs(out_dir, exist_ok=True)
        checkpoint_path = os.path.join(out_dir, CHECKPOINT)
        if resume and not os.path.exists(checkpoint_path):
            raise FileNotFoundError(f"--resume: {checkpoint_path} does not exist")
        if not resume and os.path.exists(checkpoint_path):
            raise FileExistsError(f"{out_dir} already holds a run ({CHECKPOINT}); pass --resume to continue it "
                                  "or choose another --out")

        self._seed_everything(config.seed)
        model = self._model_factory()
        if getattr(model, "grid_channels", grid_channels) != grid_channels:
            raise ConfigError(f"the network reads {model.grid_channels} grid channels but dovs grid_channels is "
                              f"{grid_channels} (an --init-from network of 1 channel is widened; one of more is "
                              "never narrowed)")
        if getattr(model, "feature_count", feature_count) != feature_count:
            raise ConfigError(f"the network reads {model.feature_count} feature inputs but dovs previous_action "
                              f"gives {feature_count} (an --init-from network of 8 is widened; one of 17 is never "
                              "narrowed)")
        if (getattr(model, "quantiles", 1), getattr(model, "cvar_alpha", 1.0)) != (mc.quantiles, mc.cvar_alpha):
            raise ConfigError(f"the network has {getattr(model, 'quantiles', 1)} quantile value(s) per action at "
                              f"cvar_alpha {getattr(model, 'cvar_alpha', 1.0)} but the model section says quantiles "
                              f"{mc.quantiles}, cvar_alpha {mc.cvar_alpha} (an --init-from network of 1 quantile is "
                              "widened; one of more is never changed)")
        if (getattr(model, "wall_rays", 0), getattr(model, "person_tokens", 0)) != (wall_rays, person_tokens):
            raise ConfigError(f"the network reads {getattr(model, 'wall_rays', 0)} wall rays and "
                              f"{getattr(model, 'person_tokens', 0)} person tokens but the dovs section gives "
                              f"{wall_rays} and {person_tokens} (an --init-from network without them is widened)")
        if getattr(model, "route_points", 0) != route_points:
            raise ConfigError(f"the network reads {getattr(model, 'route_points', 0)} route points but dovs "
                              f"route_points is {route_points} (an --init-from network without them is widened)")
        state_dim = int(getattr(model, "state_size", STATE_DIM))
        grid_values = int(getattr(model, "grid_channels", 1)) * GRID_CELLS  # every grid channel
        ac = config.auxiliary
        # The auxiliary head is made after the network, so a run without one draws the same initial weights.
        aux_head = torch.nn.Linear(model.trunk_width, 1) if ac.enabled else None
        self.agent = DQNAgent(model, config.agent, device=self.device, seed=config.seed + 1, aux_head=aux_head)
        if config.agent.l2_sp_weight > 0 and not resume:
            try:
                self.agent.set_anchor(start_parameters)
            except ValueError as error:
                raise ConfigError(f"agent.l2_sp_weight: {error}") from None
        rc = config.replay
        # A graded grid's cells are not +1 / -1: its states are stored as float32.
        compact = rc.compact_states and not config.dovs.get("grid_contact_horizon")
        self.replay = PrioritizedReplay(rc.capacity, alpha=rc.alpha, priority_eps=rc.priority_eps,
                                        seed=config.seed + 2, compact_states=compact, state_dim=state_dim,
                                        grid_cells=grid_values)
        # With the shield, the environment may run its escape instead of the chosen action: the transition
        # then stores the action executed with a one-action mask, and the n-step targets that bootstrap on
        # such a state wait one step for that mask (NStepAccumulator, defer_bootstrap).
        self.nstep = NStepAccumulator(config.num_envs, config.n_step, config.gamma, state_dim=state_dim,
                                      defer_bootstrap=config.action_shield)
        tc = config.teacher
        grid_cells = grid_values if compact else 0  # the labelled states are stored like the replay's
        self.demos = DemoBuffer(tc.buffer_capacity, seed=config.seed + 3, state_dim=state_dim,
                                grid_cells=grid_cells) if tc.enabled else None
        self._teacher_rng = np.random.default_rng(config.seed + 4)
        # Labelled steps, those where the agent's own choice was the teacher's, and those that ran the teacher's.
        self.teacher_counts = {"labels": 0, "agreed": 0, "executed": 0}
        self._demo_loss_sum = 0.0
        self._demo_loss_count = 0
        self.aux_labels = LabelBuffer(ac.buffer_capacity, seed=config.seed + 5, state_dim=state_dim,
                                      grid_cells=grid_cells) if ac.enabled else None
        self.labeller = HorizonLabeller(config.num_envs, ac.horizon, state_dim=state_dim) if ac.enabled else None
        self._aux_loss_sum = 0.0
        self._aux_loss_count = 0

        self.episodes_done = 0
        self.env_steps = 0
        self.update_credit = 0.0
        self.wall_s = 0.0
        self.best_eval = -1.0
        self._recent_outcomes: deque[int] = deque(maxlen=config.log.success_window)
        self._loss_sum = 0.0
        self._q_sum = 0.0
        self._loss_count = 0
        self._sp_sum = 0.0
        self._sp_count = 0
        self._last_loss = float("nan")
        self._timing = {"env_s": 0.0, "act_s": 0.0, "replay_s": 0.0, "learn_s": 0.0, "eval_s": 0.0}
        self._normalization: dict[str, float] | None = None
        self._state_parameters: str | None = None

        if resume:
            self._load_checkpoint(checkpoint_path)
            if config.agent.l2_sp_weight > 0 and not self.agent.has_anchor:
                raise ConfigError(f"--resume: agent.l2_sp_weight is {config.agent.l2_sp_weight} but the run in {out_dir} "
                                  "keeps no start network in its checkpoint (it was not started from --init-from "
                                  "with L2-SP)")
        else:
            with open(os.path.join(out_dir, CONFIG_COPY), "w") as f:
                yaml.safe_dump(config.to_dict(), f, sort_keys=False)

    # ---- schedules ---------------------------------------------------------------------

    def progress_fraction(self) -> float:
        return min(self.episodes_done / self.total_episodes, 1.0)

    def learning_rate(self) -> float:
        a = self.config.agent
        return a.lr_start + (a.lr_end - a.lr_start) * self.progress_fraction()

    def beta(self) -> float:
        r = self.config.replay
        return r.beta_start + (r.beta_end - r.beta_start) * self.progress_fraction()

    # ---- main loop ---------------------------------------------------------------------

    def run(self, stop_at: int | None = None) -> dict:
        """Trains to the end of the curriculum, then evaluates, checkpoints and exports
        model.dqnw. With `stop_at`, stops after that many episodes with a checkpoint only
        (continue later with resume=True)."""
        cfg = self.config
        limit = self.total_episodes if stop_at is None else min(int(stop_at), self.total_episodes)
        env = self._env_factory(cfg.num_envs, env_seed(cfg.seed, self.episodes_done), cfg.perfect_info)
        self._normalization = env.normalization()
        # What the states depend on beyond the normalisation (dovs/*, robot/*): every export names it.
        self._state_parameters = env.state_parameters() if hasattr(env, "state_parameters") else None
        e = cfg.num_envs
        env.set_stage(self.curriculum.settings_at(self.episodes_done))
        state, mask = env.reset()
        self.nstep.reset()
        if self.labeller is not None:
            self.labeller.reset()
        ep_return = np.zeros(e, np.float64)
        ep_stage = np.full(e, self.curriculum.locate(self.episodes_done)[0])  # stage each running episode began in
        # Stages count episodes in the order they start. With one episode running per
        # environment, the next one to start has index episodes_done + e: the environment
        # resets automatically inside step(), so its settings must be in place beforehand.
        # The world mixture each running episode began under (step()'s `world` indexes it).
        ep_worlds = [self.curriculum.settings_at(self.episodes_done).worlds] * e
        settings = self.curriculum.settings_at(self.episodes_done + e)
        settings_stage = self.curriculum.locate(self.episodes_done + e)[0]
        env.set_stage(settings)

        train_log = _CsvLog(os.path.join(self.out_dir, TRAIN_LOG), TRAIN_COLUMNS)
        eval_log = _CsvLog(os.path.join(self.out_dir, EVAL_LOG), EVAL_COLUMNS)
        bar = self._progress_bar()
        started = time.perf_counter()
        wall_at_start = self.wall_s
        steps_at_start, updates_at_start = self.env_steps, self.agent.updates
        perf = time.perf_counter
        try:
            while self.episodes_done < limit:
                epsilon = self.curriculum.epsilon_at(self.episodes_done)
                t0 = perf()
                actions = self.agent.act(state, mask, epsilon)
                if self.demos is not None:
                    actions = self._consult_teacher(env, state, mask, actions)
                t1 = perf()
                out = env.step(actions)
                t2 = perf()
                acted, acted_mask = self._executed(mask, actions, out)
                self.replay.add(self.nstep.push(state, acted_mask, acted, out.reward, out.next_state, out.next_mask,
                                                out.terminated, out.truncated))
                if self.labeller is not None:
                    self.aux_labels.add(*self.labeller.push(state, boxed_in_events(out), out.terminated | out.truncated))
                t3 = perf()
                self._timing["act_s"] += t1 - t0
                self._timing["env_s"] += t2 - t1
                self._timing["replay_s"] += t3 - t2
                self.env_steps += e
                ep_return += out.reward
                self._learn(e)
                state, mask = out.state, out.mask

                ended = np.flatnonzero(out.terminated | out.truncated)
                for i in ended:
                    self.wall_s = wall_at_start + time.perf_counter() - started
                    world = ep_worlds[i][int(out.world[i])].label if out.world is not None else ""
                    self._end_episode(int(i), out, ep_return[i], int(ep_stage[i]), epsilon, train_log, bar, world)
                    ep_return[i] = 0.0
                    self._after_episode(eval_log, train_log)
                    if self.episodes_done >= limit:
                        break
                if ended.size:
                    # The ended environments have already reset, under the settings in force
                    # during this step: their new episodes belong to that stage.
                    ep_stage[ended] = settings_stage
                    for i in ended:
                        ep_worlds[i] = settings.worlds
                    next_start = self.episodes_done + e
                    settings_stage = self.curriculum.locate(next_start)[0]
                    new_settings = self.curriculum.settings_at(next_start)
                    if new_settings != settings:
                        settings = new_settings
                        env.set_stage(settings)
            elapsed = time.perf_counter() - started
            self.wall_s = wall_at_start + elapsed
            finished = self.episodes_done >= self.total_episodes
            final = self._evaluate(eval_log, force_stage=len(self.curriculum.stages) - 1) if finished else None
        finally:
            bar.close()
            train_log.close()
            eval_log.close()
        self._save_checkpoint()
        model_path = self._export(os.path.join(self.out_dir, MODEL_FILE), final) if finished else None
        self._plot()
        t = self._timing
        summary = {
            "finished": finished, "episodes": self.episodes_done, "env_steps": self.env_steps,
            "updates": self.agent.updates, "wall_s": self.wall_s, "session_wall_s": elapsed,
            # Throughput of this session (training loop, evaluations included).
            "env_steps_per_s": (self.env_steps - steps_at_start) / max(elapsed, 1e-9),
            "updates_per_s": (self.agent.updates - updates_at_start) / max(elapsed, 1e-9),
            # Cost of each part over the whole run.
            "env_only_steps_per_s": self.env_steps / max(t["env_s"], 1e-9),
            "learn_only_updates_per_s": self.agent.updates / max(t["learn_s"], 1e-9),
            **{f"time_{k}": v for k, v in t.items()},
            "final_eval": final, "best_eval_success_rate": self.best_eval, "model": model_path,
        }
        if self.aux_labels is not None:
            summary["auxiliary"] = self.auxiliary_summary()
        if self.demos is not None:
            c = self.teacher_counts
            summary["teacher"] = {
                "kind": cfg.teacher.kind, **c, "agreement": c["agreed"] / max(c["labels"], 1),
                "mean_margin_loss": self._demo_loss_sum / max(self._demo_loss_count, 1),
            }
        with open(os.path.join(self.out_dir, SUMMARY), "w") as f:
            json.dump(summary, f, indent=2)
        return summary

    def auxiliary_summary(self, recent: int = 4096) -> dict:
        """Labels made and their positive share; the head's mean cross-entropy over the run, and at the end on the
        `recent` newest labelled states next to that of always answering their base rate (what a head that
        learned nothing would reach)."""
        buffer = self.aux_labels
        state, label = buffer.latest(recent)
        rate = float(label.mean()) if label.size else 0.0
        base = -(rate * math.log(rate) + (1 - rate) * math.log(1 - rate)) if 0 < rate < 1 else 0.0
        final = float("nan")
        if label.size:
            with torch.inference_mode():
                logits = self.agent.aux_head(self.agent.online.embed(self.agent._tensor(state))).squeeze(1)
                final = float(torch.nn.functional.binary_cross_entropy_with_logits(
                    logits, self.agent._tensor(label)).item())
        return {"horizon": self.config.auxiliary.horizon, "labels": buffer.added,
                "positive_share": buffer.positives / max(buffer.added, 1),
                "mean_loss": self._aux_loss_sum / max(self._aux_loss_count, 1),
                "recent_states": int(label.size), "recent_loss": final, "recent_base_rate_loss": base}

    def teacher_behaviour(self) -> float:
        t = self.config.teacher
        return t.behaviour_start + (t.behaviour_end - t.behaviour_start) * self.progress_fraction()

    def _consult_teacher(self, env: VecEnv, state: np.ndarray, mask: np.ndarray, actions: np.ndarray) -> np.ndarray:
        """Labels a random share of the current states with the teacher's action, keeps them for the margin loss
        and runs the teacher's action on some of them (DAgger's mixed behaviour). Returns the actions to run."""
        t = self.config.teacher
        n = actions.shape[0]
        # Both draws are made every step, so the random stream does not depend on the schedule's values.
        label_draw, behave_draw = self._teacher_rng.random(n), self._teacher_rng.random(n)
        ask = label_draw < t.label_fraction
        behave = ask & (behave_draw < self.teacher_behaviour())
        if not ask.any():
            return actions
        taught = env.teacher_actions(t.kind, ask, mask)
        got = np.flatnonzero(taught >= 0)
        if got.size == 0:
            return actions
        self.demos.add(state[got], mask[got], taught[got])
        self.teacher_counts["labels"] += int(got.size)
        self.teacher_counts["agreed"] += int(np.sum(actions[got] == taught[got]))
        run = got[behave[got]]
        if run.size:
            actions = np.array(actions, np.int64, copy=True)
            actions[run] = taught[run]
            self.teacher_counts["executed"] += int(run.size)
        return actions

    def _executed(self, mask: np.ndarray, actions: np.ndarray,
                  out: StepResult) -> tuple[np.ndarray, np.ndarray]:
        """The (action, mask) to store for each environment's step: the chosen ones, except where the environment
        ran the shield's escape instead (out.escaped). There the action is the one the environment reports as
        standing for the escape (out.executed_action: nearest in velocity), under a mask allowing only it, so
        that replay learns what the robot did."""
        if out.escaped is None or not out.escaped.any():
            return actions, mask
        if out.executed_action is None:
            raise EnvContractError("the environment ran its escape but did not say which action stands for it "
                                   "(executed_action)")
        escaped = np.flatnonzero(out.escaped)
        executed = out.executed_action[escaped]
        acted = np.array(actions, np.int64, copy=True)
        acted[escaped] = executed
        acted_mask = np.array(mask, bool, copy=True)
        acted_mask[escaped] = one_action_masks(executed, acted_mask.shape[1])
        return acted, acted_mask

    def _learn(self, new_transitions: int) -> None:
        rc = self.config.replay
        if len(self.replay) < rc.learning_starts:
            return
        self.update_credit += new_transitions
        t0 = time.perf_counter()
        self.agent.set_learning_rate(self.learning_rate())
        beta = self.beta()
        while self.update_credit >= rc.transitions_per_update:
            self.update_credit -= rc.transitions_per_update
            batch = self.replay.sample(rc.batch_size, beta)
            tc = self.config.teacher
            demo = (self.demos.sample(tc.batch_size)
                    if self.demos is not None and len(self.demos) >= tc.min_labels else None)
            ac = self.config.auxiliary
            aux = (self.aux_labels.sample(ac.batch_size)
                   if self.aux_labels is not None and len(self.aux_labels) >= ac.min_labels else None)
            result = self.agent.learn(batch, demo=demo, demo_weight=tc.loss_weight, margin=tc.margin,
                                      aux=aux, aux_weight=ac.loss_weight)
            if demo is not None:
                self._demo_loss_sum += result.demo_loss
                self._demo_loss_count += 1
            if aux is not None:
                self._aux_loss_sum += result.aux_loss
                self._aux_loss_count += 1
            self.replay.update_priorities(batch.indices, result.td_errors)
            self._loss_sum += result.loss
            self._q_sum += result.mean_q
            self._loss_count += 1
            if not math.isnan(result.sp_loss):
                self._sp_sum += result.sp_loss
                self._sp_count += 1
        self._timing["learn_s"] += time.perf_counter() - t0

    def _end_episode(self, i: int, out, ep_return: float, stage: int, epsilon: float, log: _CsvLog, bar,
                     world: str = "") -> None:
        outcome = int(out.outcome[i])
        self._recent_outcomes.append(outcome)
        if self._loss_count:
            loss, mean_q = self._loss_sum / self._loss_count, self._q_sum / self._loss_count
            self._last_loss = loss
            self._loss_sum = self._q_sum = 0.0
            self._loss_count = 0
        else:
            loss = mean_q = float("nan")
        sp_loss = self._sp_sum / self._sp_count if self._sp_count else float("nan")
        self._sp_sum, self._sp_count = 0.0, 0
        log.write({
            "episode": self.episodes_done, "stage": stage + 1, "stage_name": self.curriculum.stages[stage].name,
            "steps": int(out.episode_steps[i]), "env_steps": self.env_steps, "return": float(ep_return),
            "outcome": OUTCOME_NAMES.get(outcome, str(outcome)), "epsilon": float(epsilon), "loss": loss,
            "mean_q": mean_q, "lr": self.agent.learning_rate, "beta": self.beta(), "updates": self.agent.updates,
            "wall_s": self.wall_s, "world": world, "sp_loss": sp_loss,
        })
        self.episodes_done += 1
        bar.update(1)
        if self.progress and (self.episodes_done % 10 == 0 or self.episodes_done == self.total_episodes):
            recent = np.asarray(self._recent_outcomes)
            bar.set_postfix(stage=stage + 1, success=f"{np.mean(recent == OUTCOME_SUCCESS):.2f}",
                            eps=f"{epsilon:.2f}", loss=f"{self._last_loss:.3g}",
                            sps=f"{self.env_steps / max(self.wall_s, 1e-9):.0f}", refresh=False)

    def _after_episode(self, eval_log: _CsvLog, train_log: _CsvLog) -> None:
        n = self.episodes_done
        if n >= self.total_episodes:
            return  # the final evaluation, checkpoint and plots follow the loop
        ec, cc, lc = self.config.evaluation, self.config.checkpoint, self.config.log
        if ec.every_episodes and n % ec.every_episodes == 0:
            self._evaluate(eval_log)
        if cc.every_episodes and n % cc.every_episodes == 0:
            train_log.flush()
            self._save_checkpoint()
        if lc.plot_every_episodes and n % lc.plot_every_episodes == 0:
            train_log.flush()
            self._plot()

    # ---- evaluation --------------------------------------------------------------------

    def _evaluate(self, log: _CsvLog, force_stage: int | None = None) -> dict:
        """Greedy episodes on fresh environments with the fixed evaluation seed, under the
        current stage's settings at its end (the stage's hardest), or `force_stage`'s: the same
        fixed set of episodes at every evaluation of a stage (play_fixed_episodes)."""
        t0 = time.perf_counter()
        ec = self.config.evaluation
        stage = self.curriculum.locate(self.episodes_done)[0] if force_stage is None else force_stage
        quota = evaluation_quota(ec.episodes, ec.num_envs)
        env = self._env_factory(quota.size, ec.seed, self.config.perfect_info)
        env.set_stage(self.curriculum.stages[stage].settings(1.0))
        results = play_fixed_episodes(env, self.agent.greedy, quota)
        outcomes = np.array([r[0] for r in results])
        steps = np.array([r[2] for r in results], float)
        success = outcomes == OUTCOME_SUCCESS
        row = {
            "episode": self.episodes_done, "stage": stage + 1, "stage_name": self.curriculum.stages[stage].name,
            "episodes": len(results), "success_rate": float(success.mean()),
            "collision_rate": float(np.mean(outcomes == OUTCOME_COLLISION)),
            "timeout_rate": float(np.mean(outcomes == OUTCOME_TIMEOUT)),
            "mean_return": float(np.mean([r[1] for r in results])), "mean_steps": float(steps.mean()),
            "mean_success_time_s": float(steps[success].mean() * CONTROL_PERIOD_S) if success.any() else float("nan"),
            "wall_s": self.wall_s,
        }
        log.write(row)
        log.flush()
        self._timing["eval_s"] += time.perf_counter() - t0
        last_stage = stage == len(self.curriculum.stages) - 1
        if last_stage and row["success_rate"] > self.best_eval:
            self.best_eval = row["success_rate"]
            self._export(os.path.join(self.out_dir, BEST_MODEL_FILE), row)
        if last_stage and ec.keep_snapshots:
            snapshots = os.path.join(self.out_dir, SNAPSHOT_DIR)
            os.makedirs(snapshots, exist_ok=True)
            self._export(os.path.join(snapshots, f"ep{self.episodes_done:06d}.dqnw"), row)
        return row

    # ---- files -------------------------------------------------------------------------

    def _export(self, path: str, evaluation: dict) -> str:
        from .export import build_metadata, export_model  # noqa: PLC0415 - only needed here

        note = json.dumps({
            "seed": self.config.seed, "episodes": self.episodes_done, "env_steps": self.env_steps,
            "updates": self.agent.updates, "evaluation": {k: v for k, v in evaluation.items()
                                                          if isinstance(v, (int, float, str))},
        }, sort_keys=True)
        metadata = build_metadata(self.command, os.path.abspath(os.path.join(self.out_dir, CHECKPOINT)), note,
                                  self.provenance, self._state_parameters)
        export_model(copy.deepcopy(self.agent.online).cpu().eval(), path, self._normalization or {}, metadata)
        return path

    def _plot(self) -> None:
        from .plots import plot_run  # noqa: PLC0415 - matplotlib is slow to import

        plot_run(self.out_dir, curriculum=self.curriculum)

    def _save_checkpoint(self) -> None:
        replay_saved = False
        if self.config.checkpoint.save_replay:
            _atomic_torch_save({"episodes_done": self.episodes_done, "replay": self.replay.state_dict(),
                                "demos": self.demos.state_dict() if self.demos is not None else None,
                                "aux_labels": self.aux_labels.state_dict() if self.aux_labels is not None else None},
                               os.path.join(self.out_dir, REPLAY_FILE))
            replay_saved = True
        state = {
            "format": 1,
            "config": self.config.to_dict(),
            "agent": self.agent.state_dict(),
            # The online network's weights again at the top level, for the exporter's CLI.
            "model": self.agent.online.state_dict(),
            "model_class": type(self.agent.online).__name__,
            "model_config": self.agent.online.config() if hasattr(self.agent.online, "config") else {},
            "command": self.command,
            "provenance": dict(self.provenance),
            "state_parameters": self._state_parameters,
            "counters": {"episodes_done": self.episodes_done, "env_steps": self.env_steps,
                         "update_credit": self.update_credit, "wall_s": self.wall_s, "best_eval": self.best_eval},
            "timing": dict(self._timing),
            "recent_outcomes": list(self._recent_outcomes),
            "replay_saved": replay_saved,
            "teacher": {"counts": dict(self.teacher_counts), "rng": self._teacher_rng.bit_generator.state,
                        "loss_sum": self._demo_loss_sum, "loss_count": self._demo_loss_count},
            "auxiliary": {"loss_sum": self._aux_loss_sum, "loss_count": self._aux_loss_count},
            "normalization": self._normalization,
            "rng": {"python": random.getstate(), "numpy": _numpy_global_state(), "torch": torch.get_rng_state(),
                    "cuda": torch.cuda.get_rng_state_all() if torch.cuda.is_available() else None},
        }
        _atomic_torch_save(state, os.path.join(self.out_dir, CHECKPOINT))

    def _load_checkpoint(self, path: str) -> None:
        state = torch.load(path, map_location=self.device, weights_only=True)
        saved = state["config"]
        mine = self.config.to_dict()
        for key in ("seed", "num_envs", "gamma", "n_step", "scale", "curriculum", "replay", "teacher", "auxiliary",
                    "dovs", "reward", "model"):
            if key == "model" and key not in saved and mine[key] == asdict(ModelConfig()):
                continue  # a run from before the model section, resumed without one
            if key in ("teacher", "auxiliary") and key not in saved and not getattr(self.config, key).enabled:
                continue  # a run from before teachers / auxiliary heads existed, resumed without one
            if key in ("dovs", "reward") and key not in saved and not getattr(self.config, key):
                continue  # a run from before the dovs / reward section, resumed without one
            if saved.get(key) != mine.get(key):
                raise ConfigError(f"--resume: {key} differs from the one the run in {self.out_dir} was started with "
                                  f"({saved.get(key)!r} != {mine.get(key)!r}); resume with the run's own "
                                  f"{CONFIG_COPY}")
        self.agent.load_state_dict(state["agent"])
        c = state["counters"]
        self.episodes_done = int(c["episodes_done"])
        self.env_steps = int(c["env_steps"])
        self.update_credit = float(c["update_credit"])
        self.wall_s = float(c["wall_s"])
        self.best_eval = float(c["best_eval"])
        self._timing.update(state.get("timing", {}))
        self._recent_outcomes.extend(state.get("recent_outcomes", []))
        if state["replay_saved"]:
            replay_path = os.path.join(self.out_dir, REPLAY_FILE)
            saved_replay = torch.load(replay_path, weights_only=False)
            if saved_replay["episodes_done"] != self.episodes_done:
                raise ConfigError(f"--resume: {replay_path} belongs to episode {saved_replay['episodes_done']}, "
                                  f"the checkpoint to episode {self.episodes_done}")
            self.replay.load_state_dict(saved_replay["replay"])
            if self.demos is not None and saved_replay.get("demos") is not None:
                self.demos.load_state_dict(saved_replay["demos"])
            if self.aux_labels is not None and saved_replay.get("aux_labels") is not None:
                self.aux_labels.load_state_dict(saved_replay["aux_labels"])
        if "teacher" in state:
            self.teacher_counts.update(state["teacher"]["counts"])
            self._teacher_rng.bit_generator.state = state["teacher"]["rng"]
            self._demo_loss_sum = float(state["teacher"]["loss_sum"])
            self._demo_loss_count = int(state["teacher"]["loss_count"])
        if "auxiliary" in state:
            self._aux_loss_sum = float(state["auxiliary"]["loss_sum"])
            self._aux_loss_count = int(state["auxiliary"]["loss_count"])
        if state.get("provenance"):  # the run's own; a commit that changed since it started is named too
            now = self.provenance.get("source commit")
            self.provenance = dict(state["provenance"])
            if now and now != self.provenance.get("source commit"):
                self.provenance["source commit"] += f" (resumed at {now})"
        rng = state["rng"]
        random.setstate(rng["python"])
        _set_numpy_global_state(rng["numpy"])
        torch.set_rng_state(rng["torch"].cpu())
        if rng.get("cuda") is not None and torch.cuda.is_available():
            torch.cuda.set_rng_state_all(rng["cuda"])
        n = self.episodes_done
        _truncate_csv(os.path.join(self.out_dir, TRAIN_LOG), TRAIN_COLUMNS, lambda r: int(r["episode"]) < n)
        # A periodic evaluation at the checkpoint's episode ran before the checkpoint and is
        # kept; the final one (after the last episode) is redone by the resumed run.
        _truncate_csv(os.path.join(self.out_dir, EVAL_LOG), EVAL_COLUMNS,
                      lambda r: int(r["episode"]) < n or (int(r["episode"]) == n and n < self.total_episodes))

    def _progress_bar(self):
        from tqdm import tqdm  # noqa: PLC0415

        return tqdm(total=self.total_episodes, initial=self.episodes_done, unit="ep", dynamic_ncols=True,
                    disable=not self.progress, smoothing=0.05)

    @staticmethod
    def _seed_everything(seed: int) -> None:
        random.seed(seed)
        np.random.seed(seed % 2 ** 32)
        torch.manual_seed(seed)


# ---- command line --------------------------------------------------------------------------


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m dqn_dovs_py.train", description=__doc__.splitlines()[0])
    p.add_argument("--config", default=None, help="training configuration (default: config/curriculum.yaml, "
                                                   "or the run's own config.yaml with --resume)")
    p.add_argument("--out", required=True, help="run directory, e.g. runs/NAME")
    p.add_argument("--resume", action="store_true", help="continue the run in --out from its checkpoint")
    p.add_argument("--scale", type=float, default=None, help="multiply every stage's episode count (smoke runs)")
    p.add_argument("--seed", type=int, default=None, help="override the configuration's seed")
    p.add_argument("--num-envs", type=int, default=None, help="override the configuration's num_envs")
    p.add_argument("--dovs", default=None, metavar="NAME=VALUE,...",
                   help="DOVS parameters added to the configuration's `dovs` section, e.g. grid_contact_horizon=5 "
                        "(the graded grid, docs/dovs.md)")
    p.add_argument("--device", default="auto", choices=["auto", "cpu", "cuda"])
    p.add_argument("--threads", type=int, default=1,
                   help="torch.set_num_threads (default 1: the environments run their own C++ threads, and "
                        "PyTorch threads competing with them for few cores slow learning down many times; "
                        "0 keeps PyTorch's default)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar (e.g. in CI logs)")
    p.add_argument("--init-from", default=None, metavar="MODEL.dqnw",
                   help="start a fresh run from the network of this weight file (fine-tuning: new optimizer, "
                        "replay and counters; the file must have been trained with the environment's state "
                        "normalisation)")
    return p


def parse_dovs_option(text: str) -> dict[str, float]:
    """--dovs NAME=VALUE,... as {name: float}; ConfigError naming the item that is not NAME=NUMBER."""
    out: dict[str, float] = {}
    for item in text.split(","):
        name, sep, value = item.partition("=")
        try:
            number = float(value) if sep and name.strip() else math.nan
        except ValueError:
            number = math.nan
        if not math.isfinite(number):
            raise ConfigError(f"--dovs: {item!r} is not NAME=NUMBER")
        out[name.strip()] = number
    return out


def init_from_factory(path: str, grid_channels: int = 1, feature_count: int = FEATURE_COUNT, quantiles: int = 1,
                      cvar_alpha: float = 1.0, wall_rays: int = 0, person_tokens: int = 0,
                      route_points: int = 0) -> Callable[[], torch.nn.Module]:
    """A model factory returning the network stored in the weight file `path` (for --init-from). A network of one
    grid channel asked for more (`grid_channels`, dovs grid_channels) is widened: its first convolution reads the
    new channels with zero weights, so it starts as exactly the function it was (docs/training.md, "Grid
    channels"). Likewise a network of 8 features asked for the previous choice (`feature_count` 17, dovs
    previous_action): its feature stream reads the 9 new inputs with zero weights. A network of one quantile asked
    for more (`quantiles`, model.quantiles) gets a quantile head whose every quantile of action a starts at Q(a)
    (model.widen_quantiles): the same Q and action values; `cvar_alpha` is the model section's.

    The factory's `start_parameters()` gives the file's network's parameters by name, before any widening (the
    start network of L2-SP, agent.l2_sp_weight)."""
    from .export import (load_weights, model_from_weights, widen_grid_channels,  # noqa: PLC0415
                         widen_previous_action)
    from .model import widen_quantiles, widen_tokens, widened  # noqa: PLC0415

    weights = load_weights(path)  # read (and checked) once, before any training starts
    if weights.grid_channels != grid_channels and weights.grid_channels != 1:
        raise ConfigError(f"--init-from {path}: the network reads {weights.grid_channels} grid channels, the "
                          f"configuration's dovs grid_channels is {grid_channels}")
    if weights.feature_count != feature_count and weights.feature_count != FEATURE_COUNT:
        raise ConfigError(f"--init-from {path}: the network reads {weights.feature_count} feature inputs, the "
                          f"configuration's dovs previous_action gives {feature_count}")
    stored_quantiles = int(getattr(model_from_weights(weights), "quantiles", 1))
    if stored_quantiles not in (1, quantiles):
        raise ConfigError(f"--init-from {path}: the network has {stored_quantiles} quantile values per action, the "
                          f"configuration's model.quantiles is {quantiles}")

    def make() -> torch.nn.Module:
        model = model_from_weights(weights)
        if weights.grid_channels != grid_channels:
            model = widen_grid_channels(model, grid_channels)
        if weights.feature_count != feature_count:
            model = widen_previous_action(model)
        if (weights.wall_ray_count, weights.person_token_count) != (wall_rays, person_tokens):
            model = widen_tokens(model, wall_rays, person_tokens)  # new layers: the run's seeded initialisation
        if weights.route_point_count != route_points:
            if weights.route_point_count != 0:
                raise ConfigError(f"--init-from {path}: the network reads {weights.route_point_count} route points, "
                                  f"the configuration's dovs route_points is {route_points}")
            model = widened(model, route_points=route_points)  # the feature stream reads them with zero weights
        if stored_quantiles != quantiles:
            model = widen_quantiles(model, quantiles, cvar_alpha)
        elif quantiles > 1:
            model.cvar_alpha = float(cvar_alpha)  # how to act on the quantiles is the configuration's choice
        return model

    def start_parameters() -> dict[str, torch.Tensor]:
        return {name: p.detach().clone() for name, p in model_from_weights(weights).named_parameters()}

    make.start_parameters = start_parameters
    return make


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    argv_list = sys.argv[1:] if argv is None else argv
    try:
        if args.init_from and args.resume:
            raise ConfigError("--init-from starts a new run; --resume continues one from its own checkpoint")
        if args.resume:
            config_path = args.config or os.path.join(args.out, CONFIG_COPY)
        else:
            config_path = args.config or os.path.join(os.path.dirname(__file__), "..", "..", "config",
                                                      "curriculum.yaml")
        config = load_config(config_path)
        if args.scale is not None:
            config.scale = args.scale
        if args.seed is not None:
            config.seed = args.seed
        if args.num_envs is not None:
            config.num_envs = args.num_envs
        if args.dovs is not None:
            config.dovs = {**config.dovs, **parse_dovs_option(args.dovs)}
        message = config.validate()
        if message:
            raise ConfigError(message)
        model_factory = (init_from_factory(args.init_from, grid_channels_of(config.dovs), feature_count_of(config.dovs),
                                           config.model.quantiles, config.model.cvar_alpha, *tokens_of(config.dovs))
                         if args.init_from else None)
        # The configuration file and the options that change it (the seed is a key of its own).
        overrides = [f"--{name.replace('_', '-')} {getattr(args, name)}" for name in ("scale", "num_envs", "dovs")
                     if getattr(args, name) is not None]
        provenance = make_provenance(" ".join([repo_path(config_path)] + overrides), config.seed,
                                     init_from=args.init_from)
        trainer = Trainer(config, args.out, device=args.device, threads=args.threads, resume=args.resume,
                          model_factory=model_factory, progress=not args.no_progress,
                          command="python -m dqn_dovs_py.train " + " ".join(shlex.quote(a) for a in argv_list),
                          provenance=provenance,
                          start_parameters=model_factory.start_parameters() if model_factory is not None else None)
        summary = trainer.run()
    except (ConfigError, CurriculumError, DecisionConfigError, FileExistsError, FileNotFoundError, ImportError,
            WeightFileError, ProvenanceError) as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    final = summary["final_eval"]
    print(f"done: {summary['episodes']} episodes, {summary['env_steps']} env steps, {summary['updates']} updates "
          f"in {summary['wall_s']:.0f} s ({summary['env_steps_per_s']:.0f} env steps/s); final greedy evaluation "
          f"success {final['success_rate']:.2f}, collision {final['collision_rate']:.2f}, "
          f"timeout {final['timeout_rate']:.2f}; model {summary['model']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
