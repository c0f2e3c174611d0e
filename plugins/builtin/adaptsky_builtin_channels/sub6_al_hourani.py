"""2 GHz sub-6 channel: free space plus mean excess loss (Al-Hourani et al. 2014), sec. II-C.2.

LoS probability, eq. 6:  P_LoS = C (theta - theta_0)^Y for theta >= theta_0, else 0,
                         clipped to [0, 1]; theta in degrees.
Gain, eq. 7:             g_k = (c / (4 pi f_c d))^2 10^(-eta_k / 10),  k in {LoS, NLoS}.
"""

from __future__ import annotations

import numpy as np
from pydantic import Field

from adaptsky_cli.channels import (
    ChannelModel,
    ChannelParams,
    LinkGeometry,
    db_to_linear,
    free_space_gain,
)


class Sub6AlHouraniParams(ChannelParams):
    carrier_hz: float = Field(2e9, gt=0, description="carrier frequency f_c, Hz")
    los_c: float = Field(0.6, gt=0, description="C of eq. 6, 1")
    los_y: float = Field(0.11, gt=0, description="Y of eq. 6, 1")
    theta0_deg: float = Field(15.0, ge=0, lt=90, description="minimum elevation theta_0, deg")
    excess_loss_los_db: float = Field(1.0, description="mean excess loss eta_LoS, dB")
    excess_loss_nlos_db: float = Field(20.0, description="mean excess loss eta_NLoS, dB")


class Sub6AlHourani(ChannelModel):
    Params = Sub6AlHouraniParams
    description = "2 GHz sub-6, free space + mean excess loss (Al-Hourani 2014)"
    params: Sub6AlHouraniParams

    def los_probability(self, geometry: LinkGeometry) -> np.ndarray:
        above_deg = np.maximum(geometry.elevation_deg - self.params.theta0_deg, 0.0)
        p_los = self.params.los_c * above_deg ** self.params.los_y
        return np.clip(np.where(above_deg > 0, p_los, 0.0), 0.0, 1.0)

    def gain_los(self, geometry: LinkGeometry) -> np.ndarray:
        return free_space_gain(geometry.distance_m, self.params.carrier_hz) * db_to_linear(
            -self.params.excess_loss_los_db)

    def gain_nlos(self, geometry: LinkGeometry) -> np.ndarray:
        return free_space_gain(geometry.distance_m, self.params.carrier_hz) * db_to_linear(
            -self.params.excess_loss_nlos_db)
