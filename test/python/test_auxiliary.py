"""The auxiliary "boxed in" head (docs/training.md, "An auxiliary head"): the labeller that looks a few decisions
ahead, the buffer of labelled states, the agent's extra loss, and the trainer's use of it (labels, checkpoints,
export without the head) on the corridor task of chain_env.py."""

import copy
import os

import numpy as np
import pytest
import torch

from chain_env import ChainCore
from dqn_dovs_py.agent import DQNAgent
from dqn_dovs_py.env import VecEnv
from dqn_dovs_py.export import load_weights
from dqn_dovs_py.model import DuelingQNet
from dqn_dovs_py.replay import HorizonLabeller, LabelBuffer, SampledBatch, Transitions
from dqn_dovs_py.train import ConfigError, Trainer, TrainConfig, load_config

from test_teacher import RAW

REPO = os.path.join(os.path.dirname(__file__), "..", "..")


def push_episode(labeller, events, end_as="timeout"):
    """Pushes one environment's episode (state t carries t in feature 0) and returns {t: label} of every state the
    labeller gave back."""
    got = {}
    for t, event in enumerate(events):
        state = -np.ones((1, 408), np.float32)
        state[0, 400] = t
        done = t == len(events) - 1
        states, labels = labeller.push(state, np.array([event]), np.array([done]))
        for s, label in zip(states, labels):
            assert int(s[400]) not in got, f"state {int(s[400])} was labelled twice"
            got[int(s[400])] = float(label)
    return got


def test_a_state_is_positive_when_an_event_lies_within_its_horizon():
    labeller = HorizonLabeller(1, 3)
    # Events at steps 4 and 9 (the escape ran there); the episode ends at step 10 by a timeout.
    events = [False] * 11
    events[4] = events[9] = True
    got = push_episode(labeller, events)
    assert sorted(got) == list(range(11)), "every state is labelled exactly once"
    positive = sorted(t for t, label in got.items() if label == 1.0)
    # Step t's horizon is t, t + 1, t + 2.
    assert positive == [2, 3, 4, 7, 8, 9]


def test_a_collision_makes_the_states_before_it_positive_and_episodes_do_not_mix():
    labeller = HorizonLabeller(1, 5)
    got = push_episode(labeller, [False] * 7 + [True])  # collides on its 8th step
    assert [got[t] for t in range(8)] == [0, 0, 0, 1, 1, 1, 1, 1]
    # The next episode starts clean: an event-free episode shorter than the horizon is all negative.
    again = push_episode(labeller, [False] * 3)
    assert again == {0: 0.0, 1: 0.0, 2: 0.0}


def test_environments_are_labelled_independently():
    labeller = HorizonLabeller(2, 2)
    out = []
    for t in range(4):
        state = np.zeros((2, 408), np.float32)
        state[:, 400] = [t, 100 + t]
        event = np.array([t == 3, False])
        out.append(labeller.push(state, event, np.array([t == 3, False])))
    labels = {int(s[400]): float(l) for states, ls in out for s, l in zip(states, ls)}
    assert labels == {0: 0.0, 1: 0.0, 2: 1.0, 3: 1.0, 100: 0.0, 101: 0.0, 102: 0.0}
    with pytest.raises(ValueError, match="HorizonLabeller.push: state"):
        labeller.push(np.zeros((3, 408)), np.zeros(3, bool), np.zeros(3, bool))


def test_the_label_buffer_counts_round_trips_and_refuses_bad_labels():
    buffer = LabelBuffer(4, seed=1)
    states = np.where(np.arange(408) < 400, 1.0, 0.5).astype(np.float32)[None].repeat(6, axis=0)
    states[:, 400] = np.arange(6)
    buffer.add(states, np.array([0, 1, 0, 1, 1, 0]))
    assert len(buffer) == 4 and buffer.added == 6 and buffer.positives == 3
    state, label = buffer.sample(64)
    kept = {int(s): l for s, l in zip(state[:, 400], label)}
    assert set(kept) == {2, 3, 4, 5}, "the latest four are kept"
    assert kept == {2: 0.0, 3: 1.0, 4: 1.0, 5: 0.0}
    copy_ = LabelBuffer(4, seed=99)
    copy_.load_state_dict(buffer.state_dict())
    assert copy_.positives == 3 and copy_.added == 6
    mine, theirs = buffer.sample(8), copy_.sample(8)  # the random stream travels with the buffer
    assert np.array_equal(mine[0], theirs[0]) and np.array_equal(mine[1], theirs[1])
    with pytest.raises(ValueError, match="LabelBuffer.load_state_dict: capacity 4 != 5"):
        LabelBuffer(5).load_state_dict(buffer.state_dict())
    with pytest.raises(ValueError, match="LabelBuffer.add: labels must be 0 or 1"):
        buffer.add(states[:1], np.array([0.5]))
    with pytest.raises(ValueError, match="LabelBuffer.add: 2 states but 1 labels"):
        buffer.add(states[:2], np.array([1.0]))
    with pytest.raises(ValueError, match="LabelBuffer.add: state contains NaN"):
        bad = states[:1].copy()
        bad[0, 401] = np.nan
        buffer.add(bad, np.array([1.0]))


def td_batch(rng, n=32):
    state = np.where(rng.random((n, 408)) < 0.5, 1.0, -1.0).astype(np.float32)
    state[:, 400:] = rng.normal(size=(n, 8))
    mask = np.ones((n, 8), bool)
    t = Transitions(state=state, mask=mask, action=rng.integers(0, 8, n), reward=np.zeros(n, np.float32),
                    discount=np.zeros(n, np.float32), next_state=state, next_mask=mask)
    return SampledBatch(indices=np.arange(n), weights=np.ones(n, np.float32), transitions=t)


def test_the_auxiliary_loss_teaches_the_head_a_rule_of_the_state():
    torch.manual_seed(0)
    rng = np.random.default_rng(0)
    agent = DQNAgent(DuelingQNet(), device="cpu", aux_head=torch.nn.Linear(128, 1))
    losses = []
    for _ in range(150):
        batch = td_batch(rng)
        state = batch.transitions.state
        label = (state[:, 401] > 0).astype(np.float32)  # "boxed in" when feature 1 is positive
        result = agent.learn(batch, aux=(state, label), aux_weight=1.0)
        losses.append(result.aux_loss)
    assert np.mean(losses[:10]) > 0.6 and np.mean(losses[-10:]) < 0.3, losses[::15]
    with pytest.raises(ValueError, match="no auxiliary head"):
        DQNAgent(DuelingQNet(), device="cpu").learn(td_batch(rng), aux=(state, label), aux_weight=1.0)
    # Without labels, a head changes nothing in the TD step: same start, same batch, same updated network.
    torch.manual_seed(1)
    plain = DQNAgent(DuelingQNet(), device="cpu")
    torch.manual_seed(1)
    headed = DQNAgent(DuelingQNet(), device="cpu", aux_head=torch.nn.Linear(128, 1))
    batch = td_batch(np.random.default_rng(3))
    plain.learn(batch)
    headed.learn(batch)
    for a, b in zip(plain.online.parameters(), headed.online.parameters()):
        torch.testing.assert_close(a, b)


class EscapingChainCore(ChainCore):
    """The corridor, where a step taken within two cells of the goal counts as the shield's escape (the chosen action
    stands for it), and feature 2 of the state says +1 within four cells of the goal, -1 beyond: an event the
    state announces, for the head to learn."""

    def _observe(self):
        state, mask = super()._observe()
        state[:, 402] = np.where(self.goal - self.pos <= 4, 1.0, -1.0)
        return state, mask

    def step(self, actions):
        before = self.goal - self.pos
        out = super().step(actions)
        out["escaped"] = before <= 2
        out["executed_action"] = np.asarray(actions, np.int64)
        return out


def make_trainer(out_dir, auxiliary=None, resume=False, episodes=150):
    raw = copy.deepcopy(RAW)
    raw["curriculum"]["stages"][0]["episodes"] = episodes
    raw["curriculum"]["stages"][0]["goal_distance_m"] = [1.0, 8.0]
    if auxiliary is not None:
        raw["auxiliary"] = auxiliary
    return Trainer(TrainConfig.from_dict(raw), str(out_dir), device="cpu", threads=1, resume=resume, progress=False,
                   command="test",
                   env_factory=lambda n, seed, perfect: VecEnv(n, seed, perfect, core=EscapingChainCore(n, seed)))


def test_the_trainer_labels_every_step_resumes_and_exports_without_the_head(tmp_path):
    auxiliary = {"horizon": 3, "loss_weight": 1.0, "min_labels": 50}
    stopped = make_trainer(tmp_path / "run", auxiliary)
    stopped.run(stop_at=40)
    labels = stopped.aux_labels.added
    # Every step is labelled once, except those still waiting in a running episode's window.
    assert 0 < stopped.env_steps - labels <= 4 * 2
    assert 0 < stopped.aux_labels.positives < labels
    head = stopped.agent.aux_head.weight.detach().clone()
    resumed = make_trainer(tmp_path / "run", auxiliary, resume=True)
    assert resumed.aux_labels.added == labels and len(resumed.aux_labels) == len(stopped.aux_labels)
    torch.testing.assert_close(resumed.agent.aux_head.weight, head)
    summary = resumed.run()
    aux = summary["auxiliary"]
    assert aux["horizon"] == 3 and aux["labels"] > labels and 0 < aux["positive_share"] < 1
    assert aux["recent_loss"] < aux["recent_base_rate_loss"], f"the head predicts better than the base rate: {aux}"
    # The weight file holds the Q-network only: the same records as a run without the head.
    plain = make_trainer(tmp_path / "plain", episodes=8)
    plain.run()
    with_head, without = load_weights(summary["model"]), load_weights(str(tmp_path / "plain" / "model.dqnw"))
    assert [(r.stream, r.type, r.shape) for r in with_head.layers] == [(r.stream, r.type, r.shape) for r in without.layers]
    with pytest.raises(ConfigError, match="auxiliary differs"):
        make_trainer(tmp_path / "run", dict(auxiliary, horizon=5), resume=True)


@pytest.mark.parametrize("change, message", [
    ({"horizon": -1}, r"auxiliary.horizon must be >= 0 \(0: off\), got -1"),
    ({"horizon": 5, "loss_weight": -0.5}, "auxiliary.loss_weight must be >= 0, got -0.5"),
    ({"horizon": 5, "batch_size": 0}, "auxiliary.batch_size must be >= 1"),
    ({"depth": 2}, r"auxiliary: unknown field\(s\) \['depth'\]"),
])
def test_bad_auxiliary_settings_are_named(change, message):
    raw = copy.deepcopy(RAW)
    raw["auxiliary"] = change
    with pytest.raises(ConfigError, match=message):
        Trainer(TrainConfig.from_dict(raw), "/nonexistent/never-made", device="cpu")


def test_the_shipped_auxiliary_configuration_is_the_worlds_one_with_a_head():
    headed = load_config(os.path.join(REPO, "config", "finetune_worlds_aux.yaml"))
    plain = load_config(os.path.join(REPO, "config", "finetune_worlds.yaml"))
    assert headed.auxiliary.horizon == 5 and not plain.auxiliary.enabled
    assert headed.to_dict() | {"auxiliary": None} == plain.to_dict() | {"auxiliary": None}
