"""n-step transitions: full windows, terminal vs truncated episode ends, per-env windows."""

import numpy as np
import pytest

from dqn_dovs_py.replay import NStepAccumulator

GAMMA = 0.9


def state_of(env, t):
    """A state that encodes (env, step) in its first two features for identification."""
    s = np.ones(408, np.float32)
    s[400], s[401] = env, t
    return s


class Driver:
    """Steps NStepAccumulator with identifiable states; reward of step t in env e = 10*e + t + 1."""

    def __init__(self, num_envs, n):
        self.acc = NStepAccumulator(num_envs, n, GAMMA)
        self.num_envs = num_envs
        self.t = np.zeros(num_envs, int)
        self.episode = np.zeros(num_envs, int)

    def step(self, terminated=(), truncated=()):
        e = self.num_envs
        term = np.zeros(e, bool)
        trunc = np.zeros(e, bool)
        term[list(terminated)] = True
        trunc[list(truncated)] = True
        state = np.stack([state_of(i, self.t[i]) for i in range(e)])
        nxt = np.stack([state_of(i, self.t[i] + 1) for i in range(e)])
        mask = np.ones((e, 8), bool)
        next_mask = np.ones((e, 8), bool)
        next_mask[:, 7] = False  # distinguishes next masks from current ones
        reward = np.array([10 * i + self.t[i] + 1 for i in range(e)], np.float32)
        out = self.acc.push(state, mask, self.t % 5, reward, nxt, next_mask, term, trunc)
        self.t += 1
        self.t[term | trunc] = 0
        return out


def rewards_from(env, start, count):
    return [10 * env + t + 1 for t in range(start, start + count)]


def discounted(rewards):
    return sum(GAMMA ** k * r for k, r in enumerate(rewards))


def test_full_window_emits_oldest_step_with_gamma_to_the_n():
    d = Driver(1, 3)
    assert len(d.step()) == 0
    assert len(d.step()) == 0
    out = d.step()
    assert len(out) == 1
    assert out.state[0, 401] == 0 and out.next_state[0, 401] == 3
    assert out.reward[0] == pytest.approx(discounted(rewards_from(0, 0, 3)))
    assert out.discount[0] == pytest.approx(GAMMA ** 3)
    assert not out.next_mask[0, 7]
    out = d.step()
    assert out.state[0, 401] == 1 and out.next_state[0, 401] == 4
    assert out.reward[0] == pytest.approx(discounted(rewards_from(0, 1, 3)))


def test_terminal_end_flushes_window_without_bootstrap():
    d = Driver(1, 3)
    for _ in range(4):
        d.step()  # emits steps 0 and 1
    out = d.step(terminated=[0])  # step 4 ends the episode: steps 2, 3, 4 remain
    assert len(out) == 3
    np.testing.assert_array_equal(out.state[:, 401], [2, 3, 4])
    np.testing.assert_allclose(out.reward, [discounted(rewards_from(0, 2, 3)), discounted(rewards_from(0, 3, 2)),
                                            discounted(rewards_from(0, 4, 1))], rtol=1e-6)
    np.testing.assert_array_equal(out.discount, [0.0, 0.0, 0.0])
    np.testing.assert_array_equal(out.next_state[:, 401], [5, 5, 5])


def test_truncated_end_bootstraps_from_final_state_with_shortened_discount():
    d = Driver(1, 5)
    d.step()
    d.step()
    out = d.step(truncated=[0])
    np.testing.assert_array_equal(out.state[:, 401], [0, 1, 2])
    np.testing.assert_allclose(out.discount, [GAMMA ** 3, GAMMA ** 2, GAMMA], rtol=1e-6)
    np.testing.assert_allclose(out.reward, [discounted(rewards_from(0, 0, 3)), discounted(rewards_from(0, 1, 2)),
                                            discounted(rewards_from(0, 2, 1))], rtol=1e-6)
    np.testing.assert_array_equal(out.next_state[:, 401], [3, 3, 3])


def test_terminated_wins_when_both_flags_are_set():
    d = Driver(1, 2)
    out = d.step(terminated=[0], truncated=[0])
    assert out.discount[0] == 0.0


def test_new_episode_never_mixes_with_the_previous_one():
    d = Driver(1, 3)
    d.step()
    d.step(terminated=[0])
    # New episode: the first full window appears only after 3 new steps.
    assert len(d.step()) == 0
    assert len(d.step()) == 0
    out = d.step()
    assert len(out) == 1
    assert out.state[0, 401] == 0
    assert out.reward[0] == pytest.approx(discounted(rewards_from(0, 0, 3)))


def test_environments_keep_separate_windows():
    d = Driver(3, 2)
    d.step()
    out = d.step(terminated=[1])
    # env 0 and 2: one full-window transition each; env 1: two flushed transitions.
    assert len(out) == 4
    by_env = {}
    for i in range(len(out)):
        by_env.setdefault(int(out.state[i, 400]), []).append(i)
    assert sorted(by_env) == [0, 1, 2]
    for env in (0, 2):
        (i,) = by_env[env]
        assert out.reward[i] == pytest.approx(discounted(rewards_from(env, 0, 2)))
        assert out.discount[i] == pytest.approx(GAMMA ** 2)
    np.testing.assert_allclose(sorted(out.reward[by_env[1]]), sorted([discounted(rewards_from(1, 0, 2)), 12.0]))
    assert np.all(out.discount[by_env[1]] == 0.0)
    assert np.all(out.state[:, 400] == out.next_state[:, 400])


def test_one_step_returns_equal_plain_dqn():
    d = Driver(2, 1)
    out = d.step(truncated=[1])
    np.testing.assert_allclose(out.reward, [1.0, 11.0])
    np.testing.assert_allclose(out.discount, [GAMMA, GAMMA])


def test_every_step_is_emitted_exactly_once():
    rng = np.random.default_rng(0)
    d = Driver(4, 5)
    seen = set()
    pushed = 0
    for _ in range(300):
        ends = np.flatnonzero(rng.random(4) < 0.08)
        kinds = rng.random(ends.size) < 0.5
        episode_before = d.episode.copy()
        t_before = d.t.copy()
        out = d.step(terminated=ends[kinds], truncated=ends[~kinds])
        pushed += 4
        d.episode[ends] += 1
        for i in range(len(out)):
            e, t = int(out.state[i, 400]), int(out.state[i, 401])
            key = (e, int(episode_before[e]), t)
            assert key not in seen
            assert t <= t_before[e]
            seen.add(key)
    assert len(seen) == pushed - int(d.acc.pending().sum())


def test_shape_errors_name_the_argument():
    acc = NStepAccumulator(2, 3, GAMMA)
    with pytest.raises(ValueError, match="next_mask has shape"):
        acc.push(np.zeros((2, 408)), np.ones((2, 8), bool), np.zeros(2, int), np.zeros(2), np.zeros((2, 408)),
                 np.ones((3, 8), bool), np.zeros(2, bool), np.zeros(2, bool))


def one_action(action, num_actions=8):
    mask = np.zeros(num_actions, bool)
    mask[action] = True
    return mask


def test_deferred_bootstrap_takes_the_mask_pushed_with_the_bootstrap_state():
    """With defer_bootstrap, a transition bootstraps under the mask its bootstrap state was acted on with (here a
    one-action mask, as where the shield's escape ran), one step later than without."""
    n = 2
    acc = NStepAccumulator(1, n, GAMMA, defer_bootstrap=True)
    env_mask = np.ones((1, 8), bool)  # what the environment reported for every successor

    def push(t, terminated=False):
        return acc.push(state_of(0, t)[None], one_action(t % 8)[None], np.array([t % 8]),
                        np.array([10.0 + t], np.float32), state_of(0, t + 1)[None], env_mask,
                        np.array([terminated]), np.array([False]))

    assert len(push(0)) == 0
    assert len(push(1)) == 0  # without deferring, step 0 would be emitted here, under env_mask
    out = push(2)
    assert len(out) == 1
    assert out.state[0, 401] == 0 and out.next_state[0, 401] == 2
    np.testing.assert_array_equal(out.next_mask[0], one_action(2))
    assert out.reward[0] == pytest.approx(10.0 + GAMMA * 11.0)
    assert out.discount[0] == pytest.approx(GAMMA ** n)
    np.testing.assert_array_equal(out.mask[0], one_action(0))
    # Step 3 ends the episode: step 1 bootstraps on state 3 (acted on) under its mask, steps 2 and 3 are flushed.
    out = push(3, terminated=True)
    np.testing.assert_array_equal(out.state[:, 401], [1, 2, 3])
    np.testing.assert_array_equal(out.next_state[:, 401], [3, 4, 4])
    np.testing.assert_array_equal(out.next_mask[0], one_action(3))
    np.testing.assert_allclose(out.discount, [GAMMA ** 2, 0.0, 0.0], rtol=1e-6)
    np.testing.assert_allclose(out.reward, [11.0 + GAMMA * 12.0, 12.0 + GAMMA * 13.0, 13.0], rtol=1e-6)
    assert acc.pending()[0] == 0


def test_deferred_bootstrap_gives_the_same_transitions_when_no_mask_is_overridden():
    """Where each pushed mask is the previous step's next_mask (nothing overridden), deferring changes when the
    transitions come out, never what they hold, and still emits every step exactly once."""
    rng = np.random.default_rng(1)
    e, n = 3, 4
    plain = NStepAccumulator(e, n, GAMMA)
    deferred = NStepAccumulator(e, n, GAMMA, defer_bootstrap=True)
    t = np.zeros(e, int)
    episode = np.zeros(e, int)
    mask = rng.random((e, 8)) < 0.5
    mask[:, 4] = True
    outs = {"plain": [], "deferred": []}
    for _ in range(400):
        ended = rng.random(e) < 0.06
        kinds = rng.random(e) < 0.5
        state = np.stack([state_of(i, t[i]) for i in range(e)])
        state[:, 402] = episode
        nxt = np.stack([state_of(i, t[i] + 1) for i in range(e)])
        nxt[:, 402] = episode
        next_mask = rng.random((e, 8)) < 0.5
        next_mask[:, 4] = True
        args = (state, mask, t % 5, rng.normal(size=e).astype(np.float32), nxt, next_mask, ended & kinds,
                ended & ~kinds)
        outs["plain"].append(plain.push(*args))
        outs["deferred"].append(deferred.push(*args))
        t += 1
        t[ended] = 0
        episode[ended] += 1
        mask = next_mask.copy()
        fresh = rng.random((e, 8)) < 0.5
        fresh[:, 4] = True
        mask[ended] = fresh[ended]  # a new episode's first mask

    def by_step(parts):
        rows = {}
        for out in parts:
            for i in range(len(out)):
                key = (int(out.state[i, 400]), int(out.state[i, 402]), int(out.state[i, 401]))
                assert key not in rows
                rows[key] = (out.mask[i].tobytes(), int(out.action[i]), float(out.reward[i]), float(out.discount[i]),
                             out.next_state[i].tobytes(), out.next_mask[i].tobytes())
        return rows

    plain_rows = by_step(outs["plain"])
    deferred_rows = by_step(outs["deferred"])
    # The deferred accumulator holds one more step per running episode; all the rest is identical.
    assert set(deferred_rows) <= set(plain_rows)
    assert len(plain_rows) - len(deferred_rows) == int(deferred.pending().sum() - plain.pending().sum())
    for key, row in deferred_rows.items():
        assert row == plain_rows[key], key
    assert len(deferred_rows) == 400 * e - int(deferred.pending().sum())
