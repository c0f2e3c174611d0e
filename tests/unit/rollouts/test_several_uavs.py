"""The baselines of several UAVs (docs/model.md §9) against plain loops over the model's
formulas (``scalar_network``): SoA per UAV by hand, best response and OMA as fixed points
that no single UAV can improve by any lattice point and grid share (brute force), the
separation kept, one UAV's best response equal to the oracle; and the environment of several
UAVs: the separation rule and each UAV's action components."""

from __future__ import annotations

import math

import numpy as np
import pytest

from adaptsky.rollouts.oracle import oracle
from adaptsky.rollouts.several_uavs import best_oma, best_response, soa_per_uav
from adaptsky.sim.layout import user_layouts
from adaptsky.sim.network import NetworkBatch
from tests.conftest import make_scenario
from tests.helpers.scalar_models import NOISE_W, scalar_gain, scalar_network

USERS_M = [[-3.0, 1.0], [-1.0, -3.0], [3.0, 2.0], [1.0, -1.0]]
START_M = [[-2.0, 0.0, 10.0], [2.0, 0.0, 10.0]]


def tiny(min_se: float = 0.0, **uav) -> object:
    """Two UAVs over 8 m x 8 m on a lattice of 5 x 5 x 3 points, shares 0.25, 0.5, 0.75."""
    return make_scenario(
        area={"side_m": 8.0},
        users={"positions_m": USERS_M, "association": "listed", "uav": [0, 0, 1, 1],
               "pairing": "listed"},
        uav={"count": 2, "start_m": [0.0, 0.0, 10.0], "start_positions_m": START_M,
             "step_m": [2.0, 2.0, 2.0], "min_height_m": 10.0, "max_height_m": 14.0,
             "power_step": 0.25, "min_separation_m": 2.0, **uav},
        radio={"thermal_noise_dbm": -79.0, "noise_figure_db": 0.0},   # NOISE_W
        reward={"min_se": min_se})


def lattice_of(start):
    xs = [start[0] + 2 * k for k in range(-4, 5) if abs(start[0] + 2 * k) <= 4]
    ys = [start[1] + 2 * k for k in range(-4, 5) if abs(start[1] + 2 * k) <= 4]
    return [(x, y, h) for x in xs for y in ys for h in (10.0, 12.0, 14.0)]


def objective(uavs, alphas, oma=False, min_rate_bps=0.0):
    """The constrained sum rate by the plain formulas (0 where a user is below R_min)."""
    *_, rate, oma_rate = scalar_network(uavs, USERS_M, [0, 0, 1, 1], [[(0, 1)], [(2, 3)]],
                                        alphas, "full")
    rates = oma_rate if oma else rate
    return sum(rates) if min(rates) >= min_rate_bps else 0.0


def deviations(u, uavs, alphas, oma):
    """Every configuration where UAV u alone moves to a lattice point (kept 2 m from the
    other) and, for NOMA, takes any grid share."""
    other = uavs[1 - u]
    for point in lattice_of(START_M[u]):
        if math.dist(point[:2], other[:2]) < 2.0:
            continue
        for alpha in ([alphas[u][0]] if oma else (0.25, 0.5, 0.75)):
            moved, shares = list(uavs), [list(a) for a in alphas]
            moved[u], shares[u] = point, [alpha]
            yield moved, shares


@pytest.mark.parametrize("oma", [False, True])
def test_best_response_is_a_fixed_point_no_uav_improves_on(oma):
    scenario = tiny()
    search = best_oma if oma else best_response
    found = search(scenario, user_layouts(scenario, 1))
    assert found.converged[0] and 1 <= found.rounds[0] <= 10
    uavs = [tuple(p) for p in found.uav_m[0]]
    alphas = [[0.5], [0.5]] if oma else found.alpha_first[0].tolist()
    value = objective(uavs, alphas, oma)
    assert found.objective_bps[0] == pytest.approx(value, rel=1e-12)
    assert found.rate_bps[0].sum() == pytest.approx(value, rel=1e-12)
    assert math.dist(uavs[0][:2], uavs[1][:2]) >= 2.0
    for u in range(2):
        best = max(objective(moved, shares, oma) for moved, shares in
                   deviations(u, uavs, alphas, oma))
        assert best <= value * (1 + 1e-9)
    soa_uav, soa_alpha = soa_per_uav(scenario, user_layouts(scenario, 1))
    assert value > objective([tuple(p) for p in soa_uav[0]], soa_alpha[0].tolist(), oma)


def test_noma_beats_oma_at_their_best():
    scenario = tiny()
    layouts = user_layouts(scenario, 1)
    assert best_response(scenario, layouts).objective_bps[0] > best_oma(
        scenario, layouts).objective_bps[0]


def test_best_response_meets_the_minimum_rate():
    scenario = tiny(min_se=0.25)
    found = best_response(scenario, user_layouts(scenario, 1))
    min_rate_bps = 0.25 * scenario.radio.bandwidth_hz
    assert found.objective_bps[0] > 0
    assert (found.rate_bps[0] >= min_rate_bps).all()
    uavs = [tuple(p) for p in found.uav_m[0]]
    alphas = found.alpha_first[0].tolist()
    assert found.objective_bps[0] == pytest.approx(
        objective(uavs, alphas, min_rate_bps=min_rate_bps), rel=1e-12)


def test_soa_per_uav_by_hand():
    """Each UAV at its group's centroid at its start height; the weak user of each cluster
    gets the least share that meets R_min, planned from the LoS gain without interference."""
    scenario = tiny(min_se=0.5)
    uav_m, alpha_first = soa_per_uav(scenario, user_layouts(scenario, 1))
    assert uav_m[0].tolist() == [[-2.0, -1.0, 10.0], [2.0, 0.5, 10.0]]
    pg = 0.1 * 64
    for u, (first, second) in enumerate([(0, 1), (2, 3)]):
        g_first = scalar_gain(uav_m[0, u], USERS_M[first], "always")
        g_second = scalar_gain(uav_m[0, u], USERS_M[second], "always")
        weak = min(g_first, g_second)
        alpha_weak = (2 ** 0.5 - 1) / 2 ** 0.5 * (1 + NOISE_W / (pg * weak))
        expected = 1 - alpha_weak if g_first >= g_second else alpha_weak
        assert alpha_first[0, u, 0] == pytest.approx(expected, rel=1e-12)


def test_one_uav_best_response_is_the_oracle():
    scenario = make_scenario(area={"side_m": 20.0}, uav={"max_height_m": 60.0},
                             users={"count": 4, "placement": "uniform"})
    layouts = user_layouts(scenario, 2, layout_seed=3)
    found, exact = best_response(scenario, layouts), oracle(scenario, layouts)
    assert np.array_equal(found.objective_bps, exact.objective_bps)
    assert np.array_equal(found.uav_m[:, 0], exact.uav_m)
    assert found.converged.all() and (found.rounds == 1).all()


def test_moves_that_break_the_separation_are_held_back():
    """UAVs 2 m apart at the minimum separation: a step bringing them closer keeps both
    positions (their power moves still apply); a step taking them apart moves both."""
    scenario = tiny()
    env = NetworkBatch(scenario, num_envs=1)
    env.reset()
    actions = env.actions
    start = env.uav_m.copy()
    # UAV 0 (at x = -2) east and UAV 1 (at x = 2) west: 2 m apart -> 0 m
    closer = np.array([[+1, +1, +1, +1, -1, +1, +1, -1]])
    env.step(actions.encode(closer))
    assert np.array_equal(env.uav_m, start)
    assert env.alpha_first[0].tolist() == [[0.75], [0.25]]
    apart = np.array([[-1, +1, +1, +1, +1, +1, +1, +1]])
    env.step(actions.encode(apart))
    assert env.uav_m[0].tolist() == [[-4.0, 2.0, 12.0], [4.0, 2.0, 12.0]]


def test_each_uav_moves_by_its_own_components():
    scenario = make_scenario(users={"count": 8, "placement": "uniform"},
                             uav={"count": 2, "actions": "with-hover"})
    env = NetworkBatch(scenario, num_envs=1)
    assert env.actions.num_components == 2 * (3 + 2)
    env.reset()
    before = env.uav_m.copy()
    climb_uav_1 = np.zeros((1, 10), dtype=np.int64)
    climb_uav_1[0, 5 + 2] = 1
    env.step(env.actions.encode(climb_uav_1))
    assert np.array_equal(env.uav_m[0, 0], before[0, 0])
    assert env.uav_m[0, 1].tolist() == [*before[0, 1, :2].tolist(), before[0, 1, 2] + 1.0]
