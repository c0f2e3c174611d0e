"""Environments onto agents and back, torch-free: every environment's observation holds the U
local observations one after the other (B, U L) (``adaptsky.envs.observations.local_gather``);
the shared actor reads one row per UAV, its local observation and a one-hot UAV id (L + U);
MAPPO's centralised critic reads every local observation and the id (U L + U); the UAVs' own
actions make the environment's joint one (docs/agent.md, "MAPPO and IPPO")."""

from __future__ import annotations

import numpy as np


def actor_rows(observations: np.ndarray, num_uavs: int) -> np.ndarray:
    """(..., n, U L) -> (..., n U, L + U): UAV u's local observation and its one-hot id."""
    *lead, n, width = observations.shape
    local = observations.reshape(*lead, n, num_uavs, width // num_uavs)
    ids = np.broadcast_to(np.eye(num_uavs, dtype=np.float32), (*lead, n, num_uavs, num_uavs))
    return np.concatenate([local, ids], axis=-1).reshape(*lead, n * num_uavs, -1)


def critic_rows(observations: np.ndarray, num_uavs: int) -> np.ndarray:
    """(..., n, U L) -> (..., n U, U L + U): every local observation and UAV u's one-hot id
    (the agent-specific global state of Yu et al.)."""
    *lead, n, width = observations.shape
    every = np.broadcast_to(observations[..., None, :], (*lead, n, num_uavs, width))
    ids = np.broadcast_to(np.eye(num_uavs, dtype=np.float32), (*lead, n, num_uavs, num_uavs))
    return np.concatenate([every, ids], axis=-1).reshape(*lead, n * num_uavs, -1)


def joint_actions(actions: np.ndarray, num_uavs: int, per_uav: int | None) -> np.ndarray:
    """The environments' actions from every UAV's (..., n U) indices or (..., n U, D) controls
    (``per_uav`` None): continuous controls one UAV's D after the other (..., n, U D); an
    index (..., n), the UAVs' own indices as its digits in base ``per_uav`` = b^D (UAV u's
    components are the joint index's digits u D .. u D + D - 1 in base b, docs/model.md §3).
    """
    if per_uav is None:
        *lead, rows, width = actions.shape
        return actions.reshape(*lead, rows // num_uavs, num_uavs * width)
    *lead, rows = actions.shape
    powers = np.int64(per_uav) ** np.arange(num_uavs, dtype=np.int64)
    by_uav = actions.reshape(*lead, rows // num_uavs, num_uavs).astype(np.int64)
    return (by_uav * powers).sum(axis=-1)
