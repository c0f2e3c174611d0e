"""The explicit simulation state with its UAV axis, the pure step over it (docs/model.md §3)
and the reward of eq. 13 as named terms, each against numbers worked out by hand."""

from __future__ import annotations

import math

import numpy as np
import pytest

from adaptsky.sim.network import NetworkBatch
from adaptsky.sim.reward import (
    FAIRNESS,
    GAIN,
    RATE,
    REWARD_TERMS,
    SATISFIED,
    UNSATISFIED,
    RewardFromSums,
    RewardInputs,
    RewardWeights,
    weighted_sum,
    with_weights,
)
from adaptsky.sim.state import Dynamics, SimState, step
from tests.conftest import TRAINING_LAYOUT_M, make_scenario

USERS_M = [[list(p) for p in TRAINING_LAYOUT_M]]          # (B = 1, N = 4, 2)


def test_the_state_has_a_uav_axis_of_one(mmwave):
    env = NetworkBatch(mmwave, num_envs=3, seed=0)
    env.reset()
    state = env.sim_state
    assert state.config.shape == (3, 1, 3 + 2)               # (B, U, 3 + K)
    assert state.uav_m.shape == (3, 1, 3) and state.alpha_first.shape == (3, 1, 2)
    assert state.users_m.shape == (3, 4, 2) and state.num_uavs == 1 and state.t == 0
    assert state.uav_m[:, 0].tolist() == [[0.0, 0.0, 50.0]] * 3
    assert state.alpha_first[:, 0].tolist() == [[0.5, 0.5]] * 3
    # consumers outside adaptsky.sim see one UAV per environment: (B, 3), (B, K)
    assert env.uav_m.shape == (3, 3) and env.alpha_first.shape == (3, 2)
    assert np.array_equal(env.uav_m, state.uav_m[:, 0])
    _, _, _, network = env.step(np.array([0, 5, 31]))
    assert env.sim_state.t == env.t == 1
    assert network.uav_m.shape == (3, 3)
    assert np.array_equal(network.uav_m, env.sim_state.uav_m[:, 0])


def _state(uav_m, alpha_first, t=7):
    return SimState.of([[uav_m]], [[alpha_first]], USERS_M, t=t)


def test_a_hand_built_state_steps_by_its_action(mmwave):
    # directions x +1, y -1, h +1, cluster 1 -1, cluster 2 +1 are the base-2 digits
    # (1, 0, 1, 0, 1) of the action: 1 + 4 + 16 = 21 (docs/model.md §3)
    dynamics = Dynamics.of(mmwave, num_envs=1)
    before = _state([10.0, -20.0, 30.0], [0.5, 0.3])
    after = step(before, np.array([21]), dynamics)
    # delta = 1 m on every axis, delta_alpha = 0.01
    assert after.uav_m[0, 0].tolist() == [11.0, -21.0, 31.0]
    assert after.alpha_first[0, 0] == pytest.approx([0.49, 0.31], abs=1e-15)
    assert after.t == 8
    assert np.array_equal(after.users_m, before.users_m)
    # the step is pure: the state it was given is as it was
    assert before.uav_m[0, 0].tolist() == [10.0, -20.0, 30.0] and before.t == 7


def test_a_step_clips_to_the_feasible_set(mmwave):
    # x +1 (digit 1), y +1 (2), h -1 (0), cluster 1 +1 (8), cluster 2 -1 (0): action 11, from
    # x = L/2 = 50, h = h_min = 10, alpha = (0.99, 0.01): x, h and both shares stay
    dynamics = Dynamics.of(mmwave, num_envs=1)
    after = step(_state([50.0, 0.0, 10.0], [0.99, 0.01]), np.array([11]), dynamics)
    assert after.uav_m[0, 0].tolist() == [50.0, 1.0, 10.0]
    assert after.alpha_first[0, 0].tolist() == [0.99, 0.01]


def test_users_walk_along_the_headings_they_are_given():
    scenario = make_scenario(users={"speed_m_per_step": 1.5})
    dynamics = Dynamics.of(scenario, num_envs=1)
    headings_rad = np.array([[0.0, math.pi / 2, math.pi, 0.0]])
    after = step(_state([0.0, 0.0, 50.0], [0.5, 0.5]), np.array([0]), dynamics, headings_rad)
    # users at (4, 15), (-44, -49), (-5, 21), (47, 49); the last one stops at x = L/2 = 50
    expected = [[5.5, 15.0], [-44.0, -47.5], [-6.5, 21.0], [48.5, 49.0]]
    np.testing.assert_allclose(after.users_m[0], expected, rtol=0, atol=1e-12)
    after = step(after, np.array([0]), dynamics, headings_rad)
    assert after.users_m[0, 3, 0] == 50.0


def test_actions_are_checked(mmwave):
    dynamics = Dynamics.of(mmwave, num_envs=2)
    with pytest.raises(ValueError, match="expected 2 actions"):
        dynamics.checked(np.array([1]))
    with pytest.raises(ValueError, match=r"actions must lie in \[0, 32\)"):
        dynamics.checked(np.array([0, 32]))


# eq. 13 by hand: W = 1 MHz, N = 4, SE R_i/W = 3, 1, 0.5, 2 bit/s/Hz
BANDWIDTH_HZ = 1e6
RATES_BPS = np.array([[3e6, 1e6, 0.5e6, 2e6]])
GAINS = np.array([[1e-9, 2e-9, 3e-9, 4e-9]])
JAIN = 6.5**2 / (4 * (9 + 1 + 0.25 + 4))               # eq. 9
WEIGHTS = {"w_rate": 10.0, "w_fairness": 5.0, "w_gain": 1e7, "w_satisfied": 100.0,
           "w_unsatisfied": 10.0}


def _inputs(min_rate_bps):
    return RewardInputs.from_rates(RATES_BPS, GAINS, np.array([JAIN]), BANDWIDTH_HZ,
                                   min_rate_bps)


@pytest.mark.parametrize(("term", "min_rate_bps", "expected"), [
    # R_min = 0.8 Mbit/s: user 3 (0.5) is below it
    (RATE, 0.8e6, 0.0),                     # w_r R_tot/W, but not every user is satisfied
    (FAIRNESS, 0.8e6, 0.0),                 # w_f J only when R_min = 0
    (GAIN, 0.8e6, 1e7 * 1e-8),              # w_g sum g_i
    (SATISFIED, 0.8e6, 100.0 * 3),          # w_s, three users at or above R_min
    (UNSATISFIED, 0.8e6, 10.0 * 0.5),       # w_u, the SE of user 3
    # R_min = 0: every user is satisfied
    (RATE, 0.0, 10.0 * 6.5),
    (FAIRNESS, 0.0, 5.0 * JAIN),
    (GAIN, 0.0, 1e7 * 1e-8),
    (SATISFIED, 0.0, 100.0 * 4),
    (UNSATISFIED, 0.0, 0.0),
    # R_min = 0.4 Mbit/s: every user satisfied, but no fairness term
    (RATE, 0.4e6, 10.0 * 6.5),
    (FAIRNESS, 0.4e6, 0.0),
])
def test_each_reward_term_by_hand(term, min_rate_bps, expected):
    weighted = ((term, WEIGHTS[term.weight_key]),)
    assert weighted_sum(weighted, _inputs(min_rate_bps))[0] == pytest.approx(expected,
                                                                             rel=1e-12)


def _eq13(se, gains, min_se, weights):
    """Eq. 13 for one environment, in plain Python floats."""
    satisfied = [s >= min_se for s in se]
    value = weights["w_rate"] * sum(se) * all(satisfied)
    if min_se == 0:
        total, squares = sum(se), sum(s * s for s in se)
        value += weights["w_fairness"] * (total**2 / (len(se) * squares) if squares else 1.0)
    value += weights["w_gain"] * sum(gains)
    value += weights["w_satisfied"] * sum(satisfied)
    return value + weights["w_unsatisfied"] * sum(s for s, ok in zip(se, satisfied,
                                                                     strict=True) if not ok)


def test_the_terms_are_named_after_their_weights():
    assert [t.name for t in REWARD_TERMS] == ["rate", "fairness", "gain", "satisfied",
                                              "unsatisfied"]
    assert [t.weight_key for t in REWARD_TERMS] == list(WEIGHTS)
    # w_energy weighs the step's energy, which the environment adds (adaptsky.sim.energy)
    assert set(RewardWeights.__dataclass_fields__) == {*WEIGHTS, "min_rate_bps", "w_energy"}


def test_only_the_terms_that_count_are_summed_without_a_minimum_rate():
    weights = RewardWeights(w_rate=0.0, w_gain=1e7, w_unsatisfied=3.0)
    kept = RewardFromSums(weights, 4, BANDWIDTH_HZ)
    assert [term.name for term in kept.terms] == ["rate", "gain"]
    assert kept.needs_gain_sum
    every = RewardFromSums(RewardWeights(w_rate=0.0, min_rate_bps=1.0), 4, BANDWIDTH_HZ)
    assert every.terms == REWARD_TERMS


@pytest.mark.parametrize("min_se", [0.0, 2.0])
def test_the_sum_of_the_terms_is_the_environments_reward(min_se):
    scenario = make_scenario(
        users={"positions_m": None, "count": 6, "placement": "uniform", "layout_seed": 3,
               "pairing": "near-far"},
        reward={"min_se": min_se, **WEIGHTS, "w_gain": 1e9})
    env = NetworkBatch(scenario, num_envs=3, seed=0)
    env.reset()
    weights = RewardWeights(**{**WEIGHTS, "w_gain": 1e9},
                            min_rate_bps=min_se * scenario.radio.bandwidth_hz)
    bandwidth_hz = scenario.radio.bandwidth_hz
    for action in np.random.default_rng(1).integers(0, env.actions.count, size=(10, 3)):
        _, reward, _, state = env.step(action)
        inputs = RewardInputs.from_rates(state.rate_bps, state.gain, state.fairness,
                                         bandwidth_hz, weights.min_rate_bps)
        terms = weighted_sum(with_weights(REWARD_TERMS, weights), inputs)
        np.testing.assert_allclose(terms, reward, rtol=1e-15, atol=0)
        for b in range(3):
            by_hand = _eq13(list(state.rate_bps[b] / bandwidth_hz), list(state.gain[b]),
                            min_se, {**WEIGHTS, "w_gain": 1e9})
            assert reward[b] == pytest.approx(by_hand, rel=1e-12)
