"""The oracle ceiling (our addition, docs/model.md §6): the best per-step objective over the
reachable lattice, for ``los = "always"`` or ``"expected"`` (deterministic gains).

Objective: the constrained sum rate (sum of rates if every user meets R_min, else 0).
Lattice: x, y = start + k delta inside the area, h = start + k delta_h in [h_min, h_max],
alpha of each cluster's first user = start_alpha + k delta_alpha in [delta_alpha,
1 - delta_alpha] -- every point the UAV can reach.

Structure used (exact, no search over alpha): clusters have their own power and bandwidth, so
the objective is a sum over clusters. In a cluster with strong-user SNR a = s g_s and weak-user
SNR b = s g_w (a >= b, s = P_T G / sigma^2), the sum rate as a function of the strong share x is

    f(x) = W [log2(1 + x a) + log2(1 + b) - log2(1 + x b)],
    f'(x) = W (a - b) / ((1 + x a) (1 + x b) ln 2) >= 0,

so it is largest at the largest x the weak user's constraint allows,
x <= ((1 + b) / 2^m - 1) / b (m = min_se), taken on the alpha grid; the strong user's
constraint x >= (2^m - 1) / a then decides feasibility. Positions are searched exhaustively,
vectorised over the whole lattice in chunks of heights. ``tests/unit/rollouts/test_baselines.py``
checks the result against brute force over positions and every alpha combination on a reduced
lattice.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from adaptsky.errors import AdaptskyError
from adaptsky.rollouts.search import (
    Best,
    best_in_chunks,
    best_shares,
    grid_points,
    lattice,
    lattice_chunks,
    outside_buildings,
    point_geometry,
    snr_scale,
)
from adaptsky.scenario.models import Scenario
from adaptsky.sim.links import build_channel, deterministic_gain, fading_active
from adaptsky.sim.network import NetworkBatch
from adaptsky.sim.state import users_move

FloatArray = NDArray[np.float64]
__all__ = ["OracleResult", "has_oracle", "lattice", "oracle", "point_values",
           "require_deterministic_gains", "require_static_users"]


@dataclass(frozen=True)
class OracleResult:
    """Best lattice point of each layout: objective (L,), UAV (L, 3), alpha_first (L, K),
    rates (L, N); objective 0 and the start point where no point meets R_min."""

    objective_bps: FloatArray
    uav_m: FloatArray
    alpha_first: FloatArray
    rate_bps: FloatArray


def point_values(env: NetworkBatch, layout: int, points_m: FloatArray, users_m: FloatArray,
                 alphas: FloatArray, snr: float) -> tuple[FloatArray, FloatArray]:
    """The objective (P,) at every lattice point ``points_m`` (P, 3) for the users at
    ``users_m`` (N, 2), clustered as environment ``layout`` of ``env`` clusters them now, with
    each cluster's best grid share (P, K) (:func:`~adaptsky.rollouts.search.best_shares`);
    -inf where no share meets R_min and inside a building."""
    # the links' arrays held until the shares are found: freed before, they cost 10% more
    # time (the allocator hands their memory back and maps it again)
    geometry = point_geometry(env, layout, points_m, users_m)
    gain = deterministic_gain(env.channel, env.scenario.channel.los, geometry)
    alpha, rate = best_shares(gain[:, env.first_user[layout]], gain[:, env.second_user[layout]],
                              alphas, env.scenario, snr)
    return outside_buildings(env, layout, points_m, rate.sum(axis=1)), alpha


def has_oracle(scenario: Scenario) -> bool:
    """Whether the oracle applies: deterministic gains (LoS not drawn at random, no fading,
    a plugin's or the built-in one of docs/model.md §11) and users that stand (a search at
    their home positions bounds nothing once they walk)."""
    return _random_gains(scenario) is None and not users_move(scenario)


def _random_gains(scenario: Scenario) -> str | None:
    """What makes the scenario's gains random, or None."""
    if scenario.channel.los == "sampled":
        return "channel.los is 'sampled'"
    if scenario.channel.fading.model != "none":
        return f"channel.fading.model is '{scenario.channel.fading.model}'"
    if fading_active(build_channel(scenario)):
        return f"channel model '{scenario.channel.model}' draws per-step fading"
    return None


def require_deterministic_gains(scenario: Scenario, method: str = "the oracle") -> None:
    """Refuse a scenario whose gains are drawn at random: the oracle (or another search over
    the lattice, ``method``) needs fixed gains."""
    reason = _random_gains(scenario)
    if reason is not None:
        raise AdaptskyError(f"scenario '{scenario.name}': {reason}; {method} needs "
                            "deterministic gains: los = 'always' or 'expected', without "
                            "fading")


def require_static_users(scenario: Scenario, method: str = "the oracle") -> None:
    """Refuse a scenario whose users walk: the oracle (or another search over the lattice,
    ``method``) finds one configuration for the users' home positions, which neither bounds
    nor references a policy once the users move."""
    if users_move(scenario):
        model = scenario.users.mobility.model
        how, still = ((f"users.speed_m_per_step is {scenario.users.speed_m_per_step:g} m",
                       "users.speed_m_per_step=0") if model == "static" else
                      (f"users.mobility.model is '{model}'", "'users.mobility={model=\"static\"}'"))
        raise AdaptskyError(
            f"scenario '{scenario.name}': {how} (the users move); {method} searches one "
            "configuration for the users' home positions and cannot follow moving users yet; "
            f"compare with soa or random, or evaluate with --set {still}")


def oracle(scenario: Scenario, users_m: FloatArray,
           on_layout: Callable[[int], None] | None = None,
           on_search: Callable[[float, str], None] | None = None) -> OracleResult:
    """The oracle for every layout in ``users_m`` (L, N, 2), paired as the environment pairs
    them; ``on_layout`` hears the number of layouts searched after each, ``on_search`` the
    layouts searched (a fraction) and how much of the lattice after each chunk that leaves
    some of a layout's lattice to search."""
    require_deterministic_gains(scenario)
    num_layouts = len(users_m)
    env = NetworkBatch(scenario, num_envs=num_layouts, users_m=users_m)
    snr = snr_scale(scenario)                               # P_T G / sigma^2
    xs, ys, hs, alphas = lattice(scenario)
    grid = grid_points(xs, ys, hs)
    objective = np.zeros(num_layouts)
    best_uav = np.broadcast_to(np.array(scenario.uav.start_m), (num_layouts, 3)).copy()
    best_alpha = np.full((num_layouts, scenario.num_clusters), scenario.uav.start_alpha)
    for layout in range(num_layouts):
        def values(points: FloatArray, layout: int = layout) -> tuple[FloatArray, FloatArray]:
            return point_values(env, layout, points, users_m[layout], alphas, snr)

        def heard(searched: float, layout: int = layout) -> None:
            if on_search is not None and searched < 1:
                on_search(layout + searched, f"{searched:.0%} of the lattice")

        found = best_in_chunks(lattice_chunks(grid), values,
                               Best(0.0, best_uav[layout], best_alpha[layout]), heard)
        objective[layout], best_uav[layout], best_alpha[layout] = found
        if on_layout is not None:
            on_layout(layout + 1)
    state = env.evaluate_at(best_uav, best_alpha)
    return OracleResult(objective, best_uav, best_alpha, state.rate_bps)
