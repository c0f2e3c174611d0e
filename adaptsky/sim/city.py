"""The buildings of a scenario's world (docs/model.md §12): ITU-R P.1410's statistical city
(``world.buildings = "generated"``) or listed boxes (``"listed"``), as arrays per environment.

A city is :class:`City`: the footprints (M, 4) [x_min, x_max, y_min, y_max], m, shared by every
environment of a batch, and the heights (B, M), m, of environment b's buildings.

A generated city has square buildings of side 1000 sqrt(alpha / beta) m on a regular grid of
pitch 1000 / sqrt(beta) m (streets between), every building whose footprint meets the area.
The grid's offset is uniform, drawn from ``world.seed``; the squares that would stand on a UAV's
start or a listed user are left out (open squares): the footprints are the scenario's. The
heights are
Rayleigh(gamma), drawn anew for every layout of users from a generator seeded by
``world.seed`` and the layout's own numbers (a hash of its positions): the same scenario and
layout give the same city wherever the layout goes (training, evaluation, baselines, pictures)
and every fresh layout a new one.
"""

from __future__ import annotations

import functools
import hashlib
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from adaptsky.errors import AdaptskyError
from adaptsky.scenario.ground import MIN_OPEN_SHARE, open_ground_share
from adaptsky.scenario.models import Scenario, World

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

MAX_DRAWS = 10_000
"""The draws of one user's position (or hotspot offset) before the world is declared too
closed for it (docs/scenario-format.md): at the least open ground validation lets through,
1% of the area, a user fails them all with a chance below e^-100."""


class PlacementError(AdaptskyError):
    """Users could not be placed off the buildings within MAX_DRAWS draws (one line)."""


def redraw_while(misplaced: Callable[[], BoolArray], redraw: Callable[[BoolArray], None]
                 ) -> BoolArray:
    """Call ``redraw`` on the mask ``misplaced()`` gives while any is set, MAX_DRAWS draws in
    all (the caller's first included); the mask left (any set: the draws ran out)."""
    mask = misplaced()
    for _ in range(MAX_DRAWS - 1):
        if not mask.any():
            break
        redraw(mask)
        mask = misplaced()
    return mask

_OFFSET_STREAM = 3    # generator streams of a world's seed: [seed, 3] the grid offset,
_HEIGHT_STREAM = 4    # [seed, 4, layout hash...] the heights of one layout


@dataclass(frozen=True)
class City:
    """Buildings of B environments: ``footprints_m`` (M, 4) [x_min, x_max, y_min, y_max] and
    ``heights_m`` (B, M), m (docs/model.md §12)."""

    footprints_m: FloatArray
    heights_m: FloatArray

    @functools.cached_property
    def tallest_m(self) -> FloatArray:
        """The height of every environment's tallest building (B,), m (0 without any)."""
        return self.heights_m.max(axis=1, initial=0.0)

    @property
    def count(self) -> int:
        """M, the buildings of every environment."""
        return len(self.footprints_m)

    def environment(self, index: int) -> City:
        """The city of environment ``index`` alone (heights (1, M))."""
        return City(self.footprints_m, self.heights_m[index:index + 1])


def grid_geometry_m(alpha: float, beta_per_km2: float) -> tuple[float, float]:
    """(side, pitch), m, of a P.1410 city: 1000 sqrt(alpha / beta) and 1000 / sqrt(beta)."""
    return 1000.0 * math.sqrt(alpha / beta_per_km2), 1000.0 / math.sqrt(beta_per_km2)


def grid_footprints(side_m: float, pitch_m: float, offset_m: FloatArray,
                    half_area_m: float) -> FloatArray:
    """Footprints (M, 4) of the squares of side ``side_m`` whose lower-left corners sit at
    ``offset_m + pitch_m (i, j)``, every one that meets the square |x|, |y| <= half_area_m
    (row by row, x before y)."""
    corners = [o + pitch_m * np.arange(math.floor((-half_area_m - side_m - o) / pitch_m),
                                       math.ceil((half_area_m - o) / pitch_m) + 1)
               for o in offset_m]
    kept = [c[(c + side_m > -half_area_m) & (c < half_area_m)] for c in corners]
    x0, y0 = (a.ravel() for a in np.meshgrid(kept[0], kept[1], indexing="ij"))
    return np.stack([x0, x0 + side_m, y0, y0 + side_m], axis=1)


def _fixed_points(scenario: Scenario) -> FloatArray:
    """The points (P, 2) no building of a generated city stands on: every UAV's start and,
    for listed users, every user."""
    points = [start[:2] for start in scenario.uav_start_positions_m]
    if scenario.users.placement == "listed":
        points += [list(p) for p in scenario.users.positions_m or []]
    return np.asarray(points, dtype=np.float64)


def scenario_footprints(scenario: Scenario) -> FloatArray | None:
    """The footprints (M, 4) of the scenario's buildings, m; None without buildings."""
    world = scenario.world
    if world.buildings == "none":
        return None
    if world.buildings == "listed":
        return np.array([b.box_m[:4] for b in world.building], dtype=np.float64)
    points = _fixed_points(scenario)
    return _generated_footprints(world.model_dump_json(), scenario.area.side_m,
                                 tuple(map(tuple, points.tolist()))).copy()


@functools.lru_cache(maxsize=64)
def _generated_footprints(world_json: str, area_side_m: float,
                          points: tuple[tuple[float, float], ...]) -> FloatArray:
    """The footprints of a generated city (module doc), cached per world, area and fixed
    points: the grid at its uniform offset, less the squares standing on a fixed point."""
    world = World.model_validate_json(world_json)
    alpha, beta, _ = world.city_parameters
    side_m, pitch_m = grid_geometry_m(alpha, beta)
    offset_m = np.random.default_rng([world.seed, _OFFSET_STREAM]).uniform(0.0, pitch_m, 2)
    footprints = grid_footprints(side_m, pitch_m, offset_m, area_side_m / 2)
    fixed = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    x, y = fixed[:, 0, None], fixed[:, 1, None]
    f = footprints
    on_one = ((x >= f[:, 0]) & (x <= f[:, 1]) & (y >= f[:, 2]) & (y <= f[:, 3])).any(axis=0)
    return footprints[~on_one]


def layout_words(layout_m: FloatArray) -> list[int]:
    """Four 32-bit words of a hash of the layout's positions (N, 2), m: the layout's part of
    the seed of its city's heights."""
    digest = hashlib.blake2b(np.ascontiguousarray(layout_m, dtype=np.float64).tobytes(),
                             digest_size=16).digest()
    return [int.from_bytes(digest[i:i + 4], "little") for i in range(0, 16, 4)]


def city_of(scenario: Scenario, layouts_m: FloatArray) -> City | None:
    """The city of every layout ``layouts_m`` (B, N, 2) of the scenario (module doc); None
    without buildings."""
    footprints = scenario_footprints(scenario)
    if footprints is None:
        return None
    world, count = scenario.world, len(footprints)
    if world.buildings == "listed":
        heights = np.array([b.height_m for b in world.building], dtype=np.float64)
        return City(footprints, np.broadcast_to(heights, (len(layouts_m), count)).copy())
    gamma_m = world.city_parameters[2]
    heights = np.empty((len(layouts_m), count))
    for row, layout in zip(heights, layouts_m, strict=True):
        rng = np.random.default_rng([world.seed, _HEIGHT_STREAM, *layout_words(layout)])
        row[...] = rng.rayleigh(gamma_m, size=count)
    return City(footprints, heights)


def on_footprints(points_m: FloatArray, footprints_m: FloatArray) -> BoolArray:
    """Whether each point (..., 2), m, stands on a footprint (closed: its edge counts) of
    ``footprints_m`` (M, 4): (...)."""
    x, y = points_m[..., 0, None], points_m[..., 1, None]
    f = footprints_m
    return ((x >= f[:, 0]) & (x <= f[:, 1]) & (y >= f[:, 2]) & (y <= f[:, 3])).any(axis=-1)


def street_layouts(rng: np.random.Generator, count: int, num_users: int, half_m: float,
                   footprints_m: FloatArray) -> FloatArray:
    """``count`` layouts (count, N, 2) with every user uniform over the streets of the area
    (docs/model.md §12): uniform over the area (layout after layout, user after user, x before
    y), then every user on a footprint drawn again, until none is: PlacementError after
    MAX_DRAWS draws of a user."""
    users_m = rng.uniform(-half_m, half_m, size=(count, num_users, 2))

    def redraw(inside: BoolArray) -> None:
        users_m[inside] = rng.uniform(-half_m, half_m, size=(int(inside.sum()), 2))

    inside = redraw_while(lambda: on_footprints(users_m, footprints_m), redraw)
    if inside.any():
        share = open_ground_share(footprints_m.tolist(), half_m)
        raise PlacementError(f"users: {int(inside.sum())} of {inside.size} users found no "
                             f"position off the buildings in {MAX_DRAWS} draws each: the "
                             f"buildings leave {share:.1%} of the area open ground (at least "
                             f"{MIN_OPEN_SHARE:.0%} is needed, docs/scenario-format.md)")
    return users_m
