"""The SoA baseline (Chen et al. 2019 as the paper uses it; docs/model.md §6).

The UAV stays at the users' 2D centroid at the start height. Planning assumes LoS: in each
cluster the user with the smaller LoS gain is weak and gets the least power that meets R_min,

    alpha_w = min(1, (2^(R_min/W) - 1) / 2^(R_min/W) * (1 + sigma^2 / (P_T G g_w))),

the strong user the rest (R_min = 0 gives the weak user nothing). Rates are then evaluated
under the scenario's true channel.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from adaptsky.scenario.models import Scenario
from adaptsky.sim import noma
from adaptsky.sim.network import NetworkBatch

FloatArray = NDArray[np.float64]


def soa_configuration(env: NetworkBatch) -> tuple[FloatArray, FloatArray]:
    """UAV position (B, 3) and first users' power shares (B, K) for the env's B layouts of
    one UAV."""
    scenario = env.scenario
    centroid = env.layouts_m.mean(axis=1)
    height = np.full((env.num_envs, 1), scenario.uav.start_m[2])
    uav_m = np.concatenate([centroid, height], axis=1)
    gain = env.channel.gain_los(env.geometry(uav_m, env.layouts_m))
    gain_first = np.take_along_axis(gain, env.first_user, axis=1)
    gain_second = np.take_along_axis(gain, env.second_user, axis=1)
    return uav_m, soa_shares(scenario, gain_first, gain_second)


def soa_shares(scenario: Scenario, gain_first: FloatArray, gain_second: FloatArray
               ) -> FloatArray:
    """Each cluster's first user's share from the LoS gains of its two users (module doc):
    the weak user gets the least share that meets R_min, the strong one the rest."""
    radio = scenario.radio
    threshold = 2.0 ** scenario.reward.min_se
    weak_gain = np.minimum(gain_first, gain_second)
    alpha_weak = np.minimum(1.0, (threshold - 1) / threshold * (
        1 + radio.noise_w / (radio.tx_power_w * radio.antenna_gain * weak_gain)))
    first_strong = noma.is_strong(gain_first, gain_second, gain_first, gain_second, True)
    return np.where(first_strong, 1.0 - alpha_weak, alpha_weak)
