"""The discrete action set (sec. IV-B.2, docs/model.md §3).

An action moves the UAV by d_x delta_x, d_y delta_y, d_h delta_h and changes the first user's
alpha of each of the K clusters by d_k delta_alpha. Action index a encodes the 3 + K
components as digits in base 2 (``paper``: d in {-1, +1}, 2^(3+K) actions) or base 3
(``with-hover``: d in {-1, 0, +1}); digit j = (a // base^j) % base, component order
x, y, h, cluster 1, ..., cluster K.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    from adaptsky.scenario.models import Scenario

ActionMode = Literal["paper", "with-hover"]
DENSE_MODES: tuple[ActionMode, ...] = ("paper", "with-hover")

# an action index is an int64: base^D <= 2^62 keeps every index, digit and draw exact
# (docs/scenario-format.md, "Machine limits")
MAX_ACTIONS = 2**62
TABLE_MAX_ACTIONS = 4096  # action sets up to this size are looked up in a table, not decoded


def count_estimate(num_clusters: int, mode: ActionMode, num_uavs: int = 1) -> float:
    """How many actions ``ActionSet(num_clusters, mode, num_uavs)`` has, as a float, inf where
    it would overflow one (memory estimates of scenarios far beyond any machine stay
    numbers)."""
    base, components = (2 if mode == "paper" else 3), num_uavs * (3 + num_clusters)
    return math.inf if components * math.log(base) > 700 else float(base**components)


@dataclass(frozen=True)
class ActionSet:
    """The dense actions of ``num_uavs`` UAVs of ``num_clusters`` clusters each, or of
    ``clusters`` (K_u per UAV) where they differ: components x, y, h, cluster 1 .. K_u of
    UAV 0, then those of UAV 1, ... (docs/model.md §3 and §9), D = sum_u (3 + K_u). With
    clusters of M > 2 users a "cluster" here is one of its M - 1 share components
    (docs/model.md §15): ``num_clusters`` counts components, K_u (M - 1)."""

    num_clusters: int
    mode: ActionMode = "paper"
    num_uavs: int = 1
    clusters: tuple[int, ...] = ()

    @classmethod
    def of(cls, scenario: Scenario) -> ActionSet:
        """The action set of ``scenario``: its UAVs, each with its K_u clusters; a ValueError
        for continuous actions, which have none (:mod:`adaptsky.sim.controls`)."""
        mode = scenario.uav.actions
        if mode not in DENSE_MODES:
            raise ValueError(f"uav.actions = '{mode}' has no dense action set; the dense "
                             f"kinds are {', '.join(repr(m) for m in DENSE_MODES)}")
        clusters = scenario.shares_of_uavs   # K_u (M - 1) share components (K_u for pairs)
        return cls(scenario.shares_per_uav, mode, scenario.uav.count,
                   () if len(set(clusters)) == 1 else clusters)

    @property
    def clusters_of_uavs(self) -> tuple[int, ...]:
        """K_u of every UAV."""
        return self.clusters or (self.num_clusters,) * self.num_uavs

    def components_of(self, uav: int) -> int:
        """3 + K_u, the components of UAV ``uav``."""
        return 3 + self.clusters_of_uavs[uav]

    @property
    def base(self) -> int:
        return 2 if self.mode == "paper" else 3

    @property
    def num_components(self) -> int:
        """D = sum_u (3 + K_u)."""
        return sum(3 + k for k in self.clusters_of_uavs)

    @property
    def count(self) -> int:
        return self.base**self.num_components

    def __post_init__(self) -> None:
        if self.count > MAX_ACTIONS:
            raise ValueError(f"{self.base}^{self.num_components} actions of {self.num_uavs} "
                             f"UAVs of {self.num_clusters} clusters are more than an int64 "
                             f"action index holds (2^62)")

    def decode(self, actions: NDArray[np.integer]) -> NDArray[np.int64]:
        """Directions d in {-1, 0, +1} of shape (*actions.shape, 3 + K)."""
        actions = np.asarray(actions, dtype=np.int64)
        powers = self.base ** np.arange(self.num_components, dtype=np.int64)
        digits = (actions[..., None] // powers) % self.base
        return 2 * digits - 1 if self.mode == "paper" else digits - 1

    def table(self) -> NDArray[np.int64]:
        """Directions of every action, shape (count, 3 + K): row a is ``decode(a)``.

        A lookup table for small action sets (see ``TABLE_MAX_ACTIONS``), cheaper per step
        than decoding the digits.
        """
        return self.decode(np.arange(self.count, dtype=np.int64))

    def encode(self, directions: NDArray[np.integer]) -> NDArray[np.int64]:
        """Inverse of :meth:`decode`."""
        directions = np.asarray(directions, dtype=np.int64)
        digits = (directions + 1) // 2 if self.mode == "paper" else directions + 1
        powers = self.base ** np.arange(self.num_components, dtype=np.int64)
        return (digits * powers).sum(axis=-1)
