"""Imperfect SIC (docs/model.md §13): the simulator's rates against plain scalar formulas for
one and two UAVs, epsilon = 1 as no cancellation at all, and the oracle and best response
exact under it (brute force over every grid share)."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from adaptsky.rollouts.objective import constrained_sum_rate
from adaptsky.rollouts.oracle import lattice, oracle
from adaptsky.rollouts.several_uavs import best_response
from adaptsky.sim.layout import user_layouts
from adaptsky.sim.network import NetworkBatch
from tests.conftest import make_scenario
from tests.helpers.scalar_models import BANDWIDTH_HZ, scalar_network

# the scalar helpers' radio: 20 dBm, 8 x 8 antennas, -79 dBm noise, 2 GHz
RADIO = {"thermal_noise_dbm": -79.0}
USERS_M = [[-30.0, 10.0], [25.0, -40.0], [5.0, 5.0], [45.0, 35.0]]


def _one_uav(sic_residual: float, min_se: float = 0.0):
    return make_scenario(users={"positions_m": USERS_M, "pairing": "listed"},
                         radio={**RADIO, "sic_residual": sic_residual},
                         reward={"min_se": min_se})


@pytest.mark.parametrize("sic_residual", [0.0, 0.01, 0.05, 0.3, 1.0])
def test_one_uav_rates_match_the_scalar_formula(sic_residual):
    scenario = _one_uav(sic_residual)
    env = NetworkBatch(scenario, seed=0)
    uav_m, alpha_first = [12.0, -7.0, 40.0], [0.3, 0.8]
    state = env.evaluate_at(np.array([uav_m]), np.array([alpha_first]))
    clusters = [[(int(f), int(s)) for f, s in zip(env.first_user[0], env.second_user[0],
                                                  strict=True)]]
    shares = [[alpha_first[k] for k in range(2)]]
    _, _, strong, sinr, rate, _ = scalar_network([uav_m], USERS_M, [0] * 4, clusters, shares,
                                                 "full", sic_residual=sic_residual)
    assert state.strong[0].tolist() == strong
    assert state.rate_bps[0] == pytest.approx(rate, rel=1e-12)
    # the strong user's SINR by hand: alpha_s s g_s / (eps alpha_w s g_s + 1)
    for i, value in enumerate(sinr):
        expected = state.rate_bps[0, i] / BANDWIDTH_HZ
        assert math.log2(1 + value) == pytest.approx(expected, rel=1e-12)


def test_residual_one_is_the_weak_users_formula():
    """epsilon = 1: the strong user decodes with its partner's whole signal as interference,
    SINR_s = alpha_s s g_s / (alpha_w s g_s + 1), the formula of a weak user."""
    env = NetworkBatch(_one_uav(1.0), seed=0)
    state = env.evaluate_at(np.array([[0.0, 0.0, 30.0]]), np.array([[0.6, 0.6]]))
    perfect = NetworkBatch(_one_uav(0.0), seed=0).evaluate_at(
        np.array([[0.0, 0.0, 30.0]]), np.array([[0.6, 0.6]]))
    snr = 0.1 * 64 / 10 ** ((-79.0 - 30) / 10) * state.gain[0]      # s g
    alpha = state.alpha[0]
    partner = 1 - alpha
    no_cancellation = BANDWIDTH_HZ * np.log2(1 + alpha * snr / (partner * snr + 1))
    assert state.rate_bps[0] == pytest.approx(no_cancellation, rel=1e-12)
    # only the strong users lose; the weak users' rates are unchanged, bit for bit
    weak = ~state.strong[0]
    assert np.array_equal(state.rate_bps[0, weak], perfect.rate_bps[0, weak])
    assert np.all(state.rate_bps[0, ~weak] < perfect.rate_bps[0, ~weak])


@pytest.mark.parametrize("sic_residual", [0.0, 0.02, 0.5])
def test_two_uavs_rates_match_the_scalar_formula(sic_residual):
    users_m = [[-64.0, 28.0], [-7.0, -26.0], [-29.0, 58.0], [81.0, -65.0],
               [31.0, -40.0], [93.0, 84.0], [27.0, 51.0], [3.0, 65.0]]
    scenario = make_scenario(
        area={"side_m": 200.0}, radio={**RADIO, "sic_residual": sic_residual},
        users={"positions_m": users_m, "association": "listed",
               "uav": [0, 0, 0, 0, 1, 1, 1, 1], "pairing": "listed"},
        uav={"count": 2, "start_m": [0.0, 0.0, 50.0], "min_separation_m": 10.0})
    env = NetworkBatch(scenario, seed=0)
    uav_m = np.array([[[-30.0, 20.0, 40.0], [40.0, 10.0, 60.0]]])
    alpha_first = np.array([[[0.25, 0.7], [0.9, 0.4]]])
    state = env.evaluate_at(uav_m, alpha_first)
    clusters = [[(int(f), int(s)) for f, s in zip(env.first_user[0, u], env.second_user[0, u],
                                                  strict=True)] for u in range(2)]
    *_, strong, _, rate, _ = scalar_network(uav_m[0], users_m, env.roles()[0][0], clusters,
                                            alpha_first[0].tolist(), "full",
                                            sic_residual=sic_residual)
    assert state.strong[0].tolist() == strong
    assert state.rate_bps[0] == pytest.approx(rate, rel=1e-12)


def _small(sic_residual: float, min_se: float, **sections):
    """A reduced lattice: 12 m area, heights 10-16 m, alpha grid 0.1 ... 0.9."""
    return make_scenario(area={"side_m": 12.0}, users={"positions_m": None, "count": 4},
                         uav={"start_m": [0.0, 0.0, 12.0], "min_height_m": 10.0,
                              "max_height_m": 16.0, "step_m": [2.0, 2.0, 2.0],
                              "power_step": 0.1},
                         reward={"min_se": min_se}, radio={"sic_residual": sic_residual},
                         **sections)


@pytest.mark.parametrize(("sic_residual", "min_se"), [(0.05, 0.0), (0.05, 2.0), (1.0, 0.5)])
def test_oracle_under_imperfect_sic_equals_brute_force(sic_residual, min_se):
    scenario = _small(sic_residual, min_se)
    users_m = user_layouts(scenario, 3, layout_seed=5)
    result = oracle(scenario, users_m)
    xs, ys, hs, alphas = lattice(scenario)
    env = NetworkBatch(scenario, num_envs=3, users_m=users_m)
    best = np.zeros(3)
    for x, y, h in itertools.product(xs, ys, hs):
        for combo in itertools.product(alphas, repeat=2):
            state = env.evaluate_at(np.tile([x, y, h], (3, 1)), np.tile(combo, (3, 1)))
            best = np.maximum(best, constrained_sum_rate(state.rate_bps, scenario.min_rate_bps))
    assert result.objective_bps == pytest.approx(best, rel=1e-12, abs=0.0)
    assert np.all(best > 0)


def test_imperfect_sic_costs_the_oracle_and_best_response():
    """The ceiling falls as epsilon grows (the strong users lose), and best response of two
    UAVs, whose shares are searched on the grid too, never exceeds its perfect-SIC value."""
    values = []
    for eps in (0.0, 0.05, 0.5):
        scenario = _small(eps, 0.0)
        values.append(oracle(scenario, user_layouts(scenario, 2, layout_seed=1)).objective_bps)
    assert np.all(values[0] > values[1]) and np.all(values[1] > values[2])
    two = {"area": {"side_m": 20.0}, "users": {"positions_m": None, "count": 8},
           "uav": {"count": 2, "start_m": [0.0, 0.0, 12.0], "min_height_m": 10.0,
                   "max_height_m": 14.0, "step_m": [4.0, 4.0, 2.0], "power_step": 0.1,
                   "min_separation_m": 1.0}}
    results = []
    for eps in (0.0, 0.1):
        scenario = make_scenario(reward={"min_se": 0.0}, radio={"sic_residual": eps}, **two)
        results.append(best_response(scenario, user_layouts(scenario, 1, layout_seed=2),
                                     rounds=2).objective_bps)
    assert results[1][0] < results[0][0]
