"""The per-step oracle for users that move (docs/model.md §6): at every step, the best
objective over the reachable lattice at that step's user positions, clustered as the policy's
environment clusters them then -- a genie that may jump from one lattice point to any other
between steps, and so an upper bound on any policy of one UAV.

Every step is the oracle's exhaustive search (:func:`~adaptsky.rollouts.oracle.point_values` at
every lattice point), made fast by branch and bound where the channel model declares
``Supports(monotone_gains=True)`` (the built-in models: their gains fall with the distance and
the NLoS gain lies below the LoS gain). The lattice is cut into boxes of ``BOX`` points; a
user's gain anywhere in a box is then at most the LoS gain at the box's nearest point to that
user, and a cluster's best value rises with its strong user's gain and with its weak user's (at
any share: the strong user's SINR rises with its own gain, the weak user's with its own; and
the larger of two gains bounds the strong one, the smaller the weak). So a box's value is at
most the sum over clusters of the best value at those gains over every share either user can
hold (the grid and its complement), with R_min's feasibility relaxed the same way. Boxes are
valued exactly from the largest bound down (the box of the previous step's optimum first, whose
value starts the search), until a bound falls to the best value found: the objective is the
exhaustive search's, exactly (among equal optima the first found is kept). Other channel models
(the default, no such declaration) search every point at every step.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from adaptsky.channels.contract import LinkGeometry, declares_monotone_gains
from adaptsky.rollouts.oracle import best_alpha_on_grid, lattice, point_values
from adaptsky.scenario.models import Scenario
from adaptsky.sim.links import carrier_hz
from adaptsky.sim.network import NetworkBatch

FloatArray = NDArray[np.float64]
BOX = (8, 8, 8)
"""Lattice points of a box along x, y and h."""
POINTS_PER_BATCH = 16_384
"""Lattice points valued at once (whole boxes)."""

GENIE_NOTE = ("the best lattice point and shares at every step's user positions, free to jump "
              "between steps: an upper bound on any policy of one UAV")
"""What the oracle is for users that move (its label in tables and files)."""


@dataclass(frozen=True)
class GenieResult:
    """Per step and layout: objective (T, L), UAV (T, L, 3), alpha_first (T, L, K), the
    users' positions (T, L, N, 2), and the lattice points valued per step (T, L)."""

    objective_bps: FloatArray
    uav_m: FloatArray
    alpha_first: FloatArray
    users_m: FloatArray
    points_valued: NDArray[np.int64]


class LatticeBoxes:
    """Lattice axes (x, y, h) cut into boxes of :data:`BOX` points: every box's low and high
    corners (M, 3), the box of a point, and a box's points (the per-step searches)."""

    def __init__(self, axes: Sequence[FloatArray]) -> None:
        self.axes = list(axes)
        self.starts = [np.arange(0, len(axis), size) for axis, size in zip(self.axes, BOX,
                                                                            strict=True)]
        self.index = np.stack(np.meshgrid(*[np.arange(len(s)) for s in self.starts],
                                          indexing="ij"), axis=-1).reshape(-1, 3)   # (i, j, k)
        lows, highs = [], []
        for dim, (axis, starts, size) in enumerate(zip(self.axes, self.starts, BOX,
                                                       strict=True)):
            first = starts[self.index[:, dim]]
            lows.append(axis[first])
            highs.append(axis[np.minimum(first + size, len(axis)) - 1])
        self.low, self.high = np.stack(lows, axis=1), np.stack(highs, axis=1)   # (M, 3)

    @property
    def count(self) -> int:
        """The lattice points of every box together."""
        return int(np.prod([len(axis) for axis in self.axes]))

    def of_point(self, point_m: FloatArray) -> int:
        """The box holding a lattice point."""
        ijk = [int(np.argmin(np.abs(axis - value))) // size
               for axis, value, size in zip(self.axes, point_m, BOX, strict=True)]
        counts = [len(s) for s in self.starts]
        return (ijk[0] * counts[1] + ijk[1]) * counts[2] + ijk[2]

    def ranked(self, bound: FloatArray, previous_m: FloatArray | None = None
               ) -> NDArray[np.intp]:
        """The boxes from the largest ``bound`` (M,) down (equal bounds in lattice order),
        the box of ``previous_m`` (the previous step's optimum: a good start) first."""
        ranked = np.argsort(-bound, kind="stable")
        if previous_m is not None:
            first = self.of_point(previous_m)
            ranked = np.concatenate([[first], ranked[ranked != first]])
        return ranked

    def points(self, boxes: NDArray[np.intp]) -> FloatArray:
        """Every lattice point (P, 3) of ``boxes``, box after box."""
        found = []
        for box in boxes:
            ranges = [axis[s[i]:s[i] + size] for axis, s, i, size in zip(
                self.axes, self.starts, self.index[box], BOX, strict=True)]
            found.append(np.stack(np.meshgrid(*ranges, indexing="ij"), axis=-1).reshape(-1, 3))
        return np.concatenate(found)

    def nearest(self, users_m: FloatArray) -> FloatArray:
        """Every box's point nearest each user (M, N, 3): its footprint clipped to the user,
        its lowest height."""
        corners = np.empty((len(self.low), len(users_m), 3))
        corners[..., :2] = np.clip(users_m[None], self.low[:, None, :2],
                                   self.high[:, None, :2])
        corners[..., 2] = self.low[:, None, 2]
        return corners

    def farthest(self, users_m: FloatArray) -> FloatArray:
        """Every box's corner farthest from each user (M, N, 3): the farther edge along x and
        y, its greatest height."""
        corners = np.empty((len(self.low), len(users_m), 3))
        users = users_m[None]
        corners[..., :2] = np.where(np.abs(users - self.low[:, None, :2])
                                    > np.abs(users - self.high[:, None, :2]),
                                    self.low[:, None, :2], self.high[:, None, :2])
        corners[..., 2] = self.high[:, None, 2]
        return corners


def either_share(alphas: FloatArray) -> FloatArray:
    """Every share either user of a cluster may hold: the grid and its complement."""
    return np.unique(np.concatenate([alphas, 1.0 - alphas]))


def gains_at(env: NetworkBatch, corners_m: FloatArray, users_m: FloatArray,
             nlos: bool = False) -> FloatArray:
    """The channel's LoS (or NLoS) gain (M, N) from the points ``corners_m`` (M, N, 3), one
    per box and user, to each user of ``users_m`` (N, 2); no buildings (a bound's gain)."""
    scenario = env.scenario
    every_user = np.broadcast_to(users_m, (*corners_m.shape[:2], 2)).reshape(-1, 1, 2)
    geometry = LinkGeometry.between(corners_m.reshape(-1, 3), every_user,
                                    user_height_m=scenario.users.height_m,
                                    carrier_hz=carrier_hz(scenario),
                                    bandwidth_hz=env.bandwidth_hz)
    gain = env.channel.gain_nlos(geometry) if nlos else env.channel.gain_los(geometry)
    return gain.reshape(corners_m.shape[:2])


def _bounds(env: NetworkBatch, layout: int, boxes: LatticeBoxes, users_m: FloatArray,
            shares: FloatArray, snr_scale: float) -> FloatArray:
    """Every box's upper bound on the objective (M,) (module doc); -inf where no point of it
    can meet R_min."""
    gain = gains_at(env, boxes.nearest(users_m), users_m)
    first, second = gain[:, env.first_user[layout]], gain[:, env.second_user[layout]]
    _, rate = best_alpha_on_grid(np.maximum(first, second), np.minimum(first, second),
                                 shares, env.scenario, snr_scale)
    return rate.sum(axis=1)


BoxValues = Callable[[FloatArray], tuple[FloatArray, FloatArray]]
"""Lattice points (P, 3) to their objectives (P,) and best alpha_first (P, K)."""


def best_in_boxes(boxes: LatticeBoxes, bound: FloatArray, ranked: NDArray[np.intp],
                  values: BoxValues, start: tuple[float, FloatArray, FloatArray],
                  first_alone: bool = False) -> tuple[float, FloatArray, FloatArray, int]:
    """Branch and bound over ``boxes``: batches of the ``ranked`` boxes (``first_alone``: the
    first box alone, its value starting the pruning) valued by ``values`` where their
    ``bound`` exceeds the best so far, from ``start`` (objective, point, alpha_first), until a
    batch after the first has no box left (:meth:`LatticeBoxes.ranked` puts at most the first
    box out of order: the later bounds fall). The best (objective, point, alpha_first) and the
    points valued."""
    best, best_point, best_alpha = start
    per_batch = max(1, POINTS_PER_BATCH // int(np.prod(BOX)))
    starts = [0, *range(1, len(ranked), per_batch)] if first_alone else list(
        range(0, len(ranked), per_batch))
    valued = 0
    for begin, end in zip(starts, [*starts[1:], len(ranked)], strict=True):
        batch = ranked[begin:end]
        batch = batch[bound[batch] > best]
        if not len(batch):
            if begin > 0:
                break                                   # no later box can do better
            continue
        points = boxes.points(batch)
        total, alpha = values(points)
        valued += len(points)
        top = int(np.argmax(total))
        if total[top] > best:
            best, best_point, best_alpha = float(total[top]), points[top], alpha[top]
    return best, best_point, best_alpha, valued


def start_configuration(scenario: Scenario) -> tuple[float, FloatArray, FloatArray]:
    """Objective 0 at the UAV's start and start shares: what a step's search returns where
    no point does better."""
    return (0.0, np.array(scenario.uav.start_m, dtype=np.float64),
            np.full(scenario.num_clusters, scenario.uav.start_alpha))


def step_oracle(env: NetworkBatch, layout: int, users_m: FloatArray,
                boxes: LatticeBoxes | None, snr_scale: float,
                previous_m: FloatArray | None = None
                ) -> tuple[float, FloatArray, FloatArray, int]:
    """The oracle at one step (module doc): objective, UAV position (3,), alpha_first (K,) and
    the lattice points valued, for the users at ``users_m`` (N, 2) of environment ``layout``
    (its city and its clusters now); ``boxes`` None searches every point."""
    scenario = env.scenario
    start = start_configuration(scenario)
    xs, ys, hs, alphas = lattice(scenario)

    def values(points: FloatArray) -> tuple[FloatArray, FloatArray]:
        return point_values(env, layout, points, users_m, alphas, snr_scale)

    if boxes is not None:
        bound = _bounds(env, layout, boxes, users_m, either_share(alphas), snr_scale)
        return best_in_boxes(boxes, bound, boxes.ranked(bound, previous_m), values, start)
    points = np.stack(np.meshgrid(xs, ys, hs, indexing="ij"), axis=-1).reshape(-1, 3)
    total, alpha = values(points)
    top = int(np.argmax(total))
    if total[top] > start[0]:
        return float(total[top]), points[top], alpha[top], len(points)
    return (*start, len(points))


StepSearch = Callable[[NetworkBatch, int, FloatArray, "LatticeBoxes | None", float,
                       "FloatArray | None"], tuple[float, FloatArray, FloatArray, int]]
"""One step's search: (env, layout, users_m, boxes, snr_scale, previous_m) to (objective,
UAV position, alpha_first, points valued), as :func:`step_oracle`."""


def per_step_search(scenario: Scenario, users_m: FloatArray, steps: int, seed: int,
                    search: StepSearch, on_step: Callable[[int], None] | None = None
                    ) -> GenieResult:
    """``search`` at every step of ``steps`` of the layouts ``users_m`` (L, N, 2), the users
    moving as under a policy with the same ``seed`` (the same draws; the environment has
    just held the start configuration for the step when ``search`` is called), from the
    previous step's optimum; ``on_step`` hears the steps done."""
    num_layouts = len(users_m)
    env = NetworkBatch(scenario, num_envs=num_layouts, seed=seed, users_m=users_m)
    env.reset()
    radio = scenario.radio
    snr_scale = radio.tx_power_w * radio.antenna_gain / radio.noise_w
    boxes = LatticeBoxes(lattice(scenario)[:3]) if declares_monotone_gains(env.channel) else None
    k = scenario.num_clusters
    objective = np.zeros((steps, num_layouts))
    uav_m = np.zeros((steps, num_layouts, 3))
    alpha = np.zeros((steps, num_layouts, k))
    positions = np.zeros((steps, *users_m.shape))
    valued = np.zeros((steps, num_layouts), dtype=np.int64)
    start = np.broadcast_to(np.array(scenario.uav.start_m), (num_layouts, 3))
    shares = np.full((num_layouts, k), scenario.uav.start_alpha)
    for step in range(steps):
        env.hold_step(start, shares)            # the users move; the clusters are the step's
        positions[step] = env.users_m
        for layout in range(num_layouts):
            found = search(env, layout, positions[step, layout], boxes, snr_scale,
                           uav_m[step - 1, layout] if step else None)
            objective[step, layout], uav_m[step, layout], alpha[step, layout] = found[:3]
            valued[step, layout] = found[3]
        if on_step is not None:
            on_step(step + 1)
    return GenieResult(objective, uav_m, alpha, positions, valued)


def per_step_oracle(scenario: Scenario, users_m: FloatArray, steps: int, seed: int = 0,
                    on_step: Callable[[int], None] | None = None) -> GenieResult:
    """The per-step oracle (module doc) over ``steps`` steps of the layouts ``users_m``
    (L, N, 2), the users moving as under a policy with the same ``seed`` (the same draws);
    ``on_step`` hears the steps done."""
    return per_step_search(scenario, users_m, steps, seed, step_oracle, on_step)
