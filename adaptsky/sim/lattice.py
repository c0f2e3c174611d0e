"""The lattice a UAV's actions reach (docs/model.md §3): its start plus whole steps, inside
the bounds; and exploring starts drawn on it (docs/training.md, "Exploring starts")."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from adaptsky.scenario.models import Scenario

FloatArray = NDArray[np.float64]


def axis_lattice(start: float, step: float, low: float, high: float) -> FloatArray:
    """start + k step for every integer k with low <= value <= high (1e-9 tolerance)."""
    k_low = int(np.ceil((low - start) / step - 1e-9))
    k_high = int(np.floor((high - start) / step + 1e-9))
    return start + step * np.arange(k_low, k_high + 1)


def share_lattice(scenario: Scenario) -> FloatArray:
    """Every first-user share the actions reach: ``start_alpha`` plus whole ``power_step``s in
    [delta_alpha, 1 - delta_alpha]."""
    uav = scenario.uav
    return axis_lattice(uav.start_alpha, uav.power_step, uav.power_step, 1 - uav.power_step)


def exploring_shares(scenario: Scenario, rngs: Sequence[np.random.Generator],
                     shape: tuple[int, ...]) -> FloatArray:
    """First-user shares to start a training episode from (``train.exploring_starts =
    "shares"``): for environment b, ``shape`` (a UAV's K clusters, or (U, K)) shares drawn
    uniformly from :func:`share_lattice` by ``rngs[b]``; (len(rngs), *shape)."""
    shares = share_lattice(scenario)
    return np.stack([shares[rng.integers(len(shares), size=shape)] for rng in rngs])
