"""User layouts and NOMA cluster pairing (sec. II-A, docs/model.md §1)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from adaptsky.scenario.ground import open_ground_share
from adaptsky.scenario.models import Scenario
from adaptsky.sim.city import (
    MAX_DRAWS,
    PlacementError,
    on_footprints,
    redraw_while,
    scenario_footprints,
    street_layouts,
)


def user_layouts(scenario: Scenario, num_layouts: int, layout_seed: int | None = None
                 ) -> NDArray[np.float64]:
    """User positions of shape (num_layouts, N, 2), m.

    ``listed`` repeats the scenario's positions; ``uniform`` (and ``fresh``, whose fixed
    layouts are those of ``uniform``) draws every user uniformly over the area from
    ``layout_seed`` (default: the scenario's), layout after layout, so the first k of n
    layouts are the k layouts drawn for n = k.
    """
    users = scenario.users
    if users.placement == "listed":
        listed = np.asarray(users.positions_m, dtype=np.float64)
        return np.broadcast_to(listed, (num_layouts, *listed.shape)).copy()
    seed = users.layout_seed if layout_seed is None else layout_seed
    if users.placement == "hotspots":
        return hotspot_layouts(scenario, np.random.default_rng(seed), num_layouts)
    return uniform_layouts(scenario, np.random.default_rng(seed), num_layouts)


def hotspot_layouts(scenario: Scenario, rng: np.random.Generator, count: int
                    ) -> NDArray[np.float64]:
    """``count`` layouts (count, N, 2) of clustered users (``users.placement =
    "hotspots"``, docs/model.md §3), drawn from ``rng`` layout after layout: ``hotspots``
    centres uniform over the area (over the streets with buildings), each user's centre
    uniform among them, its offset from it normal with deviation ``spread_m`` along x and y;
    an offset that puts the user outside the area or on a footprint is drawn again, until
    none does (PlacementError after MAX_DRAWS draws of a user)."""
    users = scenario.users
    assert users.hotspots is not None and users.spread_m is not None
    half_m = scenario.area.side_m / 2
    footprints_m = scenario_footprints(scenario)
    layouts = np.empty((count, scenario.num_users, 2))
    for layout in layouts:
        if footprints_m is None:
            centres = rng.uniform(-half_m, half_m, size=(users.hotspots, 2))
        else:
            centres = street_layouts(rng, 1, users.hotspots, half_m, footprints_m)[0]
        layout[...] = centres[rng.integers(0, users.hotspots, size=len(layout))]
        layout += _offsets(rng, layout, users.spread_m, half_m, footprints_m)
    return layouts


def _offsets(rng: np.random.Generator, centres_m: NDArray[np.float64], spread_m: float,
             half_m: float, footprints_m: NDArray[np.float64] | None) -> NDArray[np.float64]:
    """Each user's offset (N, 2) from its centre, normal with deviation ``spread_m``, drawn
    again where it puts the user outside the area or on a footprint (PlacementError after
    MAX_DRAWS draws)."""
    offsets = rng.normal(0.0, spread_m, size=centres_m.shape)

    def again(redraw: NDArray[np.bool_]) -> None:
        offsets[redraw] = rng.normal(0.0, spread_m, size=(int(redraw.sum()), 2))

    redraw = redraw_while(lambda: _misplaced(centres_m + offsets, half_m, footprints_m), again)
    if redraw.any():
        raise PlacementError(_offset_failure(int(redraw.sum()), spread_m, half_m, footprints_m))
    return offsets


def _offset_failure(count: int, spread_m: float, half_m: float,
                    footprints_m: NDArray[np.float64] | None) -> str:
    """The line of hotspot offsets that found no place in MAX_DRAWS draws."""
    where = "in the area"
    if footprints_m is not None:
        share = open_ground_share(footprints_m.tolist(), half_m)
        where = f"in the area off the buildings ({share:.1%} of it open ground)"
    return (f"users.spread_m: {count} users found no offset from their hotspot's centre "
            f"{where} in {MAX_DRAWS} draws each (spread_m = {spread_m:g} m, area side "
            f"{2 * half_m:g} m): make spread_m smaller or open more ground")


def _misplaced(users_m: NDArray[np.float64], half_m: float,
               footprints_m: NDArray[np.float64] | None) -> NDArray[np.bool_]:
    """Whether each user (N, 2) stands outside the area or on a footprint."""
    outside = (np.abs(users_m) > half_m).any(axis=-1)
    if footprints_m is None:
        return outside
    return outside | on_footprints(users_m, footprints_m)


def uniform_layouts(scenario: Scenario, rng: np.random.Generator, count: int
                    ) -> NDArray[np.float64]:
    """``count`` layouts (count, N, 2) drawn from ``rng``, every user uniform over the area
    (layout after layout, user after user, x before y); with buildings, uniform over the
    streets (:func:`~adaptsky.sim.city.street_layouts`, docs/model.md §12)."""
    half_m = scenario.area.side_m / 2
    footprints_m = scenario_footprints(scenario)
    if footprints_m is not None:
        return street_layouts(rng, count, scenario.num_users, half_m, footprints_m)
    return rng.uniform(-half_m, half_m, size=(count, scenario.num_users, 2))


def pair_users(gains: NDArray[np.float64], pairing: str) -> tuple[NDArray[np.int64],
                                                                   NDArray[np.int64]]:
    """Indices (B, K) of each cluster's first and second user: :func:`cluster_users` with
    M = 2. ``listed``: users (1, 2), (3, 4), ... ``near-far``: users sorted by ``gains``
    (B, N); the k-th strongest is the first user of cluster k, the k-th weakest its second.
    """
    members = cluster_users(gains, pairing, 2)
    return members[..., 0], members[..., 1]


def cluster_users(gains: NDArray[np.float64], pairing: str, cluster_size: int
                  ) -> NDArray[np.int64]:
    """Indices (B, K, M) of the M = ``cluster_size`` users of each of the K = N / M clusters,
    in member order (docs/model.md §15).

    ``listed``: users (1 .. M), (M + 1 .. 2 M), ... ``near-far``: users sorted by ``gains``
    (B, N), strongest first, and dealt to the clusters in M rounds of K, every other round
    backwards (a snake): member j of cluster k is the user of rank j K + k for even j and
    (j + 1) K - 1 - k for odd j, so every cluster spans near to far. For M = 2: the k-th
    strongest first, the k-th weakest second.
    """
    num_layouts, num_users = gains.shape
    k = num_users // cluster_size
    if pairing == "listed":
        return np.broadcast_to(np.arange(num_users).reshape(k, cluster_size),
                               (num_layouts, k, cluster_size)).copy()
    order = np.argsort(-gains, axis=1, kind="stable")
    rounds = order.reshape(num_layouts, cluster_size, k).copy()            # (B, M, K)
    rounds[:, 1::2] = rounds[:, 1::2, ::-1]
    return rounds.transpose(0, 2, 1).copy()


def episode_layouts(scenario: Scenario, seeds: list[int], episode: int) -> NDArray[np.float64]:
    """The layouts (S, N, 2) of training episode ``episode`` (0-based) for ``users.placement
    = "fresh"``: every user uniform over the area, from a generator of its own per seed and
    episode, ([seed, 2, episode]): a run's layouts do not depend on how it was stopped,
    resumed or stacked."""
    return np.concatenate([uniform_layouts(scenario, np.random.default_rng([seed, 2, episode]), 1)
                           for seed in seeds])
