"""What an agent observes of the network (docs/environment.md): the observation adapter the
agent's settings pick, applied by the simulator to the network's observation.

The simulator (:class:`~adaptsky.sim.network.NetworkBatch`) observes the network with the
users as the layout lists them: the paper's layout for one UAV, the several-UAV layout
otherwise (:mod:`adaptsky.sim.observation`). The agent may see it otherwise:

- its users cluster by cluster (``agent.user_order = "clusters"``: UAV by UAV, cluster 1's
  members in order (first and second user of a pair), then cluster 2's..., the order of the
  actions' power components), so
  that a user's place tells its cluster and role on every layout (docs/agent.md);
- every UAV's local part of it, one after the other (B, U L), where the agent acts per UAV
  (MAPPO, IPPO: ``agent.local_view``; docs/environment.md, "Local observations").

Both are a gather of the network's float32 values (:class:`AgentView`), made once per
association and taken once per step: the same numbers as observing in that order.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from adaptsky.envs.world_observation import WorldObserver
from adaptsky.scenario.models import Scenario
from adaptsky.sim.association import Association
from adaptsky.sim.observation import (
    FEATURES_PER_UAV,
    FEATURES_PER_USER,
    MULTI_FEATURES_PER_USER,
    MultiObserver,
    WorldData,
    WorldReader,
    float32_outward,
    local_observation_bounds,
    multi_observation_bounds,
    observation_bounds,
)

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]


def user_order_of(scenario: Scenario) -> str:
    """The users' order in ``scenario``'s agent's observation: ``agent.user_order`` where
    the agent has one, else ``"listed"``."""
    return str(getattr(scenario.agent, "user_order", "listed"))


def scaled_of(scenario: Scenario) -> bool:
    """Whether ``scenario``'s agent observes scaled values (``agent.observation``, docs/
    environment.md), else the paper's raw ones."""
    return getattr(scenario.agent, "observation", "scaled") == "scaled"


def observes_locally(scenario: Scenario) -> bool:
    """Whether ``scenario``'s agent sees every UAV's local observation, one after the other
    (B, U L) (docs/environment.md, "Local observations"): the agents that act per UAV
    (``agent.local_view``: "mappo", "ippo"); every other agent sees the network's."""
    return bool(getattr(scenario.agent, "local_view", False))


def observation_bounds_of(scenario: Scenario, gains: tuple[float, float] | None = None
                          ) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
    """The bounds of what ``scenario``'s agent observes (``gains``: a link's linear gain
    range, None: every positive float64), scaled or raw as it asks: every UAV's local
    bounds one after the other where it observes locally, else the network's (one UAV's
    layout or the several-UAV one)."""
    scaled = scaled_of(scenario)
    if observes_locally(scenario):
        low, high = local_bounds_of(scenario, gains)
        return np.tile(low, scenario.uav.count), np.tile(high, scenario.uav.count)
    if scenario.uav.count == 1:
        low, high = observation_bounds(scenario, gains, scaled=scaled)
    else:
        low, high = multi_observation_bounds(scenario, gains, scaled=scaled)
    return _with_world_bounds(scenario, low, high, scenario.num_users, scenario.uav.count)


def local_bounds_of(scenario: Scenario, gains: tuple[float, float] | None = None
                    ) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
    """The bounds of one UAV's local observation (``gains`` as for
    :func:`observation_bounds_of`), with its observations of the world where it asks."""
    low, high = local_observation_bounds(scenario, gains, scaled=scaled_of(scenario))
    return _with_world_bounds(scenario, low, high, scenario.users_per_uav, 1)


def _with_world_bounds(scenario: Scenario, low: NDArray[np.float32], high: NDArray[np.float32],
                       users: int, uavs: int
                       ) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
    """``low`` and ``high`` with the bounds of the agent's observations of the world of
    ``users`` user slots and ``uavs`` rasters appended, rounded outward to float32."""
    world = WorldObserver.of(scenario)
    if world is None:
        return low, high
    world_low, world_high = world.bounds(scenario, users, uavs)
    return (np.concatenate([low, float32_outward(world_low, -np.inf)]),
            np.concatenate([high, float32_outward(world_high, np.inf)]))


def users_in_order(association: Association, user_order: str) -> IntArray | None:
    """The users (B, N) in observation order: None for ``"listed"`` (as the layout lists
    them), else UAV by UAV and cluster by cluster, each cluster's members in order, the first
    user first (``"clusters"``)."""
    if user_order == "listed":
        return None
    num_envs, num_users = association.serving_uav.shape
    members = association.members.reshape(num_envs, -1)
    # (-1 marks the unused cluster slots of a UAV with fewer clusters than K_max)
    return members[members >= 0].reshape(num_envs, num_users)


@dataclass(frozen=True)
class AgentView:
    """The observation adapter of an agent: users in ``user_order`` ("listed" or
    "clusters"), with ``local`` (several UAVs only) every UAV's local observation of
    ``num_slots`` = 2 K_max user slots, its values ``scaled`` (``agent.observation``) or
    raw, and the observations of the world it asked for (``agent.observe``:
    :mod:`adaptsky.envs.world_observation`), appended. The simulator calls :meth:`gather`
    once per association and :meth:`world` at every step
    (:class:`~adaptsky.sim.observation.ObservationView`)."""

    user_order: str
    local: bool
    num_slots: int
    scaled: bool = True
    world_observer: WorldObserver | None = None

    @property
    def observes_world(self) -> bool:
        return self.world_observer is not None

    def world_reader(self, association: Association) -> WorldReader:
        """What appends the observations of the world to the agent's ``observations``
        (B, W), made once per ``association``: after the whole (B, W + E), users in this
        view's order; or, for local observations (B, U L), after each UAV's own
        (B, U (L + E_local)): its users' slots, then its raster."""
        observer = self.world_observer
        assert observer is not None
        if not self.local:
            order = users_in_order(association, self.user_order)
            return lambda observations, data: np.concatenate(
                [observations, observer(data, order)], axis=1)
        slots = local_user_slots(association, self.user_order, self.num_slots)
        num_envs, num_uavs = slots.shape[:2]

        def read(observations: NDArray[np.float32], data: WorldData) -> NDArray[np.float32]:
            return np.concatenate([observations.reshape(num_envs, num_uavs, -1),
                                   observer.local(data, slots)], axis=2).reshape(num_envs, -1)
        return read

    @classmethod
    def of(cls, scenario: Scenario) -> AgentView | None:
        """The adapter ``scenario``'s agent picks; None where it sees the network's
        observation as it is (scaled, users as listed, the whole network)."""
        user_order = user_order_of(scenario)
        local = observes_locally(scenario) and scenario.uav.count > 1
        scaled = scaled_of(scenario)
        world = WorldObserver.of(scenario)
        if user_order == "listed" and not local and scaled and world is None:
            return None
        return cls(user_order, local, scenario.users_per_uav, scaled, world)

    def gather(self, association: Association) -> IntArray | None:
        """Where every component of the agent's observation (B, W) comes from in the
        network's (B, size) with a zero appended (position ``size``: a padded slot); None
        where it is the network's as it is."""
        order = users_in_order(association, self.user_order)
        num_envs, num_users = association.serving_uav.shape
        num_uavs = association.first_user.shape[1]
        local = self.local and num_uavs > 1
        if order is None and not local:
            return None
        per_user = FEATURES_PER_USER if num_uavs == 1 else MULTI_FEATURES_PER_USER
        width = per_user * num_users
        size = width + (1 if num_uavs == 1 else FEATURES_PER_UAV * num_uavs)
        positions = np.empty((num_envs, size + 1), dtype=np.intp)    # the zero appended
        positions[:] = np.arange(size + 1)
        if order is not None:
            positions[:, :width] = (per_user * order[..., None] + np.arange(per_user)
                                    ).reshape(num_envs, width)
        if not local:
            return positions[:, :size]
        serving = (association.serving_uav if order is None
                   else np.take_along_axis(association.serving_uav, order, axis=1))
        return np.take_along_axis(positions, local_gather(serving, num_uavs, self.num_slots),
                                  axis=1)


class LocalObserver:
    """Every UAV's local observation (B, U, 5 S + 3 U), float32 (docs/environment.md, "Local
    observations"; docs/model.md §9): the part of the several-UAV observation
    (:class:`~adaptsky.sim.observation.MultiObserver`, with its scaling) that UAV u sees.

    First S = 2 K_max user slots, its own users in observation order (``agent.user_order``),
    each [x_u - x_i, y_u - y_i, alpha_i, g_{u,i}, I_i]; a UAV with fewer users (K_u < K_max)
    has its last slots padded with zeros, so that every agent's observation has one size (one
    actor shared by the UAVs); a padded slot has alpha = 0, which no user has. Then its own
    [x_u, y_u, h_u] and the other UAVs' in UAV order.
    """

    def __init__(self, scenario: Scenario) -> None:
        self._observer = MultiObserver(scenario, scaled_of(scenario))
        self.num_slots = scenario.users_per_uav
        self.num_uavs = scenario.uav.count

    def __call__(self, uav_m: FloatArray, users_m: FloatArray, serving_uav: IntArray,
                 alpha: FloatArray, gain: FloatArray, interference_w: FloatArray,
                 order: IntArray | None = None) -> NDArray[np.float32]:
        """From the arrays :class:`~adaptsky.sim.observation.MultiObserver` takes (users as
        listed, ``order`` (B, N) the observation order, None: as listed)."""
        network = self._observer(uav_m, users_m, serving_uav, alpha, gain, interference_w,
                                 order)
        if order is not None:
            serving_uav = np.take_along_axis(serving_uav, order, axis=1)
        gather = local_gather(serving_uav, self.num_uavs, self.num_slots)
        return local_view(network, gather).reshape(len(network), self.num_uavs, -1)


def local_user_slots(association: Association, user_order: str, num_slots: int) -> IntArray:
    """The users (B, U, S) of every UAV's local slots in ``user_order`` (N: a padded
    slot), as :class:`LocalObserver` lays them out."""
    order = users_in_order(association, user_order)
    serving = (association.serving_uav if order is None
               else np.take_along_axis(association.serving_uav, order, axis=1))
    slots = _user_slots(serving, association.first_user.shape[1], num_slots)
    if order is None:
        return slots
    num_users = order.shape[1]          # the slots hold places in the order: back to users
    users = np.take_along_axis(order, np.minimum(slots, num_users - 1).reshape(len(order), -1),
                               axis=1).reshape(slots.shape)
    return np.where(slots < num_users, users, slots)


def local_gather(serving_uav: IntArray, num_uavs: int, num_slots: int) -> IntArray:
    """Where every component of every UAV's local observation (B, U L) comes from in the
    network's observation (B, 5 N + 3 U) with a zero appended (position 5 N + 3 U: the
    padded slots), from every user's serving UAV (B, N) in observation order
    (:class:`LocalObserver`'s layout)."""
    num_envs, num_users = serving_uav.shape
    width = MULTI_FEATURES_PER_USER * num_users
    zero = width + FEATURES_PER_UAV * num_uavs
    slots = _user_slots(serving_uav, num_uavs, num_slots)                  # (B, U, S)
    feature = np.arange(MULTI_FEATURES_PER_USER)
    users = np.where(slots[..., None] < num_users,
                     MULTI_FEATURES_PER_USER * slots[..., None] + feature, zero)   # (B, U, S, 5)
    rows = np.array([[u, *(v for v in range(num_uavs) if v != u)] for u in range(num_uavs)],
                    dtype=np.intp)          # row u: UAV u, then the others in UAV order
    uavs = width + FEATURES_PER_UAV * rows[..., None] + np.arange(FEATURES_PER_UAV)  # (U, U, 3)
    uavs = np.broadcast_to(uavs.reshape(num_uavs, -1), (num_envs, num_uavs, uavs[0].size))
    return np.concatenate([users.reshape(num_envs, num_uavs, -1), uavs],
                          axis=-1).reshape(num_envs, -1)


def local_view(network: NDArray[np.float32], gather: IntArray) -> NDArray[np.float32]:
    """Every UAV's local observation (B, U L) from the network's (B, 5 N + 3 U) and
    :func:`local_gather`'s positions: the same float32 values, copied."""
    padded = np.zeros((len(network), network.shape[1] + 1), dtype=np.float32)
    padded[:, :-1] = network
    return np.take_along_axis(padded, gather, axis=1)


def _user_slots(serving_uav: IntArray, num_uavs: int, num_slots: int) -> IntArray:
    """The users (B, U, S) of every UAV's slots: positions in ``serving_uav`` (B, N), in its
    order, N for a padded slot."""
    num_users = serving_uav.shape[1]
    by_uav = np.argsort(serving_uav, axis=1, kind="stable")      # UAV 0's users, then 1's...
    counts = np.stack([np.count_nonzero(serving_uav == u, axis=1) for u in range(num_uavs)],
                      axis=1)                                     # (B, U)
    slot = np.arange(num_slots)
    first = np.cumsum(counts, axis=1) - counts
    position = np.minimum(first[..., None] + slot, num_users - 1)
    users = np.take_along_axis(by_uav, position.reshape(len(by_uav), -1), axis=1)
    return np.where(slot < counts[..., None], users.reshape(position.shape), num_users)
