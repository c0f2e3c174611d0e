"""The oracle of one UAV whose NOMA clusters have M > 2 users (docs/model.md §15), or of the
uplink (§17): the best lattice point and power components for the users' home positions,
deterministic gains. The uplink's clusters are valued by
:func:`~adaptsky.rollouts.search.best_uplink_vectors` and bounded by W log2(1 + s sum_i g_i)
(every member at full power: the sum rate of a SIC receiver); the rest is as below.

At a point every cluster is valued apart (clusters have their own power and band) by the
kernel's best share vector (:func:`~adaptsky.rollouts.search.best_share_vectors`): every
component vector of the grid, (1 / delta_alpha - 1)^(M - 1) of them, exact for any SIC
residual and R_min. That costs V times a pair's closed form per point, so where the channel
model declares ``Supports(monotone_gains=True)`` the lattice is searched by the kernel's branch
and bound: a user's gain anywhere in a box is at most the LoS gain at the box's nearest point,
and a cluster's sum rate is at most W log2(1 + s g_max) with g_max the largest gain among its
members, whatever the shares, the order, the residual or R_min (docs/model.md §15), so a box
whose bound falls to the best value found holds no better point. Other models value every
point.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from adaptsky.channels.contract import declares_monotone_gains
from adaptsky.rollouts.oracle import OracleResult, oracle, require_deterministic_gains
from adaptsky.rollouts.search import (
    Best,
    LatticeBoxes,
    best_in_chunks,
    best_share_vectors,
    best_uplink_vectors,
    bound_gains,
    branch_and_bound,
    every_point,
    grid_points,
    lattice,
    lattice_chunks,
    outside_buildings,
    point_gains,
    share_vectors,
    snr_scale,
)
from adaptsky.scenario.models import Scenario
from adaptsky.sim.network import NetworkBatch

FloatArray = NDArray[np.float64]
POINTS_PER_CHUNK = 4096
"""Lattice points the exhaustive search values at once (each against every share vector)."""


def cluster_point_values(env: NetworkBatch, layout: int, points_m: FloatArray,
                         users_m: FloatArray, components: FloatArray, shares: FloatArray,
                         snr: float) -> tuple[FloatArray, FloatArray]:
    """The objective (P,) at every lattice point ``points_m`` (P, 3) for the users at
    ``users_m`` (N, 2) in environment ``layout``'s clusters, and every cluster's best
    components there (P, K (M - 1)); -inf where a cluster cannot meet R_min and inside a
    building."""
    gain = point_gains(env, layout, points_m, users_m)
    clusters = env.association.members[layout, 0]                          # (K, M)
    width = components.shape[1]
    best_vectors = best_uplink_vectors if env.scenario.uplink else best_share_vectors
    total = np.zeros(len(points_m))
    chosen = np.empty((len(points_m), len(clusters) * width))
    for k, members in enumerate(clusters):
        index, rate = best_vectors(gain[:, members], shares, env.scenario, snr)
        total += rate
        chosen[:, k * width:(k + 1) * width] = components[index]
    return outside_buildings(env, layout, points_m, total), chosen


def cluster_box_bounds(env: NetworkBatch, layout: int, boxes: LatticeBoxes,
                       users_m: FloatArray, snr: float) -> FloatArray:
    """Every box's upper bound on the objective: the sum over clusters of
    W log2(1 + s g_max), g_max the largest member's gain at its nearest point of the box
    (the uplink's: W log2(1 + s sum_i g_i), every member at full power)."""
    gain = bound_gains(env, boxes.nearest(users_m), users_m)
    members = gain[:, env.association.members[layout, 0]]                  # (boxes, K, M)
    best = members.sum(axis=2) if env.scenario.uplink else members.max(axis=2)
    return (env.bandwidth_hz * np.log2(1.0 + snr * best)).sum(axis=1)


def cluster_oracle(scenario: Scenario, users_m: FloatArray,
                   on_layout: Callable[[int], None] | None = None,
                   on_search: Callable[[float, str], None] | None = None) -> OracleResult:
    """The oracle (module doc) for every layout in ``users_m`` (L, N, 2), clustered as the
    environment clusters them; ``on_layout`` hears the layouts searched after each,
    ``on_search`` the layouts searched (a fraction) and what of the lattice is valued."""
    require_deterministic_gains(scenario)
    num_layouts = len(users_m)
    env = NetworkBatch(scenario, num_envs=num_layouts, users_m=users_m)
    snr = snr_scale(scenario)                       # (the uplink's: P_u G / sigma^2)
    xs, ys, hs, _ = lattice(scenario)
    components, shares = share_vectors(scenario)
    boxes = LatticeBoxes((xs, ys, hs)) if declares_monotone_gains(env.channel) else None
    objective = np.zeros(num_layouts)
    best_uav = np.broadcast_to(np.array(scenario.uav.start_m), (num_layouts, 3)).copy()
    best_components = np.full((num_layouts, scenario.shares_per_uav), scenario.uav.start_alpha)
    for layout in range(num_layouts):
        def values(points: FloatArray, layout: int = layout) -> tuple[FloatArray, FloatArray]:
            return cluster_point_values(env, layout, points, users_m[layout], components,
                                        shares, snr)

        start = Best(0.0, best_uav[layout], best_components[layout])
        if boxes is not None:
            bound = cluster_box_bounds(env, layout, boxes, users_m[layout], snr)

            def valued_so_far(begin: int, valued: int, layout: int = layout) -> None:
                if on_search is not None:
                    on_search(layout, f"{valued:,} lattice points valued")

            found, _ = branch_and_bound(bound, boxes.ranked(bound), boxes.points,
                                        every_point(values), start, on_batch=valued_so_far)
        else:
            def heard(searched: float, layout: int = layout) -> None:
                if on_search is not None and searched < 1:
                    on_search(layout + searched, f"{searched:.0%} of the lattice")

            found = best_in_chunks(lattice_chunks(grid_points(xs, ys, hs), POINTS_PER_CHUNK),
                                   values, start, heard)
        objective[layout], best_uav[layout], best_components[layout] = found
        if on_layout is not None:
            on_layout(layout + 1)
    state = env.evaluate_at(best_uav, best_components)
    return OracleResult(objective, best_uav, best_components, state.rate_bps)


def exact_oracle(scenario: Scenario, users_m: FloatArray,
                 on_layout: Callable[[int], None] | None = None,
                 on_search: Callable[[float, str], None] | None = None) -> OracleResult:
    """The oracle of one UAV for ``scenario``'s NOMA: the pairs' closed form
    (:func:`~adaptsky.rollouts.oracle.oracle`) for the paper's downlink pairs, else
    :func:`cluster_oracle` (SIC chains: clusters of M > 2, the uplink)."""
    search = cluster_oracle if scenario.sic_chains else oracle
    return search(scenario, users_m, on_layout, on_search)
