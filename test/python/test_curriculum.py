"""The curriculum files and their schedule: the paper's table (config/curriculum_paper.yaml), the rebalanced
default (config/curriculum.yaml), ramps, epsilon, scaling, errors."""

import copy
import os

import pytest
import yaml

from dqn_dovs_py.curriculum import Curriculum, CurriculumError

CONFIG_DIR = os.path.join(os.path.dirname(__file__), "..", "..", "config")
CONFIG = os.path.join(CONFIG_DIR, "curriculum_paper.yaml")
DEFAULT_CONFIG = os.path.join(CONFIG_DIR, "curriculum.yaml")


@pytest.fixture(scope="module")
def raw():
    with open(CONFIG) as f:
        return yaml.safe_load(f)["curriculum"]


@pytest.fixture(scope="module")
def curriculum(raw):
    return Curriculum.from_dict(raw)


def test_config_file_is_the_papers_table(curriculum):
    table = [(1000, "decay", "none"), (1000, "decay", "static"), (1000, 0.05, "static"),
             (1000, "decay", "dynamic"), (1000, 0.05, "dynamic"), (2500, 0.05, "both")]
    assert len(curriculum.stages) == 6
    for stage, (episodes, epsilon, kind) in zip(curriculum.stages, table):
        assert stage.episodes == episodes
        assert stage.obstacle_type == kind
        assert stage.epsilon == (None if epsilon == "decay" else epsilon)
    assert curriculum.total_episodes == 7500
    first = curriculum.stages[0]
    assert first.obstacles == (0, 0) and first.goal_distance_start_m == (1.0, 1.5)
    for stage in curriculum.stages[1:]:
        assert stage.obstacles == (0, 12)
        assert stage.goal_distance_m == stage.goal_distance_start_m == (1.0, 12.0)


def test_goal_distance_grows_from_one_metre_to_any(curriculum):
    start = curriculum.settings_at(0)
    assert (start.goal_distance_min, start.goal_distance_max) == (1.0, 1.5)
    assert start.obstacles_max == 0 and start.obstacle_type == "none"
    mid = curriculum.settings_at(500)
    assert mid.goal_distance_max == pytest.approx(1.5 + 10.5 * 0.5)
    assert curriculum.settings_at(999).goal_distance_max == pytest.approx(1.5 + 10.5 * 999 / 1000)


def test_obstacle_count_ramps_within_stage_and_is_random_in_last(curriculum):
    assert curriculum.settings_at(1000).obstacles_max == 0
    assert curriculum.settings_at(1500).obstacles_max == 6
    assert curriculum.settings_at(1999).obstacles_max == 12
    assert curriculum.settings_at(2000).obstacles_max == 0  # the next "0 to 12" stage ramps again
    last = curriculum.settings_at(5000)
    assert (last.obstacles_min, last.obstacles_max, last.obstacle_type) == (0, 12, "both")
    assert curriculum.settings_at(7499) == last


def test_epsilon_decays_in_new_tasks_and_is_fixed_otherwise(curriculum):
    assert curriculum.epsilon_at(0) == pytest.approx(1.0)
    assert curriculum.epsilon_at(500) == pytest.approx(1.0 - 0.95 * 0.5)
    assert curriculum.epsilon_at(999) == pytest.approx(1.0 - 0.95 * 0.999)
    assert curriculum.epsilon_at(1000) == pytest.approx(1.0)  # stage 2 is a new task
    assert curriculum.epsilon_at(2500) == 0.05
    assert curriculum.epsilon_at(3000) == pytest.approx(1.0)
    assert curriculum.epsilon_at(7000) == 0.05
    assert curriculum.epsilon_at(10 ** 6) == 0.05  # past the end: last stage


def test_decay_fraction_ends_decay_early(raw):
    cfg = copy.deepcopy(raw)
    cfg["epsilon_decay"] = {"start": 1.0, "end": 0.1, "fraction": 0.5}
    c = Curriculum.from_dict(cfg)
    assert c.epsilon_at(250) == pytest.approx(0.55)
    assert c.epsilon_at(600) == pytest.approx(0.1)


def test_locate_and_stage_start(curriculum):
    assert curriculum.locate(0) == (0, 0.0)
    assert curriculum.locate(1000) == (1, 0.0)
    assert curriculum.locate(6250) == (5, 0.5)
    assert curriculum.stage_start(5) == 5000


def test_scale_shrinks_every_stage_and_keeps_at_least_one(curriculum):
    small = curriculum.scaled(0.01)
    assert [s.episodes for s in small.stages] == [10, 10, 10, 10, 10, 25]
    tiny = curriculum.scaled(1e-6)
    assert all(s.episodes == 1 for s in tiny.stages)
    assert small.stages[1].obstacles == (0, 12)
    with pytest.raises(CurriculumError, match="scale"):
        curriculum.scaled(0)


@pytest.mark.parametrize("field,value,message", [
    ("episodes", 0, r"stages\[1\] \(static\)\.episodes must be a positive integer"),
    ("obstacle_type", "moving", r"obstacle_type must be one of"),
    ("epsilon", 1.5, r"epsilon must be 'decay' or a number"),
    ("obstacles", [5, 2], r"obstacles: need 0 <= min <= max"),
    ("obstacles", [0, 2.5], r"obstacles: expected two integers"),
    ("goal_distance_m", [3.0, 1.0], r"goal_distance_m: need 0 < min <= max"),
    ("goal_distance_m", [1.0, float("nan")], r"goal_distance_m: values must be finite"),
    ("colour", "red", r"unknown field\(s\) \['colour'\]"),
])
def test_bad_stage_fields_are_named(raw, field, value, message):
    cfg = copy.deepcopy(raw)
    cfg["stages"][1][field] = value
    with pytest.raises(CurriculumError, match=message):
        Curriculum.from_dict(cfg)


def test_missing_field_and_type_none_with_obstacles_are_errors(raw):
    cfg = copy.deepcopy(raw)
    del cfg["stages"][2]["epsilon"]
    with pytest.raises(CurriculumError, match=r"stages\[2\]\.epsilon: missing"):
        Curriculum.from_dict(cfg)
    cfg = copy.deepcopy(raw)
    cfg["stages"][0]["obstacles"] = 3
    with pytest.raises(CurriculumError, match="must be 0 when obstacle_type is 'none'"):
        Curriculum.from_dict(cfg)
    with pytest.raises(CurriculumError, match="non-empty list"):
        Curriculum.from_dict({"stages": []})


def load_yaml(path):
    with open(path) as f:
        return yaml.safe_load(f)


def test_default_curriculum_is_the_papers_stages_rebalanced():
    """Epsilon decays over about 30 % of a decaying stage, the hardest stage is longer than the paper's, goals are
    at least 4 m away as in the evaluation episodes; everything outside `curriculum` is the paper file's."""
    paper_file, default_file = load_yaml(CONFIG), load_yaml(DEFAULT_CONFIG)
    assert {k: v for k, v in default_file.items() if k != "curriculum"} == \
        {k: v for k, v in paper_file.items() if k != "curriculum"}
    paper, default = Curriculum.from_dict(paper_file["curriculum"]), Curriculum.from_dict(default_file["curriculum"])
    assert default.epsilon_decay.fraction == pytest.approx(0.3)
    assert (default.epsilon_decay.start, default.epsilon_decay.end) == (1.0, 0.05)
    # Stage 2 (static, decaying) explores for its first 300 episodes, then practises at 0.05.
    assert default.epsilon_at(1000) == pytest.approx(1.0)
    assert default.epsilon_at(1150) == pytest.approx(1.0 - 0.95 * 0.5)
    assert default.epsilon_at(1300) == pytest.approx(0.05)
    assert default.epsilon_at(1999) == pytest.approx(0.05)
    # Same stages in the same order; only the last (the hardest: both kinds of obstacles) is longer.
    assert [(s.name, s.obstacle_type, s.epsilon, s.obstacles, s.obstacles_start) for s in default.stages] == \
        [(s.name, s.obstacle_type, s.epsilon, s.obstacles, s.obstacles_start) for s in paper.stages]
    assert [s.episodes for s in default.stages[:-1]] == [s.episodes for s in paper.stages[:-1]]
    assert default.stages[-1].episodes > paper.stages[-1].episodes
    assert default.stages[-1].episodes >= 0.4 * default.total_episodes
    # Goals like the evaluation's (data/scenarios/README.md, dqn_dovs_eval --generate): at least 4 m.
    for stage in default.stages[1:]:
        assert stage.goal_distance_m == stage.goal_distance_start_m == (4.0, 12.0)
    first = default.stages[0]
    assert first.goal_distance_start_m == (1.0, 1.5) and first.goal_distance_m == (4.0, 12.0)
    assert default.settings_at(default.total_episodes - 1).goal_distance_min == 4.0


def test_worlds_curriculum_is_the_default_with_people_in_its_dynamic_stages():
    """config/curriculum_worlds.yaml: the default's stages and hyper-parameters; the room alone while the network
    learns goals and static obstacles, then a mixture of the room and every family with walking people, each seen
    through the learned prediction the robot runs (a file that exists)."""
    default_file = load_yaml(DEFAULT_CONFIG)
    worlds_file = load_yaml(os.path.join(CONFIG_DIR, "curriculum_worlds.yaml"))
    assert {k: v for k, v in worlds_file.items() if k != "curriculum"} == \
        {k: v for k, v in default_file.items() if k != "curriculum"}
    default = Curriculum.from_dict(default_file["curriculum"])
    worlds = Curriculum.from_dict(worlds_file["curriculum"])
    same = ("name", "episodes", "goal_distance_m", "goal_distance_start_m", "obstacles", "obstacles_start",
            "obstacle_type", "epsilon")
    assert [tuple(getattr(s, f) for f in same) for s in worlds.stages] == \
        [tuple(getattr(s, f) for f in same) for s in default.stages]
    assert worlds.epsilon_decay == default.epsilon_decay
    repo = os.path.join(CONFIG_DIR, "..")
    for stage in worlds.stages:
        families = {w.world for w in stage.worlds}
        if stage.obstacle_type in ("none", "static"):
            assert families == {"room"}, stage.name
            continue
        assert families == {"room", "crowd", "corridor", "clutter", "doorway", "junction"}, stage.name
        assert {w.sensor for w in stage.worlds} >= {"sim", "urg04lx", "rplidar_a1"}
        for w in stage.worlds:
            if w.world == "room":
                assert not w.people_predictor  # the paper's discs are not people
            else:
                assert os.path.isfile(os.path.join(repo, w.people_predictor)), w.label
