"""Observation of sec. IV-B.1: per user [dx_i, dy_i, alpha_i, g_i], then h (size 4 N + 1).

dx_i = x_UAV - x_i, dy_i = y_UAV - y_i. The raw values span 12 orders of magnitude, so by
default they are scaled (``observation = "scaled"``):

- dx_i, dy_i divided by L/2 (in [-2, 2]);
- alpha_i as is (in (0, 1));
- g_i as (10 log10 g_i - GAIN_DB_CENTER) / GAIN_DB_SCALE, i.e. (g_dB + 100) / 20;
- h divided by h_max (in (0, 1]).

``observation = "raw"`` gives the paper's values: m, 1, linear gain, m.
Relative positions make the features mean the same on every layout, so a policy trained on
one layout can be evaluated on another.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from adaptsky_cli.scenario.models import Scenario

GAIN_DB_CENTER = -100.0
GAIN_DB_SCALE = 20.0
FEATURES_PER_USER = 4


def observation_size(num_users: int) -> int:
    return FEATURES_PER_USER * num_users + 1


def observe(scenario: Scenario, uav_m: NDArray[np.float64], users_m: NDArray[np.float64],
            alpha: NDArray[np.float64], gain: NDArray[np.float64]) -> NDArray[np.float32]:
    """Observations (B, 4 N + 1), float32.

    From UAV (B, 3), users (B, N, 2), alpha and gain (B, N).
    """
    delta = uav_m[:, None, :2] - users_m
    height = uav_m[:, 2:3]
    if scenario.agent.observation == "scaled":
        delta = delta / (scenario.area.side_m / 2)
        gain = (10 * np.log10(gain) - GAIN_DB_CENTER) / GAIN_DB_SCALE
        height = height / scenario.uav.max_height_m
    per_user = np.stack([delta[..., 0], delta[..., 1], alpha, gain], axis=-1)
    flat = per_user.reshape(per_user.shape[0], -1)
    return np.concatenate([flat, height], axis=1).astype(np.float32)


def observation_bounds(scenario: Scenario) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
    """Lower and upper bounds of every observation component (gains unbounded when scaled)."""
    side_m = scenario.area.side_m
    if scenario.agent.observation == "scaled":
        delta, gain_low, gain_high = 2.0, -np.inf, np.inf
        height = (scenario.uav.min_height_m / scenario.uav.max_height_m, 1.0)
    else:
        delta, gain_low, gain_high = side_m, 0.0, np.inf
        height = (scenario.uav.min_height_m, scenario.uav.max_height_m)
    low_user = [-delta, -delta, 0.0, gain_low]
    high_user = [delta, delta, 1.0, gain_high]
    n_users = scenario.num_users
    low = np.array(low_user * n_users + [height[0]], dtype=np.float32)
    high = np.array(high_user * n_users + [height[1]], dtype=np.float32)
    return low, high
