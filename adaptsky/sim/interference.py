"""The rates stage (docs/model.md §1 and §9), for one UAV as for several: inter-UAV
interference, the SIC order by the effective gain, SINR and rates (NOMA and OMA), as pure
functions over B environments, U UAVs, N users.

Shapes: gains of every link (B, U, N); per user (B, N); the association's arrays as in
:class:`adaptsky.sim.association.Association`. Powers in W, rates in bit/s. With U = 1 the
interference is 0 and every number is the one of docs/model.md §1 (eqs. 2-3), bit for bit.
"""

from __future__ import annotations

from collections.abc import Callable

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


def sic_rates(gain: FloatArray, interference_w: FloatArray | None, alpha_k: FloatArray,
              is_first: BoolArray, partner: Callable[[np.ndarray], np.ndarray], *,
              power_w: float, noise_w: float, bandwidth_hz: float | FloatArray,
              sic_residual: float = 0.0,
              estimate: tuple[FloatArray, FloatArray | None] | None = None
              ) -> tuple[FloatArray, BoolArray, FloatArray]:
    """The rates stage, written once (eqs. 2-3; docs/model.md §9): every user's rate (bit/s),
    whether it is its cluster's strong user, and its share, each (..., N).

    From each user's serving gain ``gain``, the interference it hears ``interference_w`` (W;
    None where there is none: one UAV, orthogonal reuse), ``is_first`` and ``alpha_k``: its
    cluster's first user's share (..., N), or every user's share and its partner's already
    (2, ..., N); ``partner`` maps an array over users to its values at each user's cluster
    partner. SIC by the effective gain c_i = g_i / (I_i + sigma^2)
    (:func:`adaptsky.sim.noma.is_strong`; without interference, by g_i); SINR of eq. 2 with
    s_i = P_T G / (I_i + sigma^2) (``power_w`` = P_T G): with I = 0 the same floating-point
    operations as docs/model.md §1. ``sic_residual`` epsilon: the share of its partner's
    signal the strong user keeps after SIC (docs/model.md §13; 0, perfect SIC).
    ``estimate``: the estimated gains and interference (docs/model.md §16) that decide the SIC
    order instead; a strong user by the estimate that is truly weaker than its partner cannot
    decode its partner's message and gets rate 0.
    """
    if interference_w is None:
        effective, snr_scale = gain, power_w / noise_w
    else:
        noise_plus = interference_w + noise_w
        effective, snr_scale = gain / noise_plus, power_w / noise_plus
    gain_partner = partner(gain)
    if estimate is None:
        strong = noma.is_strong(effective, gain_partner if effective is gain
                                else partner(effective), gain, gain_partner, is_first)
    else:
        gain_hat, interference_hat = estimate
        effective_hat = (gain_hat if interference_hat is None
                         else gain_hat / (interference_hat + noise_w))
        strong = noma.is_strong(effective_hat, partner(effective_hat), gain_hat,
                                partner(gain_hat), is_first)
    if alpha_k.ndim == gain.ndim:
        second_share = 1.0 - alpha_k
        alpha = np.where(is_first, alpha_k, second_share)
        alpha_partner = np.where(is_first, second_share, alpha_k)
    else:
        alpha, alpha_partner = alpha_k
    sinr = noma.user_sinr(alpha, alpha_partner, gain, strong, snr_scale, sic_residual)
    rate = noma.rate_bps(sinr, bandwidth_hz)
    if estimate is not None:
        rate = np.where(strong & (effective < partner(effective)), 0.0, rate)
    return rate, strong, alpha


def oma_rates_bps(gain_serving: FloatArray, interference: FloatArray, *, tx_power_w: float,
                  antenna_gain: float, noise_w: float, bandwidth_hz: float,
                  cluster_size: int = 2) -> FloatArray:
    """Rates (B, N), bit/s, when each cluster's M = ``cluster_size`` users share its resources
    orthogonally (the OMA baseline, docs/model.md §9 and §15): each gets W/M and P_T/M, and
    in 1/M of the band the noise and the interference are 1/M too, so
    R_i = (W/M) log2(1 + (P_T/M) G g_{u,i} / ((I_i + sigma^2)/M))
        = (W/M) log2(1 + P_T G g_{u,i} / (I_i + sigma^2)),
    ``interference`` I_i (B, N) the NOMA interference of :func:`interference_sum_w`."""
    snr = tx_power_w * antenna_gain * gain_serving / (interference + noise_w)
    return noma.rate_bps(snr, bandwidth_hz / cluster_size)
