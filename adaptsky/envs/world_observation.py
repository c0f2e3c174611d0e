"""Observations of the world (docs/environment.md, "Observations of the world"): what an
agent may see besides its links, opt-in with ``agent.observe``, appended after the network's
observation in a fixed order whatever the order of the list:

- ``"los"``: each user's serving link's LoS state this step (1 LoS, 0 not; where LoS is not
  drawn, ``channel.los = "expected"``, its probability), users in observation order (N);
- ``"velocity"``: each user's velocity over the last step, (x_t - x_{t-1}) / step_s (0 after
  a reset), as [v_x, v_y] per user in observation order (2 N); scaled as the distance walked
  in one step over the UAV's horizontal step (``uav.step_m``), raw in m/s;
- ``"heights"``: around every UAV, in UAV order, an egocentric raster of R x R cells
  (``agent.raster_cells`` R, odd, of ``agent.raster_cell_m`` c): cell (r, k), row r along
  y and column k along x, holds the tallest roof standing over the point
  (x_u + (k - (R - 1)/2) c, y_u + (r - (R - 1)/2) c) (0 where none), rows one after the
  other (U R^2); scaled over ``uav.max_height_m``, raw in m.

The simulator hands the state (:class:`~adaptsky.sim.observation.WorldData`); this module,
on the agent's side, turns it into features: the simulator reads no agent setting.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from adaptsky.scenario.models import Scenario
from adaptsky.scenario.sections import MAX_HEIGHT_M
from adaptsky.sim.blockage import roofs_m
from adaptsky.sim.observation import WorldData

FloatArray = NDArray[np.float64]
WORLD_FEATURES = ("los", "velocity", "heights")
"""Every observation of the world, in the order they are appended."""


@dataclass(frozen=True)
class WorldObserver:
    """The observations of the world an agent asked for (module doc): ``features`` in
    :data:`WORLD_FEATURES`' order, ``scaled`` or raw, the raster's ``cells`` R and
    ``cell_m`` c, and the scales (``max_height_m``, the UAV's horizontal ``step_m``)."""

    features: tuple[str, ...]
    scaled: bool
    cells: int
    cell_m: float
    max_height_m: float
    step_m: float

    @classmethod
    def of(cls, scenario: Scenario) -> WorldObserver | None:
        """``scenario``'s agent's observations of the world; None where it asks for none."""
        asked = set(getattr(scenario.agent, "observe", ()))
        if not asked:
            return None
        agent = scenario.agent
        return cls(tuple(name for name in WORLD_FEATURES if name in asked),
                   getattr(agent, "observation", "scaled") == "scaled",
                   int(agent.raster_cells), float(agent.raster_cell_m),
                   scenario.uav.max_height_m, float(scenario.uav.step_m[0]))

    def offsets_m(self) -> FloatArray:
        """The raster's cell centres (R^2, 2) relative to the UAV, rows along y."""
        ticks = (np.arange(self.cells) - (self.cells - 1) / 2) * self.cell_m
        y, x = np.meshgrid(ticks, ticks, indexing="ij")
        return np.column_stack([x.ravel(), y.ravel()])

    def __call__(self, data: WorldData, order: NDArray[np.intp] | None
                 ) -> NDArray[np.float32]:
        """The features (B, E), float32, from the simulator's ``data``, users in ``order``
        (B, N) (None: as listed)."""
        parts = []
        for name in self.features:
            if name == "los":
                parts.append(_in_order(data.serving_los, order))
            elif name == "velocity":
                step = self._velocity(data)
                step = step if order is None else np.take_along_axis(step, order[..., None],
                                                                     axis=1)
                parts.append(step.reshape(len(step), -1))
            else:
                parts.append(self._heights(data))
        return np.concatenate(parts, axis=1).astype(np.float32)

    def local(self, data: WorldData, slots: NDArray[np.intp]) -> NDArray[np.float32]:
        """Every UAV's own features (B, U, E_local), float32, for its local observation
        (docs/environment.md, "Local observations"): its users' slots ``slots`` (B, U, S)
        (N: a padded slot, whose features are 0), then its own raster."""
        num_envs, num_uavs, num_slots = slots.shape
        rows = np.arange(num_envs)[:, None, None]
        padded = slots >= data.serving_los.shape[1]
        user = np.where(padded, 0, slots)
        parts = []
        for name in self.features:
            if name == "los":
                parts.append(np.where(padded, 0.0, data.serving_los[rows, user]))
            elif name == "velocity":
                step = np.where(padded[..., None], 0.0, self._velocity(data)[rows, user])
                parts.append(step.reshape(num_envs, num_uavs, 2 * num_slots))
            else:
                parts.append(self._heights(data).reshape(num_envs, num_uavs, -1))
        return np.concatenate(parts, axis=2).astype(np.float32)

    def _velocity(self, data: WorldData) -> FloatArray:
        """Every user's [v_x, v_y] (B, N, 2), scaled or raw (module doc)."""
        return data.moved_m / (self.step_m if self.scaled else data.step_s)

    def _heights(self, data: WorldData) -> FloatArray:
        """Every UAV's raster (B, U R^2) (module doc)."""
        points = data.uav_m[..., None, :2] + self.offsets_m()              # (B, U, R^2, 2)
        num_envs, num_uavs = data.uav_m.shape[:2]
        if data.city is None or not data.city.count:
            return np.zeros((num_envs, num_uavs * self.cells ** 2))
        roofs = roofs_m(points, data.city)                                  # (B, U, R^2)
        if self.scaled:
            roofs = roofs / self.max_height_m
        return roofs.reshape(num_envs, -1)

    def bounds(self, scenario: Scenario, num_users: int, num_uavs: int
               ) -> tuple[FloatArray, FloatArray]:
        """Lower and upper bounds (E,) of the features of ``num_users`` users and
        ``num_uavs`` rasters (the network's: N and U; a local observation's: S slots and its
        own): LoS in [0, 1], a velocity at most the area's diagonal in one step, a roof
        between 0 and the tallest the world holds."""
        low, high = [], []
        for name in self.features:
            if name == "los":
                low.append(np.zeros(num_users))
                high.append(np.ones(num_users))
            elif name == "velocity":
                fastest = scenario.area.side_m * np.sqrt(2.0) / scenario.uav.step_s
                limit = fastest * scenario.uav.step_s / self.step_m if self.scaled else fastest
                low.append(np.full(2 * num_users, -limit))
                high.append(np.full(2 * num_users, limit))
            else:
                tallest = _tallest_m(scenario)
                low.append(np.zeros(num_uavs * self.cells ** 2))
                high.append(np.full(num_uavs * self.cells ** 2,
                                    tallest / self.max_height_m if self.scaled else tallest))
        return np.concatenate(low), np.concatenate(high)


def _in_order(values: FloatArray, order: NDArray[np.intp] | None) -> FloatArray:
    return values if order is None else np.take_along_axis(values, order, axis=1)


def _tallest_m(scenario: Scenario) -> float:
    """An upper bound of every roof of ``scenario``'s world, m: the tallest listed box, or
    for a generated city the scenario format's largest height (Rayleigh heights of scale
    gamma <= 1 km pass it with probability below e^-50)."""
    world = scenario.world
    if world.buildings == "listed":
        return max((box.height_m for box in world.building), default=0.0)
    return MAX_HEIGHT_M
