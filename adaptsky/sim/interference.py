"""NOMA with several UAVs (docs/model.md §9): inter-UAV interference, the SIC order by the
effective gain, SINR and rates, as pure functions over B environments, U UAVs, N users.

Shapes: gains of every link (B, U, N); per user (B, N); the association's arrays as in
:class:`adaptsky.sim.association.Association`. Powers in W, rates in bit/s. With U = 1 the
interference is 0 and every number is the one of docs/model.md §1 (eqs. 2-3), bit for bit.
"""

from __future__ import annotations

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


def interference_w(gain: FloatArray, association: Association, tx_power_w: float,
                   antenna_gain: float, reuse: str) -> FloatArray:
    """I_i (B, N), W: under ``reuse = "full"`` the sum over the UAVs u' other than user i's
    that have a cluster on i's subchannel k (their cluster k) of P_T G g_{u',i}: both users'
    signals of that cluster, alpha_s + alpha_w = 1. ``"orthogonal"``: 0 (every cluster of
    every UAV on its own subchannel)."""
    num_envs, num_uavs, n = gain.shape
    if reuse == "orthogonal":
        return np.zeros((num_envs, n))
    if reuse != "full":
        raise ValueError(f"unknown reuse {reuse!r}; use full or orthogonal")
    # interferer[b, u', i]: UAV u' has a cluster on user i's subchannel and does not serve i
    interferer = np.moveaxis(association.has_cluster[:, association.cluster], 0, 1)
    interferer &= np.arange(num_uavs)[None, :, None] != association.serving_uav[:, None, :]
    return tx_power_w * antenna_gain * np.where(interferer, gain, 0.0).sum(axis=1)


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
    return (effective > effective_partner) | ((effective == effective_partner) & (
        (gain_serving > gain_partner) | ((gain_serving == gain_partner)
                                         & association.is_first)))


def user_shares(alpha_first: FloatArray, association: Association
                ) -> tuple[FloatArray, FloatArray]:
    """alpha_i and its partner's share (each (B, N)) from the first users' shares
    ``alpha_first`` (B, U, K_max): alpha_k for cluster k's first user, 1 - alpha_k for its
    second."""
    rows = np.arange(len(alpha_first))[:, None]
    alpha_k = alpha_first[rows, association.serving_uav, association.cluster]
    first = association.is_first
    return np.where(first, alpha_k, 1.0 - alpha_k), np.where(first, 1.0 - alpha_k, alpha_k)


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
    R_i = W log2(1 + SINR_i) (eq. 3). Both SINRs are computed as eq. 2 with the user's own
    s_i = P_T G / (I_i + sigma^2) (:func:`adaptsky.sim.noma.user_sinr`): the same quotients,
    and with I = 0 the same floating-point operations as one UAV.
    """
    g = serving_gain(gain, association.serving_uav)
    interference = interference_w(gain, association, tx_power_w, antenna_gain, reuse)
    strong = strong_users(g, interference, noise_w, association)
    alpha, alpha_partner = user_shares(alpha_first, association)
    snr_scale = tx_power_w * antenna_gain / (interference + noise_w)
    sinr = noma.user_sinr(alpha, alpha_partner, g, strong, snr_scale)
    return NomaRates(g, interference, strong, sinr, noma.rate_bps(sinr, bandwidth_hz))


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
