"""The training environment and the evaluation make the same choices on the same episodes.

The trainer acts on VecEnv's states and shielded masks (escape included) with the PyTorch network; dqn_dovs_eval
runs Episode + DqnDovsPlanner with the C++ network. Both load the shipped weight file here, with the shield of
config/*.yaml, the tracker in the loop, and play the same generated episodes: the action sequences, outcomes and
lengths must be equal. (The robot's path against the evaluation's is test/ros_unit/test_pipeline_steps.cpp.)
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch

from dqn_dovs_py.decision_config import load_shield_parameters
from dqn_dovs_py.export import load_weights, model_from_weights
from dqn_dovs_py.model import masked_argmax

ROOT = Path(__file__).resolve().parents[2]
MODEL = ROOT / "models" / "dqn_dovs.dqnw"
# Two worlds that differ in everything an episode fixes at construction (sensor, people, odometry).
MIXTURE = [{"world": "room"}, {"world": "crowd", "sensor": "rplidar_a1", "people_model": "orca", "odom_noise": "low"}]


def _trainer_episode(env, net, state, mask):
    """Environment 0's current episode acted greedily by the PyTorch network, as the trainer acts when exploiting.
    Returns its actions (-1 where the shield's escape ran), outcome and length, and the next episode's first state
    and mask (the environment starts it by itself)."""
    actions: list[int] = []
    while True:
        with torch.no_grad():
            a = int(masked_argmax(net(torch.from_numpy(state)), torch.from_numpy(mask))[0])
        out = env.step(np.array([a], dtype=np.int64))
        actions.append(-1 if out["escaped"][0] else a)
        if out["terminated"][0] or out["truncated"][0]:
            return actions, int(out["outcome"][0]), int(out["episode_steps"][0]), out["state"], out["mask"]
        state, mask = out["state"], out["mask"]


@pytest.mark.parametrize("seed, world", [(10011, {}), (10012, {}), (10013, {}),
                                         (10014, {"world": "crowd", "sensor": "urg04lx"}),
                                         (10015, {"world": "clutter", "people_model": "orca"}),
                                         (10016, MIXTURE),
                                         (10017, {"world": "doorway", "route": "on"})])
def test_training_environment_and_evaluation_choose_alike(core, seed, world):
    net = model_from_weights(load_weights(MODEL)).eval()
    mixture = world is MIXTURE
    env = core.VecEnv(1, seed, perfect_info=False, threads=1, action_shield=True,
                      shield_parameters=load_shield_parameters(str(ROOT / "config")),
                      world_options={} if mixture else world)
    env.set_stage(4.0, 8.0, 6, 10, "both")
    if mixture:
        # Episodes drawn from a mixture: the evaluation replays each in its own world's configuration.
        env.set_worlds(MIXTURE, [1.0] * len(MIXTURE))
    state, mask = env.reset()
    played = 0
    for _ in range(4 if mixture else 2):
        # planner_episode replays the episode environment 0 is about to play (same scenario, same sensor noise).
        evaluated = env.planner_episode(0, "dqn_dovs", str(MODEL))
        actions, outcome, steps, state, mask = _trainer_episode(env, net, state, mask)
        assert evaluated["actions"] == actions, f"seed {seed}: the choices part at decision " \
            f"{next(i for i, (x, y) in enumerate(zip(evaluated['actions'], actions + [None])) if x != y)}"
        assert (evaluated["outcome"], evaluated["steps"]) == (outcome, steps)
        played += steps
    assert played > 20, "the episodes were too short to compare anything"


def test_world_options_are_checked(core):
    for options, message in (({"planet": "mars"}, "unknown key 'planet'"),
                             ({"world": "maze"}, "world family 'maze' is not one of"),
                             ({"sensor": "sonar"}, "lidar profile 'sonar'"),
                             ({"people_see_robot": "yes"}, "people_see_robot must be true or false"),
                             ({"route": "maybe"}, "world_options: route 'maybe' is not one of on, off")):
        with pytest.raises(ValueError, match=message):
            core.VecEnv(1, 1, world_options=options)
