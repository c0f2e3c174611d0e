"""Eq. 13 in parts per UAV (docs/model.md §9, the BDQ's ``reward_split = "per-uav"``): each
part against a plain scalar formula written from eq. 13, and the parts adding up to the
reward."""

from __future__ import annotations

import math

import numpy as np
import pytest

from adaptsky.sim.reward import RewardWeights, reward, reward_per_uav

W_HZ = 2e9


def _plain_part(rates: list[float], gains: list[float], serving: list[int], uav: int,
                weights: RewardWeights, num_uavs: int) -> float:
    """r_u = w_r sum_{i of u} R_i/W 1[all R_i >= R_min] + (w_f J / U) 1[R_min = 0]
    + w_g sum_{i of u} g_i + w_s #{i of u: R_i >= R_min} + w_u sum_{i of u, R_i < R_min}
    R_i/W, with J = (sum R)^2 / (N sum R^2) over every user."""
    r_min = float(weights.min_rate_bps)
    every = all(rate >= r_min for rate in rates)
    jain = sum(rates) ** 2 / (len(rates) * sum(rate * rate for rate in rates))
    mine = [i for i in range(len(rates)) if serving[i] == uav]
    part = float(weights.w_rate) * sum(rates[i] / W_HZ for i in mine) * every
    part += float(weights.w_fairness) * jain / num_uavs * (r_min == 0)
    part += float(weights.w_gain) * sum(gains[i] for i in mine)
    part += float(weights.w_satisfied) * sum(rates[i] >= r_min for i in mine)
    part += float(weights.w_unsatisfied) * sum(rates[i] / W_HZ for i in mine
                                                if rates[i] < r_min)
    return part


@pytest.mark.parametrize("min_se", [0.0, 1.5, 0.2])
def test_each_uavs_part_follows_eq_13_over_its_own_users(min_se):
    rates = [6.0e9, 1.0e9, 3.2e9, 2.5e9, 0.4e9, 7.7e9]
    gains = [3e-9, 1e-10, 8e-10, 2e-9, 5e-11, 4e-9]
    serving = [0, 1, 2, 0, 2, 1]
    weights = RewardWeights(w_rate=10.0, w_fairness=3.0, w_gain=1e8, w_satisfied=0.5,
                            w_unsatisfied=2.0, min_rate_bps=min_se * W_HZ)
    rate_array, gain_array = np.array([rates]), np.array([gains])
    fairness = np.array([sum(rates) ** 2 / (6 * sum(r * r for r in rates))])
    parts = reward_per_uav(rate_array, gain_array, fairness, W_HZ, weights,
                           np.array([serving]), 3)
    assert parts.shape == (1, 3)
    for uav in range(3):
        assert parts[0, uav] == pytest.approx(
            _plain_part(rates, gains, serving, uav, weights, 3), rel=1e-12)
    whole = reward(rate_array, gain_array, fairness, W_HZ, weights)
    assert parts.sum(axis=-1) == pytest.approx(whole, rel=1e-12)


def test_parts_per_environment_with_their_own_weights_and_groups():
    rng = np.random.default_rng(4)
    rates, gains = rng.uniform(0, 5e9, (3, 4)), rng.uniform(1e-10, 1e-8, (3, 4))
    fairness = rates.sum(-1) ** 2 / (4 * (rates**2).sum(-1))
    serving = np.array([[0, 0, 1, 1], [1, 0, 1, 0], [0, 1, 1, 0]])
    weights = RewardWeights(w_rate=np.array([1.0, 10.0, 0.0]), w_fairness=np.array([0, 2, 5.0]),
                            w_gain=np.zeros(3), w_satisfied=np.zeros(3),
                            w_unsatisfied=np.zeros(3), min_rate_bps=np.array([0, 0, 1e9]))
    parts = reward_per_uav(rates, gains, fairness, W_HZ, weights, serving, 2)
    for env in range(3):
        one = RewardWeights(**{name: float(np.broadcast_to(getattr(weights, name), (3,))[env])
                               for name in RewardWeights.__dataclass_fields__})
        for uav in range(2):
            assert parts[env, uav] == pytest.approx(_plain_part(
                list(rates[env]), list(gains[env]), list(serving[env]), uav, one, 2),
                rel=1e-12, abs=1e-12)
    np.testing.assert_allclose(parts.sum(-1), reward(rates, gains, fairness, W_HZ, weights),
                               rtol=1e-12)


def _difference_scenario(count: int):
    from tests.conftest import make_scenario

    users = [[-30.0, 10.0], [-12.0, -25.0], [-40.0, -5.0], [-8.0, 30.0], [22.0, 8.0],
             [35.0, -20.0], [10.0, -6.0], [28.0, 33.0], [0.0, 40.0], [-5.0, -40.0],
             [40.0, 40.0], [-40.0, 40.0]][:4 * count]
    return make_scenario(area={"side_m": 100.0}, users={"positions_m": users,
                                                        "pairing": "near-far"},
                         uav={"count": count, "start_m": [0.0, 0.0, 12.0]},
                         radio={"noise_figure_db": 5.0},
                         reward={"w_rate": 10.0, "w_fairness": 2.0},
                         agent={"algorithm": "bdq", "reward_split": "difference"})


@pytest.mark.parametrize("count", [2, 3])
def test_the_difference_part_charges_each_uav_its_interference_by_the_plain_formula(count):
    """R_i^{-u}: user i's rate had UAV u sent nothing, by loops over the links (the gains of
    eq. 4-5 with LoS, SIC by the effective gain, eq. 2-3), and each UAV's difference part
    = its per-UAV part + w_r sum_{i not of u} (R_i - R_i^{-u}) / W."""
    from adaptsky.sim.network import NetworkBatch
    from tests.helpers.scalar_models import ANTENNA_GAIN, NOISE_W, TX_POWER_W, scalar_gain

    scenario = _difference_scenario(count)
    env = NetworkBatch(scenario, num_envs=1, seed=0)
    env.reset()
    rng = np.random.default_rng(1)
    for _ in range(5):
        _, _, _, state = env.step(rng.integers(env.actions.count, size=1))
    uavs, users = state.uav_m[0], env.users_m[0]
    a = env.association
    serving, cluster = a.serving_uav[0], a.cluster[0]
    first, second = a.first_user[0], a.second_user[0]
    pg = TX_POWER_W * ANTENNA_GAIN
    gains = [[scalar_gain(uav, user, "always") for user in users] for uav in uavs]
    n = len(users)
    for silent in range(count):
        interference = [sum(pg * gains[v][i] for v in range(count)
                            if v not in (serving[i], silent)) for i in range(n)]
        expected = []
        for i in range(n):
            u, k = serving[i], cluster[i]
            is_first = first[u, k] == i
            partner = second[u, k] if is_first else first[u, k]
            share = state.alpha[0, i]
            c_i = gains[u][i] / (interference[i] + NOISE_W)
            c_p = gains[u][partner] / (interference[partner] + NOISE_W)
            strong = c_i > c_p or (c_i == c_p and is_first)
            signal = share * pg * gains[u][i]
            sinr = signal / (interference[i] + NOISE_W) if strong else signal / (
                (1 - share) * pg * gains[u][i] + interference[i] + NOISE_W)
            expected.append(2e9 * math.log2(1 + sinr))
        without = env.rates_without(silent)[0]
        mine = serving == silent
        np.testing.assert_allclose(without, expected, rtol=1e-9)
        np.testing.assert_array_equal(without[mine], state.rate_bps[0, mine])
    parts = env.reward_parts(state, "difference")[0]
    split = env.reward_parts(state, "per-uav")[0]
    for u in range(count):
        lost = sum(state.rate_bps[0, i] - env.rates_without(u)[0, i] for i in range(n)
                   if serving[i] != u)
        assert parts[u] == pytest.approx(split[u] + 10.0 * lost / 2e9, rel=1e-12)
        assert lost <= 0  # interference only takes away
