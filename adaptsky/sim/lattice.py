"""The lattice a UAV's actions reach (docs/model.md §3): its start plus whole steps, inside
the bounds; and exploring starts drawn on it (docs/training.md, "Exploring starts")."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from adaptsky.scenario.models import Scenario
from adaptsky.sim.city import PlacementError
from adaptsky.sim.separation import horizontal_distances_m

FloatArray = NDArray[np.float64]
MAX_DRAWS = 10_000  # draws of one UAV's start before the separation is declared unreachable


def axis_lattice(start: float, step: float, low: float, high: float) -> FloatArray:
    """start + k step for every integer k with low <= value <= high (1e-9 tolerance)."""
    k_low = int(np.ceil((low - start) / step - 1e-9))
    k_high = int(np.floor((high - start) / step + 1e-9))
    return start + step * np.arange(k_low, k_high + 1)


def share_high(scenario: Scenario) -> float:
    """The largest value of a power component: 1 - delta_alpha for the downlink's shares
    (the other users keep some power), 1 for the uplink's transmit shares (a user may send at
    full power, docs/model.md §17)."""
    return 1.0 if scenario.uplink else 1 - scenario.uav.power_step


def share_lattice(scenario: Scenario) -> FloatArray:
    """Every value of a power component the actions reach: ``start_alpha`` plus whole
    ``power_step``s in [delta_alpha, 1 - delta_alpha] (the uplink's: [delta_alpha, 1])."""
    uav = scenario.uav
    return axis_lattice(uav.start_alpha, uav.power_step, uav.power_step, share_high(scenario))


def exploring_shares(scenario: Scenario, rngs: Sequence[np.random.Generator],
                     shape: tuple[int, ...]) -> FloatArray:
    """First-user shares to start a training episode from (``train.exploring_starts =
    "shares"``): for environment b, ``shape`` (a UAV's K clusters, or (U, K)) shares drawn
    uniformly from :func:`share_lattice` by ``rngs[b]``; (len(rngs), *shape)."""
    shares = share_lattice(scenario)
    return np.stack([shares[rng.integers(len(shares), size=shape)] for rng in rngs])


def position_lattices(scenario: Scenario) -> list[tuple[FloatArray, FloatArray, FloatArray]]:
    """Each UAV's reachable x, y and h values (m): its start plus whole ``uav.step_m``s,
    |x|, |y| <= L/2 and h in [min_height_m, max_height_m] (the oracle's lattice)."""
    uav, half_m = scenario.uav, scenario.area.side_m / 2
    return [(axis_lattice(x, uav.step_m[0], -half_m, half_m),
             axis_lattice(y, uav.step_m[1], -half_m, half_m),
             axis_lattice(h, uav.step_m[2], uav.min_height_m, uav.max_height_m))
            for x, y, h in scenario.uav_start_positions_m]


def exploring_positions(scenario: Scenario, rngs: Sequence[np.random.Generator]) -> FloatArray:
    """UAV positions to start a training episode from (``train.exploring_starts =
    "positions"``): for environment b, each UAV in turn at a uniform point of its
    :func:`position_lattices` drawn by ``rngs[b]`` (x, then y, then h), drawn again while it
    is closer than ``uav.min_separation_m`` horizontally to a UAV placed before it
    (PlacementError after MAX_DRAWS draws); (len(rngs), U, 3) m."""
    lattices = position_lattices(scenario)
    separation_m = scenario.uav.min_separation_m
    starts = np.empty((len(rngs), len(lattices), 3))
    for b, rng in enumerate(rngs):
        for u, axes in enumerate(lattices):
            for _ in range(MAX_DRAWS):
                starts[b, u] = [axis[rng.integers(len(axis))] for axis in axes]
                apart_m = horizontal_distances_m(starts[b:b + 1, :u + 1])[0, u, :u]
                if (apart_m >= separation_m).all():
                    break
            else:
                placed = ", ".join(f"({x:g}, {y:g})" for x, y in starts[b, :u, :2])
                raise PlacementError(f"train.exploring_starts: no start for UAV {u} at least "
                                     f"uav.min_separation_m = {separation_m:g} m from the UAVs "
                                     f"placed before it at {placed} in {MAX_DRAWS} draws: "
                                     "lower min_separation_m or use exploring_starts = "
                                     "'shares'")
    return starts
