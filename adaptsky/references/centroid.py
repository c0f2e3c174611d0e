"""Hovering above the users' centroid at the best height: the worked example of adding a
baseline (docs/evaluation.md#adding-a-reference). Each UAV over its group's 2D centroid with
SoA's shares (:mod:`adaptsky.rollouts.soa`), at the lattice height whose held configuration
has the largest mean sum rate over the policy's own draws, the same height for every UAV of
a layout; lifted above a building standing there (docs/model.md §12)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from adaptsky.progress import Tick
from adaptsky.references.reference import Reference
from adaptsky.rollouts.metrics import Method
from adaptsky.rollouts.oracle import lattice
from adaptsky.rollouts.rollout import hold
from adaptsky.rollouts.soa import soa_per_uav_configuration, soa_split
from adaptsky.scenario import Scenario
from adaptsky.sim.blockage import above_buildings
from adaptsky.sim.network import NetworkBatch


@dataclass(frozen=True)
class CentroidHover(Reference):
    """Hover above the centroid at the best height (module doc); a baseline."""

    def work(self, scenario: Scenario, steps: int, users_m: np.ndarray) -> tuple[int, str]:
        return len(lattice(scenario)[2]) + steps, "step"   # a step: a height, or one held

    def run(self, scenario: Scenario, steps: int, users_m: np.ndarray, seed: int = 0,
            on_progress: Tick | None = None) -> Method:
        env = NetworkBatch(scenario, num_envs=len(users_m), users_m=users_m)
        centroid_m, _ = soa_per_uav_configuration(env)                 # (L, U, 3)
        heights_m = lattice(scenario)[2]
        candidates, rates = [], []
        for done, height_m in enumerate(heights_m):
            uav_m = centroid_m.copy()
            uav_m[..., 2] = height_m
            if env.city is not None:
                uav_m = above_buildings(uav_m, env.city)
            candidates.append((uav_m, soa_split(env, uav_m, users_m)))
            trace = hold(scenario, *_held(*candidates[-1]), steps, users_m, seed)
            rates.append(trace.rate_bps.sum(axis=-1).mean(axis=0))       # (L,)
            if on_progress is not None:
                on_progress(done + 1)
        best, layouts = np.argmax(rates, axis=0), np.arange(len(users_m))
        uav_m, alpha = (np.stack(part)[best, layouts] for part in zip(*candidates, strict=True))
        held = None if on_progress is None else (  # (its steps after the heights)
            lambda step, *_: on_progress(len(heights_m) + step))
        trace = hold(scenario, *_held(uav_m, alpha), steps, users_m, seed, held)
        return Method.of(self.name, scenario, trace, {})


def _held(uav_m: np.ndarray, alpha: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A configuration as :func:`hold` takes it: without the UAV axis for one UAV."""
    return (uav_m[:, 0], alpha[:, 0]) if uav_m.shape[1] == 1 else (uav_m, alpha)
