"""Deprecated: the one-UAV simulator is :class:`adaptsky.sim.network.NetworkBatch` with U = 1.

``NomaUavBatch`` is an alias of ``NetworkBatch`` for one release (a ``DeprecationWarning`` on
use); the helpers once here live in :mod:`adaptsky.sim.links` (channel, geometry),
:mod:`adaptsky.sim.reward` (weights) and :mod:`adaptsky.sim.network`.
"""

from __future__ import annotations

import warnings
from typing import Any

from adaptsky.sim.links import (
    build_channel,
    carrier_hz,
    deterministic_gain,
    fading_active,
    scenario_geometry,
)
from adaptsky.sim.network import NetworkState, generators
from adaptsky.sim.reward import reward_weights

__all__ = ["NetworkState", "build_channel", "carrier_hz", "deterministic_gain",
           "fading_active", "generators", "reward_weights", "scenario_geometry"]


def __getattr__(name: str) -> Any:
    if name == "NomaUavBatch":
        from adaptsky.sim.network import NetworkBatch

        warnings.warn("adaptsky.sim.batch.NomaUavBatch is deprecated; use "
                      "adaptsky.NetworkBatch (adaptsky.sim.network.NetworkBatch)",
                      DeprecationWarning, stacklevel=2)
        return NetworkBatch
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
