"""The uplink (docs/model.md §17): the simulator's rates against a plain scalar formula with
loops for one UAV and two (pairs and clusters of three, with and without the SIC residual),
the oracle against brute force over the lattice and every transmit-share vector, and the
refusals in one line."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from adaptsky.rollouts.cluster_oracle import cluster_oracle
from adaptsky.sim.network import NetworkBatch
from adaptsky_cli.cli.main import main
from tests.conftest import ROOT, make_scenario
from tests.helpers.cli import one_line, refusal_of_scenario
from tests.helpers.scalar_models import (
    ANTENNA_GAIN,
    NOISE_W,
    assert_oracle_is,
    brute_force_lattice,
    clusters_of,
    listed_clusters_env,
    scalar_gain,
    scalar_uplink_network,
    small_lattice,
)

RADIO = {"thermal_noise_dbm": -79.0, "direction": "uplink"}
USERS_M = [[-30.0, 10.0], [25.0, -40.0], [5.0, 5.0], [45.0, 35.0], [-10.0, -45.0],
           [38.0, 2.0]]
P_U = 10 ** ((23.0 - 30) / 10)          # the default 23 dBm


@pytest.mark.parametrize("size", [2, 3])
@pytest.mark.parametrize("sic_residual", [0.0, 0.1])
def test_one_uav_rates_match_the_scalar_formula(size, sic_residual):
    env = listed_clusters_env(USERS_M, size, {**RADIO, "sic_residual": sic_residual})
    uav_m = [12.0, -7.0, 40.0]
    betas = np.random.default_rng(size).uniform(0.05, 1.0, 6)
    state = env.evaluate_at(np.array([uav_m]), betas[None])
    *_, rate = scalar_uplink_network([uav_m], USERS_M, clusters_of(env), betas.tolist(),
                                     "full", P_U, sic_residual)
    assert state.rate_bps[0] == pytest.approx(rate, rel=1e-12)
    assert np.array_equal(state.alpha[0], betas)      # the power feature: each user's share
    # the UAV decodes the strongest received signal first: it hears every other member
    received = betas * np.array([scalar_gain(uav_m, user, "always") for user in USERS_M])
    first = [max(cluster, key=lambda i: received[i]) for cluster in clusters_of(env)[0]]
    assert np.flatnonzero(state.strong[0]).tolist() == sorted(first)


@pytest.mark.parametrize("size", [2, 3])
def test_two_uavs_rates_match_the_scalar_formula(size):
    users_m = [[2 * x, 2 * y] for x, y in USERS_M * 2]
    scenario = make_scenario(
        area={"side_m": 200.0}, radio={**RADIO, "sic_residual": 0.02},
        users={"positions_m": users_m, "association": "listed", "cluster_size": size,
               "uav": [0] * 6 + [1] * 6, "pairing": "listed"},
        uav={"count": 2, "start_m": [0.0, 0.0, 50.0], "min_separation_m": 10.0})
    env = NetworkBatch(scenario, seed=0)
    uav_m = np.array([[[-30.0, 20.0, 40.0], [40.0, 10.0, 60.0]]])
    betas = np.random.default_rng(7).uniform(0.05, 1.0, 12)
    state = env.evaluate_at(uav_m, betas.reshape(1, 2, 6))
    _, interference, _, rate = scalar_uplink_network(uav_m[0], users_m, clusters_of(env),
                                                     betas.tolist(), "full", P_U, 0.02)
    assert state.interference_w[0] == pytest.approx(interference, rel=1e-12)
    assert min(interference) > 0
    assert state.rate_bps[0] == pytest.approx(rate, rel=1e-12)


def _brute_force(scenario, users_m):
    """The best objective over every lattice point and every transmit-share vector of every
    cluster, with scalar loops (one UAV, LoS always)."""
    size, step = scenario.cluster_size, scenario.uav.power_step
    grid = [round(step * i, 12) for i in range(1, round(1 / step) + 1)]
    s, eps = P_U * ANTENNA_GAIN / NOISE_W, scenario.radio.sic_residual

    def spectral(betas, g):
        r = [b * s * gi for b, gi in zip(betas, g, strict=True)]
        return [math.log2(1 + r[j] / (sum(eps * r[m] if (r[m], -m) > (r[j], -j) else r[m]
                                          for m in range(size) if m != j) + 1))
                for j in range(size)]

    return brute_force_lattice(scenario, users_m, spectral,
                               list(itertools.product(grid, repeat=size)))


@pytest.mark.parametrize("bounded", [True, False])
@pytest.mark.parametrize(("sic_residual", "min_se"), [(0.0, 0.0), (0.1, 0.0), (0.0, 2.0)])
def test_the_uplink_oracle_equals_brute_force(monkeypatch, sic_residual, min_se, bounded):
    from adaptsky.rollouts import cluster_oracle as module

    if not bounded:
        monkeypatch.setattr(module, "declares_monotone_gains", lambda model: False)
    users_m = [[-15.0, 10.0], [12.0, -18.0], [3.0, 4.0], [18.0, 16.0]]
    scenario = small_lattice(users_m, {**RADIO, "sic_residual": sic_residual}, min_se)
    assert_oracle_is(cluster_oracle(scenario, np.array([users_m])),
                     _brute_force(scenario, users_m))


def test_the_uav_spends_no_radio_power_in_the_uplink():
    """Its step's energy is the propulsion's alone: the downlink's less P_T per cluster."""
    down = NetworkBatch(make_scenario(), seed=0)
    up = NetworkBatch(make_scenario(radio={"direction": "uplink"}), seed=0)
    radio_j = 2 * 0.1 * 1.0                  # K = 2 clusters at 20 dBm for a 1 s step
    assert down.hover_energy_j[0] - up.hover_energy_j[0] == pytest.approx(radio_j, rel=1e-9)


@pytest.mark.parametrize(("body", "words"), [
    ('[users]\ntx_power_dbm = 20', "users.tx_power_dbm: the users' transmit power is the "
                                   "uplink's, but radio.direction = 'downlink'"),
    ('[radio]\ndirection = "uplink"\n[channel.csi]\nmodel = "gaussian"\nnmse_db = -10',
     "channel.csi: imperfect channel knowledge is modelled for the downlink"),
    ('[radio]\ndirection = "uplink"\n[uav]\ncount = 2\n[users]\ncount = 8\n[agent]\n'
     'algorithm = "bdq"\nreward_split = "difference"',
     "agent.reward_split: 'difference' prices a UAV's interference on the downlink"),
    ('[radio]\ndirection = "uplink"\n[channel]\nmodel = "uma-av"',
     "radio.direction: 'uplink', but channel model 'uma-av' does not state that its gains "
     "hold from the users to the UAV"),
])
def test_what_the_uplink_does_not_take_is_one_line(tmp_path, capsys, body, words):
    assert words in refusal_of_scenario(tmp_path, capsys, body)


@pytest.mark.parametrize("method", ["soa", "oma", "tracking"])
def test_downlink_baselines_refuse_the_uplink_in_one_line(capsys, method):
    scenario = ROOT / "scenarios" / "uplink_mmwave.toml"
    assert main(["baseline", str(scenario), "--method", method]) == 1
    assert f"radio.direction: '{method}' plans or searches the downlink only" in one_line(
        capsys)
