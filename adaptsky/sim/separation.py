"""The separation rule of several UAVs (docs/model.md §9): UAVs whose moves of a step would
bring two of them closer than ``uav.min_separation_m`` horizontally keep their positions."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


def horizontal_distances_m(uav_m: FloatArray) -> FloatArray:
    """Horizontal distance (B, U, U), m, between every two of the UAVs ``uav_m`` (B, U, 3)."""
    delta = uav_m[:, :, None, :2] - uav_m[:, None, :, :2]
    return np.hypot(delta[..., 0], delta[..., 1])


def separated(uav_m: FloatArray, moved_m: FloatArray, min_separation_m: float) -> FloatArray:
    """The positions (B, U, 3) after a step whose moves take the UAVs from ``uav_m`` to
    ``moved_m`` (both (B, U, 3), m): where two UAVs would end closer than
    ``min_separation_m`` horizontally and closer than they were, neither moves (both keep
    ``uav_m``); the others move. Repeated until no such pair is left (a UAV held back can
    hold back another that would come too close to it): at most U rounds, and the result
    brings no pair below the separation that was not below it before. Power moves are not
    positions and are not touched here.
    """
    before_m = horizontal_distances_m(uav_m)
    held = np.zeros(uav_m.shape[:2], dtype=bool)
    others = ~np.eye(uav_m.shape[1], dtype=bool)
    result = moved_m
    for _ in range(uav_m.shape[1]):
        after_m = horizontal_distances_m(result)
        too_close = (after_m < min_separation_m) & (after_m < before_m) & others
        blocked = too_close.any(axis=2) & ~held
        if not blocked.any():
            break
        held |= blocked
        result = np.where(held[..., None], uav_m, moved_m)
    return result
