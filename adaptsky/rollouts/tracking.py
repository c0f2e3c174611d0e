"""The tracking baseline (docs/evaluation.md, baselines): a heuristic for moving users. Every
step each UAV flies at its full step toward its group's current 2D centroid, at its own height,
and splits its clusters' power as SoA does from the LoS gains there (docs/model.md §6); under
imperfect channel knowledge from the latest estimates of its links instead (§16).

A UAV at (x, y, h) with step (dx, dy) and its group's centroid (cx, cy) of the users' positions
at the start of the step goes to (x + clip(cx - x, -dx, dx), y + clip(cy - y, -dy, dy), h):
the users then move, as under a policy with the same seed (the same draws), and the rates are
taken there. On static users it flies to SoA's position (at the start height) and stays.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from adaptsky.rollouts.rollout import Tick, Trace
from adaptsky.rollouts.soa import estimated_split, group_centroids, soa_split
from adaptsky.scenario.models import Scenario
from adaptsky.sim.network import NetworkBatch
from adaptsky.sim.state import users_move

FloatArray = NDArray[np.float64]


def tracking_target(env: NetworkBatch) -> tuple[FloatArray, FloatArray]:
    """Where every UAV flies this step (B, U, 3) and its first users' shares (B, U, K_max)
    (module doc), from the env's current UAVs and users."""
    uav_m = env.sim_state.uav_m                                       # (B, U, 3)
    users_m = env.users_m
    step_xy = np.asarray(env.scenario.uav.step_m[:2], dtype=np.float64)
    offset = group_centroids(env, users_m) - uav_m[..., :2]
    target = uav_m.copy()
    target[..., :2] += np.clip(offset, -step_xy, step_xy)
    if env.estimated_gains is not None:
        return target, estimated_split(env)
    return target, soa_split(env, target, users_m)


def track(scenario: Scenario, steps: int, users_m: FloatArray, seed: int = 0,
          on_step: Tick | None = None) -> Trace:
    """The tracking baseline on the layouts ``users_m`` (L, N, 2) for ``steps`` steps from
    the episode start, with the users moving as under a policy with the same ``seed``."""
    env = NetworkBatch(scenario, num_envs=len(users_m), seed=seed, users_m=users_m)
    env.reset()
    states, walked = [], [] if users_move(scenario) else None
    for step in range(steps):
        states.append(env.fly_step(*tracking_target(env)))
        if walked is not None:
            walked.append(env.users_m)
        if on_step is not None:
            on_step(step + 1)
    return Trace.of(states, walked)
