"""Which UAV serves which user, and the NOMA clusters of every UAV (docs/model.md §9).

Once per layout: a deterministic balanced k-means splits the N users into U groups of N/U
(``users.association = "kmeans"``) or ``users.uav`` lists them (``"listed"``); groups are
matched to UAVs by the least total distance from the UAVs' start positions; inside each group
users are put into NOMA clusters of M as for one UAV (:func:`adaptsky.sim.layout.cluster_users`;
pairs for M = 2, docs/model.md §15).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from adaptsky.sim.layout import cluster_users

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]

KMEANS_MAX_ROUNDS = 100


def min_cost_assignment(cost: FloatArray) -> IntArray:
    """The column of every row (n,) that minimises the total cost of an (n, m) matrix, n <= m,
    every column used at most once: the Hungarian method with potentials, O(n^2 m), exact and
    deterministic (ties go to the lowest column index met first)."""
    n, m = cost.shape
    if n > m:
        raise ValueError(f"{n} rows cannot take distinct columns of {m}")
    # 1-based rows and columns; row 0 / column 0 are the method's virtual start
    u, v = np.zeros(n + 1), np.zeros(m + 1)
    row_of = np.zeros(m + 1, dtype=np.intp)          # row assigned to each column, 0: none
    for row in range(1, n + 1):
        row_of[0], column = row, 0
        least = np.full(m + 1, np.inf)
        came_from = np.zeros(m + 1, dtype=np.intp)
        used = np.zeros(m + 1, dtype=bool)
        while row_of[column]:
            used[column] = True
            i = row_of[column]
            reduced = cost[i - 1] - u[i] - v[1:]
            free = ~used[1:]
            better = free & (reduced < least[1:])
            least[1:][better] = reduced[better]
            came_from[1:][better] = column
            candidates = np.where(free, least[1:], np.inf)
            nxt = int(np.argmin(candidates)) + 1
            delta = candidates[nxt - 1]
            u[row_of[used]] += delta
            v[used] -= delta
            least[1:][free] -= delta
            column = nxt
        while column:
            previous = came_from[column]
            row_of[column] = row_of[previous]
            column = previous
    assigned = np.empty(n, dtype=np.intp)
    for column in range(1, m + 1):
        if row_of[column]:
            assigned[row_of[column] - 1] = column - 1
    return assigned


def balanced_kmeans(users_m: FloatArray, centres_m: FloatArray) -> IntArray:
    """Group (n,) of each of the n users ``users_m`` (n, 2), m, in U = len(``centres_m``)
    groups of n/U users each (n divisible by U).

    Lloyd's iteration with a balanced assignment step (:func:`balanced_lloyd`), run from two
    deterministic starts: the centres ``centres_m`` (U, 2) (the UAVs' start positions) and
    the farthest-point users (:func:`farthest_points`); the grouping with the smaller total
    squared distance to its centroids is kept (the first on a tie). No random start: the
    same users always give the same groups.
    """
    best, best_cost = np.empty(0, dtype=np.intp), np.inf
    for start in (np.asarray(centres_m, dtype=np.float64),
                  users_m[farthest_points(users_m, len(centres_m))]):
        labels = balanced_lloyd(users_m, start)
        cost = sum(np.square(users_m[labels == g] - users_m[labels == g].mean(axis=0)).sum()
                   for g in range(len(centres_m)))
        if cost < best_cost:
            best, best_cost = labels, cost
    return best


def farthest_points(users_m: FloatArray, count: int) -> IntArray:
    """Indices of ``count`` users spread out: the user farthest from the centre (0, 0), then
    again and again the user farthest from those chosen (the first on a tie)."""
    chosen = [int(np.argmax(np.hypot(users_m[:, 0], users_m[:, 1])))]
    nearest_m = np.hypot(*(users_m - users_m[chosen[0]]).T)
    for _ in range(count - 1):
        chosen.append(int(np.argmax(nearest_m)))
        nearest_m = np.minimum(nearest_m, np.hypot(*(users_m - users_m[chosen[-1]]).T))
    return np.array(chosen, dtype=np.intp)


def balanced_lloyd(users_m: FloatArray, centres_m: FloatArray) -> IntArray:
    """Lloyd's iteration from the centres ``centres_m`` (U, 2), m: every round assigns the
    users ``users_m`` (n, 2) to groups of n/U at the least total squared distance to the
    centres (an exact assignment, :func:`min_cost_assignment`), then moves each centre to
    its group's mean, until the groups stop changing (at most KMEANS_MAX_ROUNDS rounds)."""
    n, groups = len(users_m), len(centres_m)
    size = n // groups
    if size * groups != n:
        raise ValueError(f"{n} users do not split into {groups} equal groups")
    centres = centres_m
    labels = np.full(n, -1, dtype=np.intp)
    for _ in range(KMEANS_MAX_ROUNDS):
        squared_m2 = np.square(users_m[:, None, :] - centres[None, :, :]).sum(axis=-1)
        slots = np.repeat(squared_m2, size, axis=1)          # (n, U * size): group g's slots
        new = min_cost_assignment(slots) // size
        if np.array_equal(new, labels):
            break
        labels = new
        centres = np.stack([users_m[labels == g].mean(axis=0) for g in range(groups)])
    return labels


def match_groups(centroids_m: FloatArray, uav_start_m: FloatArray) -> IntArray:
    """UAV (G,) of each of the G groups whose 2D centroids are ``centroids_m`` (G, 2), m: the
    one-to-one matching with the least total horizontal distance from the UAVs' start
    positions ``uav_start_m`` (G, 3) to their groups' centroids (exact)."""
    distance_m = np.hypot(*(centroids_m[:, None, :] - uav_start_m[None, :, :2]).transpose(2, 0, 1))
    return min_cost_assignment(distance_m)


@dataclass(frozen=True)
class Association:
    """Serving UAV and NOMA cluster of every user of B layouts with U UAVs.

    ``serving_uav`` (B, N): the UAV u serving each user; ``cluster`` (B, N): the cluster k of
    its UAV (its subchannel under full reuse); ``members`` (B, U, K_max, M): the users of
    cluster k of UAV u in their order (member j's share is the j-th of the cluster's, docs/
    model.md §15), -1 where UAV u has fewer clusters; ``clusters_per_uav`` (U,): K_u.
    """

    serving_uav: IntArray
    cluster: IntArray
    members: IntArray
    clusters_per_uav: IntArray

    @property
    def cluster_size(self) -> int:
        """M, the users of a cluster."""
        return self.members.shape[3]

    @property
    def first_user(self) -> IntArray:
        """(B, U, K_max): the first user of every cluster (the one alpha_k belongs to), -1
        where UAV u has fewer clusters."""
        return self.members[..., 0]

    @property
    def second_user(self) -> IntArray:
        """(B, U, K_max): the second user of every cluster, as :attr:`first_user`."""
        return self.members[..., 1]

    @property
    def member(self) -> IntArray:
        """(B, N): each user's place j in its cluster (0: the first)."""
        member = np.empty(self.serving_uav.shape, dtype=np.intp)
        valid = self.first_user >= 0                                     # (B, U, K_max)
        rows = np.broadcast_to(np.arange(len(member))[:, None, None], valid.shape)[valid]
        for j in range(self.cluster_size):
            member[rows, self.members[..., j][valid]] = j
        return member

    @property
    def has_cluster(self) -> NDArray[np.bool_]:
        """(U, K_max): whether UAV u has a cluster k."""
        k_max = self.members.shape[2]
        return np.arange(k_max)[None, :] < self.clusters_per_uav[:, None]

    @property
    def is_first(self) -> NDArray[np.bool_]:
        """(B, N): whether each user is its cluster's first user (the one alpha_k belongs to)."""
        first = np.zeros(self.serving_uav.shape, dtype=bool)
        rows = np.arange(len(first))[:, None, None]
        valid = self.first_user >= 0
        first[np.broadcast_to(rows, valid.shape)[valid], self.first_user[valid]] = True
        return first

    @property
    def partner(self) -> IntArray:
        """(B, N): the other user of each user's cluster."""
        partner = np.empty(self.serving_uav.shape, dtype=np.intp)
        rows = np.broadcast_to(np.arange(len(partner))[:, None, None], self.first_user.shape)
        valid = self.first_user >= 0
        partner[rows[valid], self.first_user[valid]] = self.second_user[valid]
        partner[rows[valid], self.second_user[valid]] = self.first_user[valid]
        return partner


def serving_groups(users_m: FloatArray, uav_start_m: FloatArray, association: str,
                   listed: list[int] | None = None) -> IntArray:
    """Serving UAV (B, N) of every user of the layouts ``users_m`` (B, N, 2), m, for UAVs
    starting at ``uav_start_m`` (U, 3), m: ``"kmeans"`` (:func:`balanced_kmeans` from the
    start positions, groups matched by :func:`match_groups`) or ``"listed"`` (``listed``,
    the same for every layout)."""
    num_layouts, n, _ = users_m.shape
    if association == "listed":
        if listed is None or len(listed) != n:
            raise ValueError("association 'listed' needs one serving UAV per user")
        return np.broadcast_to(np.asarray(listed, dtype=np.intp), (num_layouts, n)).copy()
    starts = np.asarray(uav_start_m, dtype=np.float64)
    serving = np.empty((num_layouts, n), dtype=np.intp)
    for b, layout in enumerate(users_m):
        labels = balanced_kmeans(layout, starts[:, :2])
        centroids = np.stack([layout[labels == g].mean(axis=0) for g in range(len(starts))])
        serving[b] = match_groups(centroids, starts)[labels]
    return serving


def associate(serving_uav: IntArray, start_gain: FloatArray, pairing: str,
              num_uavs: int, cluster_size: int = 2) -> Association:
    """NOMA clusters of ``cluster_size`` M users inside every UAV's group: users served by UAV
    u (in listed order) put into clusters by :func:`~adaptsky.sim.layout.cluster_users`
    (``"listed"``, or ``"near-far"`` by ``start_gain`` (B, N), each user's gain from its
    serving UAV at the start)."""
    num_layouts, n = serving_uav.shape
    sizes = np.stack([(serving_uav == u).sum(axis=1) for u in range(num_uavs)], axis=1)
    if np.any(sizes != sizes[:1]) or np.any(sizes % cluster_size):
        raise ValueError(f"every layout must give each UAV the same number of users, a "
                         f"multiple of {cluster_size}")
    clusters_per_uav = (sizes[0] // cluster_size).astype(np.intp)
    k_max = int(clusters_per_uav.max())
    members = np.full((num_layouts, num_uavs, k_max, cluster_size), -1, dtype=np.intp)
    cluster = np.empty((num_layouts, n), dtype=np.intp)
    rows = np.arange(num_layouts)[:, None]
    for u, k_u in enumerate(clusters_per_uav):
        group = np.stack([np.flatnonzero(row == u) for row in serving_uav])     # (B, n_u)
        local = cluster_users(np.take_along_axis(start_gain, group, axis=1), pairing,
                              cluster_size)                                     # (B, K_u, M)
        members[:, u, :k_u] = np.take_along_axis(
            group, local.reshape(num_layouts, -1), axis=1).reshape(local.shape)
        for j in range(cluster_size):
            cluster[rows, members[:, u, :k_u, j]] = np.arange(k_u)
    return Association(serving_uav, cluster, members, clusters_per_uav)
