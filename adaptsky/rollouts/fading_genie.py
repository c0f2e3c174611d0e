"""The per-step oracle for users that move under the built-in fading (docs/model.md §6 and
§11): at every step, the best objective over the reachable lattice at that step's user
positions and that step's fading draws (the scattered parts s_t every link drew, the same
draws as a policy's with the same seed) -- a genie that knows the fading and may jump from one
lattice point to any other between steps, and so an upper bound on any policy of one UAV.

A step's value at lattice point p is sum_k max_alpha R_k(p, alpha), the gains
g = L(p) |h_t(p)|^2 of eq. 11.1 (:class:`~adaptsky.rollouts.fading_oracle` with one step).
It is found exactly by branch and bound over the boxes of the deterministic per-step oracle
(:class:`~adaptsky.rollouts.search.LatticeBoxes`). In a box, a user's large-scale gain is at
most the LoS gain at the box's nearest point (a built-in channel: the LoS gain falls with the
distance and bounds the NLoS gain), and its |h_t|^2 = (K + 2 sqrt(K) Re s + |s|^2) / (K + 1)
is at most its largest value over the K-factors the box's elevations give (K in dB is linear
in the elevation, eq. 11.2, so the box's elevations from the lowest point at the farthest
corner to the highest at the nearest give an interval of K; the function's largest value on
it is at an end or at its one stationary point, sqrt(K) the positive root of
Re(s) u^2 - (1 - |s|^2) u - Re(s) = 0; with buildings also |s|^2, an NLoS link's). A cluster's
best value rises with either user's gain, so a box is worth at most the clusters' best over
every share either user can hold at those gains. Boxes are valued exactly from the largest
bound down (the previous step's optimum's box first) until a bound falls to the best value
found.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from adaptsky.rollouts.fading_oracle import FadingLayoutSearch, require_fading_oracle
from adaptsky.rollouts.genie import GenieResult, per_step_search, start_configuration
from adaptsky.rollouts.search import (
    LatticeBoxes,
    best_shares_on_grid,
    bound_gains,
    branch_and_bound,
    either_share,
    every_point,
    lattice,
)
from adaptsky.scenario.models import Scenario
from adaptsky.sim.fading import root_k_factor
from adaptsky.sim.network import NetworkBatch

FloatArray = NDArray[np.float64]
BOUND_SLACK = 1e-9
"""Relative margin on a box's bound, so that rounding never prunes the optimum's box."""

FADING_GENIE_NOTE = ("the best lattice point and shares at every step's user positions and "
                     "fading draws, free to jump between steps: an upper bound on any policy "
                     "of one UAV")
"""What the oracle is for users that move under the built-in fading (its label)."""


def largest_power_gain(root_k_low: FloatArray, root_k_high: FloatArray, real: FloatArray,
                       square: FloatArray) -> FloatArray:
    """The largest |h|^2 = (K + 2 sqrt(K) a + r) / (K + 1) (eq. 11.1, a = Re s, r = |s|^2)
    over sqrt(K) in [``root_k_low``, ``root_k_high``] (module doc), elementwise."""
    def value(root_k: FloatArray) -> FloatArray:
        k = np.square(root_k)
        return (k + 2 * root_k * real + square) / (k + 1)

    best = np.maximum(value(root_k_low), value(root_k_high))
    # the stationary point: a u^2 - (1 - r) u - a = 0 has roots of product -1, one positive
    with np.errstate(divide="ignore", invalid="ignore"):
        b = 1.0 - square
        root = (b + np.sign(real) * np.sqrt(np.square(b) + 4 * np.square(real))) / (2 * real)
    inside = (real != 0) & (root > root_k_low) & (root < root_k_high)
    return np.where(inside, np.maximum(best, value(np.where(inside, root, 0.0))), best)


def _elevation_deg(points_m: FloatArray, users_m: FloatArray, user_height_m: float
                   ) -> FloatArray:
    """The elevation (degrees) of each of ``points_m`` (M, N, 3) seen from its user."""
    horizontal = np.hypot(points_m[..., 0] - users_m[None, :, 0],
                          points_m[..., 1] - users_m[None, :, 1])
    return np.degrees(np.arctan2(points_m[..., 2] - user_height_m, horizontal))


def box_fading_bound(boxes: LatticeBoxes, scenario: Scenario, users_m: FloatArray,
                     scattered: FloatArray) -> FloatArray:
    """Every box's upper bound on each user's |h_t|^2 (M, N) (module doc), for the users at
    ``users_m`` (N, 2) and the step's scattered parts ``scattered`` (2, N)."""
    real, imag = scattered
    square = np.square(real) + np.square(imag)
    fading = scenario.channel.fading
    if fading.model != "rician":
        return np.broadcast_to(square, (len(boxes.low), len(square)))
    height_m = scenario.users.height_m
    low = _elevation_deg(boxes.farthest(users_m) * [1, 1, 0] + boxes.low[:, None] * [0, 0, 1],
                         users_m, height_m)
    high = _elevation_deg(boxes.nearest(users_m) * [1, 1, 0] + boxes.high[:, None] * [0, 0, 1],
                          users_m, height_m)
    k0_db, k90_db = fading.k_db
    ends = root_k_factor(low, k0_db, k90_db), root_k_factor(high, k0_db, k90_db)
    bound = largest_power_gain(np.minimum(*ends), np.maximum(*ends), real, square)
    if scenario.channel.los != "always":
        bound = np.maximum(bound, square)                  # an NLoS link is Rayleigh
    return bound


def step_fading_oracle(env: NetworkBatch, layout: int, users_m: FloatArray,
                       scattered: FloatArray, boxes: LatticeBoxes | None, snr_scale: float,
                       previous_m: FloatArray | None = None
                       ) -> tuple[float, FloatArray, FloatArray, int]:
    """The oracle at one step under the fading (module doc): objective, UAV position (3,),
    alpha_first (K,) and the lattice points valued, for the users at ``users_m`` (N, 2) of
    environment ``layout`` and the step's scattered parts ``scattered`` (2, N); ``boxes``
    None values every point."""
    scenario = env.scenario
    search = FadingLayoutSearch(env, scenario, layout, users_m, scattered[None])
    xs, ys, hs, alphas = lattice(scenario)
    if boxes is None:
        boxes = LatticeBoxes([xs, ys, hs])
        bound = np.full(len(boxes.low), np.inf)
    else:
        gain = (bound_gains(env, boxes.nearest(users_m), users_m)
                * box_fading_bound(boxes, scenario, users_m, scattered))
        first, second = gain[:, search.first], gain[:, search.second]
        _, rate = best_shares_on_grid(np.maximum(first, second), np.minimum(first, second),
                                      either_share(alphas), scenario, snr_scale)
        bound = rate.sum(axis=1) * (1 + BOUND_SLACK)

    def values(points: FloatArray) -> tuple[FloatArray, FloatArray]:
        value, alpha = search.values(search.step_gains(points), alphas)
        return search.outside(points, value), alpha

    found, valued = branch_and_bound(bound, boxes.ranked(bound, previous_m), boxes.points,
                                     every_point(values), start_configuration(scenario),
                                     first_alone=True)
    return (*found, valued)


def per_step_fading_oracle(scenario: Scenario, users_m: FloatArray, steps: int,
                           seed: int = 0, on_step: Callable[[int], None] | None = None
                           ) -> GenieResult:
    """The per-step oracle under the fading (module doc) over ``steps`` steps of the layouts
    ``users_m`` (L, N, 2), the users moving and the fading drawn as under a policy with the
    same ``seed`` (the same draws); ``on_step`` hears the steps done."""
    require_fading_oracle(scenario)

    def search(env: NetworkBatch, layout: int, step_users_m: FloatArray,
               boxes: LatticeBoxes | None, snr_scale: float, previous_m: FloatArray | None
               ) -> tuple[float, FloatArray, FloatArray, int]:
        scattered = env.step_scattered()[:, layout, 0]             # the step's draws (2, N)
        return step_fading_oracle(env, layout, step_users_m, scattered, boxes, snr_scale,
                                  previous_m)

    return per_step_search(scenario, users_m, steps, seed, search, on_step)
