"""The observation of several UAVs (docs/environment.md, "Several UAVs"; docs/model.md §9).

Per user i, served by UAV u: [x_u - x_i, y_u - y_i, alpha_i, g_{u,i}, I_i], then every UAV's
[x_u, y_u, h_u]: size 5 N + 3 U. Scaled (``agent.observation = "scaled"``, the default) as
for one UAV: offsets and UAV coordinates over L/2, h over h_max, the serving gain as
(10 log10 g + 100) / 20, and the interference as its ratio to the noise in dB over 20,
10 log10(1 + I_i / sigma^2) / 20 (0 without interference; finite). ``"raw"`` gives m, 1, the
linear gain and I_i / sigma^2.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from adaptsky.scenario.models import Scenario
from adaptsky.sim.observation import (
    FLOAT64_GAIN_RANGE,
    GAIN_DB_CENTER,
    GAIN_DB_SCALE,
    _float32_outward,
    _scaled_gain,
)

FloatArray = NDArray[np.float64]
FEATURES_PER_USER = 5
FEATURES_PER_UAV = 3


class MultiObserver:
    """Observations (B, 5 N + 3 U), float32, of a scenario of several UAVs."""

    def __init__(self, scenario: Scenario) -> None:
        self.scaled = scenario.agent.observation == "scaled"
        self.half_side_m = scenario.area.side_m / 2
        self.max_height_m = scenario.uav.max_height_m
        self.noise_w = scenario.radio.noise_w

    def __call__(self, uav_m: FloatArray, users_m: FloatArray, serving_uav: NDArray[np.intp],
                 alpha: FloatArray, gain: FloatArray, interference_w: FloatArray,
                 order: NDArray[np.intp] | None = None) -> NDArray[np.float32]:
        """From the UAVs (B, U, 3), users (B, N, 2), each user's serving UAV, share, serving
        gain and interference (B, N); ``order`` (B, N) lists the users in observation order
        (None: as listed)."""
        if order is not None:   # every feature is elementwise: permute the users first
            users_m = np.take_along_axis(users_m, order[..., None], axis=1)
            serving_uav, alpha, gain, interference_w = (
                np.take_along_axis(values, order, axis=1)
                for values in (serving_uav, alpha, gain, interference_w))
        serving_m = np.take_along_axis(uav_m, serving_uav[..., None], axis=1)   # (B, N, 3)
        return self.from_offsets(serving_m[..., 0] - users_m[..., 0],
                                 serving_m[..., 1] - users_m[..., 1], uav_m, alpha, gain,
                                 interference_w)

    def from_offsets(self, dx_m: FloatArray, dy_m: FloatArray, uav_m: FloatArray,
                     alpha: FloatArray, gain: FloatArray, interference_w: FloatArray
                     ) -> NDArray[np.float32]:
        """The observations from every user's offsets x_u - x_i and y_u - y_i to its serving
        UAV, share, serving gain and interference (each (B, N), users in observation order)
        and the UAVs ``uav_m`` (B, U, 3): each feature is computed in float64 and rounded
        once to float32, straight into its place."""
        num_envs, num_users = gain.shape
        num_uavs = uav_m.shape[1]
        width = FEATURES_PER_USER * num_users
        obs = np.empty((num_envs, width + FEATURES_PER_UAV * num_uavs), dtype=np.float32)
        features = obs[:, :width].reshape(num_envs, num_users, FEATURES_PER_USER)
        uavs = obs[:, width:].reshape(num_envs, num_uavs, FEATURES_PER_UAV)
        features[..., 2] = alpha
        inr = interference_w / self.noise_w
        if self.scaled:
            half_side_m = self.half_side_m
            features[..., 0] = dx_m / half_side_m
            features[..., 1] = dy_m / half_side_m
            features[..., 3] = (10.0 * np.log10(gain) - GAIN_DB_CENTER) / GAIN_DB_SCALE
            features[..., 4] = 10.0 * np.log10(1.0 + inr) / GAIN_DB_SCALE
            uavs[..., :2] = uav_m[..., :2] / half_side_m
            uavs[..., 2] = uav_m[..., 2] / self.max_height_m
        else:
            features[..., 0] = dx_m
            features[..., 1] = dy_m
            features[..., 3] = gain
            features[..., 4] = inr
            uavs[...] = uav_m
        return obs


def multi_observation_bounds(scenario: Scenario, gains: tuple[float, float] | None = None
                             ) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
    """Finite lower and upper bounds of every component (``gains``: the linear gain range of
    a link, None: every positive float64). The interference is at most U - 1 UAVs' full
    power P_T G at the largest gain."""
    uav, radio = scenario.uav, scenario.radio
    half_m = scenario.area.side_m / 2
    gain_low, gain_high = gains or FLOAT64_GAIN_RANGE
    inr_high = (uav.count - 1) * radio.tx_power_w * radio.antenna_gain * gain_high / radio.noise_w
    if scenario.agent.observation == "scaled":
        delta, position = 2.0, 1.0
        gain_low, gain_high = _scaled_gain(gain_low), _scaled_gain(gain_high)
        inr_high = 10.0 * math.log10(1.0 + inr_high) / GAIN_DB_SCALE if math.isfinite(
            inr_high) else float(np.finfo(np.float32).max)
        height = (uav.min_height_m / uav.max_height_m, 1.0)
    else:
        delta, position = 2 * half_m, half_m
        gain_low, gain_high = 0.0, min(gain_high, float(np.finfo(np.float32).max))
        inr_high = min(inr_high, float(np.finfo(np.float32).max))
        height = (uav.min_height_m, uav.max_height_m)
    n, u = scenario.num_users, uav.count
    low = np.array([-delta, -delta, 0.0, gain_low, 0.0] * n + [-position, -position,
                                                              height[0]] * u)
    high = np.array([delta, delta, 1.0, gain_high, inr_high] * n + [position, position,
                                                                   height[1]] * u)
    return _float32_outward(low, -np.inf), _float32_outward(high, np.inf)
