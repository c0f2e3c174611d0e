"""Every user's rates from an association, composed plainly from the rates stage's pure
functions (docs/model.md §9): the reference the simulator's index arrays are checked against."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from adaptsky.sim import noma
from adaptsky.sim.association import Association
from adaptsky.sim.interference import interference_sum_w, interferers, serving_gain, sic_rates

FloatArray = NDArray[np.float64]


class NomaRates(NamedTuple):
    """Every user's (B, N) serving gain, interference (W), whether strong, SINR, rate (bit/s)."""

    gain: FloatArray
    interference_w: FloatArray
    strong: NDArray[np.bool_]
    sinr: FloatArray
    rate_bps: FloatArray


def interference_w(gain: FloatArray, association: Association, tx_power_w: float,
                   antenna_gain: float, reuse: str) -> FloatArray:
    """I_i (B, N), W, of the gains ``gain`` (B, U, N): 0 under orthogonal reuse."""
    if reuse == "orthogonal":
        return np.zeros((gain.shape[0], gain.shape[2]))
    return interference_sum_w(gain, interferers(association), tx_power_w * antenna_gain)


def noma_rates(alpha_first: FloatArray, gain: FloatArray, association: Association, *,
               tx_power_w: float, antenna_gain: float, noise_w: float, bandwidth_hz: float,
               reuse: str) -> NomaRates:
    """Rates with first users' shares ``alpha_first`` (B, U, K_max) and link gains ``gain``
    (B, U, N)."""
    g = serving_gain(gain, association.serving_uav)
    interference = interference_w(gain, association, tx_power_w, antenna_gain, reuse)
    rows = np.arange(len(alpha_first))[:, None]
    alpha_k = alpha_first[rows, association.serving_uav, association.cluster]
    partner = association.partner
    rate, strong, alpha = sic_rates(
        g, interference, alpha_k, association.is_first,
        lambda values: np.take_along_axis(values, partner, axis=1),
        power_w=tx_power_w * antenna_gain, noise_w=noise_w, bandwidth_hz=bandwidth_hz)
    sinr = noma.user_sinr(alpha, np.take_along_axis(alpha, partner, axis=1), g, strong,
                          tx_power_w * antenna_gain / (interference + noise_w))
    return NomaRates(g, interference, strong, sinr, rate)
