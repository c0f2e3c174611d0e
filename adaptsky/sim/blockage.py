"""Geometric line of sight and the buildings' volumes (docs/model.md §12): which links a
building blocks (:meth:`Blockage.los`, the channel stage of ``los = "geometric"``), and the moves
that would take a UAV or a user into a building (:func:`kept_out`, the controls stage).

A building is the box [x_min, x_max] x [y_min, y_max] x [0, H]. A link is the segment from the
user's antenna (x_i, y_i, h_UT) to the UAV (x, y, h), with h > h_UT; it is blocked when it
passes through the inside of a box. A segment that only touches a box (runs along a wall,
grazes an edge or the roof) is not blocked. The test is the slab test: along the segment
p(t) = user + t (UAV - user), t in [0, 1], the inside of the box is the interval of t where x
and y lie inside the footprint, cut at the roof, t < (H - h_UT) / (h - h_UT), since the segment
climbs; the link is blocked when that interval is not empty. It is computed in heights above
the antenna, t (h - h_UT): the walls' offsets times (h - h_UT) / (x - x_i) (and y), the roof's
cut H - h_UT the same for every link. Its arithmetic is single precision (offsets from each
user rounded to about 0.1 mm at 1 km): a link that passes within a fraction of a millimetre of
an edge may be taken as touching it or as crossing it. That halves the test's cost against
double precision (docs/model.md §12, speed).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from adaptsky.sim.city import City, on_footprints

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

WORK = np.float32
"""The slab test's arithmetic: single precision (module doc)."""

CHUNK_ELEMENTS = 1 << 20
"""Link-building pairs tested at once: work arrays of 8 MB at most, kept from call to call.
Large, because the environments' axis is the arrays' inner loop: a chunk of a few dozen
environments costs numpy's loop overhead on every short row (a step of four UAVs and 16 users
in a 5 x 5 grid at B = 256 took 1.05 ms in chunks of 81 environments, 0.73 ms in one)."""
MIN_ENVS = 32
"""The fewest environments of a chunk: the environments' axis is the arrays' inner loop."""
GRID_CELLS_PER_BUILDING = 2
"""Footprints that share their x-extents (columns) and y-extents (rows), as a generated city's
do, are tested as a grid when it has at most this many cells per building."""


class Blockage:
    """The LoS test of the users of B environments against their city (docs/model.md §12),
    with what depends only on the users and the buildings made once per user position.

    ``city`` the buildings (M footprints, heights (B, M)); ``user_height_m`` h_UT of every
    user, m.

    The slab test's x interval of a link depends only on a footprint's x-extent, its y interval
    only on the y-extent: they are computed once per link and column (distinct x-extent) and
    per link and row, and combined for every building. Where the footprints form a grid (a
    generated city: C columns x R rows, about M cells) every cell is combined, a cell without a
    building having height 0 (it blocks nothing); otherwise each building is its own column and
    row. The numbers are those of the slab test building by building.
    """

    def __init__(self, city: City, user_height_m: float) -> None:
        self.city = city
        self.user_height_m = user_height_m
        self._users_of: FloatArray | None = None
        self._buffers: dict[tuple[str, tuple[int, ...]], np.ndarray] = {}
        f, count = city.footprints_m, city.count
        columns, column_of = np.unique(f[:, :2], axis=0, return_inverse=True)
        rows, row_of = np.unique(f[:, 2:], axis=0, return_inverse=True)
        self._grid = len(columns) * len(rows) <= GRID_CELLS_PER_BUILDING * count
        if self._grid:
            cell = column_of.ravel() * len(rows) + row_of.ravel()
            heights = np.zeros((len(city.heights_m), len(columns) * len(rows)))
            for index in range(count):    # equal footprints: the tallest counts
                np.maximum(heights[:, cell[index]], city.heights_m[:, index],
                           out=heights[:, cell[index]])
            self._columns_m, self._rows_m = columns, rows
        else:
            heights = city.heights_m
            self._columns_m, self._rows_m = f[:, :2], f[:, 2:]
        # H - h_UT of every cell or building, (C, R, B) or (M, B): a roof at or below the
        # antenna gives t <= 0 and blocks nothing
        shape = (len(columns), len(rows)) if self._grid else (count,)
        self._roof_m = np.ascontiguousarray((heights - user_height_m).T, dtype=WORK).reshape(
            *shape, len(heights))

    def _walls(self, users_m: FloatArray) -> tuple[FloatArray, FloatArray]:
        """The columns' and rows' walls seen from every user, (2, N, C, B) [x_min - x_i,
        x_max - x_i] and (2, N, R, B) [y_min - y_i, y_max - y_i], m; kept until the users
        move. The environments' axis is the last (the long, contiguous one) in every array
        of the test."""
        if users_m is not self._users_of:
            x, y = users_m[:, :, 0].T[:, None, :], users_m[:, :, 1].T[:, None, :]   # (N, 1, B)
            columns, rows = self._columns_m[:, :, None], self._rows_m[:, :, None]
            self._x_walls = np.ascontiguousarray(np.stack([columns[:, 0] - x,
                                                           columns[:, 1] - x]), dtype=WORK)
            self._y_walls = np.ascontiguousarray(np.stack([rows[:, 0] - y, rows[:, 1] - y]),
                                                 dtype=WORK)
            self._users_xy = np.ascontiguousarray(users_m.transpose(2, 1, 0)[:, None])
            self._users_of = users_m
        return self._x_walls, self._y_walls

    def los(self, uav_m: FloatArray, users_m: FloatArray) -> BoolArray:
        """Whether every link from the UAVs ``uav_m`` (B, U, 3) to the users ``users_m``
        (B, N, 2) of their environment is free of buildings: (B, U, N)."""
        x_walls, y_walls = self._walls(users_m)
        num_envs, num_uavs = uav_m.shape[:2]
        num_users = users_m.shape[1]
        blocked = np.empty((num_uavs, num_users, num_envs), dtype=bool)
        cells = int(np.prod(self._roof_m.shape[:-1]))
        per_env = max(MIN_ENVS, CHUNK_ELEMENTS // max(1, num_uavs * num_users * cells))
        with np.errstate(divide="ignore", invalid="ignore"):
            # the links' climb h - h_UT over their extents along x and y, (2, U, N, B), and
            # the climb itself (U, N, B): the test runs in heights, t (h - h_UT)
            climb = np.ascontiguousarray(uav_m[..., 2].T[:, None, :]) - self.user_height_m
            slopes = (climb / (uav_m[..., :2].transpose(2, 1, 0)[:, :, None, :]
                               - self._users_xy)).astype(WORK)
            climb = climb.astype(WORK)
            for start in range(0, num_envs, per_env):
                envs = slice(start, start + per_env)
                blocked[..., envs] = self._blocked(slopes[..., envs], climb[..., envs],
                                                   x_walls[..., envs], y_walls[..., envs],
                                                   self._roof_m[..., envs])
        return ~blocked.transpose(2, 0, 1)

    def _buffer(self, name: str, shape: tuple[int, ...], dtype: type = WORK
                ) -> np.ndarray:
        """A work array of this shape, kept from call to call (no new memory per step)."""
        key = (name, shape)
        if key not in self._buffers:
            self._buffers[key] = np.empty(shape, dtype=dtype)
        return self._buffers[key]

    def _blocked(self, slopes: FloatArray, climb: FloatArray, x_walls: FloatArray,
                 y_walls: FloatArray, roof_m: FloatArray) -> BoolArray:
        """The slab test (module doc) of every link of a few environments b, (U, N, b), in
        heights above the antenna: the segment is inside a footprint between the climbs
        t (h - h_UT) where it enters and leaves it, and blocked where it enters below the
        roof, H - h_UT."""
        x_enter, x_leave = self._slab("x", x_walls, slopes[0], climb)   # (U, N, C, b) each
        y_enter, y_leave = self._slab("y", y_walls, slopes[1], climb)   # (U, N, R, b) each
        if self._grid:
            x_enter, x_leave = x_enter[:, :, :, None], x_leave[:, :, :, None]
            y_enter, y_leave = y_enter[:, :, None], y_leave[:, :, None]
        shape = np.broadcast_shapes(x_enter.shape, y_enter.shape)
        # inside where the later start comes before the earliest end (of the x slab, the y
        # slab and the climb to the roof); a slab the link does not cross (enter > leave)
        # makes that so for every cell of it. NaN (a link in the plane of a wall) propagates
        # through maximum and minimum and compares False: touching is not blocking
        enter = np.maximum(x_enter, y_enter, out=self._buffer("enter", shape))
        leave = np.minimum(x_leave, y_leave, out=self._buffer("leave", shape))
        np.minimum(leave, roof_m, out=leave)
        inside = np.less(enter, leave, out=self._buffer("inside", shape, np.bool_))
        return inside.reshape(*shape[:2], -1, shape[-1]).any(axis=2)

    def _slab(self, axis: str, walls: FloatArray, slopes: FloatArray, climb: FloatArray
              ) -> tuple[FloatArray, FloatArray]:
        """Where links cross slabs between two walls, as climbs t (h - h_UT) cut to t in
        [0, 1], from the walls' offsets from the users (2, N, K, b), the links' climbs over
        their extents along the axis (U, N, b) and their climbs (U, N, b): (U, N, K, b)
        each."""
        slopes, climb = slopes[:, :, None], climb[:, :, None]
        shape = np.broadcast_shapes(walls.shape[1:], slopes.shape)
        first, last = self._buffer(axis + "first", shape), self._buffer(axis + "last", shape)
        enter = self._buffer(axis + "enter", shape)
        np.multiply(walls[0], slopes, out=first)
        np.multiply(walls[1], slopes, out=last)
        np.minimum(first, last, out=enter)
        np.maximum(first, last, out=last)
        np.maximum(enter, 0.0, out=enter)
        np.minimum(last, climb, out=last)
        return enter, last


def inside_buildings(points_m: FloatArray, city: City) -> BoolArray:
    """Whether each point (B, K, 3) [x, y, h], m, lies in a building of its environment,
    walls and roof included: (B, K)."""
    f = city.footprints_m
    x, y, h = points_m[..., 0, None], points_m[..., 1, None], points_m[..., 2, None]
    return ((x >= f[:, 0]) & (x <= f[:, 1]) & (y >= f[:, 2]) & (y <= f[:, 3])
            & (h <= city.heights_m[:, None, :])).any(axis=-1)


def roofs_m(points_xy_m: FloatArray, city: City) -> FloatArray:
    """The tallest roof standing over each point (B, ..., 2) [x, y] of its environment,
    m, walls included (0 where none): (B, ...)."""
    f = city.footprints_m
    x, y = points_xy_m[..., 0, None], points_xy_m[..., 1, None]
    under = (x >= f[:, 0]) & (x <= f[:, 1]) & (y >= f[:, 2]) & (y <= f[:, 3])
    heights = city.heights_m.reshape(len(city.heights_m), *[1] * (points_xy_m.ndim - 2), -1)
    return np.where(under, heights, 0.0).max(axis=-1)


def above_buildings(points_m: FloatArray, city: City, clearance_m: float = 1.0) -> FloatArray:
    """The points (B, K, 3), m, each inside a building of its environment raised to
    ``clearance_m`` above the highest roof it stands under (docs/model.md §12); the others
    as they are (``points_m`` itself where none is inside)."""
    inside = inside_buildings(points_m, city)
    if not inside.any():
        return points_m
    roof_m = roofs_m(points_m[..., :2], city)
    raised = points_m.copy()
    raised[..., 2] = np.where(inside, roof_m + clearance_m, points_m[..., 2])
    return raised


def kept_out(before_m: FloatArray, moved_m: FloatArray, city: City) -> FloatArray:
    """The UAV positions (B, U, 3) after moves from ``before_m`` to ``moved_m`` (both
    (B, U, 3), m) that keep out of the buildings: a move that ends inside one does not happen
    (that UAV keeps ``before_m``, as with the separation, docs/model.md §9 and §12).
    ``moved_m`` itself where no move ends inside a building."""
    low = np.nonzero(moved_m[..., 2] <= city.tallest_m[:, None])   # the UAVs to test
    if not len(low[0]):
        return moved_m
    env = low[0]
    blocked = inside_buildings(moved_m[low][:, None], City(city.footprints_m,
                                                          city.heights_m[env]))[:, 0]
    if not blocked.any():
        return moved_m
    kept = moved_m.copy()
    kept[env[blocked], low[1][blocked]] = before_m[env[blocked], low[1][blocked]]
    return kept


def users_kept_out(before_m: FloatArray, walked_m: FloatArray, footprints_m: FloatArray
                   ) -> FloatArray:
    """The users' positions (B, N, 2) after a walk from ``before_m`` to ``walked_m``, m: a
    user whose step ends on a footprint stands where it was that step (docs/model.md §12)."""
    blocked = on_footprints(walked_m, footprints_m)
    if not blocked.any():
        return walked_m
    return np.where(blocked[..., None], before_m, walked_m)
