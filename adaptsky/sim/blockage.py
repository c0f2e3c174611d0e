"""Geometric line of sight and the buildings' volumes (docs/model.md §12): which links a
building blocks (:func:`los_mask`, the channel stage of ``los = "geometric"``), and the moves
that would take a UAV or a user into a building (:func:`kept_out`, the controls stage).

A building is the box [x_min, x_max] x [y_min, y_max] x [0, H]. A link is the segment from the
user's antenna (x_i, y_i, h_UT) to the UAV (x, y, h), with h > h_UT; it is blocked when it
passes through the inside of a box. A segment that only touches a box (runs along a wall,
grazes an edge or the roof) is not blocked. The test is the slab test: along the segment
p(t) = user + t (UAV - user), t in [0, 1], the inside of the box is the interval of t where x
and y lie inside the footprint, cut at the roof, t < (H - h_UT) / (h - h_UT), since the segment
climbs; the link is blocked when that interval is not empty.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from adaptsky.sim.city import City, on_footprints

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

CHUNK_ELEMENTS = 1 << 14
"""Links times buildings tested at once: arrays of 128 kB, which numpy takes from its cache of
small blocks rather than from the system (and which stay in the CPU's cache)."""


class Blockage:
    """The LoS test of the users of B environments against their city (docs/model.md §12),
    with what depends only on the users and the buildings made once per user position.

    ``city`` the buildings (M footprints, heights (B, M)); ``user_height_m`` h_UT of every
    user, m.
    """

    def __init__(self, city: City, user_height_m: float) -> None:
        self.city = city
        self.user_height_m = user_height_m
        self._users_of: FloatArray | None = None
        # H - h_UT of every building (B, 1, M): the climb from a user's antenna to the roof
        self._roof_m = (city.heights_m - user_height_m)[:, None, :]
        self._tall = self._roof_m > 0      # only a roof above the antenna can block
        self._all_tall = bool(self._tall.all())

    def _walls(self, users_m: FloatArray) -> FloatArray:
        """The footprints' walls seen from every user (4, B, N, M): x_min - x_i, x_max - x_i,
        y_min - y_i, y_max - y_i, m; kept until the users move."""
        if users_m is not self._users_of:
            f = self.city.footprints_m
            x, y = users_m[..., 0, None], users_m[..., 1, None]
            self._walls_m = np.stack([f[:, 0] - x, f[:, 1] - x, f[:, 2] - y, f[:, 3] - y])
            self._users_of = users_m
        return self._walls_m

    def los(self, uav_m: FloatArray, users_m: FloatArray) -> BoolArray:
        """Whether every link from the UAVs ``uav_m`` (B, U, 3) to the users ``users_m``
        (B, N, 2) of their environment is free of buildings: (B, U, N)."""
        walls = self._walls(users_m)
        num_envs, num_uavs = uav_m.shape[:2]
        num_users = users_m.shape[1]
        blocked = np.empty((num_envs, num_uavs, num_users), dtype=bool)
        per_env = max(1, CHUNK_ELEMENTS // max(1, num_uavs * num_users * self.city.count))
        with np.errstate(divide="ignore", invalid="ignore"):
            for start in range(0, num_envs, per_env):
                rows = slice(start, start + per_env)
                blocked[rows] = self._blocked(uav_m[rows], users_m[rows], walls[:, rows],
                                              self._roof_m[rows], self._tall[rows])
        return ~blocked

    def _blocked(self, uav_m: FloatArray, users_m: FloatArray, walls: FloatArray,
                 roof_m: FloatArray, tall: BoolArray) -> BoolArray:
        """The slab test (module doc) of every link of a few environments: (b, U, N)."""
        # 1 / (UAV - user) along x, y and h of every link (3, b, U, N, 1)
        inverse = 1.0 / (np.moveaxis(uav_m, 2, 0)[..., None]
                         - np.concatenate([np.moveaxis(users_m, 2, 0),
                                           np.full((1, *users_m.shape[:2]),
                                                   self.user_height_m)])[:, :, None])
        inverse = inverse[..., None]
        walls = walls[:, :, None]                                     # (4, b, 1, N, M)
        shape = (*inverse.shape[1:-1], walls.shape[-1])
        first, last, enter, y_first, y_last = (np.empty(shape) for _ in range(5))
        # the x slab: t between (x_min - x_i) / dx and (x_max - x_i) / dx; then the y slab
        np.multiply(walls[0], inverse[0], out=first)
        np.multiply(walls[1], inverse[0], out=last)
        np.minimum(first, last, out=enter)
        np.maximum(first, last, out=last)
        np.multiply(walls[2], inverse[1], out=first)
        np.multiply(walls[3], inverse[1], out=y_last)
        np.minimum(first, y_last, out=y_first)
        np.maximum(first, y_last, out=y_last)
        np.maximum(enter, y_first, out=enter)      # the later start, not before the user
        np.maximum(enter, 0.0, out=enter)
        np.minimum(last, y_last, out=last)         # the earlier end, not after the UAV
        np.minimum(last, 1.0, out=last)
        # below the roof: t < (H - h_UT) / dh
        np.multiply(roof_m[:, :, None], inverse[2], out=first)
        np.minimum(last, first, out=last)
        # NaN (a link in the plane of a wall) compares False: touching is not blocking
        inside = np.less(enter, last)
        if not self._all_tall:
            inside &= tall[:, :, None]
        return inside.any(axis=-1)


def inside_buildings(points_m: FloatArray, city: City) -> BoolArray:
    """Whether each point (B, K, 3) [x, y, h], m, lies in a building of its environment,
    walls and roof included: (B, K)."""
    f = city.footprints_m
    x, y, h = points_m[..., 0, None], points_m[..., 1, None], points_m[..., 2, None]
    return ((x >= f[:, 0]) & (x <= f[:, 1]) & (y >= f[:, 2]) & (y <= f[:, 3])
            & (h <= city.heights_m[:, None, :])).any(axis=-1)


def above_buildings(points_m: FloatArray, city: City, clearance_m: float = 1.0) -> FloatArray:
    """The points (B, K, 3), m, each inside a building of its environment raised to
    ``clearance_m`` above the highest roof it stands under (docs/model.md §12); the others
    as they are (``points_m`` itself where none is inside)."""
    inside = inside_buildings(points_m, city)
    if not inside.any():
        return points_m
    f = city.footprints_m
    x, y = points_m[..., 0, None], points_m[..., 1, None]
    under = (x >= f[:, 0]) & (x <= f[:, 1]) & (y >= f[:, 2]) & (y <= f[:, 3])
    roof_m = np.where(under, city.heights_m[:, None, :], 0.0).max(axis=-1)
    raised = points_m.copy()
    raised[..., 2] = np.where(inside, roof_m + clearance_m, points_m[..., 2])
    return raised


def kept_out(before_m: FloatArray, moved_m: FloatArray, city: City) -> FloatArray:
    """The UAV positions (B, U, 3) after moves from ``before_m`` to ``moved_m`` (both
    (B, U, 3), m) that keep out of the buildings: a move that ends inside one does not happen
    (that UAV keeps ``before_m``, as with the separation, docs/model.md §9 and §12).
    ``moved_m`` itself where no move ends inside a building."""
    blocked = inside_buildings(moved_m, city)
    if not blocked.any():
        return moved_m
    return np.where(blocked[..., None], before_m, moved_m)


def users_kept_out(before_m: FloatArray, walked_m: FloatArray, footprints_m: FloatArray
                   ) -> FloatArray:
    """The users' positions (B, N, 2) after a walk from ``before_m`` to ``walked_m``, m: a
    user whose step ends on a footprint stands where it was that step (docs/model.md §12)."""
    blocked = on_footprints(walked_m, footprints_m)
    if not blocked.any():
        return walked_m
    return np.where(blocked[..., None], before_m, walked_m)
