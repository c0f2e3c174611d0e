"""The separation rule of several UAVs (docs/model.md §9): UAVs whose moves of a step would
bring two of them closer than ``uav.min_separation_m`` horizontally keep their positions."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


def horizontal_distances_m(uav_m: FloatArray) -> FloatArray:
    """Horizontal distance (B, U, U), m, between every two of the UAVs ``uav_m`` (B, U, 3)."""
    x_m, y_m = uav_m[..., 0], uav_m[..., 1]
    return np.hypot(x_m[:, :, None] - x_m[:, None, :], y_m[:, :, None] - y_m[:, None, :])


def _maybe_closer(uav_m: FloatArray, min_separation_m: float) -> bool:
    """False only where no two of the UAVs ``uav_m`` (B, U, 3) can be closer than
    ``min_separation_m`` horizontally: a cheap test (squares, no ``hypot``) with a 1 % margin
    over the rounding of either, so that :func:`horizontal_distances_m` decides every pair
    it lets through."""
    x_m, y_m = uav_m[..., 0], uav_m[..., 1]
    dx_m, dy_m = x_m[:, :, None] - x_m[:, None, :], y_m[:, :, None] - y_m[:, None, :]
    squared_m2 = dx_m * dx_m + dy_m * dy_m
    squared_m2[:, np.arange(uav_m.shape[1]), np.arange(uav_m.shape[1])] = np.inf
    return bool((squared_m2 < (1.01 * min_separation_m) ** 2).any())


def separated(uav_m: FloatArray, moved_m: FloatArray, min_separation_m: float) -> FloatArray:
    """The positions (B, U, 3) after a step whose moves take the UAVs from ``uav_m`` to
    ``moved_m`` (both (B, U, 3), m): where two UAVs would end closer than
    ``min_separation_m`` horizontally and closer than they were, neither moves (both keep
    ``uav_m``); the others move. Repeated until no such pair is left (a UAV held back can
    hold back another that would come too close to it): at most U rounds, and the result
    brings no pair below the separation that was not below it before. Power moves are not
    positions and are not touched here. Where no pair ends closer than the separation (most
    steps), ``moved_m`` itself is returned.
    """
    if not _maybe_closer(moved_m, min_separation_m):
        return moved_m
    others = ~np.eye(uav_m.shape[1], dtype=bool)
    after_m = horizontal_distances_m(moved_m)
    if not ((after_m < min_separation_m) & others).any():
        return moved_m
    before_m = horizontal_distances_m(uav_m)
    held = np.zeros(uav_m.shape[:2], dtype=bool)
    result = moved_m
    for round_ in range(uav_m.shape[1]):
        if round_:
            after_m = horizontal_distances_m(result)
        too_close = (after_m < min_separation_m) & (after_m < before_m) & others
        blocked = too_close.any(axis=2) & ~held
        if not blocked.any():
            break
        held |= blocked
        result = np.where(held[..., None], uav_m, moved_m)
    return result
