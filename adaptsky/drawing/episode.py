"""One episode of one layout as plain arrays (:class:`EpisodeData`), the frames an animation
shows of it (:func:`frame_steps`), and a buffer that records one step at a time
(:class:`EpisodeBuffer`, for the Gymnasium env's ``render()``). numpy only."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]
BoolArray = NDArray[np.bool_]

MAX_FRAMES = 200
"""The most frames an animation has by default (:func:`default_every`): a 1000-step episode
is 200 frames, 10 s at 20 frames per second."""


@dataclass(frozen=True, eq=False)
class EpisodeData:
    """One episode of N users and U UAVs over T steps, time-major; row t is the state after
    step ``first_step + t`` (a file's trajectory: steps 1 to T; an env's: 0, the reset, on).

    ``users_m`` (N, 2) user positions, m; ``uav_m`` (T, U, 3) every UAV's [x, y, h], m (a
    (T, 3) array is taken as U = 1); ``alpha`` (T, N) every user's share of its cluster's
    power; ``rate_bps`` (T, N) every user's rate, bit/s; ``serving_uav`` (N,) the UAV u that
    serves each user and ``cluster`` (N,) its cluster k among that UAV's (its subchannel
    under full reuse); ``los`` (T, N) the LoS state of every user's serving link, or None
    where LoS is not drawn (``los = "always"`` or ``"expected"``, or not stored);
    ``power_w`` (T, U) every UAV's propulsion power, W, or None (not modelled);
    ``user_track_m`` (T, N, 2) every user's position at every row, m, where the users move
    (``users_m`` is then where they started), or None where they stand at ``users_m``;
    ``step_s`` the duration of a step, s, or None (the steps are counted, not timed);
    ``label`` the title of its picture; ``buildings_m`` (M, 5) every building's
    [x_min, x_max, y_min, y_max, height], m, or None (no buildings, docs/model.md §12).
    """

    users_m: FloatArray
    uav_m: FloatArray
    alpha: FloatArray
    rate_bps: FloatArray
    serving_uav: IntArray
    cluster: IntArray
    los: BoolArray | None = None
    power_w: FloatArray | None = None
    step_s: float | None = None
    first_step: int = 1
    label: str = ""
    user_track_m: FloatArray | None = None
    buildings_m: FloatArray | None = None

    def __post_init__(self) -> None:
        set_ = object.__setattr__  # frozen: normalise the arrays once, here
        set_(self, "users_m", np.asarray(self.users_m, dtype=np.float64))
        uav_m = np.asarray(self.uav_m, dtype=np.float64)
        set_(self, "uav_m", uav_m[:, None, :] if uav_m.ndim == 2 else uav_m)
        for name in ("alpha", "rate_bps"):
            set_(self, name, np.asarray(getattr(self, name), dtype=np.float64))
        for name in ("serving_uav", "cluster"):
            set_(self, name, np.asarray(getattr(self, name), dtype=np.intp))
        if self.los is not None:
            set_(self, "los", np.asarray(self.los, dtype=bool))
        for name in ("power_w", "user_track_m", "buildings_m"):
            if getattr(self, name) is not None:
                set_(self, name, np.asarray(getattr(self, name), dtype=np.float64))
        self._check_shapes()

    def _check_shapes(self) -> None:
        n = len(self.users_m)
        steps, uavs = self.uav_m.shape[:2] if self.uav_m.ndim == 3 else (-1, -1)
        expected = {"users_m": (n, 2), "uav_m": (steps, uavs, 3), "alpha": (steps, n),
                    "rate_bps": (steps, n), "serving_uav": (n,), "cluster": (n,),
                    "los": (steps, n), "power_w": (steps, uavs),
                    "user_track_m": (steps, n, 2),
                    "buildings_m": (len(self.buildings_m) if self.buildings_m is not None
                                    else 0, 5)}
        for name, shape in expected.items():
            value = getattr(self, name)
            if value is not None and value.shape != shape:
                raise ValueError(f"EpisodeData.{name}: shape {value.shape}, expected {shape} "
                                 f"(T = {steps} steps, U = {uavs} UAVs, N = {n} users)")
        if steps < 1:
            raise ValueError("EpisodeData: an episode needs at least one row")
        if n and not (self.serving_uav.min() >= 0 and self.serving_uav.max() < uavs):
            raise ValueError(f"EpisodeData.serving_uav: UAVs 0 to {uavs - 1}, got "
                             f"{self.serving_uav.min()} to {self.serving_uav.max()}")
        if self.step_s is not None and not self.step_s > 0:
            raise ValueError(f"EpisodeData.step_s: {self.step_s} s; a step lasts > 0 s")

    @property
    def steps(self) -> int:
        """T, the number of rows."""
        return self.uav_m.shape[0]

    @property
    def num_uavs(self) -> int:
        return self.uav_m.shape[1]

    @property
    def num_users(self) -> int:
        return len(self.users_m)

    @property
    def users_move(self) -> bool:
        """Whether the users have a track (they move; None: they stand at ``users_m``)."""
        return self.user_track_m is not None

    def users_at(self, row: int) -> FloatArray:
        """Every user's position (N, 2) at row ``row``."""
        return self.users_m if self.user_track_m is None else self.user_track_m[row]

    @property
    def held(self) -> bool:
        """Whether every UAV stays where it is (a baseline holding one configuration)."""
        return bool(np.all(self.uav_m == self.uav_m[:1]))

    @property
    def time(self) -> FloatArray:
        """The x of every row (T,): its step, or its time in s where ``step_s`` is given."""
        steps = np.arange(self.first_step, self.first_step + self.steps, dtype=np.float64)
        return steps if self.step_s is None else steps * self.step_s

    def pairs(self) -> list[tuple[int, int, list[int]]]:
        """Every cluster as (UAV u, cluster k, its users in listed order), by u then k."""
        found: dict[tuple[int, int], list[int]] = {}
        for user, key in enumerate(zip(self.serving_uav.tolist(), self.cluster.tolist(),
                                       strict=True)):
            found.setdefault(key, []).append(user)
        return [(u, k, users) for (u, k), users in sorted(found.items())]

    def share_lines(self) -> list[tuple[int, int, int, list[int]]]:
        """The shares a figure draws, as (UAV u, cluster k, user, the cluster's users): each
        cluster's members but the last where its shares split the cluster's power (they sum
        to 1 at every step: the downlink's, docs/model.md §15; a pair's first user alone),
        every member where they do not (the uplink's transmit shares, §17)."""
        lines = []
        for u, k, users in self.pairs():
            split = np.allclose(self.alpha[:, users].sum(axis=1), 1.0)
            lines += [(u, k, user, users) for user in (users[:-1] if split else users)]
        return lines

    def until(self, steps: int) -> EpisodeData:
        """The first ``steps`` rows (views, no copy)."""
        return replace(self, uav_m=self.uav_m[:steps], alpha=self.alpha[:steps],
                       rate_bps=self.rate_bps[:steps],
                       los=None if self.los is None else self.los[:steps],
                       power_w=None if self.power_w is None else self.power_w[:steps],
                       user_track_m=None if self.user_track_m is None
                       else self.user_track_m[:steps])


def default_every(steps: int, max_frames: int = MAX_FRAMES) -> int:
    """Steps per frame so that an episode of ``steps`` is at most about ``max_frames``."""
    return max(1, math.ceil(steps / max_frames))


def frame_steps(steps: int, every: int) -> list[int]:
    """The rows an animation of ``steps`` rows shows, one per frame: every ``every``-th row
    and the last, ``every - 1, 2 every - 1, ..., steps - 1``: ceil(steps / every) frames."""
    if every < 1:
        raise ValueError(f"every: {every} steps per frame; give 1 or more")
    return [min(end, steps) - 1 for end in range(every, steps + every, every)]


@dataclass
class EpisodeBuffer:
    """Rows of an episode recorded as it runs, in arrays made once for ``capacity`` rows:
    :meth:`record` adds one, :meth:`episode` gives those so far as :class:`EpisodeData`.

    Rows recorded with the users' positions give the episode a user track once the users
    have moved within an episode; from then on every episode has one (cleared or not), so
    that a figure of one episode fits the next (:meth:`EpisodeFigure.fits`). Users that
    never move give none: the picture of standing users."""

    capacity: int
    num_uavs: int
    num_users: int
    with_los: bool
    rows: int = 0
    uav_m: FloatArray = field(init=False)
    alpha: FloatArray = field(init=False)
    rate_bps: FloatArray = field(init=False)
    los: BoolArray = field(init=False)
    power_w: FloatArray = field(init=False)
    users_m: FloatArray = field(init=False)

    def __post_init__(self) -> None:
        self.uav_m = np.zeros((self.capacity, self.num_uavs, 3))
        self.alpha = np.zeros((self.capacity, self.num_users))
        self.rate_bps = np.zeros((self.capacity, self.num_users))
        self.power_w = np.zeros((self.capacity, self.num_uavs))
        self._powered = True   # every row so far came with its power
        self.los = np.zeros((self.capacity, self.num_users if self.with_los else 0), dtype=bool)
        self.users_m = np.zeros((self.capacity, self.num_users, 2))
        self._placed = True    # every row so far came with the users' positions
        self.walks = False     # the users moved within an episode (kept by clear())

    def clear(self) -> None:
        self.rows = 0
        self._powered = True
        self._placed = True

    def record(self, uav_m: FloatArray, alpha: FloatArray, rate_bps: FloatArray,
               los: BoolArray | None = None, power_w: FloatArray | None = None,
               users_m: FloatArray | None = None) -> None:
        """One row: positions (U, 3) (or (3,)), shares and rates (N,), LoS states (N,), every
        UAV's power (U,) (or a number), W, every user's position (N, 2), m (copied)."""
        if self.rows >= self.capacity:
            raise ValueError(f"EpisodeBuffer holds {self.capacity} rows; clear() it first")
        row = self.rows
        self.uav_m[row] = np.reshape(uav_m, (self.num_uavs, 3))
        self.alpha[row], self.rate_bps[row] = alpha, rate_bps
        if self.with_los and los is not None:
            self.los[row] = los
        if power_w is None:
            self._powered = False
        else:
            self.power_w[row] = power_w
        if users_m is None:
            self._placed = False
        else:
            self.users_m[row] = users_m
            self.walks = self.walks or (row > 0 and not np.array_equal(self.users_m[row],
                                                                        self.users_m[0]))
        self.rows += 1

    def episode(self, users_m: FloatArray, serving_uav: IntArray, cluster: IntArray,
                first_step: int = 0, label: str = "", buildings_m: FloatArray | None = None
                ) -> EpisodeData:
        """The rows so far (views of the buffer: valid until the next :meth:`record`), with
        users at ``users_m`` (N, 2); where the users walk (:attr:`walks`), with their track
        and starting at the first row's positions instead; among ``buildings_m`` (M, 5)
        where given (:class:`EpisodeData`)."""
        rows = self.rows
        track = self.users_m[:rows] if self.walks and self._placed and rows else None
        return EpisodeData(users_m if track is None else track[0], self.uav_m[:rows],
                           self.alpha[:rows], self.rate_bps[:rows], serving_uav, cluster,
                           self.los[:rows] if self.with_los else None,
                           power_w=self.power_w[:rows] if self._powered else None,
                           first_step=first_step, label=label, user_track_m=track,
                           buildings_m=buildings_m)
