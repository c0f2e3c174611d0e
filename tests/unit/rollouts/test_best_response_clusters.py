"""Best response of several UAVs for NOMA clusters of three users (docs/model.md §15) and for
the uplink (§17) against plain loops over the model's formulas (``scalar_chain_network``,
``scalar_uplink_network``): a fixed point that no single UAV can improve by any lattice point
and any share vector of the grid (brute force), its objective the scalar network's; one UAV's
best response the cluster oracle; OMA's of clusters of three a fixed point too."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from adaptsky.references.registry import refusal
from adaptsky.rollouts.cluster_oracle import cluster_oracle
from adaptsky.rollouts.several_uavs import best_oma, best_response
from adaptsky.sim.layout import user_layouts
from tests.conftest import make_scenario
from tests.helpers.scalar_models import (
    ANTENNA_GAIN,
    BANDWIDTH_HZ,
    NOISE_W,
    scalar_chain_network,
    scalar_gain,
    scalar_uplink_network,
)

START_M = [[-2.0, 0.0, 10.0], [2.0, 0.0, 10.0]]
TRIPLES_M = [[-3.0, 1.0], [-1.0, -3.0], [-2.5, -0.5], [3.0, 2.0], [1.0, -1.0], [2.0, 3.5]]
PAIRS_M = [[-3.0, 1.0], [-1.0, -3.0], [3.0, 2.0], [1.0, -1.0]]


def two_uavs(users_m, size, min_se=0.0, sic_residual=0.0, direction="downlink", channel=None,
             **users):
    """Two UAVs over 8 m x 8 m on a lattice of 5 x 5 x 3 points, shares on a 0.25 grid,
    each serving one cluster of ``size`` listed users."""
    half = len(users_m) // 2
    return make_scenario(
        area={"side_m": 8.0},
        users={"positions_m": users_m, "association": "listed",
               "uav": [0] * half + [1] * half, "pairing": "listed", "cluster_size": size,
               **users},
        uav={"count": 2, "start_m": [0.0, 0.0, 10.0], "start_positions_m": START_M,
             "step_m": [2.0, 2.0, 2.0], "min_height_m": 10.0, "max_height_m": 14.0,
             "power_step": 0.25, "min_separation_m": 2.0},
        radio={"thermal_noise_dbm": -79.0, "noise_figure_db": 0.0,   # NOISE_W
               "sic_residual": sic_residual, "direction": direction},
        reward={"min_se": min_se}, **({} if channel is None else {"channel": channel}))


def lattice_of(start):
    xs = [start[0] + 2 * k for k in range(-4, 5) if abs(start[0] + 2 * k) <= 4]
    ys = [start[1] + 2 * k for k in range(-4, 5) if abs(start[1] + 2 * k) <= 4]
    return [(x, y, h) for x in xs for y in ys for h in (10.0, 12.0, 14.0)]


def constrained(rates, min_rate_bps):
    return sum(rates) if min(rates) >= min_rate_bps else -math.inf


def downlink_objective(users_m, min_rate_bps, residual):
    """The network's constrained sum rate of clusters of three by the scalar formulas, from
    the UAVs' positions and each UAV's two components."""
    clusters = [[(0, 1, 2)], [(3, 4, 5)]]

    def value(uavs, components):
        rates = scalar_chain_network(uavs, users_m, clusters, [[c] for c in components], "full",
                                     residual)[-1]
        return constrained(rates, min_rate_bps)
    return value


def deviations(u, uavs, shares, vectors):
    """Every configuration where UAV u alone moves to a lattice point (kept 2 m from the
    other) and takes any vector of the grid."""
    other = uavs[1 - u]
    for point in lattice_of(START_M[u]):
        if math.dist(point[:2], other[:2]) < 2.0:
            continue
        for vector in vectors:
            moved, changed = list(uavs), [list(s) for s in shares]
            moved[u] = point
            if vector is not None:
                changed[u] = list(vector)
            yield moved, changed


def assert_fixed_point(found, value, vectors):
    """Best response converged, its objective the scalar one, and no UAV improves on it by
    any lattice point and vector (brute force)."""
    assert found.converged[0] and 1 <= found.rounds[0] <= 10
    uavs = [tuple(p) for p in found.uav_m[0]]
    shares = found.alpha_first[0].tolist()
    reached = value(uavs, shares)
    assert reached > 0
    assert found.objective_bps[0] == pytest.approx(reached, rel=1e-12)
    assert found.rate_bps[0].sum() == pytest.approx(reached, rel=1e-12)
    assert math.dist(uavs[0][:2], uavs[1][:2]) >= 2.0
    for u in range(2):
        best = max(value(moved, changed) for moved, changed in
                   deviations(u, uavs, shares, vectors))
        assert best <= reached * (1 + 1e-9)
    return reached


@pytest.mark.parametrize("min_se, residual", [(0.0, 0.0), (0.2, 0.05)])
def test_best_response_of_clusters_of_three_is_a_fixed_point(min_se, residual):
    scenario = two_uavs(TRIPLES_M, 3, min_se, residual)
    found = best_response(scenario, user_layouts(scenario, 1))
    grid = (0.25, 0.5, 0.75)
    reached = assert_fixed_point(found, downlink_objective(
        TRIPLES_M, min_se * BANDWIDTH_HZ, residual), list(itertools.product(grid, grid)))
    start = downlink_objective(TRIPLES_M, min_se * BANDWIDTH_HZ, residual)(
        [tuple(p) for p in START_M], [[0.5, 0.5], [0.5, 0.5]])
    assert reached > start


@pytest.mark.parametrize("min_se, residual", [(0.0, 0.0), (0.2, 0.05)])
def test_best_response_of_the_uplink_is_a_fixed_point(min_se, residual):
    scenario = two_uavs(PAIRS_M, 2, min_se, residual, "uplink", tx_power_dbm=23.0)
    power_w = 10 ** ((23.0 - 30) / 10)                # 23 dBm
    assert scenario.user_tx_power_w == pytest.approx(power_w, rel=1e-12)
    users_m = PAIRS_M

    def value(uavs, betas):
        rates = scalar_uplink_network(uavs, users_m, [[(0, 1)], [(2, 3)]],
                                      [b for pair in betas for b in pair], "full", power_w,
                                      residual)[-1]
        return constrained(rates, min_se * BANDWIDTH_HZ)

    found = best_response(scenario, user_layouts(scenario, 1))
    grid = (0.25, 0.5, 0.75, 1.0)
    assert_fixed_point(found, value, list(itertools.product(grid, grid)))


def test_one_uavs_best_response_of_clusters_is_the_cluster_oracle():
    scenario = make_scenario(
        area={"side_m": 8.0},
        users={"positions_m": TRIPLES_M, "pairing": "listed", "cluster_size": 3},
        uav={"start_m": [0.0, 0.0, 10.0], "step_m": [2.0, 2.0, 2.0], "min_height_m": 10.0,
             "max_height_m": 14.0, "power_step": 0.25})
    layouts = user_layouts(scenario, 1)
    found, exact = best_response(scenario, layouts), cluster_oracle(scenario, layouts)
    assert found.objective_bps[0] == exact.objective_bps[0] > 0
    np.testing.assert_array_equal(found.uav_m[:, 0], exact.uav_m)
    np.testing.assert_array_equal(found.alpha_first[:, 0], exact.alpha_first)


def test_oma_of_clusters_of_three_is_held_at_the_scalar_rates():
    """OMA of clusters of three, each user on W/3 with P_T/3 hearing the other UAV at full
    power (docs/model.md §9, §15): its objective is the scalar formula's at what it found,
    and no UAV improves on it by moving alone."""
    scenario = two_uavs(TRIPLES_M, 3)
    found = best_oma(scenario, user_layouts(scenario, 1))

    def value(uavs, _):
        gains = [[scalar_gain(uav, user, "always") for user in TRIPLES_M] for uav in uavs]
        total = 0.0
        for i in range(6):
            u = i // 3
            snr = (0.1 / 3 * ANTENNA_GAIN * gains[u][i]
                   / ((0.1 * ANTENNA_GAIN * gains[1 - u][i] + NOISE_W) / 3))
            total += BANDWIDTH_HZ / 3 * math.log2(1 + snr)
        return total

    assert_fixed_point(found, value, [None])


def test_best_response_refuses_clusters_and_the_uplink_under_fading():
    faded = two_uavs(TRIPLES_M, 3, channel={"fading": {"model": "rician"}})
    reason = refusal("best-response", faded)
    assert reason is not None and "fading" in reason and "\n" not in reason
    assert refusal("best-response", two_uavs(TRIPLES_M, 3)) is None
    assert refusal("best-response", two_uavs(PAIRS_M, 2, direction="uplink")) is None
