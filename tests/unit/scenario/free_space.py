"""A channel model for scenario tests: Friis at any carrier, every link LoS, NLoS 10 dB down (a
model that reaches any carrier and declares no radio of its own)."""

from __future__ import annotations

import numpy as np

from adaptsky.channels import ChannelModel, free_space_gain


class FreeSpaceAny(ChannelModel):
    """Friis at any carrier, every link LoS."""

    contract_version = 2

    def los_probability(self, geometry):
        return np.ones(geometry.shape)

    def gain_los(self, geometry):
        return free_space_gain(geometry.distance_m, geometry.carrier_hz)

    def gain_nlos(self, geometry):
        return 0.1 * self.gain_los(geometry)
