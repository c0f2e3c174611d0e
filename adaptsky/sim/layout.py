"""User layouts and NOMA cluster pairing (sec. II-A, docs/model.md §1)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from adaptsky.scenario.models import Scenario
from adaptsky.sim.city import scenario_footprints, street_layouts


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
    return uniform_layouts(scenario, np.random.default_rng(seed), num_layouts)


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
    """Indices (B, K) of each cluster's first and second user.

    ``listed``: users (1, 2), (3, 4), ... ``near-far``: users sorted by ``gains`` (B, N); the
    k-th strongest is the first user of cluster k, the k-th weakest its second.
    """
    num_layouts, num_users = gains.shape
    if pairing == "listed":
        first = np.broadcast_to(np.arange(0, num_users, 2), (num_layouts, num_users // 2))
        return first.copy(), first + 1
    order = np.argsort(-gains, axis=1, kind="stable")
    half = num_users // 2
    return order[:, :half].copy(), order[:, ::-1][:, :half].copy()


def episode_layouts(scenario: Scenario, seeds: list[int], episode: int) -> NDArray[np.float64]:
    """The layouts (S, N, 2) of training episode ``episode`` (0-based) for ``users.placement
    = "fresh"``: every user uniform over the area, from a generator of its own per seed and
    episode, ([seed, 2, episode]): a run's layouts do not depend on how it was stopped,
    resumed or stacked."""
    return np.concatenate([uniform_layouts(scenario, np.random.default_rng([seed, 2, episode]), 1)
                           for seed in seeds])
