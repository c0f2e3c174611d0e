"""28 GHz mmWave channel, New York City measurements (Akdeniz et al. 2014), sec. II-C.1.

Valid at 28 GHz only: the carrier is in the measured constants, so the model declares
``Supports(carrier_hz=(28e9, 28e9))`` and a scenario with another ``radio.carrier_hz`` is
refused.

LoS probability, eq. 4:  P_LoS = 1 / (1 + C exp(-Y (theta - C))), theta in degrees.
Gain, eq. 5:             g_k = C_k d^(-a_k),  k in {LoS, NLoS}, d in m.
"""

from __future__ import annotations

from types import MappingProxyType

import numpy as np
from pydantic import Field

from adaptsky.channels import ChannelModel, ChannelParams, LinkGeometry, Supports, db_to_linear

_ONE = np.array(1.0)


class MmWaveNycParams(ChannelParams):
    """Ranges keep exp() in eq. 4 finite (Y (90 + C) < 700) and every gain at or below its
    1 m intercept, which is at most 0 dB (links are >= 1 m long)."""

    los_c: float = Field(9.6117, gt=0, le=100.0, description="C of eq. 4 (environment), 1")
    los_y: float = Field(0.1581, gt=0, le=2.0, description="Y of eq. 4 (environment), 1/deg")
    intercept_los_db: float = Field(-64.0, ge=-200.0, le=0.0,
                                    description="C_LoS of eq. 5 (gain at 1 m), dB")
    intercept_nlos_db: float = Field(-72.0, ge=-200.0, le=0.0,
                                     description="C_NLoS of eq. 5 (gain at 1 m), dB")
    exponent_los: float = Field(2.0, gt=0, le=10.0, description="path-loss exponent a_LoS, 1")
    exponent_nlos: float = Field(2.92, gt=0, le=10.0,
                                 description="path-loss exponent a_NLoS, 1")


class MmWaveNyc(ChannelModel):
    Params = MmWaveNycParams
    contract_version = 3
    # the constants of eq. 4-5 are measured at 28 GHz (Table I): no other carrier is modelled;
    # eq. 5's gains fall with the 3D distance, the NLoS one below the LoS one (its intercept
    # and exponent are the weaker): the per-step searches may bound them
    supports = Supports(carrier_hz=(28e9, 28e9), monotone_gains=True, reciprocal=True)
    # the paper's Table I, mmWave column: what a scenario's [radio] leaves out
    default_radio = MappingProxyType({
        "carrier_hz": 28e9, "tx_power_dbm": 20.0, "bandwidth_hz": 2e9,
        "thermal_noise_dbm": -84.0, "noise_figure_db": 0.0, "antennas_uav": 8, "antennas_ue": 8})
    description = "28 GHz mmWave, NYC path loss (Akdeniz 2014), sigmoid LoS probability"
    params: MmWaveNycParams

    def __init__(self, params: MmWaveNycParams | None = None) -> None:
        super().__init__(params)
        # the constants of eq. 4 and 5, once (the parameters are frozen), as 0-d arrays:
        # numpy combines those with an array faster than Python floats, to the same numbers
        p = self.params
        self._c, self._minus_y = np.array(p.los_c), np.array(-p.los_y)
        self._intercept_los = np.asarray(db_to_linear(p.intercept_los_db))
        self._intercept_nlos = np.asarray(db_to_linear(p.intercept_nlos_db))
        self._exponent_los = np.array(-p.exponent_los)
        self._exponent_nlos = np.array(-p.exponent_nlos)

    def los_probability(self, geometry: LinkGeometry) -> np.ndarray:
        c = self._c
        return _ONE / (_ONE + c * np.exp(self._minus_y * (geometry.elevation_deg - c)))

    def gain_los(self, geometry: LinkGeometry) -> np.ndarray:
        return self._intercept_los * geometry.distance_m ** self._exponent_los

    def gain_nlos(self, geometry: LinkGeometry) -> np.ndarray:
        return self._intercept_nlos * geometry.distance_m ** self._exponent_nlos
