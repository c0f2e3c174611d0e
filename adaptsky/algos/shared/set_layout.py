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

from adaptsky.algos.shared.shapes import Shapes, mlp_shapes
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


@dataclass(frozen=True)
class SetEncoder:
    """The set encoder of ``agent.network = "set"`` (docs/agent.md, "The set encoder"): each
    user's F features of ``layout`` through one network of ``sizes`` shared by the users
    (the activation after every layer), pooled by mean and max over the users, beside the
    rest of the observation: the input (:attr:`width` = 2 H + G) of the MLP after it."""

    layout: SetLayout
    sizes: tuple[int, ...]

    @property
    def width(self) -> int:
        return 2 * self.sizes[-1] + len(self.layout.rest)

    def shapes(self, prefix: str) -> Shapes:
        """The shared network's parameters, ``<prefix>.0.weight`` (out, in) ..."""
        return mlp_shapes(prefix, [self.layout.per_user.shape[1], *self.sizes])


def reading_shapes(prefix: str, obs: int, sizes: list[int], encoder: SetEncoder | None,
                   extra_inputs: int = 0) -> Shapes:
    """The MLP ``prefix`` of layers ``sizes`` reading an observation of ``obs`` components
    (and ``extra_inputs`` more: an action), or with a set ``encoder`` its shared network
    ``<prefix>_set.*`` first and the MLP reading its output."""
    shapes = {} if encoder is None else encoder.shapes(f"{prefix}_set")
    width = obs if encoder is None else encoder.width
    return shapes | mlp_shapes(prefix, [width + extra_inputs, *sizes])


def set_encoder_of(scenario: Scenario) -> SetEncoder | None:
    """``scenario``'s agent's set encoder, None where its networks read the whole vector."""
    if getattr(scenario.agent, "network", "mlp") != "set":
        return None
    return SetEncoder(set_layout(scenario), tuple(scenario.agent.set_sizes))
