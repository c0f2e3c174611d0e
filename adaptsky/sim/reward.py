"""The reward of eq. 13 as a tuple of named terms (sec. IV-B.3; docs/model.md §4).

r = w_r R_tot/W 1[all R_i >= R_min] + w_f J 1[R_min = 0] + w_g sum g_i
    + w_s #{R_i >= R_min} + w_u sum_{R_i < R_min} R_i / W

Each summand is a :class:`RewardTerm`: a name, its weight's key in the scenario's ``[reward]``
section (also the field of :class:`RewardWeights`), the value it weighs, and the indicator of
eq. 13 that multiplies it, if any. The reward is the weighted sum over :data:`REWARD_TERMS`,
in that order. The energy term of docs/model.md §10, - w_e E_t / (P(0) step_s), needs the
step's flight, not the users' rates: the environment adds it (``adaptsky.sim.energy``), and
only where ``w_energy`` is set, so that every other reward keeps its bits.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from adaptsky.scenario.models import Scenario

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class RewardWeights:
    """Weights of eq. 13 and the minimum rate R_min = min_se W: numbers, or arrays (B,) with
    one value per environment (see :func:`stack_weights`)."""

    w_rate: float | FloatArray = 1.0
    w_fairness: float | FloatArray = 0.0
    w_gain: float | FloatArray = 0.0
    w_satisfied: float | FloatArray = 0.0
    w_unsatisfied: float | FloatArray = 0.0
    min_rate_bps: float | FloatArray = 0.0
    w_energy: float | FloatArray = 0.0


def reward_weights(scenario: Scenario) -> RewardWeights:
    """The weights of eq. 13 in ``scenario`` (its ``[reward]`` section and R_min)."""
    r = scenario.reward
    return RewardWeights(w_rate=r.w_rate, w_fairness=r.w_fairness, w_gain=r.w_gain,
                         w_satisfied=r.w_satisfied, w_unsatisfied=r.w_unsatisfied,
                         min_rate_bps=scenario.min_rate_bps, w_energy=r.w_energy)


def stack_weights(weights: list[RewardWeights]) -> RewardWeights:
    """One ``RewardWeights`` of arrays (B,) from B environments' weights."""
    fields = RewardWeights.__dataclass_fields__
    return RewardWeights(**{name: np.array([getattr(w, name) for w in weights], dtype=float)
                            for name in fields})


class RewardInputs(NamedTuple):
    """What the terms of eq. 13 read from one step; arrays (B,) unless marked (B, N).

    ``se_sum`` is sum_i R_i/W (bit/s/Hz, eq. 8 over W), ``fairness`` Jain's index J (eq. 9),
    ``gain_sum`` sum_i g_i (linear gains of one antenna pair; None where no term needs it),
    ``num_users`` N. ``se`` (B, N) R_i/W, ``satisfied`` (B, N) R_i >= R_min and
    ``min_rate_bps`` R_min ((B,) or a number) are None when R_min = 0 in every environment:
    then every user is satisfied (a rate is never negative) and every indicator is 1.

    A named tuple, not a frozen dataclass: one is made every step, and a tuple is made
    faster.
    """

    se_sum: FloatArray
    fairness: FloatArray
    gain_sum: FloatArray | None
    num_users: int
    se: FloatArray | None = None
    satisfied: NDArray[np.bool_] | None = None
    min_rate_bps: FloatArray | None = None

    @classmethod
    def from_rates(cls, rates_bps: FloatArray, gains: FloatArray, fairness: FloatArray,
                   bandwidth_hz: float, min_rate_bps: float | FloatArray) -> RewardInputs:
        """The inputs from rates R_i and gains g_i (B, N), J (B,), W and R_min."""
        min_rate_bps = np.asarray(min_rate_bps)
        se = rates_bps / bandwidth_hz
        return cls(se_sum=se.sum(axis=-1), fairness=fairness, gain_sum=gains.sum(axis=-1),
                   num_users=rates_bps.shape[-1], se=se,
                   satisfied=rates_bps >= min_rate_bps[..., None], min_rate_bps=min_rate_bps)


Indicator = Callable[[RewardInputs], NDArray[np.bool_]]


@dataclass(frozen=True)
class RewardTerm:
    """One summand of eq. 13: the weight named ``weight_key`` times ``value``, times
    ``indicator`` where eq. 13 has one (see :func:`weighted_sum`).

    ``vanishes_when_satisfied``: the value is 0 when every user is satisfied.
    """

    name: str
    weight_key: str
    value: Callable[[RewardInputs], FloatArray | int]
    indicator: Indicator | None = None
    vanishes_when_satisfied: bool = False


def rate_se(inputs: RewardInputs) -> FloatArray:
    """R_tot/W = sum_i R_i/W, bit/s/Hz (eq. 8 over W)."""
    return inputs.se_sum


def every_user_satisfied(inputs: RewardInputs) -> NDArray[np.bool_]:
    """prod_i 1[R_i >= R_min]."""
    assert inputs.satisfied is not None
    return inputs.satisfied.all(axis=-1)


def jain_index(inputs: RewardInputs) -> FloatArray:
    """J (eq. 9)."""
    return inputs.fairness


def no_min_rate(inputs: RewardInputs) -> NDArray[np.bool_]:
    """1[R_min = 0]."""
    return inputs.min_rate_bps == 0


def gain_sum(inputs: RewardInputs) -> FloatArray:
    """sum_i g_i, linear gains of one antenna pair."""
    assert inputs.gain_sum is not None
    return inputs.gain_sum


def satisfied_count(inputs: RewardInputs) -> FloatArray | int:
    """#{R_i >= R_min}: N when every user is satisfied."""
    if inputs.satisfied is None:
        return inputs.num_users
    return inputs.satisfied.sum(axis=-1)


def unsatisfied_se(inputs: RewardInputs) -> FloatArray:
    """sum_i R_i/W 1[R_i < R_min], bit/s/Hz: the spectral efficiency of users below R_min."""
    assert inputs.se is not None
    return np.where(inputs.satisfied, 0.0, inputs.se).sum(axis=-1)


RATE = RewardTerm("rate", "w_rate", rate_se, every_user_satisfied)
FAIRNESS = RewardTerm("fairness", "w_fairness", jain_index, no_min_rate)
GAIN = RewardTerm("gain", "w_gain", gain_sum)
SATISFIED = RewardTerm("satisfied", "w_satisfied", satisfied_count)
UNSATISFIED = RewardTerm("unsatisfied", "w_unsatisfied", unsatisfied_se,
                         vanishes_when_satisfied=True)
REWARD_TERMS: tuple[RewardTerm, ...] = (RATE, FAIRNESS, GAIN, SATISFIED, UNSATISFIED)
"""Eq. 13's terms in the order they are summed."""


Weighted = tuple[tuple[RewardTerm, "float | FloatArray"], ...]
"""Terms with their weights, ((term, w_t), ...): numbers, or arrays (B,)."""


def weighted_sum(weighted_terms: Weighted, inputs: RewardInputs) -> FloatArray:
    """sum_t (w_t v_t) 1_t over ``weighted_terms`` (at least one): each weight times its
    term's value, times the term's indicator 1_t where it has one and ``inputs`` has R_min
    (else every indicator is 1 and is left out), added left to right from the first term
    (not from 0: no bit depends on an extra addition).

    (w v) 1 is the product with a bool array: for the finite values >= 0 of eq. 13 it is
    w v or +0.0, as ``np.where(1, w v, 0.0)`` would give.
    """
    value = None
    indicators = inputs.satisfied is not None
    for term, weight in weighted_terms:
        weighted = weight * term.value(inputs)
        if indicators and term.indicator is not None:
            weighted = weighted * term.indicator(inputs)
        value = weighted if value is None else value + weighted
    if value is None:
        raise ValueError("no reward term")
    return value


def with_weights(terms: tuple[RewardTerm, ...], weights: RewardWeights) -> Weighted:
    """Each term with its weight from ``weights`` (by its ``weight_key``)."""
    return tuple((term, getattr(weights, term.weight_key)) for term in terms)


def reward(rates_bps: FloatArray, gains: FloatArray, fairness: FloatArray, bandwidth_hz: float,
           weights: RewardWeights) -> FloatArray:
    """Reward of eq. 13 over the last (user) axis: every term of :data:`REWARD_TERMS`."""
    inputs = RewardInputs.from_rates(rates_bps, gains, fairness, bandwidth_hz,
                                     weights.min_rate_bps)
    return weighted_sum(with_weights(REWARD_TERMS, weights), inputs)


class RewardFromSums:
    """Eq. 13 for a fixed ``weights``, from sums over the users that the caller already has.

    The same numbers as :func:`reward`. When R_min = 0 in every environment, every user is
    satisfied, so every indicator is 1 and is left out, and so are the terms that then vanish
    (``vanishes_when_satisfied``) and, after the first, the terms whose weight is 0 in every
    environment: every term is >= 0, so adding its 0 changes no bit. The reward is then
    r = w_r R_tot/W + w_f J + w_g sum g_i + w_s N, from R_tot/W and sum g_i as summed by the
    caller. Otherwise every term is computed from the rates, as :func:`reward` does.
    """

    def __init__(self, weights: RewardWeights, num_users: int, bandwidth_hz: float) -> None:
        self.weights = weights
        self.num_users = num_users
        self.bandwidth_hz = bandwidth_hz
        self.all_satisfied = not np.any(weights.min_rate_bps)
        terms = REWARD_TERMS
        if self.all_satisfied:
            terms = terms[:1] + tuple(
                term for term in terms[1:]
                if not term.vanishes_when_satisfied and np.any(getattr(weights,
                                                                       term.weight_key)))
        self.terms = terms
        self.needs_gain_sum = self.all_satisfied and GAIN in terms
        # the weights as arrays: numbers as 0-d arrays, which numpy combines with an array
        # faster than Python floats (the same numbers)
        self._weighted_terms = tuple((term, np.asarray(weight, dtype=np.float64))
                                     for term, weight in with_weights(terms, weights))

    def __call__(self, rates_bps: FloatArray, gains: FloatArray, fairness: FloatArray,
                 se_sum: FloatArray, gain_sum: FloatArray | None) -> FloatArray:
        """Rewards (B,) from rates and gains (B, N), Jain's index, sum R_i/W and (where
        ``needs_gain_sum``) sum g_i, each (B,)."""
        if not self.all_satisfied:
            return reward(rates_bps, gains, fairness, self.bandwidth_hz, self.weights)
        # RewardInputs(se_sum, fairness, gain_sum, N), made without the named tuple's
        # __new__ and its defaults (once per step)
        inputs = tuple.__new__(RewardInputs, (se_sum, fairness, gain_sum, self.num_users,
                                              None, None, None))
        return weighted_sum(self._weighted_terms, inputs)


def reward_per_uav(rates_bps: FloatArray, gains: FloatArray, fairness: FloatArray,
                   bandwidth_hz: float, weights: RewardWeights, serving_uav: NDArray[np.integer],
                   num_uavs: int) -> FloatArray:
    """Eq. 13 in parts (..., U), one per UAV (docs/model.md §9, the BDQ's ``reward_split``):
    part u is every term's value over UAV u's users (``serving_uav`` (..., N) names each
    user's UAV) times the term's indicator over all users, and 1/U of w_f J (Jain's index is
    not a sum over users). The parts add up to :func:`reward` (up to rounding)."""
    whole = RewardInputs.from_rates(rates_bps, gains, fairness, bandwidth_hz,
                                    weights.min_rate_bps)
    assert whole.se is not None and whole.satisfied is not None
    weighted = with_weights(REWARD_TERMS, weights)
    parts = []
    for uav in range(num_uavs):
        mine = serving_uav == uav
        se = np.where(mine, whole.se, 0.0)
        inputs = RewardInputs(se_sum=se.sum(axis=-1), fairness=fairness / num_uavs,
                              gain_sum=np.where(mine, gains, 0.0).sum(axis=-1),
                              num_users=whole.num_users, se=se,
                              satisfied=whole.satisfied & mine,
                              min_rate_bps=whole.min_rate_bps)
        part = None
        for term, weight in weighted:
            value = weight * term.value(inputs)
            if term.indicator is not None:
                value = value * term.indicator(whole)
            part = value if part is None else part + value
        parts.append(part)
    return np.stack(parts, axis=-1)
