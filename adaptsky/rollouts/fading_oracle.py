"""The oracle under the built-in fading (docs/model.md §11): the fixed lattice position and
fixed shares whose objective, averaged over the policy's own fading draws, is the largest --
a ceiling for static policies only (a policy that moves with the fading may pass it).

The draws are those a policy evaluated with the same seed sees (common random numbers): the
scattered parts s_t of every link, t = 1..T (:meth:`NetworkBatch.next_scattered`). At a
lattice point p a user's gain at step t is g_t = L(p) |h_t(p)|^2, L the large-scale gain (LoS
or NLoS by the buildings under geometric LoS) and |h_t|^2 of eq. 11.1, whose K-factor follows
p's elevation (eq. 11.2). The objective is the sum rate (``reward.min_se = 0``, so that the
clusters are separable: each cluster's best share is found on its own); the value of p is

    V(p) = sum_k max_alpha mean_t R_k(p, alpha, t),

R_k the cluster's two rates at step t (the SIC order by that step's gains, eq. 2; imperfect
SIC of §13 included). It is found exactly by branch and bound, with two upper bounds that
hold for any share: a cluster's NOMA sum rate is at most the strong user's single-user rate,
R_k <= W log2(1 + s max(g_1, g_2)) (the sum rises with the strong user's share, and a
residual only lowers it), so

    V(p) <= B_2(p) = sum_k mean_t W log2(1 + s max(g_1t, g_2t))
         <= B_1(p) = sum_k W log2(1 + s (mean_t g_1t + mean_t g_2t))   (Jensen).

B_1 needs only each link's mean |h|^2, linear in the means of Re s and |s|^2 over the draws,
and is computed for the whole lattice as the deterministic oracle's search is; the points are
then visited from the largest B_1 down by the kernel's branch and bound
(:func:`~adaptsky.rollouts.search.branch_and_bound`, each point its own box), B_2 and V
computed for batches of them, until B_1 falls to the best V found. No point that could be
better is left out.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from adaptsky.errors import AdaptskyError
from adaptsky.rollouts.search import (
    Best,
    best_on_grid,
    branch_and_bound,
    from_largest,
    grid_points,
    lattice,
    lattice_chunks,
    outside_buildings,
    point_geometry,
    snr_scale,
)
from adaptsky.scenario.models import Scenario
from adaptsky.sim import noma
from adaptsky.sim.fading import power_gain, root_k_factor
from adaptsky.sim.links import deterministic_gain
from adaptsky.sim.network import NetworkBatch

FloatArray = NDArray[np.float64]
POINTS_PER_BATCH = 64
"""Points whose B_2 and value are computed at once (T x 64 x N gains)."""

STATIC_CEILING_NOTE = ("the fixed position and fixed shares with the largest mean objective "
                       "over the policy's own fading draws: a ceiling for static policies "
                       "only")
"""What the oracle is under the built-in fading (its label in tables and files)."""


@dataclass(frozen=True)
class FadingOracleResult:
    """Best static configuration of each layout: mean objective (L,), UAV (L, 3), alpha_first
    (L, K), and the lattice points whose value was computed (L,)."""

    objective_bps: FloatArray
    uav_m: FloatArray
    alpha_first: FloatArray
    points_valued: NDArray[np.int64]


def fading_oracle_refusal(scenario: Scenario) -> str | None:
    """Why the fading oracle cannot serve the scenario, or None: it needs the built-in fading,
    one UAV, LoS not sampled, no plugin fading and no minimum rate."""
    if scenario.channel.fading.model == "none":
        return "channel.fading.model is 'none'"
    if scenario.uav.count != 1:
        return f"it is defined for one UAV ({scenario.uav.count})"
    if scenario.channel.los == "sampled":
        return "channel.los is 'sampled'"
    if scenario.reward.min_se != 0:
        return (f"reward.min_se is {scenario.reward.min_se:g}: under fading the oracle needs "
                "min_se = 0, where the clusters' shares are separable")
    return None


def require_fading_oracle(scenario: Scenario) -> None:
    """Refuse, in one line, a scenario the fading oracle cannot serve."""
    reason = fading_oracle_refusal(scenario)
    if reason is not None:
        raise AdaptskyError(f"scenario '{scenario.name}': the oracle under fading: {reason}")


class FadingLayoutSearch:
    """One layout's search: its users, clusters, draws and the lattice's gains."""

    def __init__(self, env: NetworkBatch, scenario: Scenario, layout: int,
                 users_m: FloatArray, scattered: FloatArray) -> None:
        self.env, self.scenario, self.layout = env, scenario, layout
        self.users_m = users_m
        self.first = env.first_user[layout]                    # (K,)
        self.second = env.second_user[layout]
        self.real, self.imag = scattered[:, 0], scattered[:, 1]  # (T, N) each
        self.mean_real = self.real.mean(axis=0)
        self.mean_square = (np.square(self.real) + np.square(self.imag)).mean(axis=0)
        fading = scenario.channel.fading
        self.rician = fading.model == "rician"
        self.k0_db, self.k90_db = fading.k_db
        radio = scenario.radio
        self.snr_scale = snr_scale(scenario)
        self.bandwidth_hz = radio.bandwidth_hz
        self.residual = radio.sic_residual

    def gains(self, points_m: FloatArray) -> tuple[FloatArray, FloatArray | None]:
        """Large-scale gains (P, N) at ``points_m`` (P, 3) and sqrt(K) (P, N) (None:
        Rayleigh on every link)."""
        geometry = point_geometry(self.env, self.layout, points_m, self.users_m)
        gain = deterministic_gain(self.env.channel, self.scenario.channel.los, geometry)
        if not self.rician:
            return gain, None
        root_k = root_k_factor(geometry.elevation_deg, self.k0_db, self.k90_db)
        if self.scenario.channel.los != "always":
            root_k *= geometry.los.reshape(root_k.shape)
        return gain, root_k

    def jensen_bound(self, points_m: FloatArray) -> FloatArray:
        """B_1 of every point (P,) (module doc), -inf inside a building."""
        gain, root_k = self.gains(points_m)
        if root_k is None:
            mean_power = self.mean_square
        else:    # mean |h|^2 = (K + 2 sqrt(K) mean Re s + mean |s|^2) / (K + 1)
            k = np.square(root_k)
            mean_power = (k + 2 * root_k * self.mean_real + self.mean_square) / (k + 1)
        mean_gain = gain * mean_power
        pair = mean_gain[:, self.first] + mean_gain[:, self.second]
        bound = noma.rate_bps(self.snr_scale * pair, self.bandwidth_hz).sum(axis=1)
        return self.outside(points_m, bound)

    def outside(self, points_m: FloatArray, values: FloatArray) -> FloatArray:
        """``values`` (P,) at ``points_m`` (P, 3), -inf inside a building."""
        return outside_buildings(self.env, self.layout, points_m, values)

    def step_gains(self, points_m: FloatArray) -> FloatArray:
        """Every user's gain at every step (T, P, N) at ``points_m`` (P, 3): L |h_t|^2, as
        the step computes it (eq. 11.1)."""
        gain, root_k = self.gains(points_m)
        steps = len(self.real)
        real = np.broadcast_to(self.real[:, None], (steps, *gain.shape))
        imag = np.broadcast_to(self.imag[:, None], (steps, *gain.shape))
        factors = power_gain(real, imag, None if root_k is None else
                             np.broadcast_to(root_k, (steps, *gain.shape)))
        return gain * factors

    def step_bound(self, gains: FloatArray) -> FloatArray:
        """B_2 (P,) from the steps' gains (T, P, N)."""
        strongest = np.maximum(gains[..., self.first], gains[..., self.second])
        return noma.rate_bps(self.snr_scale * strongest, self.bandwidth_hz).mean(axis=0).sum(
            axis=-1)

    def values(self, gains: FloatArray, alphas: FloatArray) -> tuple[FloatArray, FloatArray]:
        """V (P,) and each cluster's best grid share (P, K) from the steps' gains (T, P, N):
        every grid share tried, the smallest of equal ones kept."""
        gain_first, gain_second = gains[..., self.first], gains[..., self.second]

        def mean_sum_rate(alpha: float) -> FloatArray:
            sinr_first, sinr_second = noma.cluster_sinr(alpha, gain_first, gain_second,
                                                        self.snr_scale, self.residual)
            return (noma.rate_bps(sinr_first, self.bandwidth_hz)
                    + noma.rate_bps(sinr_second, self.bandwidth_hz)).mean(axis=0)

        best, best_alpha = best_on_grid(alphas, mean_sum_rate,
                                        np.full(gain_first.shape[1:], np.nan))
        return best.sum(axis=-1), best_alpha


def fading_oracle(scenario: Scenario, users_m: FloatArray, steps: int, seed: int = 0,
                  on_layout: Callable[[int], None] | None = None,
                  on_search: Callable[[float, str], None] | None = None
                  ) -> FadingOracleResult:
    """The static ceiling of the module doc for every layout ``users_m`` (L, N, 2) over the
    fading draws of ``steps`` steps of an evaluation with ``seed``; ``on_layout`` hears the
    layouts done, ``on_search`` a fraction and where the search is."""
    require_fading_oracle(scenario)
    num_layouts = len(users_m)
    env = NetworkBatch(scenario, num_envs=num_layouts, seed=seed, users_m=users_m)
    env.reset()
    scattered = env.next_scattered(steps)[:, :, :, 0]             # (T, 2, L, N)
    xs, ys, hs, alphas = lattice(scenario)
    grid = grid_points(xs, ys, hs)
    objective = np.zeros(num_layouts)
    best_uav = np.broadcast_to(np.array(scenario.uav.start_m), (num_layouts, 3)).copy()
    best_alpha = np.full((num_layouts, scenario.num_clusters), scenario.uav.start_alpha)
    valued = np.zeros(num_layouts, dtype=np.int64)
    for layout in range(num_layouts):
        search = FadingLayoutSearch(env, scenario, layout, users_m[layout],
                                    scattered[:, :, layout])
        bound = np.concatenate([search.jensen_bound(chunk) for chunk, _ in lattice_chunks(grid)])

        def values(points: FloatArray, best: float, search: FadingLayoutSearch = search
                   ) -> tuple[FloatArray, FloatArray, int]:
            gains = search.step_gains(points)
            hopeful = search.step_bound(gains) > best             # B_2 beats the best
            total = np.full(len(points), -np.inf)
            shares = np.zeros((len(points), scenario.num_clusters))
            if hopeful.any():
                total[hopeful], shares[hopeful] = search.values(gains[:, hopeful], alphas)
            return total, shares, int(hopeful.sum())

        def heard(begin: int, count: int, layout: int = layout) -> None:
            if on_search is not None:
                on_search(layout + min(begin / len(grid), 0.99), f"{count} points valued")

        # from the largest B_1 down, equal bounds in lattice order; each point its own box
        found, valued[layout] = branch_and_bound(
            bound, from_largest(bound), lambda items: grid[items], values,
            Best(-np.inf, best_uav[layout], best_alpha[layout]),
            per_batch=POINTS_PER_BATCH, on_batch=heard)
        objective[layout] = max(found.value, 0.0)
        best_uav[layout], best_alpha[layout] = found.point_m, found.shares
        if on_layout is not None:
            on_layout(layout + 1)
    return FadingOracleResult(objective, best_uav, best_alpha, valued)
