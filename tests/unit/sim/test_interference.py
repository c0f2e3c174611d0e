"""Several UAVs' physics (docs/model.md §9) against plain scalar formulas written from the
model, for U = 2 and 4: link gains, interference, SINR, SIC order, NOMA and OMA rates; a
layout where the interference flips the SIC order; and U = 1 against today's single-UAV
computation (``NetworkBatch``), bit for bit."""

from __future__ import annotations

import math

import numpy as np
import pytest

from adaptsky.channels.contract import LinkGeometry
from adaptsky.sim import noma
from adaptsky.sim.association import associate, serving_groups
from adaptsky.sim.interference import oma_rates_bps, serving_gain
from adaptsky.sim.links import build_channel, link_gains, links_geometry
from adaptsky.sim.network import NetworkBatch
from tests.conftest import make_scenario
from tests.helpers.rates_reference import interference_w, noma_rates
from tests.helpers.scalar_models import (
    ANTENNA_GAIN,
    BANDWIDTH_HZ,
    NOISE_W,
    TX_POWER_W,
    scalar_gain,
    scalar_network,
)

# ---- the vectorised functions -------------------------------------------------------------

def _vectorised(uav_m, users_m, association, alpha_first, reuse, los="always"):
    scenario = make_scenario(channel={"los": los})
    geometry = links_geometry(uav_m, users_m, user_height_m=0.0, carrier_hz=28e9,
                                  bandwidth_hz=BANDWIDTH_HZ)
    gain, _, _ = link_gains(build_channel(scenario), los, geometry,
                            num_uavs=uav_m.shape[1])
    rates = noma_rates(alpha_first, gain, association, tx_power_w=TX_POWER_W,
                       antenna_gain=ANTENNA_GAIN, noise_w=NOISE_W,
                       bandwidth_hz=BANDWIDTH_HZ, reuse=reuse)
    oma = oma_rates_bps(rates.gain, rates.interference_w, tx_power_w=TX_POWER_W,
                        antenna_gain=ANTENNA_GAIN, noise_w=NOISE_W, bandwidth_hz=BANDWIDTH_HZ)
    return gain, rates, oma


def _random_network(rng, num_envs, num_uavs, n):
    """B layouts of n users, U UAVs at random positions, k-means association, near-far
    pairs by each user's gain from its serving UAV's start, random shares."""
    users_m = rng.uniform(-100, 100, size=(num_envs, n, 2))
    starts = np.array([[70 * math.cos(a), 70 * math.sin(a), 50.0]
                       for a in 2 * math.pi * np.arange(num_uavs) / num_uavs])
    serving = serving_groups(users_m, starts, "kmeans")
    start_gain = np.array([[scalar_gain(starts[s], user, "always") for s, user in
                            zip(row, layout, strict=True)]
                           for row, layout in zip(serving, users_m, strict=True)])
    association = associate(serving, start_gain, "near-far", num_uavs)
    uav_m = np.concatenate([rng.uniform(-100, 100, size=(num_envs, num_uavs, 2)),
                            rng.uniform(10, 200, size=(num_envs, num_uavs, 1))], axis=2)
    alpha_first = rng.uniform(0.01, 0.99, size=(num_envs, num_uavs, n // num_uavs // 2))
    return uav_m, users_m, association, alpha_first


@pytest.mark.parametrize("los", ["always", "expected"])
@pytest.mark.parametrize("reuse", ["full", "orthogonal"])
@pytest.mark.parametrize(("num_uavs", "n"), [(2, 8), (4, 16), (2, 4), (4, 8)])
def test_physics_equals_the_plain_formulas(num_uavs, n, reuse, los):
    rng = np.random.default_rng([num_uavs, n])
    uav_m, users_m, association, alpha_first = _random_network(rng, 3, num_uavs, n)
    gain, rates, oma = _vectorised(uav_m, users_m, association, alpha_first, reuse, los)
    assert gain.shape == (3, num_uavs, n)
    flips = 0
    for b in range(3):
        clusters = [[(int(f), int(s)) for f, s in zip(association.first_user[b, u],
                                                     association.second_user[b, u],
                                                     strict=True)]
                    for u in range(num_uavs)]
        gains, interference, strong, sinr, rate, oma_rate = scalar_network(
            uav_m[b], users_m[b], association.serving_uav[b], clusters,
            alpha_first[b].tolist(), reuse, los)
        assert gain[b] == pytest.approx(np.array(gains), rel=1e-12)
        assert rates.interference_w[b] == pytest.approx(interference, rel=1e-12, abs=0)
        assert rates.strong[b].tolist() == strong
        assert rates.sinr[b] == pytest.approx(sinr, rel=1e-12)
        assert rates.rate_bps[b] == pytest.approx(rate, rel=1e-12)
        assert oma[b] == pytest.approx(oma_rate, rel=1e-12)
        plain = [gains[association.serving_uav[b, i]][i] for i in range(n)]
        partner = association.partner[b]
        flips += sum(strong[i] != (plain[i] > plain[partner[i]]) for i in range(n))
    if reuse == "orthogonal":
        assert not rates.interference_w.any() and flips == 0


def test_interference_flips_the_sic_order_the_plain_gains_give():
    """Two UAVs 40 m apart at 30 m; UAV 0 serves A (0, 0), midway, and B (-45, 0), farther
    from it than A but far from UAV 1; UAV 1 serves two users by itself. A has the larger
    gain from UAV 0, yet UAV 1's signal on the shared subchannel drowns it: B's effective
    gain is larger and B is the strong user."""
    users_m = np.array([[[0.0, 0.0], [-45.0, 0.0], [40.0, 10.0], [30.0, -10.0]]])
    uav_m = np.array([[[-20.0, 0.0, 30.0], [20.0, 0.0, 30.0]]])
    serving = np.array([[0, 0, 1, 1]])
    association = associate(serving, np.zeros((1, 4)), "listed", 2)
    alpha_first = np.full((1, 2, 1), 0.3)
    _, full, _ = _vectorised(uav_m, users_m, association, alpha_first, "full")
    _, orthogonal, _ = _vectorised(uav_m, users_m, association, alpha_first, "orthogonal")
    g = full.gain[0]
    assert g[0] > g[1]                                     # A nearer UAV 0
    assert orthogonal.strong[0].tolist()[:2] == [True, False]   # no interference: A strong
    assert full.interference_w[0, 0] > 3 * full.interference_w[0, 1]
    assert full.strong[0].tolist()[:2] == [False, True]    # the flip: B strong
    *_, strong, _, rate, _ = scalar_network(
        uav_m[0], users_m[0], serving[0], [[(0, 1)], [(2, 3)]], [[0.3], [0.3]], "full")
    assert strong[:2] == [False, True]
    assert full.rate_bps[0] == pytest.approx(rate, rel=1e-12)


def _strong(gains: np.ndarray, interference_w: np.ndarray, noise_w: float) -> np.ndarray:
    """The SIC order (noma.is_strong) of users 0-3 in clusters (0, 1) and (2, 3)."""
    association = associate(np.zeros((1, 4), dtype=np.intp), np.zeros((1, 4)), "listed", 1)
    partner = association.partner
    effective = gains / (interference_w + noise_w)
    return noma.is_strong(effective, np.take_along_axis(effective, partner, axis=1), gains,
                          np.take_along_axis(gains, partner, axis=1), association.is_first)


def test_the_order_ties_go_to_the_larger_plain_gain_then_to_the_first_user():
    gains = np.array([[2.0, 1.0, 1.0, 1.0]])
    # equal effective gains for users 0 and 1 (twice the gain, twice the interference + noise)
    strong = _strong(gains, np.array([[1.0, 0.0, 0.0, 0.0]]), 1.0)
    assert strong.tolist() == [[True, False, True, False]]
    strong = _strong(gains[:, ::-1].copy(), np.array([[0.0, 0.0, 0.0, 1.0]]), 1.0)
    assert strong.tolist() == [[True, False, False, True]]


@pytest.mark.parametrize("los", ["always", "expected", "sampled"])
@pytest.mark.parametrize("pairing", ["near-far", "listed"])
def test_one_uav_gives_todays_numbers_bit_for_bit(los, pairing):
    """No ulp of difference: the same geometry, the same generator draws, the same SIC order
    and the same floating-point operations as ``NetworkBatch``'s step."""
    scenario = make_scenario(users={"count": 8, "placement": "uniform", "layout_seed": 3,
                                    "pairing": pairing},
                             channel={"los": los}, radio={"noise_figure_db": 5.0})
    num_envs = 32
    batch = NetworkBatch(scenario, num_envs=num_envs, seed=11)
    rng = np.random.default_rng(5)
    uav_m = np.concatenate([rng.uniform(-50, 50, (num_envs, 2)),
                            rng.uniform(10, 200, (num_envs, 1))], axis=1)
    alpha_first = rng.uniform(0.01, 0.99, (num_envs, scenario.num_clusters))
    state = batch.evaluate_at(uav_m, alpha_first)

    radio = scenario.radio
    users_m = batch.layouts_m
    start = np.broadcast_to(scenario.uav_start_positions_m, (num_envs, 1, 3))
    start_geometry = links_geometry(start, users_m, user_height_m=0.0,
                                        carrier_hz=radio.carrier_hz,
                                        bandwidth_hz=radio.bandwidth_hz)
    deterministic = "always" if los == "always" else "expected"
    start_gain, _, _ = link_gains(batch.channel, deterministic, start_geometry)
    serving = serving_groups(users_m, np.array(scenario.uav_start_positions_m),
                             scenario.users.association)
    association = associate(serving, serving_gain(start_gain, serving), pairing, 1)
    assert np.array_equal(association.first_user[:, 0], batch.first_user)
    assert np.array_equal(association.second_user[:, 0], batch.second_user)

    geometry = links_geometry(uav_m[:, None, :], users_m, user_height_m=0.0,
                                  carrier_hz=radio.carrier_hz, bandwidth_hz=radio.bandwidth_hz)
    gain, los_state, p_los = link_gains(batch.channel, los, geometry, np.random.default_rng(11))
    assert np.array_equal(gain[:, 0], state.gain)
    assert np.array_equal(los_state[:, 0], state.los)
    assert np.array_equal(p_los[:, 0], state.p_los)
    rates = noma_rates(alpha_first[:, None, :], gain, association,
                       tx_power_w=radio.tx_power_w, antenna_gain=radio.antenna_gain,
                       noise_w=radio.noise_w, bandwidth_hz=radio.bandwidth_hz,
                       reuse=radio.reuse)
    assert not rates.interference_w.any()
    assert np.array_equal(rates.rate_bps, state.rate_bps)
    assert np.array_equal(rates.gain, state.gain)


def test_one_uav_draws_as_todays_batch_with_a_generator_per_environment():
    scenario = make_scenario(users={"count": 4, "placement": "uniform"},
                             channel={"los": "sampled"})
    seeds = [np.random.SeedSequence(s) for s in (3, 4, 5)]
    batch = NetworkBatch(scenario, num_envs=3, seed=seeds)
    uav_m = np.array([[0.0, 0.0, 50.0], [10.0, -5.0, 20.0], [-30.0, 40.0, 120.0]])
    state = batch.evaluate_at(uav_m, np.full((3, 2), 0.5))
    geometry = links_geometry(uav_m[:, None, :], batch.layouts_m, user_height_m=0.0,
                                  carrier_hz=28e9, bandwidth_hz=2e9)
    rngs = [np.random.default_rng(s) for s in (3, 4, 5)]
    gain, los, _ = link_gains(batch.channel, "sampled", geometry, rngs)
    assert np.array_equal(los[:, 0], state.los) and np.array_equal(gain[:, 0], state.gain)


def test_with_a_generator_per_environment_each_draws_its_own_uavs_links():
    rng = np.random.default_rng(0)
    uav_m = np.concatenate([rng.uniform(-50, 50, (2, 3, 2)), rng.uniform(10, 90, (2, 3, 1))],
                           axis=2)
    users_m = rng.uniform(-50, 50, (2, 4, 2))
    channel = build_channel(make_scenario())
    geometry = links_geometry(uav_m, users_m, user_height_m=0.0, carrier_hz=28e9,
                                  bandwidth_hz=2e9)
    _, both, _ = link_gains(channel, "sampled", geometry,
                            [np.random.default_rng(1), np.random.default_rng(2)], num_uavs=3)
    second = links_geometry(uav_m[1:], users_m[1:], user_height_m=0.0, carrier_hz=28e9,
                                bandwidth_hz=2e9)
    _, alone, _ = link_gains(channel, "sampled", second, np.random.default_rng(2), num_uavs=3)
    assert np.array_equal(both[1], alone[0])


def test_oma_halves_band_power_noise_and_interference():
    gain, interference = np.array([[1e-10, 3e-11]]), np.array([[0.0, 2e-8]])
    rates = oma_rates_bps(gain, interference, tx_power_w=TX_POWER_W, antenna_gain=64,
                          noise_w=NOISE_W, bandwidth_hz=BANDWIDTH_HZ)
    for i in range(2):
        # half the power over half the noise and interference, in half the band
        half_snr = (TX_POWER_W / 2) * 64 * gain[0, i] / ((interference[0, i] + NOISE_W) / 2)
        assert rates[0, i] == pytest.approx(BANDWIDTH_HZ / 2 * math.log2(1 + half_snr),
                                            rel=1e-14)


def test_gains_of_every_link_are_the_plugins_gains_of_each_uav_alone():
    """Flattening (B*U, N): row (b, u) is exactly what the plugin gives UAV u of layout b."""
    rng = np.random.default_rng(2)
    uav_m = np.concatenate([rng.uniform(-50, 50, (3, 4, 2)), rng.uniform(10, 90, (3, 4, 1))],
                           axis=2)
    users_m = rng.uniform(-50, 50, (3, 6, 2))
    channel = build_channel(make_scenario(channel={"model": "sub6-al-hourani"}))
    gain, _, _ = link_gains(channel, "expected", links_geometry(
        uav_m, users_m, user_height_m=0.0, carrier_hz=2e9, bandwidth_hz=50e6), num_uavs=4)
    for b in range(3):
        for u in range(4):
            alone = LinkGeometry.between(uav_m[b, u][None], users_m[b][None], carrier_hz=2e9,
                                         bandwidth_hz=50e6)
            assert np.array_equal(gain[b, u], channel.expected_gain(alone)[0])


def test_interference_needs_a_cluster_on_the_same_subchannel():
    """UAV 1 has one cluster, UAV 0 two: cluster 1 of UAV 0 sees no interference."""
    serving = np.array([[0, 0, 0, 0, 1, 1]])
    association = associate(serving, np.zeros((1, 6)), "listed", 2)
    gain = np.ones((1, 2, 6))
    interference = interference_w(gain, association, 1.0, 1.0, "full")
    assert interference.tolist() == [[1.0, 1.0, 0.0, 0.0, 1.0, 1.0]]


def test_groups_of_different_sizes_give_the_plain_formulas():
    """users.uav = [0, 0, 0, 0, 1, 1]: UAV 0 serves two clusters, UAV 1 one (docs/model.md
    §9). Under full reuse cluster 0's users hear the other UAV; UAV 0's cluster 1 has its
    subchannel alone. Every step gives finite numbers; no action moves UAV 1's unused share."""
    users = [[-30.0, 10.0], [-10.0, -20.0], [-40.0, -35.0], [-5.0, 30.0], [30.0, 20.0],
             [40.0, -10.0]]
    serving = [0, 0, 0, 0, 1, 1]
    scenario = make_scenario(
        users={"positions_m": users, "association": "listed", "uav": serving,
               "pairing": "listed"},
        uav={"count": 2, "start_positions_m": [[-20.0, 0.0, 50.0], [25.0, 0.0, 50.0]]},
        radio={"noise_figure_db": 5.0})
    batch = NetworkBatch(scenario, num_envs=1, seed=0)
    uav_m = np.array([[[-25.0, 5.0, 40.0], [20.0, -5.0, 60.0]]])
    state = batch.evaluate_at(uav_m, np.array([[[0.3, 0.8], [0.6, 0.5]]]))
    _, interference, strong, _, rate, _ = scalar_network(
        uav_m[0], users, serving, [[(0, 1), (2, 3)], [(4, 5)]], [[0.3, 0.8], [0.6]], "full")
    assert interference[2] == interference[3] == 0.0 < min(interference[:2] + interference[4:])
    assert state.interference_w[0] == pytest.approx(interference, rel=1e-12, abs=0)
    assert state.strong[0].tolist() == strong
    assert state.rate_bps[0] == pytest.approx(rate, rel=1e-12)
    assert batch.actions.num_components == (3 + 2) + (3 + 1)
    obs, start = batch.reset()
    assert np.isfinite(start.reward).all() and np.isfinite(obs).all()
    for action in np.random.default_rng(0).integers(0, batch.actions.count, 30):
        obs, reward, _, _ = batch.step(np.array([action]))
        assert np.isfinite(reward).all() and np.isfinite(obs).all()
    assert batch.sim_state.alpha_first[0, 1, 1] == scenario.uav.start_alpha
