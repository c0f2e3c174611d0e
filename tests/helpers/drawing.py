"""Episodes drawn from random walks, for the drawing tests."""

from __future__ import annotations

import numpy as np

from adaptsky.drawing.episode import (
    EpisodeData,
)


def walk(steps: int, uavs: int, users: int, *, seed: int = 0, los: bool = False,
         power: bool = False, **extra: object) -> EpisodeData:
    """A random walk of ``uavs`` UAVs over ``users`` users in pairs, UAV u serving users
    u, u + U, ...; smooth shares (each pair's summing to 1, as the downlink's split) and
    rates."""
    rng = np.random.default_rng(seed)
    uav_m = np.cumsum(rng.choice([-1.0, 1.0], size=(steps, uavs, 3)), axis=0)
    uav_m[:, :, 2] += 50.0
    serving = np.arange(users) % uavs
    cluster = (np.arange(users) // uavs) // 2
    alpha = 0.5 + np.cumsum(rng.choice([-0.01, 0.01], size=(steps, users)), axis=0)
    second = np.arange(users) // uavs % 2 == 1           # a pair's second user: the rest
    alpha[:, second] = 1.0 - alpha[:, np.flatnonzero(second) - uavs]
    return EpisodeData(
        users_m=rng.uniform(-40, 40, (users, 2)), uav_m=uav_m, alpha=alpha,
        rate_bps=1e9 * (2 + np.cumsum(rng.normal(0, 0.05, (steps, users)), axis=0)),
        serving_uav=serving, cluster=cluster,
        los=rng.random((steps, users)) < 0.7 if los else None,
        power_w=150 + rng.normal(0, 5, (steps, uavs)) if power else None, **extra)
