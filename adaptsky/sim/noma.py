"""NOMA maths as pure, vectorised functions (sec. II-B, III, IV-B; docs/model.md §1 and §4).

Arrays broadcast over any leading batch shape; the last axis is users (N) or clusters (K).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]

# 0 and 1 as 0-d arrays: numpy combines a 0-d array with an array faster than a Python float
# (same numbers); the functions the environment calls every step use them
_ZERO = np.array(0.0)
_ONE = np.array(1.0)


def cluster_sinr(alpha_first: FloatArray, gain_first: FloatArray, gain_second: FloatArray,
                 snr_scale: float) -> tuple[FloatArray, FloatArray]:
    """SINR of the two users of each cluster (eq. 2), with the SIC order set by the gains.

    ``alpha_first`` is the power share of each cluster's first user (the second gets
    1 - alpha_first); ``snr_scale`` = P_T G / sigma^2. The user with the larger gain (the
    first on a tie) is strong: it cancels the other's signal, SINR = alpha_s s g_s. The weak
    user sees the strong user's share as interference, SINR = alpha_w s g_w / (alpha_s s g_w + 1).
    """
    alpha_second = 1.0 - alpha_first
    first_strong = gain_first >= gain_second
    signal_first = snr_scale * gain_first
    signal_second = snr_scale * gain_second
    sinr_first = alpha_first * signal_first / np.where(
        first_strong, 1.0, alpha_second * signal_first + 1.0)
    sinr_second = alpha_second * signal_second / np.where(
        first_strong, alpha_first * signal_second + 1.0, 1.0)
    return sinr_first, sinr_second


def user_sinr(alpha: FloatArray, alpha_partner: FloatArray, gain: FloatArray,
              strong: NDArray[np.bool_], snr_scale: float | FloatArray) -> FloatArray:
    """SINR of eq. 2 in user order: the numbers of :func:`cluster_sinr`, every user at once.

    User i has power share ``alpha`` alpha_i, its cluster partner the share ``alpha_partner``
    alpha_p, and ``strong`` says whether i is its cluster's strong user (the first user on a
    tie). The strong user cancels its partner, SINR = alpha_i s g_i; the weak user sees the
    partner's share as interference, SINR = alpha_i s g_i / (alpha_p s g_i + 1).
    """
    signal = snr_scale * gain
    return alpha * signal / np.where(strong, _ONE, alpha_partner * signal + _ONE)


def rate_bps(sinr: FloatArray, bandwidth_hz: float) -> FloatArray:
    """Shannon rate R = W log2(1 + SINR) (eq. 3)."""
    return bandwidth_hz * np.log2(1.0 + sinr)


def jain_fairness(rates_bps: FloatArray) -> FloatArray:
    """Jain's index (sum R)^2 / (N sum R^2) over the last axis (eq. 9); 1 when all rates are 0."""
    total = rates_bps.sum(axis=-1)
    squares = np.square(rates_bps).sum(axis=-1)
    return jain_from_sums(total, squares, rates_bps.shape[-1])


def jain_from_sums(total: FloatArray, squares: FloatArray, n_users: int | FloatArray
                   ) -> FloatArray:
    """Jain's index (eq. 9) from sum R and sum R^2 over the N = ``n_users`` users: 1 where
    sum R^2 = 0 (no division there)."""
    fairness = np.empty_like(squares)
    fairness.fill(1.0)
    return np.divide(total**2, n_users * squares, out=fairness, where=squares > _ZERO)


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


def stack_weights(weights: list[RewardWeights]) -> RewardWeights:
    """One ``RewardWeights`` of arrays (B,) from B environments' weights."""
    fields = RewardWeights.__dataclass_fields__
    return RewardWeights(**{name: np.array([getattr(w, name) for w in weights], dtype=float)
                            for name in fields})


def reward(rates_bps: FloatArray, gains: FloatArray, fairness: FloatArray, bandwidth_hz: float,
           weights: RewardWeights) -> FloatArray:
    """Reward of eq. 13 over the last (user) axis.

    r = w_r R_tot/W [all R_i >= R_min] + w_f J [R_min = 0] + w_g sum g_i
        + w_s #{R_i >= R_min} + w_u sum_{R_i < R_min} R_i / W
    """
    min_rate_bps = np.asarray(weights.min_rate_bps)
    satisfied = rates_bps >= min_rate_bps[..., None]
    se = rates_bps / bandwidth_hz
    value = weights.w_rate * se.sum(axis=-1) * satisfied.all(axis=-1)
    value = value + np.where(min_rate_bps == 0, weights.w_fairness * fairness, 0.0)
    value = value + weights.w_gain * gains.sum(axis=-1)
    value = value + weights.w_satisfied * satisfied.sum(axis=-1)
    return value + weights.w_unsatisfied * np.where(satisfied, 0.0, se).sum(axis=-1)


class RewardFromSums:
    """Eq. 13 for a fixed ``weights``, from sums over the users that the caller already has.

    The same numbers as :func:`reward`. When R_min = 0 in every environment, every user is
    satisfied (a rate is never negative), so the reward is
    r = w_r R_tot/W + w_f J + w_g sum g_i + w_s N, and a term whose weight is 0 in every
    environment is left out: every term is >= 0, so adding its 0 changes no bit. Otherwise
    it calls :func:`reward`.
    """

    def __init__(self, weights: RewardWeights, num_users: int, bandwidth_hz: float) -> None:
        self.weights = weights
        self.bandwidth_hz = bandwidth_hz
        self.all_satisfied = not np.any(weights.min_rate_bps)
        self.with_fairness = bool(np.any(weights.w_fairness))
        self.needs_gain_sum = self.all_satisfied and bool(np.any(weights.w_gain))
        # the weights as arrays (numbers as 0-d arrays, see _ONE), and w_s times the count of
        # satisfied users, N (satisfied.sum() in reward())
        self._w_rate = np.asarray(weights.w_rate, dtype=np.float64)
        self._w_fairness = np.asarray(weights.w_fairness, dtype=np.float64)
        self._w_gain = np.asarray(weights.w_gain, dtype=np.float64)
        self.satisfied_term = (np.asarray(weights.w_satisfied * num_users, dtype=np.float64)
                               if np.any(weights.w_satisfied) else None)

    def __call__(self, rates_bps: FloatArray, gains: FloatArray, fairness: FloatArray,
                 se_sum: FloatArray, gain_sum: FloatArray | None) -> FloatArray:
        """Rewards (B,) from rates and gains (B, N), Jain's index, sum R_i/W and (where
        ``needs_gain_sum``) sum g_i, each (B,)."""
        if not self.all_satisfied:
            return reward(rates_bps, gains, fairness, self.bandwidth_hz, self.weights)
        value = self._w_rate * se_sum
        if self.with_fairness:
            value = value + self._w_fairness * fairness
        if gain_sum is not None:
            value = value + self._w_gain * gain_sum
        if self.satisfied_term is not None:
            value = value + self.satisfied_term
        return value
