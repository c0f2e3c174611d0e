"""The search kernel (issue 53, item 2): branch and bound finds what the exhaustive search
finds, the chunks do not change the exhaustive search, the grid keeps the smallest of equal
shares, the closed form is the grid's under perfect SIC, and rounds of best responses stop as
documented."""

import numpy as np
import pytest

from adaptsky.rollouts.search import (
    Best,
    LatticeBoxes,
    best_in_chunks,
    best_on_grid,
    best_shares,
    best_shares_on_grid,
    branch_and_bound,
    every_point,
    grid_points,
    lattice_chunks,
    response_rounds,
)
from tests.conftest import make_scenario

START = Best(0.0, np.zeros(3), np.zeros(2))


def _problem(seed: int):
    """A lattice of 20 x 12 x 9 points in boxes, a random value per point (some below 0,
    some -inf as in a building), and each box's bound: its largest value plus a slack."""
    rng = np.random.default_rng(seed)
    boxes = LatticeBoxes([np.arange(20.0), np.arange(12.0) * 2, 10.0 + np.arange(9.0)])
    table = rng.normal(0.0, 1.0, (20, 12, 9))
    table[rng.random(table.shape) < 0.1] = -np.inf

    def values(points):
        i, j, k = points[:, 0].astype(int), (points[:, 1] / 2).astype(int), (
            points[:, 2] - 10).astype(int)
        return table[i, j, k], np.column_stack([points[:, 0], points[:, 2]])

    bound = np.array([values(boxes.points(np.array([box])))[0].max()
                      for box in range(len(boxes.low))])
    return boxes, values, bound + rng.exponential(0.3, len(bound))


@pytest.mark.parametrize("seed", range(6))
def test_branch_and_bound_finds_what_the_exhaustive_search_finds(seed):
    boxes, values, bound = _problem(seed)
    every = grid_points(*boxes.axes)
    exhaustive = best_in_chunks(lattice_chunks(every, 97), values, START)
    assert exhaustive.value > 1.0                          # a point beats the start
    for previous, first_alone in ((None, False), (every[seed * 100], True),
                                  (every[-1], False)):
        found, valued = branch_and_bound(bound, boxes.ranked(bound, previous), boxes.points,
                                         every_point(values), START, first_alone=first_alone,
                                         per_batch=2)
        assert found.value == exhaustive.value
        np.testing.assert_array_equal(found.point_m, exhaustive.point_m)
        np.testing.assert_array_equal(found.shares, exhaustive.shares)
        assert valued < boxes.count                        # it pruned
    # a threshold no box's bound exceeds: nothing valued, the start kept
    found, valued = branch_and_bound(bound, boxes.ranked(bound), boxes.points,
                                     every_point(values), START, beat=bound.max())
    assert found is START and valued == 0


def test_the_chunk_size_does_not_change_the_exhaustive_search():
    boxes, values, _ = _problem(7)
    every = grid_points(*boxes.axes)
    heard = []
    whole = best_in_chunks([(every, 1.0)], values, START)
    sizes = (1, 13, 500, len(every) + 1)
    for size in sizes:
        found = best_in_chunks(lattice_chunks(every, size), values, START, heard.append)
        assert found.value == whole.value
        np.testing.assert_array_equal(found.point_m, whole.point_m)
        assert heard[-1] == 1.0
    assert len(heard) == sum(-(-len(every) // size) for size in sizes)
    # nothing beats the start: the start comes back
    assert best_in_chunks(lattice_chunks(every), lambda p: (np.full(len(p), -1.0),
                                                            np.zeros((len(p), 2))),
                          START) is START


def test_the_grid_keeps_the_smallest_of_equal_shares():
    grid = np.array([0.1, 0.2, 0.3, 0.4])
    peak = np.array([0.3, 0.1, 0.25])                # the third lies between 0.2 and 0.3
    value, share = best_on_grid(grid, lambda s: np.round(-np.abs(s - peak), 12),
                                np.full(3, np.nan))
    np.testing.assert_array_equal(share, [0.3, 0.1, 0.2])
    np.testing.assert_array_equal(value, [0.0, 0.0, -0.05])
    # no share beats -inf: the start stays
    value, share = best_on_grid(grid, lambda s: np.full(2, -np.inf), np.array([0.7, 0.8]))
    np.testing.assert_array_equal(share, [0.7, 0.8])
    assert np.all(value == -np.inf)


@pytest.mark.parametrize("min_se", [0.0, 0.5, 2.0])
def test_the_closed_form_is_the_grids_best_share_under_perfect_sic(min_se):
    scenario = make_scenario(reward={"min_se": min_se}, uav={"power_step": 0.05})
    rng = np.random.default_rng(3)
    gains = 10.0 ** rng.uniform(-12, -8, (2, 400, 2))
    alphas = np.round(np.arange(0.05, 0.96, 0.05), 12)
    snr = 1e11
    closed_alpha, closed_rate = best_shares(gains[0], gains[1], alphas, scenario, snr)
    grid_alpha, grid_rate = best_shares_on_grid(gains[0], gains[1], alphas, scenario, snr)
    np.testing.assert_allclose(closed_rate, grid_rate, rtol=1e-12)
    feasible = np.isfinite(grid_rate)
    assert 0 < feasible.sum() <= feasible.size
    np.testing.assert_allclose(closed_alpha[feasible], grid_alpha[feasible], rtol=1e-12)


def test_rounds_stop_when_a_round_gains_nothing_or_at_the_limit():
    # two UAVs on a line, the value -(x0 - 3)^2 - (x1 + 1)^2; a response jumps to the optimum
    target = np.array([3.0, -1.0])

    def worth(uav_m):
        return float(-np.sum((uav_m[:, 0] - target) ** 2))

    def respond(round_index, u, value):
        moved = uav_m.copy()
        moved[u, 0] = target[u]
        return Best(worth(moved), moved[u], np.array([0.5]))

    uav_m, shares = np.zeros((2, 3)), np.zeros((2, 1))
    value, rounds, converged = response_rounds(respond, uav_m, shares, worth(uav_m), 10)
    assert (value, rounds, converged) == (0.0, 2, True)      # the second round gains nothing
    np.testing.assert_array_equal(uav_m[:, 0], target)
    np.testing.assert_array_equal(shares, 0.5)
    uav_m, shares = np.zeros((2, 3)), np.zeros((2, 1))
    value, rounds, converged = response_rounds(respond, uav_m, shares, worth(uav_m), 1)
    assert (value, rounds, converged) == (0.0, 1, False)
