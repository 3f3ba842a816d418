"""Training across worlds: the environment's mixture of worlds (VecEnv.set_worlds), the curriculum's `worlds`
and the trainer's log of which world each episode ran in."""

from __future__ import annotations

import csv
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
import yaml

from dqn_dovs_py.curriculum import Curriculum, CurriculumError, WorldSpec
from dqn_dovs_py.decision_config import load_shield_parameters
from dqn_dovs_py.env import VecEnv

ROOT = Path(__file__).resolve().parents[2]
CROWD = {"world": "crowd", "sensor": "urg04lx"}


def _roll(env, steps: int) -> list[tuple]:
    """`steps` steps of action 0 ("keep"); what each step returned, for comparisons."""
    n = env.num_envs
    out = []
    for _ in range(steps):
        r = env.step(np.zeros(n, dtype=np.int64))
        out.append((r["state"].tobytes(), r["reward"].tobytes(), r["outcome"].tobytes()))
    return out


def _ended_worlds(env, steps: int) -> Counter:
    """The world index of every episode that ended within `steps` steps of action 0."""
    n = env.num_envs
    ended = Counter()
    for _ in range(steps):
        r = env.step(np.zeros(n, dtype=np.int64))
        for w, t, u in zip(r["world"], r["terminated"], r["truncated"]):
            if t or u:
                ended[int(w)] += 1
    return ended


def test_a_single_world_set_later_replays_the_world_given_at_construction(core):
    a = core.VecEnv(2, 77, threads=1, world_options=CROWD)
    b = core.VecEnv(2, 77, threads=1)
    b.set_worlds([CROWD], [5.0])
    for env in (a, b):
        env.set_stage(4.0, 8.0, 5, 8, "both")
    assert a.reset()[0].tobytes() == b.reset()[0].tobytes()
    assert _roll(a, 60) == _roll(b, 60)


def test_a_mixture_draws_every_world_by_weight_and_by_seed(core):
    worlds = [{"world": "room"}, CROWD, {"world": "clutter", "odom_noise": "low"}]
    counts = []
    for _ in range(2):
        env = core.VecEnv(4, 5, threads=2)
        env.set_stage(4.0, 8.0, 3, 6, "both")
        env.set_worlds(worlds, [1.0, 1.0, 6.0])
        env.reset()
        counts.append(_ended_worlds(env, 400))
    assert counts[0] == counts[1], "the same seed must draw the same worlds"
    c = counts[0]
    assert set(c) == {0, 1, 2}, f"every world is drawn: {dict(c)}"
    assert c[2] > c[0] + c[1], f"the world of weight 6 of 8 is drawn most: {dict(c)}"


def test_a_running_episode_finishes_in_its_own_world(core):
    env = core.VecEnv(1, 3, threads=1, world_options=CROWD)
    env.set_stage(4.0, 8.0, 6, 6, "both")
    env.reset()
    env.set_worlds([{"world": "room"}, {"world": "corridor"}], [1.0, 1.0])
    first = env.step(np.zeros(1, dtype=np.int64))
    assert int(first["world"][0]) == 0  # the crowd episode, the only world of the mixture it began under
    assert not (first["terminated"][0] or first["truncated"][0])


@pytest.mark.parametrize("worlds, weights, message", [
    ([], [], "at least one world"),
    ([{"world": "room"}], [1.0, 2.0], "2 weights for 1 worlds"),
    ([{"world": "room"}, {"world": "crowd"}], [1.0, 0.0], "world 1: weight must be finite and positive"),
    ([{"world": "room"}, {"world": "crowd", "sensor": "sonar"}], [1.0, 1.0], "world 1: .*lidar profile 'sonar'"),
    ([{"world": "room", "planet": "mars"}], [1.0], "world 0: unknown key 'planet'"),
    ([{"world": "crowd", "people_predictor": "/nonexistent/p.dqnp"}], [1.0],
     "world 0: people_predictor: .*/nonexistent/p.dqnp"),
])
def test_bad_mixtures_are_refused_naming_the_world(core, worlds, weights, message):
    env = core.VecEnv(1, 1)
    with pytest.raises(ValueError, match=message):
        env.set_worlds(worlds, weights)


def test_a_world_with_a_people_predictor_gives_the_dovs_its_predicted_arcs(core):
    """The same crowd episodes with and without the learned prediction: the states the network sees differ (a track
    without a history is walked back at its present velocity, so even the first decisions are predicted); in the
    paper's room they do not."""
    predicted = dict(CROWD, people_predictor=str(ROOT / "models" / "people_predictor_tracks.dqnp"))
    runs = []
    for world in (CROWD, predicted):
        env = core.VecEnv(2, 41, threads=1, world_options=world)
        env.set_stage(4.0, 8.0, 10, 10, "both")
        env.reset()
        runs.append(_roll(env, 25))
    differing = sum(a[0] != b[0] for a, b in zip(*runs))
    assert differing >= 10, f"the predicted arcs change what the network sees ({differing} of 25 steps differ)"
    # The prediction is of people: the paper's room of discs (no legs to pair) runs as without it.
    room = []
    for world in ({"world": "room"}, {"world": "room", "people_predictor": predicted["people_predictor"]}):
        env = core.VecEnv(2, 41, threads=1, world_options=world)
        env.set_stage(4.0, 8.0, 10, 10, "both")
        env.reset()
        room.append(_roll(env, 25))
    assert room[0] == room[1]
    spec = WorldSpec(world="crowd", people_predictor="models/p.dqnp")
    assert spec.options()["people_predictor"] == "models/p.dqnp" and spec.label == "crowd/predicted"
    assert "people_predictor" not in WorldSpec(world="crowd").options()


def _curriculum(**extra) -> dict:
    stage = {"name": "s", "episodes": 10, "goal_distance_m": [4.0, 8.0], "obstacles": [2, 4],
             "obstacle_type": "both", "epsilon": 0.05}
    stage.update(extra.pop("stage", {}))
    return {"stages": [stage, dict(stage, name="t")], **extra}


def test_curriculum_worlds_default_to_the_room_and_stages_may_override():
    assert Curriculum.from_dict(_curriculum()).settings_at(0).worlds == (WorldSpec(),)
    c = Curriculum.from_dict(_curriculum(worlds=[{"world": "crowd", "sensor": "urg04lx", "weight": 2}]))
    assert c.settings_at(0).worlds == (WorldSpec(world="crowd", sensor="urg04lx", weight=2.0),)
    assert c.settings_at(0).worlds[0].label == "crowd/urg04lx"
    c = Curriculum.from_dict(_curriculum(worlds=[{"world": "doorway", "route": "off"}]))
    assert c.settings_at(0).worlds[0].label == "doorway/route_off"
    assert c.settings_at(0).worlds[0].options()["route"] == "off"
    c = Curriculum.from_dict({"worlds": [{"world": "clutter"}],
                              "stages": [_curriculum()["stages"][0],
                                         dict(_curriculum()["stages"][0], worlds=[{"world": "corridor"}])]})
    assert [w.world for w in c.settings_at(0).worlds] == ["clutter"]
    assert [w.world for w in c.settings_at(15).worlds] == ["corridor"]


@pytest.mark.parametrize("worlds, message", [
    ([], "non-empty list of worlds"),
    ([{"sensor": "sim"}], r"worlds\[0\].world must be one of"),
    ([{"world": "maze"}], r"worlds\[0\].world must be one of"),
    ([{"world": "room", "wieght": 2}], r"unknown field\(s\) \['wieght'\]"),
    ([{"world": "room", "weight": 0}], r"worlds\[0\].weight must be a positive number"),
    ([{"world": "room", "people_see_robot": "yes"}], "people_see_robot must be true or false"),
    ([{"world": "room", "sensor": ""}], "sensor must be a non-empty string"),
    ([{"world": "corridor", "route": "maybe"}], r"worlds\[0\].route must be 'on' or 'off'"),
])
def test_bad_curriculum_worlds_are_named(worlds, message):
    with pytest.raises(CurriculumError, match=message):
        Curriculum.from_dict(_curriculum(worlds=worlds))


def test_finetune_worlds_config_trains_and_logs_each_episodes_world(core, tmp_path):
    """A few episodes of config/finetune_worlds.yaml: every episode's world is one of the mixture's, in the log."""
    from dqn_dovs_py.train import TrainConfig, Trainer  # noqa: PLC0415 - torch import kept to the tests that train

    with open(ROOT / "config" / "finetune_worlds.yaml") as f:
        raw = yaml.safe_load(f)
    raw["replay"]["learning_starts"] = 200
    raw["evaluation"].update(every_episodes=0, episodes=4, num_envs=4)
    raw["checkpoint"]["save_replay"] = False
    raw["curriculum"]["stages"][0]["episodes"] = 24
    config = TrainConfig.from_dict(raw)
    labels = {WorldSpec(**{**w, "weight": float(w.get("weight", 1))}).label for w in raw["curriculum"]["worlds"]}
    Trainer(config, str(tmp_path / "run"), device="cpu", progress=False).run()
    with open(tmp_path / "run" / "train_log.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 24
    logged = Counter(r["world"] for r in rows)
    assert set(logged) <= labels, f"unknown world labels {set(logged) - labels}"
    assert len(logged) >= 3, f"24 episodes from a mixture of {len(labels)} worlds ran in {dict(logged)}"


def test_the_python_environment_refuses_worlds_without_set_worlds():
    class RoomOnly:
        def set_stage(self, *args):
            pass

    env = VecEnv(1, 1, core=RoomOnly())
    settings = Curriculum.from_dict(_curriculum(worlds=[{"world": "crowd"}])).settings_at(0)
    with pytest.raises(ValueError, match="no set_worlds"):
        env.set_stage(settings)


def test_a_world_that_cannot_be_laid_out_is_redrawn_and_then_named(core):
    """Scenarios the generator cannot lay out are skipped like those that end before their first step; when every
    draw fails the error names the world and the reason."""
    env = core.VecEnv(1, 1, threads=1)
    env.set_worlds([{"world": "clutter"}], [1.0])
    env.set_stage(4.0, 12.0, 150, 150, "both")
    with pytest.raises(RuntimeError, match=r"could not be laid out \(last: world generator 'clutter'.*no free place"):
        env.reset()
