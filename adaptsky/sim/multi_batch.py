"""Deprecated: the simulator of any number of UAVs is
:class:`adaptsky.sim.network.NetworkBatch`.

``MultiUavBatch`` and ``network_batch`` are aliases of ``NetworkBatch`` for one release (a
``DeprecationWarning`` on use); ``MultiNetworkState`` is
:class:`adaptsky.sim.network.NetworkState`.
"""

from __future__ import annotations

import warnings
from typing import Any

from adaptsky.scenario.models import Scenario
from adaptsky.sim import noma
from adaptsky.sim.network import FloatArray, NetworkBatch, NetworkState, Seed

MultiNetworkState = NetworkState


def network_batch(scenario: Scenario, num_envs: int = 1, seed: Seed = None,
                  users_m: FloatArray | None = None,
                  weights: list[noma.RewardWeights] | None = None) -> NetworkBatch:
    """Deprecated: ``NetworkBatch(scenario, ...)``, for one UAV as for several."""
    warnings.warn("adaptsky.sim.multi_batch.network_batch is deprecated; use "
                  "adaptsky.NetworkBatch (adaptsky.sim.network.NetworkBatch)",
                  DeprecationWarning, stacklevel=2)
    return NetworkBatch(scenario, num_envs=num_envs, seed=seed, users_m=users_m,
                        weights=weights)


def __getattr__(name: str) -> Any:
    if name == "MultiUavBatch":
        warnings.warn("adaptsky.sim.multi_batch.MultiUavBatch is deprecated; use "
                      "adaptsky.NetworkBatch (adaptsky.sim.network.NetworkBatch)",
                      DeprecationWarning, stacklevel=2)
        return NetworkBatch
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
