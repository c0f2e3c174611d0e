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
from adaptsky.scenario.models import Scenario
from adaptsky.sim import noma
from adaptsky.sim.blockage import inside_buildings
from adaptsky.sim.lattice import axis_lattice, share_lattice
from adaptsky.sim.links import build_channel, deterministic_gain, fading_active
from adaptsky.sim.network import NetworkBatch
from adaptsky.sim.state import users_move

FloatArray = NDArray[np.float64]
POINTS_PER_CHUNK = 200_000


@dataclass(frozen=True)
class OracleResult:
    """Best lattice point of each layout: objective (L,), UAV (L, 3), alpha_first (L, K),
    rates (L, N); objective 0 and the start point where no point meets R_min."""

    objective_bps: FloatArray
    uav_m: FloatArray
    alpha_first: FloatArray
    rate_bps: FloatArray


def lattice(scenario: Scenario) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """The reachable x, y, h values and the alpha_first grid."""
    uav, half_m = scenario.uav, scenario.area.side_m / 2
    xs = axis_lattice(uav.start_m[0], uav.step_m[0], -half_m, half_m)
    ys = axis_lattice(uav.start_m[1], uav.step_m[1], -half_m, half_m)
    hs = axis_lattice(uav.start_m[2], uav.step_m[2], uav.min_height_m, uav.max_height_m)
    alphas = share_lattice(scenario)
    return xs, ys, hs, alphas


def best_alpha_first(gain_first: FloatArray, gain_second: FloatArray, alphas: FloatArray,
                     scenario: Scenario, snr_scale: float) -> tuple[FloatArray, FloatArray]:
    """Per point and cluster: the grid alpha_first maximising the cluster's sum rate under
    R_min, and that sum rate (-inf where no grid alpha meets R_min): the closed form of the
    module doc under perfect SIC, every grid alpha under imperfect SIC (docs/model.md §13),
    where the sum rate need not rise with the strong user's share."""
    if scenario.radio.sic_residual:
        return best_alpha_on_grid(gain_first, gain_second, alphas, scenario, snr_scale)
    first_strong = noma.is_strong(gain_first, gain_second, gain_first, gain_second, True)
    weak_snr = snr_scale * np.minimum(gain_first, gain_second)
    threshold = 2.0 ** scenario.reward.min_se
    strong_share_max = ((1 + weak_snr) / threshold - 1) / weak_snr
    # largest strong share on the grid: alpha_first itself, or 1 - alpha_first
    index_first = np.searchsorted(alphas, strong_share_max * (1 + 1e-12), side="right") - 1
    index_second = np.searchsorted(alphas, (1 - strong_share_max) * (1 - 1e-12), side="left")
    index = np.where(first_strong, index_first, index_second)
    best_rate = np.full(gain_first.shape, -np.inf)
    best_alpha = np.full(gain_first.shape, np.nan)
    # the closed form's neighbour guards against rounding at the constraint's edge
    for shift in (0, -1, 1):
        candidate = np.where(first_strong, index + shift, index - shift)
        valid = (candidate >= 0) & (candidate < len(alphas))
        alpha = alphas[np.clip(candidate, 0, len(alphas) - 1)]
        sinr_first, sinr_second = noma.cluster_sinr(alpha, gain_first, gain_second, snr_scale)
        rate_first = noma.rate_bps(sinr_first, scenario.radio.bandwidth_hz)
        rate_second = noma.rate_bps(sinr_second, scenario.radio.bandwidth_hz)
        feasible = valid & (rate_first >= scenario.min_rate_bps) & (
            rate_second >= scenario.min_rate_bps)
        total = np.where(feasible, rate_first + rate_second, -np.inf)
        better = total > best_rate
        best_rate = np.where(better, total, best_rate)
        best_alpha = np.where(better, alpha, best_alpha)
    return best_alpha, best_rate


def best_alpha_on_grid(gain_first: FloatArray, gain_second: FloatArray, alphas: FloatArray,
                       scenario: Scenario, snr_scale: float) -> tuple[FloatArray, FloatArray]:
    """:func:`best_alpha_first` by trying every grid alpha of every cluster (exact for any
    SIC residual; ties to the smallest alpha)."""
    best_rate = np.full(gain_first.shape, -np.inf)
    best_alpha = np.full(gain_first.shape, np.nan)
    residual, bandwidth_hz = scenario.radio.sic_residual, scenario.radio.bandwidth_hz
    for alpha in alphas:
        sinr_first, sinr_second = noma.cluster_sinr(alpha, gain_first, gain_second, snr_scale,
                                                    residual)
        rate_first = noma.rate_bps(sinr_first, bandwidth_hz)
        rate_second = noma.rate_bps(sinr_second, bandwidth_hz)
        feasible = (rate_first >= scenario.min_rate_bps) & (rate_second >= scenario.min_rate_bps)
        total = np.where(feasible, rate_first + rate_second, -np.inf)
        better = total > best_rate
        best_rate = np.where(better, total, best_rate)
        best_alpha = np.where(better, alpha, best_alpha)
    return best_alpha, best_rate


def point_values(env: NetworkBatch, layout: int, points_m: FloatArray, users_m: FloatArray,
                 alphas: FloatArray, snr_scale: float) -> tuple[FloatArray, FloatArray]:
    """The objective (P,) at every lattice point ``points_m`` (P, 3) for the users at
    ``users_m`` (N, 2), clustered as environment ``layout`` of ``env`` clusters them now, with
    each cluster's best grid share (P, K); -inf where no share meets R_min and inside a
    building (a UAV never stands there)."""
    scenario = env.scenario
    users = np.broadcast_to(users_m, (len(points_m), *users_m.shape))
    geometry = env.geometry(points_m, users, layout=layout)
    gain = deterministic_gain(env.channel, scenario.channel.los, geometry)
    gain_first = gain[:, env.first_user[layout]]
    gain_second = gain[:, env.second_user[layout]]
    alpha, rate = best_alpha_first(gain_first, gain_second, alphas, scenario, snr_scale)
    total = rate.sum(axis=1)
    if env.city is not None:     # a UAV never stands inside a building
        total = np.where(inside_buildings(points_m[None], env.city.environment(layout))[0],
                         -np.inf, total)
    return total, alpha


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
    radio = scenario.radio
    snr_scale = radio.tx_power_w * radio.antenna_gain / radio.noise_w   # P_T G / sigma^2
    xs, ys, hs, alphas = lattice(scenario)
    grid = np.stack(np.meshgrid(xs, ys, hs, indexing="ij"), axis=-1).reshape(-1, 3)
    k = scenario.num_clusters
    objective = np.zeros(num_layouts)
    best_uav = np.broadcast_to(np.array(scenario.uav.start_m), (num_layouts, 3)).copy()
    best_alpha = np.full((num_layouts, k), scenario.uav.start_alpha)
    for layout in range(num_layouts):
        for start in range(0, len(grid), POINTS_PER_CHUNK):
            points = grid[start:start + POINTS_PER_CHUNK]
            total, alpha = point_values(env, layout, points, users_m[layout], alphas,
                                        snr_scale)
            best = int(np.argmax(total))
            if total[best] > objective[layout]:
                objective[layout] = total[best]
                best_uav[layout] = points[best]
                best_alpha[layout] = alpha[best]
            searched = (start + len(points)) / len(grid)
            if on_search is not None and searched < 1:
                on_search(layout + searched, f"{searched:.0%} of the lattice")
        if on_layout is not None:
            on_layout(layout + 1)
    state = env.evaluate_at(best_uav, best_alpha)
    return OracleResult(objective, best_uav, best_alpha, state.rate_bps)
