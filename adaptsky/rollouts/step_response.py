"""Best response at every step, for several UAVs and users that move (docs/model.md §9): a
reference, not an optimum, as best response is. At every step it starts from the previous
step's configuration (SoA per UAV at the first) and runs best-response rounds on that step's
user positions and clusters, until a round gains less than 1e-9 relative or ``rounds`` rounds.

Each UAV's response is the exhaustive search of best response
(:meth:`~adaptsky.rollouts.several_uavs.BestResponseSearch.totals` at every lattice point),
made fast by branch and bound over boxes of ``BOX`` lattice points where the channel model
declares ``Supports(monotone_gains=True)`` (the built-in models: the gains fall with the
distance, the NLoS gain below the LoS gain). In a box of UAV u's positions: each of u's users'
gain is at most the LoS gain at the box's nearest point (its interference, from the others,
is fixed), so its effective gain c = P g / (I + sigma^2)
is bounded, and each of u's clusters is worth at most its best value over every share either
user may hold at those gains (R_min relaxed alike); every other user hears at least u's gain
at the box's farthest point (the LoS gain there for LoS always, else the NLoS gain, the
smaller), so its effective gain is bounded, and each other cluster, at its fixed share, is
worth at most the larger of its sum rate in either SIC order at those bounds. A box is
valued exactly only where that bound exceeds the value the response must beat (the current
configuration's): the response is the exhaustive search's (among equal values the first
found). Other channel models (the default, no such declaration) search every point.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from adaptsky.channels.contract import declares_monotone_gains
from adaptsky.rollouts.genie import (
    BOX,
    POINTS_PER_BATCH,
    LatticeBoxes,
    either_share,
    gains_at,
)
from adaptsky.rollouts.oracle import best_alpha_on_grid
from adaptsky.rollouts.several_uavs import (
    DEFAULT_ROUNDS,
    RELATIVE_TOLERANCE,
    BestResponseSearch,
)
from adaptsky.rollouts.soa import soa_per_uav_configuration
from adaptsky.scenario.models import Scenario
from adaptsky.sim import noma
from adaptsky.sim.network import NetworkBatch

FloatArray = NDArray[np.float64]

STEP_RESPONSE_NOTE = ("best response at every step's user positions, from the previous "
                      "step's configuration: a reference, not an optimum")
"""What best response of several UAVs is for users that move (its label)."""


@dataclass(frozen=True)
class StepResponseResult:
    """Per step and layout: objective (T, L), every UAV (T, L, U, 3), alpha_first
    (T, L, U, K), users (T, L, N, 2), rounds (T, L), lattice points valued (T, L), and the
    process time per step."""

    objective_bps: FloatArray
    uav_m: FloatArray
    alpha_first: FloatArray
    users_m: FloatArray
    rounds: NDArray[np.int64]
    points_valued: NDArray[np.int64]
    seconds_per_step: float


class _StepSearch(BestResponseSearch):
    """Best responses of one layout at one step: the env's clusters now, the users at
    ``users_m`` (N, 2)."""

    def __init__(self, env: NetworkBatch, layout: int, users_m: FloatArray) -> None:
        super().__init__(env, layout, oma=False)
        self.users_m = users_m
        self.bounded = declares_monotone_gains(env.channel)
        self.shares = either_share(self.alphas)
        self._boxes = [LatticeBoxes([np.unique(plane[:, 0]), np.unique(plane[:, 1]), heights])
                       for plane, heights in zip(self.planes, self.heights, strict=True)]

    def _box_points(self, u: int, box: int, uav_m: FloatArray) -> FloatArray:
        """The lattice points of UAV u's ``box`` that keep the separation from the others."""
        points = self._boxes[u].points(np.array([box]))
        apart = np.ones(len(points), dtype=bool)
        for v in range(len(uav_m)):
            if v != u:
                apart &= np.hypot(*(points[:, :2] - uav_m[v, :2]).T) >= self.min_separation_m
        return points[apart]

    def bounds(self, u: int, fixed_gain: FloatArray, alpha_first: FloatArray) -> FloatArray:
        """Every box of UAV u's lattice: an upper bound on the objective there (module doc)."""
        boxes = self._boxes[u]
        most = gains_at(self.env, boxes.nearest(self.users_m), self.users_m)     # (M, N)
        least = gains_at(self.env, boxes.farthest(self.users_m), self.users_m,
                         nlos=self.scenario.channel.los != "always")
        own = self.serving == u
        gain = np.broadcast_to(fixed_gain, (len(boxes.low), *fixed_gain.shape)).copy()
        gain[:, u] = np.where(own, most, least)
        serving_gain, interference = self._serving(gain)             # (M, N) each
        effective = self.power * serving_gain / (interference + self.noise_w)
        bound = np.zeros(len(boxes.low))
        first, second = self.first, self.second
        for v in range(len(fixed_gain)):
            valid = first[v] >= 0
            c1, c2 = effective[:, first[v][valid]], effective[:, second[v][valid]]
            if v == u:
                _, rate = best_alpha_on_grid(np.maximum(c1, c2), np.minimum(c1, c2),
                                             self.shares, self.scenario, 1.0)
                bound += rate.sum(axis=1)
                continue
            alpha = alpha_first[v][valid]
            strong, weak = np.maximum(c1, c2), np.minimum(c1, c2)
            sums = []
            for share in (alpha, 1.0 - alpha):    # the strong user holds either share
                s_strong, s_weak = noma.cluster_sinr(share, strong, weak, 1.0,
                                                     self.scenario.radio.sic_residual)
                sums.append(noma.rate_bps(s_strong, self.bandwidth_hz)
                            + noma.rate_bps(s_weak, self.bandwidth_hz))
            bound += np.maximum(*sums).sum(axis=1)
        return bound

    def respond_bounded(self, u: int, uav_m: FloatArray, alpha_first: FloatArray,
                        beat: float) -> tuple[float, FloatArray, FloatArray, int]:
        """UAV u's best lattice point and shares with the others fixed (as
        :meth:`respond`), searching only boxes whose bound exceeds ``beat`` and the best
        found so far: (objective, point, shares, points valued); -inf where nothing beats
        ``beat``."""
        fixed_gain = self.gains(uav_m)
        if not self.bounded:
            found = self.respond(u, uav_m, alpha_first)
            return (*found, len(self.planes[u]) * len(self.heights[u]))
        bound = self.bounds(u, fixed_gain, alpha_first)
        ranked = np.argsort(-bound, kind="stable")
        best: tuple[float, FloatArray, FloatArray] = (-np.inf, uav_m[u], alpha_first[u])
        valued = 0
        per_batch = max(1, POINTS_PER_BATCH // int(np.prod(BOX)))
        for start in range(0, len(ranked), per_batch):
            batch = ranked[start:start + per_batch]
            batch = batch[bound[batch] > max(beat, best[0])]
            if not len(batch):
                break          # every later box has a lower bound
            points = np.concatenate([self._box_points(u, box, uav_m) for box in batch])
            if not len(points):
                continue
            total, shares = self.totals(u, points, fixed_gain, alpha_first)
            valued += len(points)
            index = int(np.argmax(total))
            if total[index] > best[0]:
                best = (float(total[index]), points[index], shares[index])
        return (*best, valued)


def per_step_response(scenario: Scenario, users_m: FloatArray, steps: int, seed: int = 0,
                      rounds: int = DEFAULT_ROUNDS,
                      on_step: Callable[[int], None] | None = None) -> StepResponseResult:
    """Best response at every step (module doc) over ``steps`` steps of the layouts
    ``users_m`` (L, N, 2), the users moving as under a policy with the same ``seed``."""
    started = time.process_time()
    num_layouts = len(users_m)
    env = NetworkBatch(scenario, num_envs=num_layouts, seed=seed, users_m=users_m)
    env.reset()
    uav_now, alpha_now = soa_per_uav_configuration(env)
    uav_now, alpha_now = uav_now.copy(), alpha_now.copy()
    shape = (steps, num_layouts)
    objective, rounds_run = np.zeros(shape), np.zeros(shape, dtype=np.int64)
    valued = np.zeros(shape, dtype=np.int64)
    uav_m = np.zeros((*shape, *uav_now.shape[1:]))
    alpha_first = np.zeros((*shape, *alpha_now.shape[1:]))
    positions = np.zeros((steps, *users_m.shape))
    for step in range(steps):
        env.hold_step(uav_now, alpha_now)      # the users move; the clusters are the step's
        positions[step] = env.users_m
        for layout in range(num_layouts):
            search = _StepSearch(env, layout, positions[step, layout])
            where, shares = uav_now[layout], alpha_now[layout]
            value = search.objective(where, shares)
            for round_index in range(rounds):
                before = value
                for u in range(env.num_uavs):
                    found, point, alpha, count = search.respond_bounded(u, where, shares,
                                                                        value)
                    valued[step, layout] += count
                    if found > value:
                        value = found
                        where[u], shares[u] = point, alpha
                rounds_run[step, layout] = round_index + 1
                if value - before <= RELATIVE_TOLERANCE * abs(before):
                    break
            objective[step, layout] = max(value, 0.0)
        uav_m[step], alpha_first[step] = uav_now, alpha_now
        if on_step is not None:
            on_step(step + 1)
    seconds = (time.process_time() - started) / max(1, steps)
    return StepResponseResult(objective, uav_m, alpha_first, positions, rounds_run, valued,
                              seconds)

