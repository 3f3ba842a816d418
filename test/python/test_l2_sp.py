"""L2-SP fine-tuning (agent.l2_sp_weight): the loss pulls the network towards the parameters it started from
(--init-from), over the tensors the start network had; the trainer logs the distance and keeps the start network
across a resume."""

import copy
import csv

import numpy as np
import pytest
import torch
import yaml

from chain_env import ChainCore
from dqn_dovs_py.agent import AgentConfig, DQNAgent
from dqn_dovs_py.env import VecEnv
from dqn_dovs_py.export import export_model, widen_grid_channels
from dqn_dovs_py.model import DuelingQNet, widen_quantiles
from dqn_dovs_py.replay import SampledBatch, Transitions
from dqn_dovs_py.train import ConfigError, Trainer, TrainConfig, init_from_factory
from dqn_dovs_py.train import main as train_main


def batches(count, n=32, seed=0):
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(count):
        state = np.where(rng.random((n, 408)) < 0.5, 1.0, -1.0).astype(np.float32)
        state[:, 400:] = rng.normal(size=(n, 8))
        mask = np.ones((n, 8), bool)
        t = Transitions(state=state, mask=mask, action=rng.integers(0, 8, n),
                        reward=(5 * rng.normal(size=n)).astype(np.float32),
                        discount=np.where(rng.random(n) < 0.3, 0.0, 0.9).astype(np.float32),
                        next_state=state[rng.permutation(n)], next_mask=mask)
        out.append(SampledBatch(indices=np.arange(n), weights=np.ones(n, np.float32), transitions=t))
    return out


def distance(model, start):
    """||theta - theta_0||^2 over the start network's parameters, computed here without the agent."""
    params = dict(model.named_parameters())
    with torch.no_grad():
        return sum(float(((params[name] - p) ** 2).sum()) for name, p in start.named_parameters())


def sp(agent):
    with torch.no_grad():
        return float(agent.l2_sp_distance())


def start_network(seed=0):
    torch.manual_seed(seed)
    return DuelingQNet()


def test_the_weight_is_checked_naming_the_field():
    assert AgentConfig().l2_sp_weight == 0.0 and AgentConfig(l2_sp_weight=0.5).validate() == ""
    for bad in (-0.1, float("nan"), float("inf")):
        assert "agent.l2_sp_weight must be >= 0" in AgentConfig(l2_sp_weight=bad).validate()
    with pytest.raises(ValueError, match="agent.l2_sp_weight"):
        DQNAgent(DuelingQNet(), AgentConfig(l2_sp_weight=-1.0))
    agent = DQNAgent(DuelingQNet(), AgentConfig(l2_sp_weight=0.1))
    with pytest.raises(ValueError, match="agent.l2_sp_weight is 0.1 but no start network was given"):
        agent.learn(batches(1)[0])


def test_the_penalty_is_zero_at_the_start_and_keeps_the_parameters_near_it():
    start = start_network()
    theta_0 = {name: p.detach().clone() for name, p in start.named_parameters()}
    steps = batches(30)
    agents = {}
    for weight in (0.0, 0.05):
        agent = DQNAgent(copy.deepcopy(start), AgentConfig(lr_start=1e-3, target_update_period=20, l2_sp_weight=weight),
                         seed=4)
        agent.set_anchor(theta_0)
        assert agent.anchor_excluded == []
        results = [agent.learn(b) for b in steps]
        agents[weight] = (agent, results)
    free, pulled = agents[0.0], agents[0.05]
    # Step 0: the network is the start network, the penalty is 0 and the loss is the TD loss alone.
    assert free[1][0].sp_loss == 0.0 and pulled[1][0].sp_loss == 0.0
    assert free[1][0].loss == pulled[1][0].loss
    # Each step reports the distance before its update; the weight-0 run records it without pulling.
    assert 0 < free[1][1].sp_loss and 0 < pulled[1][1].sp_loss
    far, near = distance(free[0].online, start), distance(pulled[0].online, start)
    assert near < 0.5 * far, (near, far)
    assert sp(pulled[0]) == pytest.approx(near, rel=1e-4)
    # Both still learn: the pulled network moves, just less.
    assert near > 0


def test_widened_tensors_are_pulled_only_over_what_the_start_network_had():
    start = start_network(1)
    theta_0 = {name: p.detach().clone() for name, p in start.named_parameters()}

    quantile = DQNAgent(widen_quantiles(start, 8, 0.5), AgentConfig(l2_sp_weight=1.0))
    quantile.set_anchor(theta_0)
    assert quantile.anchor_excluded == ["value.weight", "value.bias", "advantage.weight", "advantage.bias"]
    assert sp(quantile) == 0.0
    with torch.no_grad():
        quantile.online.value.weight.add_(1.0)  # not pulled
    assert sp(quantile) == 0.0

    channels = DQNAgent(widen_grid_channels(start, 3), AgentConfig(l2_sp_weight=1.0))
    channels.set_anchor(theta_0)
    assert channels.anchor_excluded == []
    assert sp(channels) == 0.0
    conv = channels.online.grid[0].weight
    assert conv.shape[1] == 3
    with torch.no_grad():
        conv[:, 1:].add_(0.5)  # the new channels' weights: free
    assert sp(channels) == 0.0
    with torch.no_grad():
        conv[0, 0, 0, 0].add_(0.5)  # a weight the start network had: pulled
    assert sp(channels) == pytest.approx(0.25)

    with pytest.raises(ValueError, match="no parameter of the start network matches"):
        quantile.set_anchor({"something.else": torch.zeros(3)})


RAW = {
    "seed": 3, "num_envs": 4, "gamma": 0.97, "n_step": 3,
    "agent": {"lr_start": 1e-3, "lr_end": 3e-4, "target_update_period": 50, "l2_sp_weight": 0.01},
    "replay": {"capacity": 5000, "batch_size": 32, "learning_starts": 100, "transitions_per_update": 2},
    "evaluation": {"every_episodes": 0, "episodes": 4, "num_envs": 4, "seed": 7},
    "checkpoint": {"every_episodes": 20, "save_replay": True},
    "log": {"success_window": 20, "plot_every_episodes": 0},
    "curriculum": {
        "epsilon_decay": {"start": 1.0, "end": 0.05, "fraction": 0.8},
        "stages": [{"name": "near", "episodes": 40, "goal_distance_m": [1.0, 3.0], "obstacles": 0,
                    "obstacle_type": "none", "epsilon": "decay"}]},
}


def chain_env(num_envs, seed, perfect_info):
    return VecEnv(num_envs, seed, perfect_info, core=ChainCore(num_envs, seed))


def test_a_fine_tune_logs_the_distance_and_keeps_its_start_network_across_a_resume(tmp_path):
    start = start_network(2)
    weights = tmp_path / "start.dqnw"
    export_model(start, weights, ChainCore(1, 0).normalization(), "L2-SP test start network", onnx=False)
    config = TrainConfig.from_dict(copy.deepcopy(RAW))
    out = tmp_path / "run"

    with pytest.raises(ConfigError, match=r"agent.l2_sp_weight is 0.01 but the run does not start from a network "
                                          r"\(--init-from\)"):
        Trainer(config, str(tmp_path / "fresh"), device="cpu", threads=1, env_factory=chain_env, progress=False)

    factory = init_from_factory(str(weights))
    first = Trainer(config, str(out), device="cpu", threads=1, env_factory=chain_env, progress=False,
                    model_factory=factory, start_parameters=factory.start_parameters())
    assert first.agent.has_anchor
    first.run(stop_at=20)
    resumed = Trainer(config, str(out), device="cpu", threads=1, env_factory=chain_env, progress=False, resume=True)
    assert resumed.agent.has_anchor and resumed.agent.updates > 0
    # The resumed run measures from the file's network, not from where it was resumed.
    assert sp(resumed.agent) == pytest.approx(distance(resumed.agent.online, start), rel=1e-5)
    assert sp(resumed.agent) > 0
    resumed.run()
    with open(out / "train_log.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert [int(r["episode"]) for r in rows] == list(range(40))
    logged = np.array([float(r["sp_loss"]) for r in rows if r["sp_loss"]])
    learned = [r for r in rows if r["loss"]]
    assert learned and logged.size == len(learned)  # every row with learning steps has the distance
    assert np.all(np.isfinite(logged)) and np.all(logged >= 0) and logged.max() > 0

    # A resume of a run made without a start network cannot switch L2-SP on.
    plain = copy.deepcopy(RAW)
    plain["agent"]["l2_sp_weight"] = 0.0
    Trainer(TrainConfig.from_dict(plain), str(tmp_path / "plain"), device="cpu", threads=1, env_factory=chain_env,
            progress=False).run(stop_at=8)
    with pytest.raises(ConfigError, match=r"--resume: agent.l2_sp_weight is 0.01 but the run in .*plain keeps no start "
                                          r"network"):
        Trainer(config, str(tmp_path / "plain"), device="cpu", threads=1, env_factory=chain_env, progress=False,
                resume=True)


def test_the_command_line_refuses_l2_sp_without_init_from(tmp_path, capsys):
    raw = copy.deepcopy(RAW)
    path = tmp_path / "l2sp.yaml"
    path.write_text(yaml.safe_dump(raw))
    assert train_main(["--config", str(path), "--out", str(tmp_path / "run"), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "agent.l2_sp_weight is 0.01" in err and "--init-from" in err
