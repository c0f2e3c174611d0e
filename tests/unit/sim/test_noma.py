"""NOMA maths (eq. 2, 3, 9, 13) against hand calculations."""

import math

import numpy as np
import pytest

from adaptsky.sim import noma


def test_strong_and_weak_sinr_by_hand():
    # s = P_T G / sigma^2 = 1e12; first user g = 1e-10 (strong), second g = 1e-11 (weak),
    # alpha_first = 0.3: strong SINR = 0.3 * 100 = 30; weak = 0.7 * 10 / (0.3 * 10 + 1) = 1.75
    sinr_first, sinr_second = noma.cluster_sinr(np.array([0.3]), np.array([1e-10]),
                                                np.array([1e-11]), 1e12)
    assert sinr_first[0] == pytest.approx(30.0)
    assert sinr_second[0] == pytest.approx(1.75)


def test_sic_order_follows_the_gains():
    # swap the gains: now the second user is strong, SINR = 0.7 * 100 = 70, and the first
    # user is weak with the second's share as interference: 0.3 * 10 / (0.7 * 10 + 1) = 0.375
    sinr_first, sinr_second = noma.cluster_sinr(np.array([0.3]), np.array([1e-11]),
                                                np.array([1e-10]), 1e12)
    assert sinr_second[0] == pytest.approx(70.0)
    assert sinr_first[0] == pytest.approx(0.375)


def test_equal_gains_make_the_first_user_strong():
    sinr_first, sinr_second = noma.cluster_sinr(np.array([0.5]), np.array([1e-10]),
                                                np.array([1e-10]), 1e12)
    assert sinr_first[0] == pytest.approx(50.0)
    assert sinr_second[0] == pytest.approx(50.0 / 51.0)


def test_rate_is_shannon():
    assert noma.rate_bps(np.array([3.0]), 2e9)[0] == pytest.approx(2e9 * 2.0)


@pytest.mark.parametrize(("rates", "expected"), [
    ([1.0, 1.0, 1.0, 1.0], 1.0),
    ([4.0, 0.0, 0.0, 0.0], 0.25),                # one user served: 1/N
    ([1.0, 2.0, 3.0, 4.0], 100 / (4 * 30)),      # (10)^2 / (4 (1+4+9+16))
    ([0.0, 0.0, 0.0, 0.0], 1.0),                 # docs/model.md §1: J = 1 when all rates are 0
])
def test_jain(rates, expected):
    assert noma.jain_fairness(np.array([rates]))[0] == pytest.approx(expected)


def test_reward_terms_by_hand():
    bandwidth_hz = 1e6
    rates = np.array([[3e6, 1e6, 0.5e6, 2e6]])       # SE 3, 1, 0.5, 2
    gains = np.array([[1e-9, 2e-9, 3e-9, 4e-9]])
    fairness = noma.jain_fairness(rates)
    weights = noma.RewardWeights(w_rate=10, w_fairness=5, w_gain=1e7, w_satisfied=100,
                                 w_unsatisfied=10, min_rate_bps=0.8e6)
    # user 3 (0.5 < 0.8) is unsatisfied: no rate term, no fairness term (R_min > 0),
    # gain 1e7 * 1e-8 = 0.1, satisfied 3 * 100, unsatisfied 10 * 0.5
    value = noma.reward(rates, gains, fairness, bandwidth_hz, weights)[0]
    assert value == pytest.approx(0.1 + 300 + 5)
    weights = noma.RewardWeights(w_rate=10, w_fairness=5, w_gain=1e7, w_satisfied=100,
                                 w_unsatisfied=10, min_rate_bps=0.0)
    # R_min = 0: every user satisfied; 10 * 6.5 + 5 J + 0.1 + 400
    jain = 6.5**2 / (4 * (9 + 1 + 0.25 + 4))
    value = noma.reward(rates, gains, fairness, bandwidth_hz, weights)[0]
    assert value == pytest.approx(65 + 5 * jain + 0.1 + 400)
    assert math.isclose(fairness[0], jain)
