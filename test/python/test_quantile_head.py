"""The quantile head (QR-DQN with CVaR action choice): DuelingQNet(quantiles=Nq, cvar_alpha=alpha), its learning
step in DQNAgent, its widening from a one-quantile network and the trainer's `model` section, down to a short run
of `python -m dqn_dovs_py.train` on the C++ environment."""

import copy
import csv
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import torch
import yaml

from dqn_dovs_py.agent import AgentConfig, DQNAgent, quantile_huber_loss
from dqn_dovs_py.export import load_weights, model_from_weights
from dqn_dovs_py.model import (DuelingQNet, cvar_of_quantiles, cvar_quantile_count, masked_argmax,
                               widen_quantiles)
from dqn_dovs_py.replay import SampledBatch, Transitions
from dqn_dovs_py.train import ConfigError, TrainConfig, init_from_factory, load_config

ROOT = Path(__file__).resolve().parents[2]
SHIPPED = ROOT / "models" / "dqn_dovs.dqnw"


def random_states(n, seed=0):
    rng = np.random.default_rng(seed)
    state = np.where(rng.random((n, 408)) < 0.5, 1.0, -1.0).astype(np.float32)
    state[:, 400:] = rng.normal(size=(n, 8))
    return state


def brute_force_cvar(z, alpha):
    """CVaR_alpha of each row of z [..., Nq] by the definition: sort ascending, the mean of the first ceil(alpha Nq)."""
    m = math.ceil(alpha * z.shape[-1])
    out = np.empty(z.shape[:-1])
    for index in np.ndindex(*z.shape[:-1]):
        out[index] = np.mean(sorted(z[index])[:m])
    return out


def test_a_one_quantile_network_is_the_network_it_always_was():
    torch.manual_seed(5)
    old = DuelingQNet()
    torch.manual_seed(5)
    new = DuelingQNet(quantiles=1, cvar_alpha=1.0)
    shapes = {name: tuple(t.shape) for name, t in old.state_dict().items()}
    assert shapes == {name: tuple(t.shape) for name, t in new.state_dict().items()}
    assert shapes["value.weight"] == (1, 128) and shapes["advantage.weight"] == (8, 128)
    for name, tensor in old.state_dict().items():  # the same initial weights from the same seed
        assert torch.equal(tensor, new.state_dict()[name]), name
    assert new.config()["quantiles"] == 1 and new.config()["cvar_alpha"] == 1.0

    # The shipped network loads into it, and every output is the dueling Q as it was defined before the head.
    net = model_from_weights(load_weights(str(SHIPPED)))
    assert net.quantiles == 1
    state = torch.from_numpy(random_states(64))
    with torch.no_grad():
        h = net.embed(state)
        advantage = net.advantage(h)
        q_before = net.value(h) + advantage - advantage.mean(dim=1, keepdim=True)
        assert torch.equal(net(state), q_before)
        assert torch.equal(net.action_values(state), q_before)
        assert torch.equal(net.quantile_values(state), q_before[..., None])
    # A checkpoint of the network without the new arguments loads strictly into one built with them, and back.
    rebuilt = DuelingQNet(**net.config())
    rebuilt.load_state_dict(net.state_dict(), strict=True)
    with torch.no_grad():
        assert torch.equal(rebuilt(state), q_before)


def test_the_advantage_head_is_action_major_and_the_quantiles_follow_the_dueling_rule():
    nq = 4
    net = DuelingQNet(quantiles=nq)
    layout = torch.arange(8 * nq, dtype=torch.float32) ** 1.5  # advantage output a * Nq + j
    with torch.no_grad():
        for head in (net.value, net.advantage):
            head.weight.zero_()
        net.value.bias.copy_(torch.tensor([1.0, -2.0, 3.0, 0.5]))
        net.advantage.bias.copy_(layout)
        z = net.quantile_values(torch.from_numpy(random_states(3)))
    a = layout.reshape(8, nq)
    expected = torch.tensor([1.0, -2.0, 3.0, 0.5])[None, :] + a - a.mean(dim=0, keepdim=True)
    assert z.shape == (3, 8, nq)
    for row in z:
        torch.testing.assert_close(row, expected, rtol=0, atol=1e-5)
    torch.testing.assert_close(net.quantile_fractions(), torch.tensor([0.125, 0.375, 0.625, 0.875]))


@pytest.mark.parametrize("nq, alpha, m", [(8, 1.0, 8), (8, 0.5, 4), (8, 0.3, 3), (8, 0.125, 1), (8, 0.01, 1),
                                          (7, 0.9, 7), (32, 0.25, 8), (51, 0.1, 6)])
def test_action_values_are_the_brute_force_cvar(nq, alpha, m):
    assert cvar_quantile_count(nq, alpha) == m
    torch.manual_seed(nq)
    net = DuelingQNet(quantiles=nq, cvar_alpha=alpha)
    with torch.no_grad():  # spread the quantile values so that sorting matters
        net.advantage.weight.mul_(50.0)
        net.value.weight.mul_(50.0)
        state = torch.from_numpy(random_states(16, seed=nq))
        z = net.quantile_values(state)
        values = net.action_values(state)
        q = net(state)
    z_np = z.double().numpy()
    assert values.shape == q.shape == (16, 8)
    assert not np.allclose(np.sort(z_np, axis=2), z_np), "the quantile values came out sorted: sorting is untested"
    np.testing.assert_allclose(values.numpy(), brute_force_cvar(z_np, alpha), rtol=0, atol=1e-4)
    np.testing.assert_allclose(q.numpy(), z_np.mean(axis=2), rtol=0, atol=1e-4)
    if m == nq:  # every quantile: the mean
        torch.testing.assert_close(values, q, rtol=0, atol=1e-4)
    else:
        assert np.all(values.numpy() <= q.numpy() + 1e-4), "CVaR below 1 exceeded the mean"
        assert np.any(values.numpy() < q.numpy() - 1e-3)


def test_cvar_on_random_quantile_values_matches_numpy():
    rng = np.random.default_rng(1)
    z = rng.normal(size=(5, 8, 10)) * 3
    for alpha in (1.0, 0.75, 0.35, 0.1):
        got = cvar_of_quantiles(torch.from_numpy(z), alpha).numpy()
        np.testing.assert_allclose(got, brute_force_cvar(z, alpha), rtol=0, atol=1e-12)
    np.testing.assert_allclose(cvar_of_quantiles(torch.from_numpy(z), 1.0).numpy(), z.mean(axis=2), atol=1e-12)
    # alpha * Nq that is an integer in exact arithmetic is not pushed up by rounding (0.3 * 10 = 3.0000000000000004).
    assert cvar_quantile_count(10, 0.3) == 3 and cvar_quantile_count(5, 0.6) == 3
    assert cvar_quantile_count(8, 0.51) == 5 and cvar_quantile_count(256, 1.0) == 256


@pytest.mark.parametrize("kwargs, field", [({"quantiles": 0}, "quantiles"), ({"quantiles": 257}, "quantiles"),
                                           ({"quantiles": 2.5}, "quantiles"), ({"cvar_alpha": 0.0}, "cvar_alpha"),
                                           ({"cvar_alpha": 1.5}, "cvar_alpha"),
                                           ({"cvar_alpha": float("nan")}, "cvar_alpha")])
def test_bad_head_arguments_are_refused_naming_them(kwargs, field):
    with pytest.raises(ValueError, match=field):
        DuelingQNet(**kwargs)


def test_a_widened_network_starts_as_its_one_quantile_source():
    start = model_from_weights(load_weights(str(SHIPPED)))
    state = torch.from_numpy(random_states(256, seed=3))
    with torch.no_grad():
        q_start = start(state)
        h = start.embed(state)
        # Equal up to the float32 rounding of the wider matrix products: a few units in the last place of the
        # heads' outputs, which reach ~230 in magnitude on these random states (the largest difference seen: 4.6e-5).
        tol = 1e-6 * float(start.value(h).abs().max() + start.advantage(h).abs().max())
    for nq, alpha in ((8, 0.5), (5, 0.3), (32, 1.0)):
        wide = widen_quantiles(start, nq, alpha)
        assert (wide.quantiles, wide.cvar_alpha) == (nq, alpha)
        assert wide.value.weight.shape == (nq, 128) and wide.advantage.weight.shape == (8 * nq, 128)
        with torch.no_grad():
            z = wide.quantile_values(state)
            torch.testing.assert_close(z, q_start[..., None].expand_as(z), rtol=0, atol=tol)
            torch.testing.assert_close(wide(state), q_start, rtol=0, atol=tol)
            torch.testing.assert_close(wide.action_values(state), q_start, rtol=0, atol=tol)
        mask = torch.ones_like(q_start, dtype=torch.bool)
        ranked = torch.sort(q_start, dim=1, descending=True).values
        clear = ranked[:, 0] - ranked[:, 1] > 2 * tol
        assert clear.sum() > 200
        assert torch.equal(masked_argmax(wide.action_values(state).detach(), mask)[clear],
                           masked_argmax(q_start, mask)[clear])
    with pytest.raises(ValueError, match="widens a network of 1 quantile"):
        widen_quantiles(widen_quantiles(start, 4), 8)

    # --init-from does the same, and refuses nothing it can widen.
    made = init_from_factory(str(SHIPPED), quantiles=8, cvar_alpha=0.25)()
    assert (made.quantiles, made.cvar_alpha) == (8, 0.25)
    with torch.no_grad():
        torch.testing.assert_close(made.action_values(state), q_start, rtol=0, atol=tol)


def quantile_batch(n=48, seed=0):
    rng = np.random.default_rng(seed)
    state = random_states(n, seed)
    mask = np.ones((n, 8), bool)
    mask[:, 5:] = rng.random((n, 3)) < 0.5
    discount = np.where(rng.random(n) < 0.25, 0.0, 0.97 ** 3).astype(np.float32)
    t = Transitions(state=state, mask=mask, action=rng.integers(0, 5, n), reward=rng.normal(size=n).astype(np.float32),
                    discount=discount, next_state=random_states(n, seed + 1), next_mask=mask)
    return SampledBatch(indices=np.arange(n), weights=rng.uniform(0.3, 1.0, n).astype(np.float32), transitions=t)


def test_the_quantile_loss_is_the_pairwise_definition():
    rng = np.random.default_rng(2)
    z = rng.normal(size=(3, 4))
    target = rng.normal(size=(3, 4)) * 2
    tau = (2 * np.arange(4) + 1) / 8
    kappa = 0.7
    expected = np.zeros(3)
    for b in range(3):
        for i in range(4):
            for j in range(4):
                u = target[b, j] - z[b, i]
                huber = 0.5 * u * u if abs(u) <= kappa else kappa * (abs(u) - 0.5 * kappa)
                expected[b] += abs(tau[i] - (u < 0)) * huber / kappa / 4  # summed over i, meaned over j
    got = quantile_huber_loss(torch.from_numpy(z), torch.from_numpy(target), torch.from_numpy(tau), kappa)
    np.testing.assert_allclose(got.numpy(), expected, rtol=1e-12)


def test_the_quantile_loss_falls_on_a_fixed_batch_with_finite_gradients():
    torch.manual_seed(0)
    agent = DQNAgent(DuelingQNet(quantiles=8, cvar_alpha=0.5), AgentConfig(lr_start=1e-3, target_update_period=10 ** 9),
                     seed=0)
    batch = quantile_batch()
    first = agent.learn(batch)
    grads = [p.grad for p in agent.online.parameters()]
    assert all(g is not None and torch.isfinite(g).all() for g in grads)
    assert any(g.abs().sum() > 0 for g in grads)
    losses = [agent.learn(batch).loss for _ in range(150)]
    assert np.isfinite(first.loss) and losses[-1] < 0.3 * first.loss, (first.loss, losses[::30])
    assert first.td_errors.shape == (48,) and np.all(np.isfinite(first.td_errors))
    # td_errors are the mean target minus the mean prediction of the taken action.
    t = batch.transitions
    with torch.no_grad():
        target = agent.compute_quantile_targets(*(torch.from_numpy(x) for x in (t.reward, t.discount)),
                                                torch.from_numpy(t.next_state), torch.from_numpy(t.next_mask))
        z = agent.online.quantile_values(torch.from_numpy(t.state))[np.arange(48), t.action]
    last = agent.learn(batch)
    np.testing.assert_allclose(last.td_errors, (target.mean(1) - z.mean(1)).numpy(), rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(last.mean_q, z.mean().item(), rtol=1e-5, atol=1e-5)


def test_the_target_distribution_bootstraps_the_cvar_choice_and_stops_at_terminals():
    nq = 2
    net = DuelingQNet(quantiles=nq, cvar_alpha=0.5)
    a = torch.full((8, nq), -50.0)
    a[0] = torch.tensor([-10.0, 10.0])  # the highest mean
    a[1] = torch.tensor([-1.0, -1.0])  # the highest CVaR at 0.5 (its lower quantile)
    with torch.no_grad():
        for head in (net.value, net.advantage):
            head.weight.zero_()
        net.value.bias.zero_()
        net.advantage.bias.copy_(a.reshape(-1))
    agent = DQNAgent(net, AgentConfig(), seed=0)
    state = random_states(2, seed=9)
    mask = np.ones((2, 8), bool)
    z = (a - a.mean(dim=0, keepdim=True)).numpy()
    assert np.argmax(z.mean(axis=1)) == 0 and np.argmax(z.min(axis=1)) == 1
    assert np.all(agent.q_values(state).argmax(axis=1) == 0)
    np.testing.assert_array_equal(agent.greedy(state, mask), [1, 1])
    np.testing.assert_array_equal(agent.act(state, mask, 0.0), [1, 1])
    # Masking action 1 out leaves the next CVaR, action 0 (-10 - mean beats every -50).
    np.testing.assert_array_equal(agent.greedy(state, np.array([[True, False] + [True] * 6] * 2)), [0, 0])

    next_state = torch.from_numpy(random_states(3, seed=4))
    next_state[2] = float("nan")  # a terminal transition ignores its next state entirely
    reward = torch.tensor([0.5, -2.0, 15.0])
    discount = torch.tensor([0.9, 0.5, 0.0])
    target = agent.compute_quantile_targets(reward, discount, next_state, torch.ones(3, 8, dtype=torch.bool))
    torch.testing.assert_close(target[0], 0.5 + 0.9 * torch.from_numpy(z[1]))
    torch.testing.assert_close(target[1], -2.0 + 0.5 * torch.from_numpy(z[1]))
    assert torch.equal(target[2], torch.full((nq,), 15.0))
    # Without Double DQN the target network's own CVaR picks the action (the same network here).
    agent.config.double_dqn = False
    target = agent.compute_quantile_targets(reward, discount, next_state, torch.ones(3, 8, dtype=torch.bool))
    torch.testing.assert_close(target[0], 0.5 + 0.9 * torch.from_numpy(z[1]))
    assert torch.equal(target[2], torch.full((nq,), 15.0))


def test_the_model_section_is_parsed_and_checked():
    curriculum = yaml.safe_load((ROOT / "config" / "curriculum.yaml").read_text())["curriculum"]
    config = TrainConfig.from_dict({"model": {"quantiles": 8, "cvar_alpha": 0.5}, "curriculum": curriculum})
    assert (config.model.quantiles, config.model.cvar_alpha) == (8, 0.5) and config.validate() == ""
    assert TrainConfig.from_dict({}).model.quantiles == 1
    for raw, message in (({"quantiles": 0}, "model.quantiles must be in [1, 256]"),
                         ({"quantiles": 300}, "model.quantiles must be in [1, 256]"),
                         ({"quantiles": 8, "cvar_alpha": 0}, "model.cvar_alpha must be in (0, 1]"),
                         ({"quantiles": 8, "cvar_alpha": 1.2}, "model.cvar_alpha must be in (0, 1]"),
                         ({"cvar_alpha": 0.5}, "model.cvar_alpha is 0.5 but model.quantiles is 1")):
        assert message in TrainConfig.from_dict({"model": raw, "curriculum": curriculum}).validate()
    with pytest.raises(ConfigError, match="model.quantiles: expected a finite int"):
        TrainConfig.from_dict({"model": {"quantiles": 2.5}})
    with pytest.raises(ConfigError, match=r"model: unknown field\(s\) \['atoms'\]"):
        TrainConfig.from_dict({"model": {"atoms": 51}})


def test_a_quantile_run_of_the_command_line_trains_and_exports_its_head(core, tmp_path):
    """`python -m dqn_dovs_py.train` with quantiles 8 and cvar_alpha 0.5 on the C++ environment, to its model.dqnw:
    the file holds the trained quantile head and its CVaR count."""
    raw = yaml.safe_load((ROOT / "config" / "curriculum.yaml").read_text())
    raw["model"] = {"quantiles": 8, "cvar_alpha": 0.5}
    raw["replay"] = {**raw.get("replay", {}), "capacity": 20000, "batch_size": 16, "learning_starts": 64,
                     "transitions_per_update": 4}
    raw["evaluation"] = {**raw.get("evaluation", {}), "every_episodes": 0, "episodes": 2, "num_envs": 2,
                         "keep_snapshots": False}
    raw["checkpoint"] = {"every_episodes": 0, "save_replay": False}
    raw["log"] = {"success_window": 10, "plot_every_episodes": 0}
    config_path = tmp_path / "quantiles.yaml"
    config_path.write_text(yaml.safe_dump(raw, sort_keys=False))
    assert load_config(str(config_path)).model.quantiles == 8
    out = tmp_path / "run"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT / "python"), os.environ.get("PYTHONPATH", "")]),
           "MPLBACKEND": "Agg"}
    result = subprocess.run([sys.executable, "-m", "dqn_dovs_py.train", "--config", str(config_path), "--out", str(out),
                             "--scale", "0.001", "--num-envs", "2", "--device", "cpu", "--no-progress"],
                            capture_output=True, text=True, timeout=600, env=env, cwd=str(ROOT))
    with open(out / "train_log.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) >= 6, result.stderr[-3000:]
    losses = np.array([float(r["loss"]) for r in rows if r["loss"]])
    assert losses.size and np.all(np.isfinite(losses)) and np.all(losses >= 0)
    assert yaml.safe_load((out / "config.yaml").read_text())["model"] == {"quantiles": 8, "cvar_alpha": 0.5}
    assert result.returncode == 0, result.stderr[-3000:]

    weights = load_weights(str(out / "model.dqnw"))
    assert (weights.quantile_count, weights.cvar_count) == (8, 4)
    exported = model_from_weights(weights)
    checkpoint = torch.load(out / "checkpoint.pt", map_location="cpu", weights_only=True)
    assert checkpoint["model_config"]["quantiles"] == 8 and checkpoint["model_config"]["cvar_alpha"] == 0.5
    trained = DuelingQNet(**checkpoint["model_config"])
    trained.load_state_dict(checkpoint["model"])
    state = torch.from_numpy(random_states(32, seed=8))
    with torch.no_grad():
        z = trained.quantile_values(state)
        assert z.std(dim=2).max() > 1e-4, "training left every quantile of every action equal"
        assert torch.equal(exported.quantile_values(state), z)
        assert torch.equal(exported.action_values(state), trained.action_values(state))

