"""Best response at every step, for several UAVs and users that move (docs/model.md §9): a
reference, not an optimum, as best response is. At every step it starts from the previous
step's configuration (SoA per UAV at the first) and runs best-response rounds on that step's
user positions and clusters, until a round gains less than 1e-9 relative or ``rounds`` rounds.

Each UAV's response is the exhaustive search of best response
(:meth:`~adaptsky.rollouts.several_uavs.BestResponseSearch.totals` at every lattice point), made
fast by the kernel's branch and bound (:func:`~adaptsky.rollouts.search.branch_and_bound`) over
boxes of lattice points (:class:`~adaptsky.rollouts.search.LatticeBoxes`) where the channel
model declares ``Supports(monotone_gains=True)`` (the built-in models: the gains fall with the
distance, the NLoS gain below the LoS gain). In a box of UAV u's positions: each of u's users'
gain is at most the LoS gain at the box's nearest point (its interference, from the others, is
fixed), so its effective gain c = P g / (I + sigma^2) is bounded, and each of u's clusters is
worth at most its best value over every share either user may hold at those gains (R_min relaxed
alike); every other user hears at least u's gain at the box's farthest point (the LoS gain there
for LoS always, else the NLoS gain, the smaller), so its effective gain is bounded, and each
other cluster, at its fixed share, is worth at most the larger of its sum rate in either SIC
order at those bounds. A box is valued exactly only where that bound exceeds the value the
response must beat (the current configuration's): the response is the exhaustive search's (among
equal values the first found). Other channel models (the default, no such declaration) search
every point.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from adaptsky.channels.contract import declares_monotone_gains
from adaptsky.rollouts.search import (
    Best,
    LatticeBoxes,
    best_shares_on_grid,
    bound_gains,
    branch_and_bound,
    each_step,
    either_share,
    every_point,
    response_rounds,
    walking_env,
)
from adaptsky.rollouts.several_uavs import DEFAULT_ROUNDS, BestResponseSearch
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


class StepResponseSearch(BestResponseSearch):
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
        most = bound_gains(self.env, boxes.nearest(self.users_m), self.users_m)   # (M, N)
        least = bound_gains(self.env, boxes.farthest(self.users_m), self.users_m,
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
                _, rate = best_shares_on_grid(np.maximum(c1, c2), np.minimum(c1, c2),
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
                        beat: float) -> tuple[Best, int]:
        """UAV u's best lattice point and shares with the others fixed (as
        :meth:`respond`), searching only boxes whose bound exceeds ``beat`` and the best
        found so far: (objective, point, shares) and the points valued; -inf where nothing
        beats ``beat``."""
        if not self.bounded:
            return (self.respond(u, uav_m, alpha_first),
                    len(self.planes[u]) * len(self.heights[u]))
        fixed_gain = self.gains(uav_m)
        bound = self.bounds(u, fixed_gain, alpha_first)

        def points_of(boxes: NDArray[np.intp]) -> FloatArray:
            return np.concatenate([self._box_points(u, box, uav_m) for box in boxes])

        def values(points: FloatArray) -> tuple[FloatArray, FloatArray]:
            return self.totals(u, points, fixed_gain, alpha_first)

        return branch_and_bound(bound, self._boxes[u].ranked(bound), points_of,
                                every_point(values), Best(-np.inf, uav_m[u], alpha_first[u]),
                                beat=beat)


def per_step_response(scenario: Scenario, users_m: FloatArray, steps: int, seed: int = 0,
                      rounds: int = DEFAULT_ROUNDS,
                      on_step: Callable[[int], None] | None = None) -> StepResponseResult:
    """Best response at every step (module doc) over ``steps`` steps of the layouts
    ``users_m`` (L, N, 2), the users moving as under a policy with the same ``seed``."""
    started = time.process_time()
    env = walking_env(scenario, users_m, seed)
    uav_now, alpha_now = soa_per_uav_configuration(env)
    uav_now, alpha_now = uav_now.copy(), alpha_now.copy()
    shape = (steps, len(users_m))
    objective, rounds_run = np.zeros(shape), np.zeros(shape, dtype=np.int64)
    valued = np.zeros(shape, dtype=np.int64)
    uav_m = np.zeros((*shape, *uav_now.shape[1:]))
    alpha_first = np.zeros((*shape, *alpha_now.shape[1:]))

    def search_layout(step: int, layout: int, step_users_m: FloatArray) -> None:
        search = StepResponseSearch(env, layout, step_users_m)
        where, shares = uav_now[layout], alpha_now[layout]

        def respond(round_index: int, u: int, value: float) -> Best:
            found, count = search.respond_bounded(u, where, shares, value)
            valued[step, layout] += count
            return found

        value, rounds_run[step, layout], _ = response_rounds(
            respond, where, shares, search.objective(where, shares), rounds)
        objective[step, layout] = max(value, 0.0)
        uav_m[step, layout], alpha_first[step, layout] = where, shares

    positions = each_step(env, steps, lambda: (uav_now, alpha_now), search_layout, on_step)
    seconds = (time.process_time() - started) / max(1, steps)
    return StepResponseResult(objective, uav_m, alpha_first, positions, rounds_run, valued,
                              seconds)
