"""The separation rule (docs/model.md §9): UAVs whose moves would bring two of them closer
than ``uav.min_separation_m`` horizontally keep their positions that step."""

from __future__ import annotations

import itertools

import numpy as np

from adaptsky.sim.separation import horizontal_distances_m, separated


def _step(before, after, min_separation_m=10.0):
    return separated(np.array([before], dtype=float), np.array([after], dtype=float),
                     min_separation_m)[0].tolist()


def test_two_uavs_closing_below_the_separation_both_stay():
    before = [[0, 0, 50], [11, 0, 50], [40, 0, 50]]
    after = [[1, 0, 51], [10, 0, 49], [41, 0, 50]]       # 9 m apart: too close
    assert _step(before, after) == [[0, 0, 50], [11, 0, 50], [41, 0, 50]]


def test_height_does_not_count_and_moves_that_keep_the_separation_go_ahead():
    before = [[0, 0, 50], [12, 0, 10]]
    after = [[1, 0, 51], [11, 0, 11]]                     # 10 m apart: allowed
    assert _step(before, after) == after
    assert _step([[0, 0, 10], [10, 0, 200]], [[0, 0, 11], [10, 0, 199]]) == [[0, 0, 11],
                                                                               [10, 0, 199]]


def test_a_uav_held_back_holds_back_one_that_would_come_too_close_to_it():
    before = [[0, 0, 50], [10, 0, 50], [21, 0, 50]]
    after = [[1, 0, 50], [9, 0, 50], [20, 0, 50]]
    # 0 and 1 close to 8 m: both stay; then 2 at 20 would be 10 m from 1 at 10 -> allowed
    assert _step(before, after) == [[0, 0, 50], [10, 0, 50], [20, 0, 50]]
    after = [[1, 0, 50], [9, 0, 50], [19, 0, 50]]
    # 1 stays at 10; 2 at 19 would be 9 m from it (10 m from 1's proposed 9): held too
    assert _step(before, after) == before


def test_uavs_already_too_close_may_move_apart():
    assert _step([[0, 0, 50], [5, 0, 50]], [[-1, 0, 50], [6, 0, 50]]) == [[-1, 0, 50],
                                                                            [6, 0, 50]]


def test_every_uav_moves_or_stays_and_no_pair_comes_closer_below_the_separation():
    rng = np.random.default_rng(0)
    for _ in range(200):
        before = np.concatenate([rng.uniform(-30, 30, (4, 5, 2)), np.full((4, 5, 1), 50.0)],
                                axis=2)
        after = before + rng.choice([-3.0, 0.0, 3.0], size=before.shape)
        result = separated(before, after, 10.0)
        moved = np.all(result == after, axis=2)
        assert np.all(moved | np.all(result == before, axis=2))
        d_before, d_result = horizontal_distances_m(before), horizontal_distances_m(result)
        for b, u, v in itertools.product(range(4), range(5), range(5)):
            if u != v and d_result[b, u, v] < 10.0:
                assert d_result[b, u, v] >= d_before[b, u, v]
        # a UAV held back had a reason: letting it move alone would break the rule
        for b, u in itertools.product(range(4), range(5)):
            if not moved[b, u] and not np.all(after[b, u] == before[b, u]):
                trial = result[b].copy()
                trial[u] = after[b, u]
                d_trial = horizontal_distances_m(trial[None])[0]
                closer = (d_trial[u] < 10.0) & (d_trial[u] < d_before[b, u])
                closer[u] = False
                was_close = (horizontal_distances_m(after[b][None])[0][u] < 10.0) & (
                    horizontal_distances_m(after[b][None])[0][u] < d_before[b, u])
                was_close[u] = False
                assert closer.any() or was_close.any()
