"""2 GHz sub-6 channel: free space plus mean excess loss (Al-Hourani et al. 2014), sec. II-C.2.

LoS probability, eq. 6:  P_LoS = C (theta - theta_0)^Y for theta >= theta_0, else 0,
                         clipped to [0, 1]; theta in degrees.
Gain, eq. 7:             g_k = (c / (4 pi f_c d))^2 10^(-eta_k / 10),  k in {LoS, NLoS}.
"""

from __future__ import annotations

from types import MappingProxyType

import numpy as np
from pydantic import Field

from adaptsky.channels import ChannelModel, ChannelParams, LinkGeometry, Supports, db_to_linear
from adaptsky.channels.contract import SPEED_OF_LIGHT_M_PER_S

_ZERO = np.array(0.0)
_ONE = np.array(1.0)


class Sub6AlHouraniParams(ChannelParams):
    """Ranges: physical values (an excess loss is a loss, >= 0 dB) whose gains stay finite."""

    carrier_hz: float = Field(2e9, ge=1e8, le=1e11, description="carrier frequency f_c, Hz")
    los_c: float = Field(0.6, gt=0, le=10.0, description="C of eq. 6, 1")
    los_y: float = Field(0.11, gt=0, le=5.0, description="Y of eq. 6, 1")
    theta0_deg: float = Field(15.0, ge=0, lt=90, description="minimum elevation theta_0, deg")
    excess_loss_los_db: float = Field(1.0, ge=0.0, le=100.0,
                                      description="mean excess loss eta_LoS, dB")
    excess_loss_nlos_db: float = Field(20.0, ge=0.0, le=100.0,
                                       description="mean excess loss eta_NLoS, dB")


class Sub6AlHourani(ChannelModel):
    Params = Sub6AlHouraniParams
    contract_version = 3
    # eq. 7's gains fall with the 3D distance, the NLoS one below the LoS one (its excess
    # loss is the larger): the per-step searches may bound them
    supports = Supports(monotone_gains=True, reciprocal=True)
    # the paper's Table I, sub-6 column: what a scenario's [radio] leaves out
    default_radio = MappingProxyType({
        "carrier_hz": 2e9, "tx_power_dbm": 30.0, "bandwidth_hz": 50e6,
        "thermal_noise_dbm": -88.0, "noise_figure_db": 0.0, "antennas_uav": 1, "antennas_ue": 1})
    description = "2 GHz sub-6, free space + mean excess loss (Al-Hourani 2014)"
    params: Sub6AlHouraniParams

    def __init__(self, params: Sub6AlHouraniParams | None = None) -> None:
        super().__init__(params)
        # the constants of eq. 6 and 7, once (the parameters are frozen), as 0-d arrays:
        # numpy combines those with an array faster than Python floats, to the same numbers
        p = self.params
        self._c, self._y = np.array(p.los_c), np.array(p.los_y)
        self._theta0_deg = np.array(p.theta0_deg)
        self._speed_of_light = np.array(SPEED_OF_LIGHT_M_PER_S)
        self._four_pi_carrier = np.array(4 * np.pi * p.carrier_hz)
        self._excess_los = np.asarray(db_to_linear(-p.excess_loss_los_db))
        self._excess_nlos = np.asarray(db_to_linear(-p.excess_loss_nlos_db))

    def los_probability(self, geometry: LinkGeometry) -> np.ndarray:
        above_deg = np.maximum(geometry.elevation_deg - self._theta0_deg, _ZERO)
        p_los = np.where(above_deg > _ZERO, self._c * above_deg ** self._y, _ZERO)
        # clipped to [0, 1] (np.clip as maximum then minimum, in place: the same numbers)
        return np.minimum(np.maximum(p_los, _ZERO, out=p_los), _ONE, out=p_los)

    def _free_space_gain(self, geometry: LinkGeometry) -> np.ndarray:
        """``free_space_gain(distance_m, carrier_hz)`` (eq. 7, first factor)."""
        return (self._speed_of_light / (self._four_pi_carrier * geometry.distance_m)) ** 2

    def gain_los(self, geometry: LinkGeometry) -> np.ndarray:
        return self._free_space_gain(geometry) * self._excess_los

    def gain_nlos(self, geometry: LinkGeometry) -> np.ndarray:
        return self._free_space_gain(geometry) * self._excess_nlos
