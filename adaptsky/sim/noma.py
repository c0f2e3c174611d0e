"""NOMA maths as pure, vectorised functions (sec. II-B, III; docs/model.md §1).

Arrays broadcast over any leading batch shape; the last axis is users (N) or clusters (K).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

# the reward of eq. 13 lives in adaptsky.sim.reward; its names stay importable from here
from adaptsky.sim.reward import RewardFromSums, RewardWeights, reward, stack_weights

__all__ = ["RewardFromSums", "RewardWeights", "chain_sinr", "cluster_sinr", "first_in_order",
           "heard_shares", "in_member_order", "is_strong", "jain_fairness", "jain_from_sums",
           "member_shares", "rate_bps", "reward", "sic_order", "stack_weights", "undecodable",
           "user_sinr"]

FloatArray = NDArray[np.float64]

# 0 and 1 as 0-d arrays: numpy combines a 0-d array with an array faster than a Python float
# (same numbers); the functions the environment calls every step use them
_ZERO = np.array(0.0)
_ONE = np.array(1.0)


def is_strong(effective: FloatArray, effective_partner: FloatArray, gain: FloatArray,
              gain_partner: FloatArray, is_first: NDArray[np.bool_] | bool
              ) -> NDArray[np.bool_]:
    """The SIC order (eq. 2; docs/model.md §9), the one rule: a user is its cluster's strong
    user (decodes and cancels its partner's signal) where its effective gain
    c_i = g_i / (I_i + sigma^2) is the larger; where the two c are equal, where its gain g_i
    is the larger; where those are equal too, where it is the cluster's first user. Without
    interference c is g over one positive number, so this is "the larger gain, the first user
    on a tie" (pass ``effective = gain`` there)."""
    if effective is gain:   # the same rule, two comparisons fewer
        return (gain > gain_partner) | ((gain == gain_partner) & is_first)
    return (effective > effective_partner) | ((effective == effective_partner) & (
        (gain > gain_partner) | ((gain == gain_partner) & is_first)))


def cluster_sinr(alpha_first: FloatArray, gain_first: FloatArray, gain_second: FloatArray,
                 snr_scale: float, sic_residual: float = 0.0) -> tuple[FloatArray, FloatArray]:
    """SINR of the two users of each cluster (eq. 2), with the SIC order set by the gains.

    ``alpha_first`` is the power share of each cluster's first user (the second gets
    1 - alpha_first); ``snr_scale`` = P_T G / sigma^2. The user with the larger gain (the
    first on a tie) is strong: it cancels the other's signal, SINR = alpha_s s g_s. The weak
    user sees the strong user's share as interference, SINR = alpha_w s g_w / (alpha_s s g_w + 1).
    With imperfect SIC (``sic_residual`` epsilon > 0, docs/model.md §13) the strong user keeps
    epsilon of the weak user's signal: SINR = alpha_s s g_s / (epsilon alpha_w s g_s + 1).
    """
    alpha_second = 1.0 - alpha_first
    first_strong = is_strong(gain_first, gain_second, gain_first, gain_second, True)
    return (user_sinr(alpha_first, alpha_second, gain_first, first_strong, snr_scale,
                      sic_residual),
            user_sinr(alpha_second, alpha_first, gain_second, ~first_strong, snr_scale,
                      sic_residual))


def user_sinr(alpha: FloatArray, alpha_partner: FloatArray, gain: FloatArray,
              strong: NDArray[np.bool_], snr_scale: float | FloatArray,
              sic_residual: float = 0.0) -> FloatArray:
    """SINR of eq. 2 in user order: the numbers of :func:`cluster_sinr`, every user at once.

    User i has power share ``alpha`` alpha_i, its cluster partner the share ``alpha_partner``
    alpha_p, and ``strong`` says whether i is its cluster's strong user (the first user on a
    tie). The strong user cancels its partner, SINR = alpha_i s g_i; the weak user sees the
    partner's share as interference, SINR = alpha_i s g_i / (alpha_p s g_i + 1).
    Imperfect SIC (docs/model.md §13): the strong user keeps ``sic_residual`` epsilon of its
    partner's signal, SINR = alpha_i s g_i / (epsilon alpha_p s g_i + 1); epsilon = 1 is the
    weak user's formula (no cancellation), epsilon = 0 (the default) perfect SIC.
    """
    signal = snr_scale * gain
    if sic_residual:
        kept = np.where(strong, sic_residual, _ONE)    # the share of the partner heard
        return alpha * signal / (alpha_partner * signal * kept + _ONE)
    return alpha * signal / np.where(strong, _ONE, alpha_partner * signal + _ONE)


def member_shares(components: FloatArray) -> FloatArray:
    """The power shares (..., M) of a cluster's M members from its M - 1 share components
    c_1 .. c_{M-1} (..., M - 1) (docs/model.md §15): member j takes c_j of the power the
    members before it left, alpha_j = c_j prod_{i<j} (1 - c_i), and the last member the rest,
    alpha_M = prod_{i<M} (1 - c_i). Every component in (0, 1) gives every share > 0, and the
    shares sum to 1. For M = 2: alpha_1 = c_1, alpha_2 = 1 - c_1, the paper's split."""
    size = components.shape[-1] + 1
    shares = np.empty((*components.shape[:-1], size))
    left = 1.0 - components[..., 0]
    shares[..., 0] = components[..., 0]
    for j in range(1, size - 1):
        shares[..., j] = left * components[..., j]
        left = left * (1.0 - components[..., j])
    shares[..., size - 1] = left
    return shares


def sic_order(effective: FloatArray, gain: FloatArray) -> NDArray[np.intp]:
    """The SIC order of every cluster (..., M), strongest first (docs/model.md §15): by the
    effective gain c_i = g_i / (I_i + sigma^2), on a tie by the gain g_i, on a tie of both
    the member listed first; :func:`is_strong`'s rule for M = 2."""
    member = np.broadcast_to(np.arange(gain.shape[-1]), gain.shape)
    return np.lexsort((member, -gain, -effective), axis=-1)


def heard_shares(ordered: FloatArray, sic_residual: float = 0.0) -> FloatArray:
    """Per member of clusters whose shares ``ordered`` (..., M) are in SIC order, strongest
    first: the shares it hears, those of the stronger members before it plus
    ``sic_residual`` of the weaker ones after it (docs/model.md §15)."""
    stronger, weaker = np.zeros_like(ordered), np.zeros_like(ordered)
    np.cumsum(ordered[..., :-1], axis=-1, out=stronger[..., 1:])
    np.cumsum(ordered[..., :0:-1], axis=-1, out=weaker[..., -2::-1])
    return stronger + sic_residual * weaker if sic_residual else stronger


def chain_sinr(shares: FloatArray, gain: FloatArray, effective: FloatArray,
               snr_scale: float | FloatArray, sic_residual: float = 0.0,
               order: NDArray[np.intp] | None = None) -> FloatArray:
    """SINR (..., M) of every member of clusters of M users decoded by a SIC chain
    (docs/model.md §15). Member k, with share alpha_k and gain g_k, removes every weaker
    member's signal (keeping ``sic_residual`` epsilon of each) and hears the stronger ones':

        SINR_k = alpha_k s g_k / (s g_k (sum_{j stronger} alpha_j
                                          + epsilon sum_{j weaker} alpha_j) + 1),

    ``snr_scale`` s = P_T G / (I_k + sigma^2) (per member, or one number), the order by
    :func:`sic_order` of ``effective`` and ``gain`` (or ``order``, strongest first: the
    order of estimated gains, docs/model.md §16). For M = 2 these are eq. 2's numbers."""
    if order is None:
        order = sic_order(effective, gain)
    heard = in_member_order(heard_shares(np.take_along_axis(shares, order, axis=-1),
                                         sic_residual), order)
    signal = snr_scale * gain
    return shares * signal / (signal * heard + 1.0)


def undecodable(effective: FloatArray, order: NDArray[np.intp]) -> NDArray[np.bool_]:
    """(..., M): the members that cannot decode a message they must remove (docs/model.md
    §16): decoding in ``order`` (strongest first, by estimated gains), member k removes every
    member after it, which succeeds where its true effective gain ``effective`` is at least
    theirs (the same SINR formula at a larger gain); it fails where one of them is truly
    stronger, and then decodes nothing."""
    ordered = np.take_along_axis(effective, order, axis=-1)
    weaker_best = np.full(ordered.shape, -np.inf)      # the largest after each, in the order
    np.maximum.accumulate(ordered[..., :0:-1], axis=-1, out=weaker_best[..., -2::-1])
    return in_member_order(ordered < weaker_best, order)


def in_member_order(ordered: NDArray[np.generic], order: NDArray[np.intp]
                    ) -> NDArray[np.generic]:
    """Values (..., M) given in ``order`` (each cluster's members as :func:`sic_order` ranks
    them) back in member order."""
    values = np.empty_like(ordered)
    np.put_along_axis(values, order, ordered, axis=-1)
    return values


def first_in_order(order: NDArray[np.intp]) -> NDArray[np.bool_]:
    """(..., M): each cluster's member that ``order`` puts first (its strongest: it decodes
    every other, or in the uplink is decoded first)."""
    first = np.zeros(order.shape, dtype=bool)
    np.put_along_axis(first, order[..., :1], True, axis=-1)
    return first


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
    fairness = np.empty(squares.shape, dtype=squares.dtype)  # empty_like, without dispatch
    fairness.fill(1.0)
    return np.divide(total**2, n_users * squares, out=fairness, where=squares > _ZERO)
