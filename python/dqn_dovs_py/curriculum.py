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
# World families of the simulator (include/dqn_dovs/sim/worlds.h); their other options are checked by the core.
WORLD_FAMILIES = ("room", "crowd", "corridor", "doorway", "clutter", "junction")


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
class WorldSpec:
    """One world of a stage's mixture: the options of `dqn_dovs_eval --world ... --sensor ... --people-model ...
    [--people-see-robot] --odom-noise ...`, drawn for an episode with probability weight / sum of weights."""

    # room (the paper's room of disc obstacles) or a building family holding the stage's obstacle count as people.
    world: str = "room"
    # LIDAR profile: sim, hokuyo, urg04lx, rplidar_a1.
    sensor: str = "sim"
    # How people move: social_force, orca, constant.
    people_model: str = "social_force"
    # People see the robot and give way (false: the robot is invisible to them, the hardest case).
    people_see_robot: bool = False
    # How people treat the robot: attentive=A,impassive=I,oblivious=O shares, or headline (docs/simulator.md, "People
    # who notice the robot"); "": every person oblivious (unless people_see_robot).
    people_mix: str = ""
    # Wheel-odometry drift: none, low, high.
    odom_noise: str = "none"
    # Worlds with walls: follow a route planned on the known walls and furniture (on, as the robot), or drive at the
    # goal (off).
    route: str = "on"
    # A people predictor file (models/people_predictor_tracks.dqnp): the moving obstacles the DOVS sees move on the arc
    # of their learned prediction, as `dqn_dovs_eval --predict-people` ("": their present velocity). A relative path
    # is taken from the directory training runs in.
    people_predictor: str = ""
    weight: float = 1.0

    @property
    def label(self) -> str:
        """Short name for logs: the family, then every option that differs from the defaults."""
        parts = [self.world]
        default = WorldSpec()
        for name in ("sensor", "people_model", "odom_noise"):
            if getattr(self, name) != getattr(default, name):
                parts.append(str(getattr(self, name)))
        if self.people_see_robot:
            parts.append("see_robot")
        if self.people_mix:
            parts.append(self.people_mix)
        if self.route != default.route:
            parts.append(f"route_{self.route}")
        if self.people_predictor:
            parts.append("predicted")
        return "/".join(parts)

    def options(self) -> dict[str, str]:
        """The core's world_options mapping (VecEnv.set_worlds)."""
        options = {"world": self.world, "sensor": self.sensor, "people_model": self.people_model,
                   "people_see_robot": "true" if self.people_see_robot else "false", "odom_noise": self.odom_noise,
                   "route": self.route}
        if self.people_predictor:
            options["people_predictor"] = self.people_predictor
        if self.people_mix:
            options["people_mix"] = self.people_mix
        return options


ROOM_ONLY = (WorldSpec(),)


@dataclass(frozen=True)
class StageSettings:
    """What the environment is told for the episodes reset from now on (VecEnv.set_stage)."""

    goal_distance_min: float
    goal_distance_max: float
    obstacles_min: int
    obstacles_max: int
    obstacle_type: str
    # The worlds episodes are drawn from (world families take the obstacle count as their number of people; their
    # own generator places start and goal, so the goal distances apply to the room only).
    worlds: tuple[WorldSpec, ...] = ROOM_ONLY


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
    # The stage's mixture of worlds (default: the curriculum's `worlds`, else the paper's room only).
    worlds: tuple[WorldSpec, ...] = ROOM_ONLY

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
            worlds=self.worlds,
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
        unknown = set(config) - {"any_goal_distance_m", "epsilon_decay", "stages", "worlds"}
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
        worlds = _parse_worlds(config["worlds"], "curriculum.worlds") if "worlds" in config else ROOM_ONLY
        stages = tuple(_parse_stage(raw, i, any_range, worlds) for i, raw in enumerate(raw_stages))
        return Curriculum(stages=stages, epsilon_decay=decay)


_STAGE_FIELDS = {"name", "episodes", "goal_distance_m", "goal_distance_start_m", "obstacles", "obstacles_start",
                 "obstacle_type", "epsilon", "worlds"}


def _parse_worlds(raw, where: str) -> tuple[WorldSpec, ...]:
    """A list of world mappings (WorldSpec's fields); every field but `world` is optional."""
    if not isinstance(raw, list) or not raw:
        raise CurriculumError(f"{where}: expected a non-empty list of worlds, e.g. [{{world: room}}, "
                              "{world: crowd, sensor: urg04lx}]")
    known = {f for f in WorldSpec.__dataclass_fields__}
    out = []
    for k, item in enumerate(raw):
        at = f"{where}[{k}]"
        if not isinstance(item, dict):
            raise CurriculumError(f"{at}: expected a mapping with at least 'world'")
        unknown = set(item) - known
        if unknown:
            raise CurriculumError(f"{at}: unknown field(s) {sorted(unknown)} (known: {sorted(known)})")
        if item.get("world") not in WORLD_FAMILIES:
            raise CurriculumError(f"{at}.world must be one of {list(WORLD_FAMILIES)}, got {item.get('world')!r}")
        if "route" in item and item["route"] not in ("on", "off"):
            raise CurriculumError(f"{at}.route must be 'on' or 'off', got {item['route']!r}")
        for name in ("sensor", "people_model", "odom_noise", "people_predictor", "people_mix"):
            if name in item and not (isinstance(item[name], str) and item[name]):
                raise CurriculumError(f"{at}.{name} must be a non-empty string, got {item[name]!r}")
        if "people_see_robot" in item and not isinstance(item["people_see_robot"], bool):
            raise CurriculumError(f"{at}.people_see_robot must be true or false, got {item['people_see_robot']!r}")
        weight = item.get("weight", 1.0)
        if isinstance(weight, bool) or not isinstance(weight, (int, float)) or not (
                math.isfinite(weight) and weight > 0):
            raise CurriculumError(f"{at}.weight must be a positive number, got {weight!r}")
        out.append(WorldSpec(**{**item, "weight": float(weight)}))
    return tuple(out)


def _parse_stage(raw: dict, index: int, any_range: tuple[float, float],
                 default_worlds: tuple[WorldSpec, ...] = ROOM_ONLY) -> Stage:
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

    worlds = _parse_worlds(raw["worlds"], f"{where}.worlds") if "worlds" in raw else default_worlds
    return Stage(name=name, episodes=episodes, goal_distance_m=goal, goal_distance_start_m=goal_start,
                 obstacles=obstacles, obstacles_start=obstacles_start, obstacle_type=obstacle_type, epsilon=epsilon,
                 worlds=worlds)


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
