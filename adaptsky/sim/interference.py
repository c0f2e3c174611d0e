"""NOMA with several UAVs (docs/model.md §9): inter-UAV interference, the SIC order by the
effective gain, SINR and rates, as pure functions over B environments, U UAVs, N users.

Shapes: gains of every link (B, U, N); per user (B, N); the association's arrays as in
:class:`adaptsky.sim.association.Association`. Powers in W, rates in bit/s. With U = 1 the
interference is 0 and every number is the one of docs/model.md §1 (eqs. 2-3), bit for bit.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from adaptsky.sim import noma
from adaptsky.sim.association import Association

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]


def serving_gain(gain: FloatArray, serving_uav: NDArray[np.intp]) -> FloatArray:
    """g_{u,i} (B, N): each user's gain from its serving UAV, of the gains ``gain``
    (B, U, N)."""
    return np.take_along_axis(gain, serving_uav[:, None, :], axis=1)[:, 0]


def interferers(association: Association) -> BoolArray:
    """(B, U, N): whether UAV u' sends on user i's subchannel k (has a cluster k) and does not
    serve i, under full reuse (docs/model.md §9)."""
    num_uavs = association.has_cluster.shape[0]
    interferer = np.moveaxis(association.has_cluster[:, association.cluster], 0, 1)
    interferer &= np.arange(num_uavs)[None, :, None] != association.serving_uav[:, None, :]
    return interferer


def interference_sum_w(gain: FloatArray, interferer: BoolArray, power_w: float) -> FloatArray:
    """I_i (..., N), W, the one interference sum: ``power_w`` (P_T G) times the sum over the
    UAV axis (-2) of the gains ``gain`` (..., U, N) of the links that interfere
    (``interferer``, broadcast to the gains)."""
    return power_w * np.where(interferer, gain, 0.0).sum(axis=-2)


def interference_w(gain: FloatArray, association: Association, tx_power_w: float,
                   antenna_gain: float, reuse: str) -> FloatArray:
    """I_i (B, N), W: under ``reuse = "full"`` the sum over the UAVs u' other than user i's
    that have a cluster on i's subchannel k (their cluster k) of P_T G g_{u',i}: both users'
    signals of that cluster, alpha_s + alpha_w = 1. ``"orthogonal"``: 0 (every cluster of
    every UAV on its own subchannel)."""
    num_envs, _, n = gain.shape
    if reuse == "orthogonal":
        return np.zeros((num_envs, n))
    if reuse != "full":
        raise ValueError(f"unknown reuse {reuse!r}; use full or orthogonal")
    return interference_sum_w(gain, interferers(association), tx_power_w * antenna_gain)


def strong_users(gain_serving: FloatArray, interference: FloatArray, noise_w: float,
                 association: Association) -> BoolArray:
    """Whether each user (B, N) is its cluster's strong user (decodes and cancels its
    partner's signal): the larger effective gain c_i = g_{u,i} / (I_i + sigma^2); where the
    two c are equal, the larger plain gain g_{u,i}; where those are equal too, the first user.
    (With I = 0 this is exactly the order of docs/model.md §1: c is g scaled by one positive
    number, so it never reverses two gains, and where rounding makes two c equal the gains
    decide.)"""
    effective = gain_serving / (interference + noise_w)
    partner = association.partner
    effective_partner = np.take_along_axis(effective, partner, axis=1)
    gain_partner = np.take_along_axis(gain_serving, partner, axis=1)
    return noma.is_strong(effective, effective_partner, gain_serving, gain_partner,
                          association.is_first)


def user_shares(alpha_first: FloatArray, association: Association
                ) -> tuple[FloatArray, FloatArray]:
    """alpha_i and its partner's share (each (B, N)) from the first users' shares
    ``alpha_first`` (B, U, K_max): alpha_k for cluster k's first user, 1 - alpha_k for its
    second."""
    rows = np.arange(len(alpha_first))[:, None]
    alpha_k = alpha_first[rows, association.serving_uav, association.cluster]
    first = association.is_first
    return np.where(first, alpha_k, 1.0 - alpha_k), np.where(first, 1.0 - alpha_k, alpha_k)


def sic_rates(gain: FloatArray, interference_w: FloatArray, alpha_k: FloatArray,
              is_first: BoolArray, partner: Callable[[np.ndarray], np.ndarray], *,
              power_w: float, noise_w: float, bandwidth_hz: float | FloatArray
              ) -> tuple[FloatArray, BoolArray, FloatArray]:
    """The rates stage, written once (eqs. 2-3; docs/model.md §9): every user's rate (bit/s),
    whether it is its cluster's strong user, and its share, each (..., N).

    From each user's serving gain ``gain``, the interference it hears ``interference_w`` (W),
    its cluster's first user's share ``alpha_k`` and ``is_first``; ``partner`` maps an array
    over users to its values at each user's cluster partner. SIC by the effective gain
    c_i = g_i / (I_i + sigma^2) (:func:`adaptsky.sim.noma.is_strong`); SINR of eq. 2 with
    s_i = P_T G / (I_i + sigma^2) (``power_w`` = P_T G): with I = 0 the same floating-point
    operations as docs/model.md §1.
    """
    noise_plus = interference_w + noise_w
    effective = gain / noise_plus
    strong = noma.is_strong(effective, partner(effective), gain, partner(gain), is_first)
    second_share = 1.0 - alpha_k
    alpha = np.where(is_first, alpha_k, second_share)
    alpha_partner = np.where(is_first, second_share, alpha_k)
    sinr = noma.user_sinr(alpha, alpha_partner, gain, strong, power_w / noise_plus)
    return noma.rate_bps(sinr, bandwidth_hz), strong, alpha


class NomaRates(NamedTuple):
    """Every user's (B, N) serving gain, interference (W), whether strong, SINR, rate
    (bit/s)."""

    gain: FloatArray
    interference_w: FloatArray
    strong: BoolArray
    sinr: FloatArray
    rate_bps: FloatArray


def noma_rates(alpha_first: FloatArray, gain: FloatArray, association: Association, *,
               tx_power_w: float, antenna_gain: float, noise_w: float, bandwidth_hz: float,
               reuse: str) -> NomaRates:
    """SINR and rate of every user (docs/model.md §9) with first users' shares
    ``alpha_first`` (B, U, K_max) and link gains ``gain`` (B, U, N):

    strong: alpha_s P_T G g_{u,s} / (I_s + sigma^2);
    weak:   alpha_w P_T G g_{u,w} / (alpha_s P_T G g_{u,w} + I_w + sigma^2);
    R_i = W log2(1 + SINR_i) (eq. 3), by :func:`sic_rates`.
    """
    g = serving_gain(gain, association.serving_uav)
    interference = interference_w(gain, association, tx_power_w, antenna_gain, reuse)
    rows = np.arange(len(alpha_first))[:, None]
    alpha_k = alpha_first[rows, association.serving_uav, association.cluster]
    partner = association.partner
    rate, strong, alpha = sic_rates(
        g, interference, alpha_k, association.is_first,
        lambda values: np.take_along_axis(values, partner, axis=1),
        power_w=tx_power_w * antenna_gain, noise_w=noise_w, bandwidth_hz=bandwidth_hz)
    alpha_partner = np.take_along_axis(alpha, partner, axis=1)
    snr_scale = tx_power_w * antenna_gain / (interference + noise_w)
    sinr = noma.user_sinr(alpha, alpha_partner, g, strong, snr_scale)
    return NomaRates(g, interference, strong, sinr, rate)


def oma_rates_bps(gain_serving: FloatArray, interference: FloatArray, *, tx_power_w: float,
                  antenna_gain: float, noise_w: float, bandwidth_hz: float) -> FloatArray:
    """Rates (B, N), bit/s, when each cluster's two users share its resources orthogonally
    (the OMA baseline, docs/model.md §9): each gets W/2 and P_T/2, and in half the band the
    noise and the interference are halved too, so
    R_i = (W/2) log2(1 + (P_T/2) G g_{u,i} / ((I_i + sigma^2)/2))
        = (W/2) log2(1 + P_T G g_{u,i} / (I_i + sigma^2)),
    ``interference`` I_i (B, N) the NOMA interference of :func:`interference_w`."""
    snr = tx_power_w * antenna_gain * gain_serving / (interference + noise_w)
    return noma.rate_bps(snr, bandwidth_hz / 2)
