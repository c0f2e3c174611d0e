"""NOMA maths as pure, vectorised functions (sec. II-B, III, IV-B; docs/model.md §1 and §4).

Arrays broadcast over any leading batch shape; the last axis is users (N) or clusters (K).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


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


def rate_bps(sinr: FloatArray, bandwidth_hz: float) -> FloatArray:
    """Shannon rate R = W log2(1 + SINR) (eq. 3)."""
    return bandwidth_hz * np.log2(1.0 + sinr)


def jain_fairness(rates_bps: FloatArray) -> FloatArray:
    """Jain's index (sum R)^2 / (N sum R^2) over the last axis (eq. 9); 1 when all rates are 0."""
    total = rates_bps.sum(axis=-1)
    squares = np.square(rates_bps).sum(axis=-1)
    n_users = rates_bps.shape[-1]
    safe = np.where(squares > 0, squares, 1.0)
    return np.where(squares > 0, total**2 / (n_users * safe), 1.0)


@dataclass(frozen=True)
class RewardWeights:
    """Weights of eq. 13 and the minimum rate R_min = min_se W."""

    w_rate: float = 1.0
    w_fairness: float = 0.0
    w_gain: float = 0.0
    w_satisfied: float = 0.0
    w_unsatisfied: float = 0.0
    min_rate_bps: float = 0.0


def reward(rates_bps: FloatArray, gains: FloatArray, fairness: FloatArray, bandwidth_hz: float,
           weights: RewardWeights) -> FloatArray:
    """Reward of eq. 13 over the last (user) axis.

    r = w_r R_tot/W [all R_i >= R_min] + w_f J [R_min = 0] + w_g sum g_i
        + w_s #{R_i >= R_min} + w_u sum_{R_i < R_min} R_i / W
    """
    satisfied = rates_bps >= weights.min_rate_bps
    se = rates_bps / bandwidth_hz
    value = weights.w_rate * se.sum(axis=-1) * satisfied.all(axis=-1)
    if weights.min_rate_bps == 0:
        value = value + weights.w_fairness * fairness
    value = value + weights.w_gain * gains.sum(axis=-1)
    value = value + weights.w_satisfied * satisfied.sum(axis=-1)
    return value + weights.w_unsatisfied * np.where(satisfied, 0.0, se).sum(axis=-1)
