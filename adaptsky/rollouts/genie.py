"""The per-step oracle for users that move (docs/model.md §6): at every step, the best
objective over the reachable lattice at that step's user positions, clustered as the policy's
environment clusters them then -- a genie that may jump from one lattice point to any other
between steps, and so an upper bound on any policy of one UAV.

Every step is the oracle's exhaustive search (:func:`~adaptsky.rollouts.oracle.point_values` at
every lattice point), made fast by the kernel's branch and bound
(:func:`~adaptsky.rollouts.search.branch_and_bound`) where the channel model declares
``Supports(monotone_gains=True)`` (the built-in models: their gains fall with the distance and
the NLoS gain lies below the LoS gain). The lattice is cut into boxes
(:class:`~adaptsky.rollouts.search.LatticeBoxes`); a user's gain anywhere in a box is then at
most the LoS gain at the box's nearest point to that user, and a cluster's best value rises with
its strong user's gain and with its weak user's (at any share: the strong user's SINR rises with
its own gain, the weak user's with its own; and the larger of two gains bounds the strong one,
the smaller the weak). So a box's value is at most the sum over clusters of the best value at
those gains over every share either user can hold (the grid and its complement), with R_min's
feasibility relaxed the same way. Boxes are valued exactly from the largest bound down (the box
of the previous step's optimum first, whose value starts the search), until a bound falls to the
best value found: the objective is the exhaustive search's, exactly (among equal optima the
first found is kept). Other channel models (the default, no such declaration) search every point
at every step.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from adaptsky.channels.contract import declares_monotone_gains
from adaptsky.rollouts.oracle import point_values
from adaptsky.rollouts.search import (
    Best,
    LatticeBoxes,
    best_in_chunks,
    best_shares_on_grid,
    bound_gains,
    branch_and_bound,
    each_step,
    either_share,
    every_point,
    grid_points,
    lattice,
    snr_scale,
    walking_env,
)
from adaptsky.scenario.models import Scenario
from adaptsky.sim.network import NetworkBatch

FloatArray = NDArray[np.float64]

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


def box_bounds(env: NetworkBatch, layout: int, boxes: LatticeBoxes, users_m: FloatArray,
               shares: FloatArray, snr: float) -> FloatArray:
    """Every box's upper bound on the objective (M,) (module doc); -inf where no point of it
    can meet R_min."""
    gain = bound_gains(env, boxes.nearest(users_m), users_m)
    first, second = gain[:, env.first_user[layout]], gain[:, env.second_user[layout]]
    _, rate = best_shares_on_grid(np.maximum(first, second), np.minimum(first, second),
                                  shares, env.scenario, snr)
    return rate.sum(axis=1)


def start_configuration(scenario: Scenario) -> Best:
    """Objective 0 at the UAV's start and start shares: what a step's search returns where
    no point does better."""
    return Best(0.0, np.array(scenario.uav.start_m, dtype=np.float64),
                np.full(scenario.num_clusters, scenario.uav.start_alpha))


def step_oracle(env: NetworkBatch, layout: int, users_m: FloatArray,
                boxes: LatticeBoxes | None, snr: float,
                previous_m: FloatArray | None = None
                ) -> tuple[float, FloatArray, FloatArray, int]:
    """The oracle at one step (module doc): objective, UAV position (3,), alpha_first (K,) and
    the lattice points valued, for the users at ``users_m`` (N, 2) of environment ``layout``
    (its city and its clusters now); ``boxes`` None searches every point."""
    scenario = env.scenario
    start = start_configuration(scenario)
    xs, ys, hs, alphas = lattice(scenario)

    def values(points: FloatArray) -> tuple[FloatArray, FloatArray]:
        return point_values(env, layout, points, users_m, alphas, snr)

    if boxes is not None:
        bound = box_bounds(env, layout, boxes, users_m, either_share(alphas), snr)
        found, valued = branch_and_bound(bound, boxes.ranked(bound, previous_m), boxes.points,
                                         every_point(values), start)
        return (*found, valued)
    points = grid_points(xs, ys, hs)
    return (*best_in_chunks([(points, 1.0)], values, start), len(points))


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
    env = walking_env(scenario, users_m, seed)
    snr = snr_scale(scenario)
    boxes = LatticeBoxes(lattice(scenario)[:3]) if declares_monotone_gains(env.channel) else None
    k = scenario.num_clusters
    objective = np.zeros((steps, num_layouts))
    uav_m = np.zeros((steps, num_layouts, 3))
    alpha = np.zeros((steps, num_layouts, k))
    valued = np.zeros((steps, num_layouts), dtype=np.int64)
    start = np.broadcast_to(np.array(scenario.uav.start_m), (num_layouts, 3))
    shares = np.full((num_layouts, k), scenario.uav.start_alpha)

    def search_layout(step: int, layout: int, step_users_m: FloatArray) -> None:
        found = search(env, layout, step_users_m, boxes, snr,
                       uav_m[step - 1, layout] if step else None)
        objective[step, layout], uav_m[step, layout], alpha[step, layout] = found[:3]
        valued[step, layout] = found[3]

    positions = each_step(env, steps, lambda: (start, shares), search_layout, on_step)
    return GenieResult(objective, uav_m, alpha, positions, valued)


def per_step_oracle(scenario: Scenario, users_m: FloatArray, steps: int, seed: int = 0,
                    on_step: Callable[[int], None] | None = None) -> GenieResult:
    """The per-step oracle (module doc) over ``steps`` steps of the layouts ``users_m``
    (L, N, 2), the users moving as under a policy with the same ``seed`` (the same draws);
    ``on_step`` hears the steps done."""
    return per_step_search(scenario, users_m, steps, seed, step_oracle, on_step)
