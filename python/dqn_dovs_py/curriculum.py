"""The training curriculum: stages of episodes with their goal distances, obstacles and
exploration (the paper's Table "Curriculum learning stages"; config/curriculum.yaml).

Within a stage the goal-distance range and the obstacle-count range may grow linearly
from a start range to an end range ("progressively increased inside some stages");
the environment then draws each new episode's goal distance and obstacle count
uniformly from the current range. Epsilon either decays linearly over the stage
(new task: explore again) or stays fixed (consolidation of a known task).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

OBSTACLE_TYPES = ("none", "static", "dynamic", "both")


class CurriculumError(ValueError):
    """A malformed curriculum; the message names the stage and the field."""


@dataclass(frozen=True)
class EpsilonDecay:
    """Linear epsilon decay used by stages whose epsilon is `decay`."""

    # Epsilon at the first episode of a decaying stage.
    start: float = 1.0
    # Epsilon reached after `fraction` of the stage's episodes, and kept until its end.
    end: float = 0.05
    # Share of the stage's episodes over which epsilon falls from start to end.
    fraction: float = 1.0

    def validate(self) -> str:
        if not (0.0 <= self.end <= self.start <= 1.0):
            return f"epsilon_decay: need 0 <= end <= start <= 1, got start {self.start}, end {self.end}"
        if not (0.0 < self.fraction <= 1.0):
            return f"epsilon_decay.fraction must be in (0, 1], got {self.fraction}"
        return ""


@dataclass(frozen=True)
class StageSettings:
    """What the environment is told for the episodes reset from now on (VecEnv.set_stage)."""

    goal_distance_min: float
    goal_distance_max: float
    obstacles_min: int
    obstacles_max: int
    obstacle_type: str


@dataclass(frozen=True)
class Stage:
    """One curriculum stage."""

    # Short name for logs and plots.
    name: str
    # Episodes (completed, over all environments) that this stage lasts.
    episodes: int
    # Goal distance range [min, max] in metres at the end of the stage.
    goal_distance_m: tuple[float, float]
    # Goal distance range at the start of the stage (equal to goal_distance_m: no ramp).
    goal_distance_start_m: tuple[float, float]
    # Obstacle count range [min, max] at the end of the stage.
    obstacles: tuple[int, int]
    # Obstacle count range at the start of the stage (equal to obstacles: no ramp).
    obstacles_start: tuple[int, int]
    # none | static | dynamic | both (both: each obstacle is dynamic with the environment's own probability).
    obstacle_type: str
    # None: epsilon decays over the stage (EpsilonDecay); a number: fixed epsilon.
    epsilon: float | None

    def settings(self, progress: float) -> StageSettings:
        """Environment settings after `progress` (0..1) of this stage's episodes."""
        p = min(max(progress, 0.0), 1.0)

        def lerp(a: float, b: float) -> float:
            return a + (b - a) * p

        return StageSettings(
            goal_distance_min=lerp(self.goal_distance_start_m[0], self.goal_distance_m[0]),
            goal_distance_max=lerp(self.goal_distance_start_m[1], self.goal_distance_m[1]),
            obstacles_min=int(math.floor(lerp(self.obstacles_start[0], self.obstacles[0]) + 0.5)),
            obstacles_max=int(math.floor(lerp(self.obstacles_start[1], self.obstacles[1]) + 0.5)),
            obstacle_type=self.obstacle_type,
        )

    def epsilon_at(self, progress: float, decay: EpsilonDecay) -> float:
        if self.epsilon is not None:
            return self.epsilon
        p = min(max(progress / decay.fraction, 0.0), 1.0)
        return decay.start + (decay.end - decay.start) * p


@dataclass(frozen=True)
class Curriculum:
    stages: tuple[Stage, ...]
    epsilon_decay: EpsilonDecay = EpsilonDecay()

    @property
    def total_episodes(self) -> int:
        return sum(s.episodes for s in self.stages)

    def locate(self, episode: int) -> tuple[int, float]:
        """(stage index, progress within it in [0, 1)) for the 0-based global episode index.
        Episodes past the end belong to the last stage at progress 1."""
        start = 0
        for i, stage in enumerate(self.stages):
            if episode < start + stage.episodes:
                return i, (episode - start) / stage.episodes
            start += stage.episodes
        return len(self.stages) - 1, 1.0

    def stage_start(self, index: int) -> int:
        """Global episode index at which stage `index` begins."""
        return sum(s.episodes for s in self.stages[:index])

    def settings_at(self, episode: int) -> StageSettings:
        i, progress = self.locate(episode)
        return self.stages[i].settings(progress)

    def epsilon_at(self, episode: int) -> float:
        i, progress = self.locate(episode)
        return self.stages[i].epsilon_at(progress, self.epsilon_decay)

    def scaled(self, scale: float) -> "Curriculum":
        """Every stage's episode count times `scale` (at least 1): short smoke runs keep the
        shape of the full curriculum."""
        if not (scale > 0 and math.isfinite(scale)):
            raise CurriculumError(f"curriculum scale must be a positive number, got {scale}")
        return replace(self, stages=tuple(replace(s, episodes=max(1, int(round(s.episodes * scale))))
                                          for s in self.stages))

    @staticmethod
    def from_dict(config: dict) -> "Curriculum":
        """Parses the `curriculum` section of the training configuration (see config/curriculum.yaml)."""
        if not isinstance(config, dict):
            raise CurriculumError("curriculum: expected a mapping with 'stages'")
        unknown = set(config) - {"any_goal_distance_m", "epsilon_decay", "stages"}
        if unknown:
            raise CurriculumError(f"curriculum: unknown field(s) {sorted(unknown)}")
        any_range = _pair(config.get("any_goal_distance_m", [1.0, 12.0]), float, "curriculum.any_goal_distance_m")
        decay_cfg = config.get("epsilon_decay", {}) or {}
        unknown = set(decay_cfg) - {"start", "end", "fraction"}
        if unknown:
            raise CurriculumError(f"curriculum.epsilon_decay: unknown field(s) {sorted(unknown)}")
        decay = EpsilonDecay(**{k: float(v) for k, v in decay_cfg.items()})
        error = decay.validate()
        if error:
            raise CurriculumError("curriculum." + error)
        raw_stages = config.get("stages")
        if not isinstance(raw_stages, list) or not raw_stages:
            raise CurriculumError("curriculum.stages: expected a non-empty list of stages")
        stages = tuple(_parse_stage(raw, i, any_range) for i, raw in enumerate(raw_stages))
        return Curriculum(stages=stages, epsilon_decay=decay)


_STAGE_FIELDS = {"name", "episodes", "goal_distance_m", "goal_distance_start_m", "obstacles", "obstacles_start",
                 "obstacle_type", "epsilon"}


def _parse_stage(raw: dict, index: int, any_range: tuple[float, float]) -> Stage:
    where = f"curriculum.stages[{index}]"
    if not isinstance(raw, dict):
        raise CurriculumError(f"{where}: expected a mapping")
    unknown = set(raw) - _STAGE_FIELDS
    if unknown:
        raise CurriculumError(f"{where}: unknown field(s) {sorted(unknown)}")
    for required in ("episodes", "goal_distance_m", "obstacles", "obstacle_type", "epsilon"):
        if required not in raw:
            raise CurriculumError(f"{where}.{required}: missing")
    name = str(raw.get("name", f"stage{index + 1}"))
    where = f"curriculum.stages[{index}] ({name})"

    episodes = raw["episodes"]
    if not isinstance(episodes, int) or isinstance(episodes, bool) or episodes < 1:
        raise CurriculumError(f"{where}.episodes must be a positive integer, got {episodes!r}")

    def distance(value, field):
        pair = any_range if value == "any" else _pair(value, float, f"{where}.{field}")
        if not (0.0 < pair[0] <= pair[1]):
            raise CurriculumError(f"{where}.{field}: need 0 < min <= max, got {list(pair)}")
        return pair

    goal = distance(raw["goal_distance_m"], "goal_distance_m")
    goal_start = distance(raw.get("goal_distance_start_m", raw["goal_distance_m"]), "goal_distance_start_m")

    def count(value, field):
        pair = (value, value) if isinstance(value, int) and not isinstance(value, bool) else \
            _pair(value, int, f"{where}.{field}")
        if not (0 <= pair[0] <= pair[1]):
            raise CurriculumError(f"{where}.{field}: need 0 <= min <= max, got {list(pair)}")
        return pair

    obstacles = count(raw["obstacles"], "obstacles")
    obstacles_start = count(raw.get("obstacles_start", raw["obstacles"]), "obstacles_start")

    obstacle_type = raw["obstacle_type"]
    if obstacle_type not in OBSTACLE_TYPES:
        raise CurriculumError(f"{where}.obstacle_type must be one of {list(OBSTACLE_TYPES)}, got {obstacle_type!r}")
    if obstacle_type == "none" and max(obstacles[1], obstacles_start[1]) > 0:
        raise CurriculumError(f"{where}.obstacles must be 0 when obstacle_type is 'none'")

    epsilon = raw["epsilon"]
    if epsilon == "decay":
        epsilon = None
    elif isinstance(epsilon, (int, float)) and not isinstance(epsilon, bool) and 0.0 <= float(epsilon) <= 1.0:
        epsilon = float(epsilon)
    else:
        raise CurriculumError(f"{where}.epsilon must be 'decay' or a number in [0, 1], got {epsilon!r}")

    return Stage(name=name, episodes=episodes, goal_distance_m=goal, goal_distance_start_m=goal_start,
                 obstacles=obstacles, obstacles_start=obstacles_start, obstacle_type=obstacle_type, epsilon=epsilon)


def _pair(value, kind, where):
    if not isinstance(value, (list, tuple)) or len(value) != 2:
        raise CurriculumError(f"{where}: expected [min, max], got {value!r}")
    try:
        a, b = kind(value[0]), kind(value[1])
    except (TypeError, ValueError):
        raise CurriculumError(f"{where}: expected two numbers, got {value!r}") from None
    if kind is int and (a != value[0] or b != value[1]):
        raise CurriculumError(f"{where}: expected two integers, got {value!r}")
    if kind is float and not (math.isfinite(a) and math.isfinite(b)):
        raise CurriculumError(f"{where}: values must be finite, got {value!r}")
    return a, b
