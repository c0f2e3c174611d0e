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
