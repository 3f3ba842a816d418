"""Agent maths on a tiny linear Q-function whose outputs the tests set by hand."""

import numpy as np
import pytest
import torch
from torch import nn

from dqn_dovs_py.agent import AgentConfig, DQNAgent
from dqn_dovs_py.replay import SampledBatch, Transitions


class FeatureQ(nn.Module):
    """Q(s) = W s[400:408] + b: with W = I the 8 state features are the 8 Q-values."""

    def __init__(self):
        super().__init__()
        self.linear = nn.Linear(8, 8)
        with torch.no_grad():
            self.linear.weight.copy_(torch.eye(8))
            self.linear.bias.zero_()

    def forward(self, state):
        return self.linear(state[:, 400:])


def state_with_q(*rows):
    s = np.ones((len(rows), 408), np.float32)
    s[:, 400:] = np.asarray(rows, np.float32)
    return s


def make_agent(**overrides):
    torch.manual_seed(0)
    return DQNAgent(FeatureQ(), AgentConfig(**overrides), seed=0)


def set_target(agent, scale, bias):
    with torch.no_grad():
        agent.target.linear.weight.copy_(scale * torch.eye(8))
        agent.target.linear.bias.copy_(torch.as_tensor(bias, dtype=torch.float32))


def targets(agent, reward, discount, next_state, next_mask):
    return agent.compute_targets(torch.tensor(reward, dtype=torch.float32), torch.tensor(discount, dtype=torch.float32),
                                 torch.from_numpy(next_state), torch.from_numpy(np.asarray(next_mask, bool))).numpy()


def test_invalid_action_with_huge_target_value_is_never_bootstrapped():
    agent = make_agent()
    online_q = [1, 2, 3, 4, 5, 6, 7, 100]  # the online argmax over all actions would be 7
    set_target(agent, 1.0, [0, 0, 0, 0, 0, 0, 0, 1e6])  # and the target net values 7 hugely
    next_state = state_with_q(online_q)
    mask = np.array([[True] * 7 + [False]])
    y = targets(agent, [0.5], [0.9], next_state, mask)
    # Online argmax over valid actions is 6 -> the target net's value of action 6 (= 7).
    assert y[0] == pytest.approx(0.5 + 0.9 * 7.0)
    # The same case without the mask does bootstrap from the huge value: the mask is what prevents it.
    y_unmasked = targets(agent, [0.5], [0.9], next_state, np.ones((1, 8), bool))
    assert y_unmasked[0] > 1e5


def test_masked_target_over_many_random_cases():
    agent = make_agent()
    rng = np.random.default_rng(4)
    online_q = rng.normal(size=(256, 8)).astype(np.float32)
    set_target(agent, 1.0, np.zeros(8))  # target net = online net here
    mask = rng.random((256, 8)) < 0.6
    mask[:, 0] = True
    # Make every invalid action the favourite of both nets by a wide margin.
    online_q = np.where(mask, online_q, 50.0).astype(np.float32)
    y = targets(agent, np.zeros(256), np.ones(256), state_with_q(*online_q), mask)
    expected = np.where(mask, online_q, -np.inf).max(axis=1)
    np.testing.assert_allclose(y, expected, rtol=1e-6)


def test_double_dqn_evaluates_online_choice_with_target_net():
    agent = make_agent()
    # Online net prefers action 2; target net's own maximum is action 5.
    next_state = state_with_q([0, 0, 3, 0, 0, 1, 0, 0])
    set_target(agent, 1.0, [0, 0, -1, 0, 0, 4, 0, 0])  # target Q = [0,0,2,0,0,5,0,0]
    mask = np.ones((1, 8), bool)
    y = targets(agent, [1.0], [0.5], next_state, mask)
    assert y[0] == pytest.approx(1.0 + 0.5 * 2.0)
    plain = make_agent(double_dqn=False)
    set_target(plain, 1.0, [0, 0, -1, 0, 0, 4, 0, 0])
    assert targets(plain, [1.0], [0.5], next_state, mask)[0] == pytest.approx(1.0 + 0.5 * 5.0)


def test_terminal_target_ignores_next_state_even_if_nan():
    agent = make_agent()
    next_state = state_with_q([np.nan] * 8, [1, 2, 3, 4, 5, 6, 7, 8])
    y = targets(agent, [15.0, -1.0], [0.0, 0.97 ** 5], next_state, np.ones((2, 8), bool))
    assert y[0] == 15.0
    assert y[1] == pytest.approx(-1.0 + 0.97 ** 5 * 8.0)


def make_batch(states, actions, rewards, discounts, next_states, weights, masks=None):
    n = len(actions)
    masks = np.ones((n, 8), bool) if masks is None else masks
    t = Transitions(state=states, mask=masks, action=np.asarray(actions, np.int64),
                    reward=np.asarray(rewards, np.float32), discount=np.asarray(discounts, np.float32),
                    next_state=next_states, next_mask=masks)
    return SampledBatch(indices=np.arange(n), weights=np.asarray(weights, np.float32), transitions=t)


def test_loss_is_importance_weighted_huber():
    agent = make_agent(huber_delta=1.0)
    states = state_with_q([0.0] * 8, [0.0] * 8)
    batch = make_batch(states, [0, 1], [0.5, 3.0], [0.0, 0.0], states, [1.0, 0.25])
    result = agent.learn(batch)
    # TD errors 0.5 (quadratic branch) and 3.0 (linear branch).
    expected = (1.0 * 0.5 * 0.5 ** 2 + 0.25 * (3.0 - 0.5)) / 2
    assert result.loss == pytest.approx(expected)
    np.testing.assert_allclose(result.td_errors, [0.5, 3.0])


def test_zero_importance_weights_leave_the_network_unchanged():
    agent = make_agent()
    before = [p.detach().clone() for p in agent.online.parameters()]
    states = state_with_q([1.0] * 8)
    agent.learn(make_batch(states, [3], [10.0], [0.0], states, [0.0]))
    for a, b in zip(before, agent.online.parameters()):
        torch.testing.assert_close(a, b.detach())


def test_learning_reduces_td_error_on_a_fixed_batch():
    agent = make_agent(lr_start=1e-2)
    rng = np.random.default_rng(0)
    states = state_with_q(*rng.normal(size=(32, 8)))
    batch = make_batch(states, rng.integers(0, 8, 32), rng.normal(size=32), np.zeros(32), states, np.ones(32))
    first = agent.learn(batch).loss
    for _ in range(200):
        last = agent.learn(batch).loss
    assert last < 0.05 * first


def test_target_network_syncs_every_period():
    agent = make_agent(target_update_period=5, lr_start=1e-2)
    states = state_with_q([0.5] * 8)
    batch = make_batch(states, [1], [2.0], [0.0], states, [1.0])
    for i in range(4):
        agent.learn(batch)
    assert not torch.equal(agent.online.linear.bias, agent.target.linear.bias)
    agent.learn(batch)
    assert torch.equal(agent.online.linear.bias, agent.target.linear.bias)


def test_act_never_picks_invalid_and_explores_uniformly_over_valid():
    agent = make_agent()
    rng = np.random.default_rng(1)
    n = 4000
    mask = np.ones((n, 8), bool)
    mask[:, 5:] = rng.random((n, 3)) < 0.5
    q = np.tile(np.arange(8, dtype=np.float32), (n, 1))  # greedy would always pick the highest valid
    actions = agent.act(state_with_q(*q), mask, epsilon=1.0)
    assert np.all(mask[np.arange(n), actions])
    all_valid = mask.all(axis=1)
    counts = np.bincount(actions[all_valid], minlength=8) / all_valid.sum()
    np.testing.assert_allclose(counts, 1 / 8, atol=0.03)
    greedy = agent.act(state_with_q(*q), mask, epsilon=0.0)
    np.testing.assert_array_equal(greedy, np.where(mask, q, -np.inf).argmax(axis=1))


def test_act_is_deterministic_by_seed_and_rejects_empty_masks():
    q = np.random.default_rng(2).normal(size=(16, 8))
    mask = np.ones((16, 8), bool)
    a = make_agent().act(state_with_q(*q), mask, 0.5)
    b = make_agent().act(state_with_q(*q), mask, 0.5)
    np.testing.assert_array_equal(a, b)
    mask[3] = False
    with pytest.raises(ValueError, match="no valid action in the mask of environment 3"):
        make_agent().act(state_with_q(*q), mask, 0.5)


def test_config_validation_names_the_field():
    assert "agent.target_update_period" in AgentConfig(target_update_period=0).validate()
    assert "agent.lr_end" in AgentConfig(lr_end=float("nan")).validate()
    with pytest.raises(ValueError, match="agent.huber_delta"):
        DQNAgent(FeatureQ(), AgentConfig(huber_delta=-1))


def test_divergence_is_reported_not_propagated():
    agent = make_agent()
    states = state_with_q([np.inf] * 8)
    with pytest.raises(FloatingPointError, match="non-finite loss"):
        agent.learn(make_batch(states, [0], [1.0], [0.0], states, [1.0]))
