"""Baselines of several UAVs (docs/model.md §9): SoA per UAV, best response, OMA.

- **SoA per UAV** (:func:`soa_per_uav`): every UAV at its group's 2D centroid at the start
  height, each cluster's power split of docs/model.md §6 planned without interference; rates
  evaluated with the true interference.
- **Best response** (:func:`best_response`, our reference, never called the optimum): from
  SoA's positions, each UAV in turn takes the lattice point and alphas (the oracle's lattice,
  docs/model.md §6) that maximise the whole network's objective with the others fixed (its
  interference on the other groups included); rounds until one gains less than 1e-9
  relative, or ``rounds`` rounds. For U = 1 it is the oracle.
- **OMA** (:func:`best_oma`): the same search when each cluster's users share its
  resources orthogonally (1/M of the band and of the power each; half for pairs), from SoA's
  positions.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from adaptsky.rollouts.cluster_oracle import exact_oracle
from adaptsky.rollouts.objective import constrained_sum_rate
from adaptsky.rollouts.oracle import require_deterministic_gains
from adaptsky.rollouts.search import (
    POINTS_PER_CHUNK,
    Best,
    best_in_chunks,
    best_share_vectors,
    best_shares,
    best_uplink_vectors,
    grid_points,
    lattice,
    outside_buildings,
    point_gains,
    response_rounds,
    share_vectors,
)
from adaptsky.rollouts.soa import soa_per_uav_configuration, soa_positions
from adaptsky.scenario.models import Scenario
from adaptsky.sim.chain import LayoutClusters
from adaptsky.sim.interference import interference_sum_w, interferers, oma_rates_bps, sic_rates
from adaptsky.sim.lattice import axis_lattice, share_lattice
from adaptsky.sim.network import NetworkBatch

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]
DEFAULT_ROUNDS = 10
EXPECTED_ROUNDS = 3.0
"""Rounds a layout is taken to need until some layout is done (then their mean), for the
share of a layout done that progress reports: a round's end is known only when it gains."""

RESPONSE_MAX_VALUES = 10**9
"""The most (lattice point, share vector) pairs one UAV's response may value for clusters of
M > 2 or the uplink (every vector at every point); beyond, best response is refused in one
line. Measured on two_uavs_mmwave.toml (5 m lattice, 0.1 grid): about 2.5 s of CPU per 10^8
pairs for clusters of four, about 18 s for the uplink's pairs (docs/model.md §15, §17)."""

OnSearch = Callable[[float, str], None]
"""Hears, after each chunk of a UAV's lattice, the layouts done (a fraction within one) and
where the search is: 'round 2, UAV 3/3: 40%' (of that UAV's lattice searched)."""


@dataclass(frozen=True)
class UplinkBlock:
    """One uplink cluster of the responding UAV: its users ``members`` and the slice
    ``width`` of its components; under full reuse with other UAVs, the other UAVs' users on
    its block ``senders`` (N,), their power sent ``sent_w`` and the other UAVs' sum rate on
    the block with each grid vector of this cluster ``others_bps`` (V,) (else None)."""

    members: IntArray
    width: slice
    senders: NDArray[np.bool_] | None = None
    sent_w: FloatArray | None = None
    others_bps: FloatArray | None = None


@dataclass(frozen=True)
class SearchResult:
    """The configuration a search found for each of L layouts: ``objective_bps`` (L,) the
    constrained sum rate (0 where no point meets R_min), ``uav_m`` (L, U, 3),
    ``alpha_first`` (L, U, K_u) (NaN for OMA, which splits no power), ``rate_bps`` (L, N)
    every user's rate there, ``rounds`` (L,) rounds run, ``converged`` (L,) whether the last
    round gained less than 1e-9 relative (True for U = 1: the oracle is one search),
    ``seconds_per_layout`` the process time per layout."""

    objective_bps: FloatArray
    uav_m: FloatArray
    alpha_first: FloatArray
    rate_bps: FloatArray
    rounds: NDArray[np.int64]
    converged: NDArray[np.bool_]
    seconds_per_layout: float


def response_refusal(scenario: Scenario) -> str | None:
    """Where one UAV's best response of several would value more than
    :data:`RESPONSE_MAX_VALUES` (point, vector) pairs (clusters of M > 2, the uplink), the
    one-line refusal, else None."""
    if scenario.uav.count == 1 or not scenario.sic_chains:
        return None
    xs, ys, hs, _ = lattice(scenario)
    points = len(xs) * len(ys) * len(hs)
    vectors = len(share_lattice(scenario)) ** scenario.shares_per_cluster
    if points * vectors <= RESPONSE_MAX_VALUES:
        return None
    return (f"scenario '{scenario.name}': best response would value {points:,} lattice points "
            f"x {vectors:,} share vectors per cluster in each UAV's response (at most "
            f"{RESPONSE_MAX_VALUES:,} pairs); raise uav.power_step or uav.step_m")


def soa_per_uav(scenario: Scenario, users_m: FloatArray) -> tuple[FloatArray, FloatArray]:
    """UAV positions (L, U, 3) and first users' shares (L, U, K_u) of SoA per UAV on the
    layouts ``users_m`` (L, N, 2): each UAV at its group's 2D centroid at its start height,
    each cluster's split of docs/model.md §6 planned from the LoS gains without
    interference."""
    env = NetworkBatch(scenario, num_envs=len(users_m), users_m=users_m)
    return soa_per_uav_configuration(env)


class BestResponseSearch:
    """Best responses of one layout (module doc): the lattice of every UAV, the fixed
    association, and the constants of the rates."""

    def __init__(self, env: NetworkBatch, layout: int, oma: bool) -> None:
        scenario = env.scenario
        self.env, self.scenario, self.oma = env, scenario, oma
        self.association = a = env.association
        self.users_m = env.layouts_m[layout]
        self.layout = layout
        self.serving = a.serving_uav[layout]
        self.cluster = a.cluster[layout]
        self.first = a.first_user[layout]       # (U, K_max), -1 in unused slots
        self.second = a.second_user[layout]
        # each user's cluster partner and whether it is the first user (alpha_k is its share):
        # NOMA's rates of pairs (OMA's of clusters of any size need neither)
        self.cluster_size = scenario.cluster_size
        self.uplink = scenario.uplink
        radio = scenario.radio
        self.full_reuse = radio.reuse == "full"
        # clusters of M > 2 and the uplink: their SIC chains (docs/model.md §15, §17)
        self.chains = None
        if not oma and scenario.sic_chains:
            self.chains = LayoutClusters.of(a, layout, scenario.shares_per_uav,
                                            scenario.shares_per_cluster,
                                            self.uplink and self.full_reuse)
            self.components, self.vectors = share_vectors(scenario)
        elif self.cluster_size == 2:
            self.partner = a.partner[layout]
            self.is_first = a.is_first[layout]
        self.interferer = interferers(a)[layout]      # (U, N)
        self.tx_power_w, self.antenna_gain = radio.tx_power_w, radio.antenna_gain
        self.power = scenario.sender_power_w * radio.antenna_gain   # P_T G (uplink: P_u G)
        self.noise_w = radio.noise_w
        self.bandwidth_hz = radio.bandwidth_hz
        self.min_rate_bps = scenario.min_rate_bps
        uav, half_m = scenario.uav, scenario.area.side_m / 2
        self.alphas = share_lattice(scenario)
        self.heights = [axis_lattice(h, uav.step_m[2], uav.min_height_m, uav.max_height_m)
                        for h in env.start_m[:, 2]]
        self.planes = []
        for x0, y0, _ in env.start_m:
            xs = axis_lattice(x0, uav.step_m[0], -half_m, half_m)
            ys = axis_lattice(y0, uav.step_m[1], -half_m, half_m)
            self.planes.append(grid_points(xs, ys))
        self.min_separation_m = uav.min_separation_m

    def gains(self, points_m: FloatArray) -> FloatArray:
        """Deterministic gains (M, N) from UAV positions ``points_m`` (M, 3) to every user
        (through the layout's buildings, docs/model.md §12)."""
        return point_gains(self.env, self.layout, points_m, self.users_m)

    def rates(self, gain: FloatArray, alpha_first: FloatArray) -> FloatArray:
        """Every user's rate (..., N) with the gains (..., U, N) of every UAV and the shares
        (..., U, K) (NOMA, SIC by effective gain), or OMA's rates."""
        if self.chains is not None:
            return self._chain_rates(gain, alpha_first)
        serving_gain, interference = self._serving(gain)
        if self.oma:
            return oma_rates_bps(serving_gain, interference, tx_power_w=self.tx_power_w,
                                 antenna_gain=self.antenna_gain, noise_w=self.noise_w,
                                 bandwidth_hz=self.bandwidth_hz, cluster_size=self.cluster_size)
        partner = self.partner
        return sic_rates(serving_gain, interference, alpha_first[..., self.serving, self.cluster],
                         self.is_first, lambda values: values[..., partner],
                         power_w=self.power, noise_w=self.noise_w,
                         bandwidth_hz=self.bandwidth_hz,
                         sic_residual=self.scenario.radio.sic_residual)[0]

    def _chain_rates(self, gain: FloatArray, shares: FloatArray) -> FloatArray:
        """:meth:`rates` of clusters of M > 2 or of the uplink, by their SIC chains."""
        assert self.chains is not None
        batch = gain.shape[:-2]
        gain = gain.reshape(-1, *gain.shape[-2:])                          # (P, U, N)
        shares = shares.reshape(len(gain), -1)                             # (P, U S)
        common = {"noise_w": self.noise_w, "bandwidth_hz": self.bandwidth_hz,
                  "sic_residual": self.scenario.radio.sic_residual, "power_w": self.power}
        if self.uplink:
            rates = self.chains.uplink_rates(gain, shares, **common)
        else:
            serving_gain, interference = self._serving(gain)
            rates = self.chains.rates(serving_gain, interference if self.full_reuse else None,
                                      shares, **common)
        return rates.reshape(*batch, -1)

    def _serving(self, gain: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Each user's serving gain (..., N) and interference I_i (..., N), W
        (:func:`~adaptsky.sim.interference.interference_sum_w`, 0 under orthogonal reuse)."""
        users = np.arange(len(self.serving))
        serving_gain = gain[..., self.serving, users]
        if not self.full_reuse:
            return serving_gain, np.zeros(serving_gain.shape)
        return serving_gain, interference_sum_w(gain, self.interferer, self.power)

    def objective(self, uav_m: FloatArray, alpha_first: FloatArray) -> float:
        gain = self.gains(uav_m).reshape(len(uav_m), -1)                  # (U, N)
        return float(constrained_sum_rate(self.rates(gain, alpha_first), self.min_rate_bps))

    def respond(self, u: int, uav_m: FloatArray, alpha_first: FloatArray,
                on_chunk: Callable[[float], None] | None = None) -> Best:
        """UAV ``u``'s best lattice point and shares with the others at ``uav_m`` (U, 3),
        ``alpha_first`` (U, K), by the exhaustive search: (objective, its position, its
        shares), -inf where no point meets R_min; ties to the first point met. ``on_chunk``
        hears the share of the lattice searched after each chunk."""
        fixed_gain = self.gains(uav_m)                                      # (U, N)
        plane = self.planes[u]
        apart = np.ones(len(plane), dtype=bool)
        for v in np.flatnonzero(np.arange(len(uav_m)) != u):   # apart from every other UAV
            apart &= np.hypot(*(plane - uav_m[v, :2]).T) >= self.min_separation_m
        plane = plane[apart]
        heights = self.heights[u]
        per_chunk = max(1, POINTS_PER_CHUNK // max(1, len(plane)))

        def chunks() -> Iterator[tuple[FloatArray, float]]:
            for start in range(0, len(heights), per_chunk):     # whole heights at once
                chunk_h = heights[start:start + per_chunk]
                yield (np.column_stack([np.tile(plane, (len(chunk_h), 1)),
                                        np.repeat(chunk_h, len(plane))]),
                       (start + len(chunk_h)) / len(heights))

        blocks = self._uplink_blocks(u, fixed_gain, alpha_first) if self.uplink else None

        def values(points: FloatArray) -> tuple[FloatArray, FloatArray]:
            return self.totals(u, points, fixed_gain, alpha_first, blocks)

        return best_in_chunks(chunks(), values, Best(-np.inf, uav_m[u], alpha_first[u]),
                              on_chunk)

    def totals(self, u: int, points_m: FloatArray, fixed_gain: FloatArray,
               alpha_first: FloatArray, blocks: list[UplinkBlock] | None = None
               ) -> tuple[FloatArray, FloatArray]:
        """The network's objective (P,) with UAV ``u`` at each of ``points_m`` (P, 3) with its
        best shares there (P, K) (its ``alpha_first`` row for OMA), the others at the gains
        ``fixed_gain`` (U, N) with their ``alpha_first`` (U, K); -inf where a user misses
        R_min or the point lies in a building. The uplink's ``blocks``
        (:meth:`_uplink_blocks` of the same UAV and the others' configuration)."""
        gain = np.broadcast_to(fixed_gain, (len(points_m), *fixed_gain.shape)).copy()
        gain[:, u] = self.gains(points_m)
        shares = np.broadcast_to(alpha_first, (len(points_m), *alpha_first.shape)).copy()
        if self.uplink:
            assert blocks is not None
            shares[:, u] = self._best_uplink_shares(u, gain, blocks)
        elif self.chains is not None:
            shares[:, u] = self._best_share_vectors(u, gain)
        elif not self.oma:
            shares[:, u] = self._best_shares(u, gain)
        rates = self.rates(gain, shares)
        feasible = (rates >= self.min_rate_bps).all(axis=-1)
        total = np.where(feasible, rates.sum(axis=-1), -np.inf)
        return outside_buildings(self.env, self.layout, points_m, total), shares[:, u]

    def _best_shares(self, u: int, gain: FloatArray) -> FloatArray:
        """UAV ``u``'s best first users' shares (M, K) on the grid, cluster by cluster: its
        shares change no interference, so each cluster's sum rate is maximised alone (the
        closed form of docs/model.md §6 with effective SNRs)."""
        serving_gain, interference = self._serving(gain)
        effective = self.power / (interference + self.noise_w) * serving_gain
        valid = self.first[u] >= 0           # its own K_u clusters
        alpha, _ = best_shares(effective[:, self.first[u][valid]],
                               effective[:, self.second[u][valid]], self.alphas,
                               self.scenario, 1.0)
        shares = np.full((len(gain), len(valid)), self.alphas[0])
        shares[:, valid] = np.where(np.isnan(alpha), self.alphas[0], alpha)
        return shares

    def _best_share_vectors(self, u: int, gain: FloatArray) -> FloatArray:
        """UAV ``u``'s best components (P, S) on the grid for clusters of M > 2, cluster by
        cluster (its shares change no interference): the kernel's best share vector on the
        members' effective SNRs (docs/model.md §15)."""
        serving_gain, interference = self._serving(gain)
        effective = self.power / (interference + self.noise_w) * serving_gain
        chosen = np.full((len(gain), self.scenario.shares_per_uav), self.scenario.uav.start_alpha)
        for members, width in self._clusters_of(u):
            index, _ = best_share_vectors(effective[:, members], self.vectors, self.scenario,
                                          1.0)
            chosen[:, width] = self.components[index]
        return chosen

    def _uplink_blocks(self, u: int, fixed_gain: FloatArray, fixed: FloatArray
                       ) -> list[UplinkBlock]:
        """What UAV ``u``'s response in the uplink needs of each of its clusters, the other
        UAVs at the gains ``fixed_gain`` (U, N) with the transmit shares ``fixed`` (U, S):
        none of it depends on where ``u`` goes, so it is made once per response."""
        assert self.chains is not None
        blocks = []
        for members, width in self._clusters_of(u):
            if self.chains.cross is None:          # no other UAV's user on the block
                blocks.append(UplinkBlock(members, width))
                continue
            senders = self.chains.cross[members[0]]     # the other UAVs' users on the block
            sent_w = self.power * self.chains.user_shares(fixed.reshape(-1))[senders]
            blocks.append(UplinkBlock(members, width, senders, sent_w, self._block_rates(
                u, width, senders, fixed_gain, fixed)))
        return blocks

    def _best_uplink_shares(self, u: int, gain: FloatArray, blocks: list[UplinkBlock]
                            ) -> FloatArray:
        """UAV ``u``'s users' best transmit shares (P, S) on the grid at the gains ``gain``
        (P, U, N) (docs/model.md §17). A cluster's shares change what the other UAVs hear on
        its block, not where ``u`` is: so each cluster takes the vector of the largest sum of
        its own rate (at each point, hearing the other UAVs' users on its block) and the
        other UAVs' rates on that block (its block's ``others_bps``, one number per vector),
        exact for the network's objective."""
        chosen = np.full((len(gain), self.scenario.shares_per_uav), self.scenario.uav.start_alpha)
        for block in blocks:
            own = gain[:, u, block.members]
            if block.senders is not None:
                heard_w = gain[:, u, block.senders] @ block.sent_w                # (P,), W
                own = own / (1.0 + heard_w / self.noise_w)[:, None]
            index, _ = best_uplink_vectors(own, self.vectors, self.scenario,
                                           self.power / self.noise_w, block.others_bps)
            chosen[:, block.width] = self.components[index]
        return chosen

    def _block_rates(self, u: int, width: slice, senders: NDArray[np.bool_],
                     gain: FloatArray, fixed: FloatArray) -> FloatArray:
        """The sum rate (V,) of the other UAVs' users ``senders`` on the block of UAV ``u``'s
        cluster of components ``width`` with its transmit shares at each grid vector (the
        gains ``gain`` (U, N) and shares ``fixed``), -inf where one misses R_min."""
        shares = np.broadcast_to(fixed, (len(self.vectors), *fixed.shape)).copy()
        shares[:, u, width] = self.vectors
        rates = self._chain_rates(np.broadcast_to(gain, (len(shares), *gain.shape)), shares)
        on_block = rates[:, senders]
        return np.where((on_block >= self.min_rate_bps).all(axis=1), on_block.sum(axis=1),
                        -np.inf)

    def _clusters_of(self, u: int) -> Iterator[tuple[IntArray, slice]]:
        """UAV ``u``'s clusters: each one's users and the slice of its components in the
        UAV's row."""
        per_cluster = self.scenario.shares_per_cluster
        for k in np.flatnonzero(self.association.has_cluster[u]):
            yield (self.association.members[self.layout, u, k],
                   slice(k * per_cluster, (k + 1) * per_cluster))


def layout_share(rounds_done: float, expected: float) -> float:
    """The share of a layout done (below 1) after ``rounds_done`` rounds (a fraction within
    one) where a layout is taken to need ``expected`` rounds: 0.9 of it over those, the rest
    halved with every further round."""
    if rounds_done <= expected:
        return 0.9 * rounds_done / expected
    return 0.9 + 0.1 * (1.0 - 0.5 ** (rounds_done - expected))


def _search(scenario: Scenario, users_m: FloatArray, rounds: int, oma: bool,
            on_layout: Callable[[int], None] | None,
            on_search: OnSearch | None = None) -> SearchResult:
    """Best responses from SoA per UAV on every layout (module doc)."""
    require_deterministic_gains(scenario)
    if rounds < 1:
        raise ValueError(f"rounds must be >= 1, got {rounds}")
    started = time.process_time()
    env = NetworkBatch(scenario, num_envs=len(users_m), users_m=users_m)
    if not scenario.sic_chains:
        start_uav, start_alpha = soa_per_uav_configuration(env)
    else:   # SoA's positions, the start's components (SoA plans the downlink's pairs)
        start_uav = soa_positions(env)
        start_alpha = np.full((*start_uav.shape[:2], scenario.shares_per_uav),
                              scenario.uav.start_alpha)
    num_layouts = len(users_m)
    objective = np.zeros(num_layouts)
    uav_m, alpha_first = start_uav.copy(), start_alpha.copy()
    done_rounds = np.zeros(num_layouts, dtype=np.int64)
    converged = np.zeros(num_layouts, dtype=bool)
    rates = np.zeros((num_layouts, env.num_users))
    num_uavs = env.num_uavs

    def chunk_reporter(layout: int, round_index: int, u: int
                       ) -> Callable[[float], None] | None:
        if on_search is None:
            return None
        expected = (float(done_rounds[:layout].mean()) if layout else EXPECTED_ROUNDS)

        def report(searched: float) -> None:
            share = layout_share(round_index + (u + searched) / num_uavs, expected)
            on_search(layout + share,
                      f"round {round_index + 1}, UAV {u + 1}/{num_uavs}: {searched:.0%}")
        return report

    for layout in range(num_layouts):
        search = BestResponseSearch(env, layout, oma)
        positions, shares = uav_m[layout], alpha_first[layout]

        def respond(round_index: int, u: int, value: float, layout: int = layout,
                    search: BestResponseSearch = search, positions: FloatArray = positions,
                    shares: FloatArray = shares) -> Best:
            return search.respond(u, positions, shares, chunk_reporter(layout, round_index, u))

        value, done_rounds[layout], converged[layout] = response_rounds(
            respond, positions, shares, search.objective(positions, shares), rounds)
        objective[layout] = value
        gain = search.gains(positions).reshape(env.num_uavs, env.num_users)
        rates[layout] = search.rates(gain, shares)
        if on_layout is not None:
            on_layout(layout + 1)
    if oma:
        alpha_first = np.full(alpha_first.shape, np.nan)
    seconds = (time.process_time() - started) / max(1, num_layouts)
    return SearchResult(objective, uav_m, alpha_first, rates, done_rounds, converged, seconds)


def best_response(scenario: Scenario, users_m: FloatArray, *, rounds: int = DEFAULT_ROUNDS,
                  on_layout: Callable[[int], None] | None = None,
                  on_search: OnSearch | None = None) -> SearchResult:
    """Best response on every layout (module doc); ``on_layout`` hears the layouts done,
    ``on_search`` where the search is within one (:data:`OnSearch`). For one UAV, the oracle
    (one search, converged)."""
    if scenario.uav.count == 1:
        started = time.process_time()
        found = exact_oracle(scenario, users_m, on_layout, on_search)
        seconds = (time.process_time() - started) / max(1, len(users_m))
        count = len(users_m)
        return SearchResult(found.objective_bps, found.uav_m[:, None], found.alpha_first[:, None],
                            found.rate_bps, np.ones(count, dtype=np.int64),
                            np.ones(count, dtype=bool), seconds)
    return _search(scenario, users_m, rounds, False, on_layout, on_search)


def best_oma(scenario: Scenario, users_m: FloatArray, *, rounds: int = DEFAULT_ROUNDS,
             on_layout: Callable[[int], None] | None = None,
             on_search: OnSearch | None = None) -> SearchResult:
    """The best OMA configuration found the same way (module doc): each cluster's two users
    on half its band with half its power, R_i = (W/2) log2(1 + P_T G g_{u,i} / (I_i +
    sigma^2)) (:func:`adaptsky.sim.interference.oma_rates_bps`); progress as for
    :func:`best_response`."""
    return _search(scenario, users_m, rounds, True, on_layout, on_search)
