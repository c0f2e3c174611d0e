"""Where each user's features and the rest lie in what an agent observes: the layout a set
encoder (``agent.network = "set"``, a shared network per user, pooled) reads its inputs by
(docs/environment.md: the observation, its local form and the observations of the world).

An observation of width W is split into ``per_user`` (slots, F) positions, row j the F
features of the user in slot j (its offsets, share, gain and, for several UAVs, interference;
then its LoS flag and velocity where ``agent.observe`` asks), and ``rest`` (G,) positions
(the UAVs' heights or positions, then their rasters). A local observation (MAPPO, IPPO) is
one UAV's block: its S slots, its own and the other UAVs' positions, its own raster.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from adaptsky.scenario.models import Scenario
from adaptsky.sim.observation import (
    FEATURES_PER_UAV,
    FEATURES_PER_USER,
    MULTI_FEATURES_PER_USER,
    local_observation_size,
    observation_size,
)

IntArray = NDArray[np.intp]


@dataclass(frozen=True)
class SetLayout:
    """``per_user`` (slots, F) and ``rest`` (G,) positions in an observation of ``width``
    (module doc)."""

    per_user: IntArray
    rest: IntArray
    width: int

    def __post_init__(self) -> None:
        every = np.concatenate([self.per_user.ravel(), self.rest])
        if not np.array_equal(np.sort(every), np.arange(self.width)):
            raise ValueError("a set layout must place every component of the observation once")


def set_layout(scenario: Scenario) -> SetLayout:
    """The layout of what ``scenario``'s agent observes (one UAV's local observation where it
    acts per UAV: ``agent.local_view``)."""
    agent = scenario.agent
    observe = set(getattr(agent, "observe", ()))
    cells = int(getattr(agent, "raster_cells", 0)) ** 2 if "heights" in observe else 0
    num_uavs = scenario.uav.count
    if getattr(agent, "local_view", False):
        slots, per_slot = scenario.users_per_uav, MULTI_FEATURES_PER_USER
        base, uav_part, rasters = local_observation_size(scenario), num_uavs * FEATURES_PER_UAV, 1
    else:
        slots = scenario.num_users
        per_slot = FEATURES_PER_USER if num_uavs == 1 else MULTI_FEATURES_PER_USER
        base = observation_size(slots, num_uavs)
        uav_part, rasters = base - per_slot * slots, num_uavs
    columns = [per_slot * np.arange(slots)[:, None] + np.arange(per_slot)]
    at = base
    if "los" in observe:
        columns.append(at + np.arange(slots)[:, None])
        at += slots
    if "velocity" in observe:
        columns.append(at + 2 * np.arange(slots)[:, None] + np.arange(2))
        at += 2 * slots
    rest = np.concatenate([per_slot * slots + np.arange(uav_part),
                           at + np.arange(rasters * cells)])
    return SetLayout(np.concatenate(columns, axis=1).astype(np.intp), rest.astype(np.intp),
                     at + rasters * cells)
