"""Association of users to several UAVs (docs/model.md §9): the exact assignment, the
deterministic balanced k-means, the matching of groups to UAVs by least total distance, and
NOMA clusters inside each group."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from adaptsky.sim.association import (
    associate,
    balanced_kmeans,
    match_groups,
    min_cost_assignment,
    serving_groups,
)


@pytest.mark.parametrize("seed", range(20))
def test_the_assignment_is_the_least_total_cost_of_brute_force(seed):
    rng = np.random.default_rng(seed)
    rows = int(rng.integers(1, 6))
    cost = rng.uniform(0, 10, size=(rows, int(rng.integers(rows, 7))))
    if seed % 4 == 0:
        cost = np.round(cost)            # ties
    columns = min_cost_assignment(cost)
    assert len(set(columns.tolist())) == rows
    best = min(sum(cost[i, p[i]] for i in range(rows))
               for p in itertools.permutations(range(cost.shape[1]), rows))
    assert cost[np.arange(rows), columns].sum() == pytest.approx(best, abs=1e-12)


def _circle(num_uavs, radius_m=50.0):
    return np.array([[radius_m * math.cos(2 * math.pi * u / num_uavs),
                      radius_m * math.sin(2 * math.pi * u / num_uavs), 50.0]
                     for u in range(num_uavs)])


@pytest.mark.parametrize(("n", "num_uavs"), [(8, 2), (12, 3), (16, 4), (12, 6), (4, 1)])
def test_balanced_kmeans_gives_equal_groups_and_is_deterministic(n, num_uavs):
    rng = np.random.default_rng(n * 10 + num_uavs)
    for _ in range(5):
        users_m = rng.uniform(-100, 100, size=(n, 2))
        labels = balanced_kmeans(users_m, _circle(num_uavs)[:, :2])
        assert np.bincount(labels, minlength=num_uavs).tolist() == [n // num_uavs] * num_uavs
        assert np.array_equal(balanced_kmeans(users_m.copy(), _circle(num_uavs)[:, :2]),
                              labels)
        # a fixed point of Lloyd's balanced step: no two equal groups nearer its centres
        centres = np.stack([users_m[labels == g].mean(axis=0) for g in range(num_uavs)])
        if num_uavs == 2:
            mine = sum(np.sum((users_m[labels == g] - centres[g]) ** 2) for g in range(2))
            for group in itertools.combinations(range(n), n // 2):
                other = np.ones(n, dtype=int)
                other[list(group)] = 0
                assert mine <= sum(np.sum((users_m[other == g] - centres[g]) ** 2)
                                   for g in range(2)) + 1e-9


def test_balanced_kmeans_finds_separated_clumps():
    clumps = np.array([[-60.0, -60.0], [60.0, 60.0], [-60.0, 60.0], [60.0, -60.0]])
    rng = np.random.default_rng(4)
    users_m = np.concatenate([c + rng.uniform(-5, 5, size=(4, 2)) for c in clumps])
    labels = balanced_kmeans(users_m, _circle(4)[:, :2])
    for c in range(4):
        assert len(set(labels[4 * c:4 * c + 4].tolist())) == 1
    assert len(set(labels.tolist())) == 4


@pytest.mark.parametrize("num_uavs", [1, 2, 3, 4, 5])
def test_groups_are_matched_to_uavs_by_least_total_distance(num_uavs):
    rng = np.random.default_rng(num_uavs)
    for _ in range(10):
        centroids = rng.uniform(-100, 100, size=(num_uavs, 2))
        starts = np.concatenate([rng.uniform(-100, 100, size=(num_uavs, 2)),
                                 np.full((num_uavs, 1), 50.0)], axis=1)
        uav_of_group = match_groups(centroids, starts)
        assert sorted(uav_of_group.tolist()) == list(range(num_uavs))

        def total(perm, centroids=centroids, starts=starts):
            return sum(math.dist(centroids[g], starts[perm[g], :2]) for g in range(num_uavs))
        best = min(total(p) for p in itertools.permutations(range(num_uavs)))
        assert total(uav_of_group) == pytest.approx(best, rel=1e-12)


def test_serving_groups_put_each_clump_with_its_nearest_uav_whatever_the_start_order():
    clumps = np.array([[-60.0, -60.0], [60.0, 60.0]])
    users_m = np.concatenate([c + np.array([[0, 0], [3, 1], [1, 3], [-2, 2.0]])
                              for c in clumps])[None]
    starts = np.array([[40.0, 40.0, 50.0], [-40.0, -40.0, 50.0]])
    serving = serving_groups(users_m, starts, "kmeans")
    assert serving.tolist() == [[1, 1, 1, 1, 0, 0, 0, 0]]
    assert serving_groups(users_m, starts[::-1], "kmeans").tolist() == [[0] * 4 + [1] * 4]
    listed = serving_groups(np.repeat(users_m, 2, axis=0), starts, "listed",
                            [0, 1, 0, 1, 0, 1, 0, 1])
    assert listed.tolist() == [[0, 1, 0, 1, 0, 1, 0, 1]] * 2


def test_clusters_inside_each_group_listed_and_near_far():
    serving = np.array([[1, 0, 1, 0, 0, 1, 0, 1]])
    listed = associate(serving, np.zeros((1, 8)), "listed", 2)
    # UAV 0 serves users 1, 3, 4, 6 (listed order): clusters (1, 3), (4, 6)
    assert listed.first_user[0].tolist() == [[1, 4], [0, 5]]
    assert listed.second_user[0].tolist() == [[3, 6], [2, 7]]
    assert listed.cluster[0].tolist() == [0, 0, 0, 0, 1, 1, 1, 1]
    assert listed.partner[0].tolist() == [2, 3, 0, 1, 6, 7, 4, 5]
    assert listed.is_first[0].tolist() == [True, True, False, False, True, True, False, False]
    gains = np.array([[8.0, 1.0, 7.0, 4.0, 3.0, 6.0, 2.0, 5.0]])
    near_far = associate(serving, gains, "near-far", 2)
    # UAV 0's users by gain: 3 (4), 4 (3), 6 (2), 1 (1): clusters (3, 1) and (4, 6)
    assert near_far.first_user[0, 0].tolist() == [3, 4]
    assert near_far.second_user[0, 0].tolist() == [1, 6]
    # UAV 1's: 0 (8), 2 (7), 5 (6), 7 (5): clusters (0, 7) and (2, 5)
    assert near_far.first_user[0, 1].tolist() == [0, 2]
    assert near_far.second_user[0, 1].tolist() == [7, 5]
    assert near_far.clusters_per_uav.tolist() == [2, 2]


def test_unequal_listed_groups_leave_missing_clusters_empty():
    association = associate(np.array([[0, 0, 0, 0, 1, 1]]), np.zeros((1, 6)), "listed", 2)
    assert association.clusters_per_uav.tolist() == [2, 1]
    assert association.has_cluster.tolist() == [[True, True], [True, False]]
    assert association.first_user[0].tolist() == [[0, 2], [4, -1]]
