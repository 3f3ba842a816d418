"""Sum tree and prioritized replay: tree sums, sampling proportions, IS weights, masks."""

import numpy as np
import pytest

from dqn_dovs_py.replay import PrioritizedReplay, SumTree, Transitions


def make_transitions(n, start=0, rng=None, num_actions=8):
    rng = rng or np.random.default_rng(0)
    state = np.where(rng.random((n, 408)) < 0.5, -1.0, 1.0).astype(np.float32)
    state[:, 400:] = rng.normal(size=(n, 8))
    mask = np.ones((n, num_actions), bool)
    mask[:, 5:] = rng.random((n, 3)) < 0.5
    next_state = state[::-1].copy()
    return Transitions(
        state=state, mask=mask, action=(np.arange(n) % 5).astype(np.int64),
        reward=np.arange(start, start + n, dtype=np.float32), discount=np.full(n, 0.9, np.float32),
        next_state=next_state, next_mask=mask[::-1].copy())


def test_sum_tree_totals_and_minimum_follow_updates():
    tree = SumTree(5)
    tree.update(np.arange(5), np.array([1.0, 2.0, 3.0, 4.0, 5.0]))
    assert tree.total == pytest.approx(15.0)
    assert tree.min_priority == pytest.approx(1.0)
    tree.update(np.array([0, 4]), np.array([10.0, 0.5]))
    assert tree.total == pytest.approx(10 + 2 + 3 + 4 + 0.5)
    assert tree.min_priority == pytest.approx(0.5)
    np.testing.assert_allclose(tree.get(np.arange(5)), [10, 2, 3, 4, 0.5])


def test_sum_tree_repeated_index_keeps_last_write():
    tree = SumTree(4)
    tree.update(np.array([1, 1, 2, 1]), np.array([5.0, 6.0, 1.0, 7.0]))
    assert tree.get(np.array([1]))[0] == 7.0
    assert tree.total == pytest.approx(8.0)


def test_sum_tree_find_maps_cumulative_intervals():
    tree = SumTree(4)
    tree.update(np.arange(4), np.array([1.0, 0.0, 2.0, 3.0]))
    # Intervals: leaf 0 [0,1), leaf 1 empty, leaf 2 [1,3), leaf 3 [3,6).
    found = tree.find(np.array([0.0, 0.999, 1.0, 2.9, 3.0, 5.999]))
    np.testing.assert_array_equal(found, [0, 0, 2, 2, 3, 3])


def test_sum_tree_never_lands_on_empty_leaf_at_the_top():
    tree = SumTree(6)  # padded to 8 leaves; leaves 6 and 7 stay empty
    tree.update(np.arange(6), np.ones(6))
    found = tree.find(np.array([np.nextafter(6.0, 0.0), 6.0, 7.5]))
    assert np.all(found <= 5)


def test_sum_tree_rejects_bad_input():
    tree = SumTree(3)
    with pytest.raises(IndexError, match="out of range"):
        tree.update(np.array([3]), np.array([1.0]))
    with pytest.raises(ValueError, match="finite"):
        tree.update(np.array([0]), np.array([np.nan]))
    with pytest.raises(ValueError, match="capacity"):
        SumTree(0)


def test_sampling_frequencies_follow_priorities():
    replay = PrioritizedReplay(capacity=8, alpha=1.0, priority_eps=1e-9, seed=3)
    replay.add(make_transitions(8))
    td = np.array([1.0, 2.0, 3.0, 4.0, 0.5, 0.5, 8.0, 1.0])
    replay.update_priorities(np.arange(8), td)
    counts = np.zeros(8)
    draws = 0
    for _ in range(2000):
        batch = replay.sample(32, beta=0.4)
        np.add.at(counts, batch.indices, 1)
        draws += 32
    expected = td / td.sum()
    np.testing.assert_allclose(counts / draws, expected, atol=0.01)


def test_alpha_flattens_priorities():
    replay = PrioritizedReplay(capacity=2, alpha=0.5, priority_eps=1e-12, seed=0)
    replay.add(make_transitions(2))
    replay.update_priorities(np.arange(2), np.array([1.0, 4.0]))
    np.testing.assert_allclose(replay.priorities(np.arange(2)), [1.0, 2.0], rtol=1e-6)


def test_importance_weights_match_definition():
    replay = PrioritizedReplay(capacity=4, alpha=1.0, priority_eps=1e-12, seed=1)
    replay.add(make_transitions(4))
    p = np.array([1.0, 2.0, 3.0, 4.0])
    replay.update_priorities(np.arange(4), p)
    beta = 0.6
    batch = replay.sample(64, beta)
    probs = p / p.sum()
    weights = (4 * probs[batch.indices]) ** -beta
    np.testing.assert_allclose(batch.weights, weights / weights.max(), rtol=1e-5)
    assert batch.weights.max() <= 1.0 + 1e-6
    # beta = 0: no correction at all.
    np.testing.assert_allclose(replay.sample(16, 0.0).weights, 1.0)


def test_importance_weights_are_normalised_by_the_batch_maximum():
    """One tiny priority elsewhere in the buffer must not shrink the weights of a batch that does not hold it."""
    replay = PrioritizedReplay(capacity=64, alpha=1.0, priority_eps=1e-12, seed=4)
    replay.add(make_transitions(64))
    p = np.linspace(1.0, 2.0, 64)
    p[0] = 1e-6  # sampled with probability ~1e-8 per draw
    replay.update_priorities(np.arange(64), p)
    beta = 1.0
    batch = replay.sample(16, beta)
    assert 0 not in batch.indices
    probs = p / p.sum()
    weights = (64 * probs[batch.indices]) ** -beta
    np.testing.assert_allclose(batch.weights, weights / weights.max(), rtol=1e-5)
    assert batch.weights.max() == pytest.approx(1.0)
    assert np.all((batch.weights > 0.0) & (batch.weights <= 1.0 + 1e-6))
    # The smallest priority of the batch gets weight 1, the largest (p_min / p_max) ** beta of the batch.
    sampled = p[batch.indices]
    assert batch.weights.min() == pytest.approx((sampled.min() / sampled.max()) ** beta, rel=1e-5)


def test_new_transitions_get_max_priority():
    replay = PrioritizedReplay(capacity=10, alpha=1.0, priority_eps=1e-12)
    replay.add(make_transitions(3))
    replay.update_priorities(np.array([0, 1, 2]), np.array([0.1, 7.0, 0.2]))
    slots = replay.add(make_transitions(2, start=3))
    np.testing.assert_allclose(replay.priorities(slots), [7.0, 7.0], rtol=1e-6)


def test_stored_data_round_trips_exactly_and_wraps():
    replay = PrioritizedReplay(capacity=5, seed=0)
    first = make_transitions(4, rng=np.random.default_rng(1))
    second = make_transitions(3, start=100, rng=np.random.default_rng(2))
    replay.add(first)
    slots = replay.add(second)
    np.testing.assert_array_equal(slots, [4, 0, 1])
    assert len(replay) == 5
    got = replay.gather(slots)
    for name in ("state", "mask", "action", "reward", "discount", "next_state", "next_mask"):
        np.testing.assert_array_equal(getattr(got, name), getattr(second, name), err_msg=name)
    # Slot 2 still holds the third transition of the first batch.
    np.testing.assert_array_equal(replay.gather(np.array([2])).state[0], first.state[2])


def test_compact_storage_rejects_non_binary_grid():
    replay = PrioritizedReplay(capacity=4)
    batch = make_transitions(2)
    batch.state[1, 17] = 0.5
    with pytest.raises(ValueError, match=r"state grid cells must be exactly \+1 or -1"):
        replay.add(batch)
    loose = PrioritizedReplay(capacity=4, compact_states=False)
    loose.add(batch)
    assert loose.gather(np.array([1])).state[0, 17] == 0.5


def test_add_rejects_action_invalid_under_its_mask_and_nan():
    replay = PrioritizedReplay(capacity=4)
    batch = make_transitions(2)
    batch.mask[0, batch.action[0]] = False
    with pytest.raises(ValueError, match="invalid under its own mask"):
        replay.add(batch)
    batch = make_transitions(2)
    batch.reward[1] = np.nan
    with pytest.raises(ValueError, match="reward contains NaN"):
        replay.add(batch)


def test_non_finite_td_error_is_a_clear_error():
    replay = PrioritizedReplay(capacity=4)
    replay.add(make_transitions(2))
    with pytest.raises(FloatingPointError, match="diverged"):
        replay.update_priorities(np.array([0]), np.array([np.inf]))


def test_state_dict_restores_sampling_exactly():
    replay = PrioritizedReplay(capacity=16, seed=5)
    replay.add(make_transitions(10))
    replay.update_priorities(np.arange(10), np.linspace(0.1, 3.0, 10))
    state = replay.state_dict()
    twin = PrioritizedReplay(capacity=16, seed=99)
    twin.load_state_dict(state)
    a, b = replay.sample(8, 0.5), twin.sample(8, 0.5)
    np.testing.assert_array_equal(a.indices, b.indices)
    np.testing.assert_allclose(a.weights, b.weights)
    np.testing.assert_array_equal(a.transitions.next_state, b.transitions.next_state)
