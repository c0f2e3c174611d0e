"""The action set of sec. IV-B.2: 2^(3+K) actions, every component in {-1, +1}."""

import itertools

import numpy as np
import pytest

from adaptsky.sim.actions import ActionSet


def test_paper_action_set_has_32_distinct_actions_for_four_users():
    actions = ActionSet(num_clusters=2)
    assert actions.count == 32
    decoded = actions.decode(np.arange(32))
    assert decoded.shape == (32, 5)
    assert set(np.unique(decoded)) == {-1, 1}          # no "stay" move
    as_tuples = {tuple(row) for row in decoded}
    assert as_tuples == set(itertools.product((-1, 1), repeat=5))


def test_component_order_is_x_y_h_then_clusters():
    actions = ActionSet(num_clusters=2)
    assert actions.decode(np.array([0]))[0].tolist() == [-1, -1, -1, -1, -1]
    assert actions.decode(np.array([1]))[0].tolist() == [1, -1, -1, -1, -1]
    assert actions.decode(np.array([4]))[0].tolist() == [-1, -1, 1, -1, -1]
    assert actions.decode(np.array([16]))[0].tolist() == [-1, -1, -1, -1, 1]


@pytest.mark.parametrize(("mode", "clusters", "count"), [("paper", 1, 16), ("paper", 3, 64),
                                                          ("with-hover", 2, 243)])
def test_encode_inverts_decode(mode, clusters, count):
    actions = ActionSet(clusters, mode)
    assert actions.count == count
    indices = np.arange(count)
    decoded = actions.decode(indices)
    assert len({tuple(row) for row in decoded}) == count
    assert np.array_equal(actions.encode(decoded), indices)


def test_with_hover_contains_staying_put():
    actions = ActionSet(2, "with-hover")
    stay = actions.encode(np.zeros(5, dtype=int))
    assert actions.decode(np.array([stay]))[0].tolist() == [0, 0, 0, 0, 0]


def test_eight_uavs_of_four_clusters_index_2_to_the_56_actions_exactly():
    """The dense index of eight UAVs (56 components) is an int64: every digit survives."""
    actions = ActionSet(4, "paper", 8)
    assert (actions.num_components, actions.count) == (56, 2**56)
    directions = np.random.default_rng(0).choice([-1, 1], size=(5, 56))
    indices = actions.encode(directions)
    assert np.array_equal(actions.decode(indices), directions)
    assert actions.decode(np.array([actions.count - 1]))[0].tolist() == [1] * 56


def test_an_action_set_beyond_an_int64_index_is_refused():
    with pytest.raises(ValueError, match=r"^2\^63 actions of 9 UAVs of 4 clusters are more "
                                         r"than an int64 action index holds \(2\^62\)$"):
        ActionSet(4, "paper", 9)
