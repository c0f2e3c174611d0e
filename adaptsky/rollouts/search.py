"""The search kernel every lattice search of :mod:`adaptsky.rollouts` runs on (docs/model.md §6
and §9): the reachable lattice and its points' gains (a point inside a building is worth
-inf), one best share on the grid, the exhaustive search in chunks, branch and bound over
ranked boxes, rounds of best responses and the per-step driver. The oracles and best
responses keep only their bounds, their objectives and what differs.

The kernel never changes what it is given: among equal values the first met is kept, the
points are valued in the order and the batches the caller's chunks and ranking give (numpy's
vector loops may give a point's value other last bits at another array position).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Sequence
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from adaptsky.channels.contract import LinkGeometry
from adaptsky.scenario.models import Scenario
from adaptsky.sim import noma
from adaptsky.sim.blockage import inside_buildings
from adaptsky.sim.lattice import axis_lattice, share_lattice
from adaptsky.sim.links import carrier_hz, deterministic_gain
from adaptsky.sim.network import NetworkBatch

FloatArray = NDArray[np.float64]
POINTS_PER_CHUNK = 200_000
"""Lattice points the exhaustive searches value at once."""
BOX = (8, 8, 8)
"""Lattice points of a box along x, y and h (branch and bound)."""
POINTS_PER_BATCH = 16_384
"""Lattice points branch and bound values at once (whole boxes)."""
RELATIVE_TOLERANCE = 1e-9
"""Best responses stop after a round that gains less than this, relative."""


class Best(NamedTuple):
    """The best a search has found: its value, the point (3,) and the shares there (K,)."""

    value: float
    point_m: FloatArray
    shares: FloatArray


PointValues = Callable[[FloatArray], tuple[FloatArray, FloatArray]]
"""Lattice points (P, 3) to their values (P,) and best shares (P, K)."""
Valuation = Callable[[FloatArray, float], tuple[FloatArray, FloatArray, int]]
"""Branch and bound's valuation: points (P, 3) and the best value so far to their values (P,)
(-inf where the caller's finer bound spares a point), shares (P, K) and the points valued."""


# ---- the lattice and its points ---------------------------------------------------------------

def lattice(scenario: Scenario) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """The reachable x, y, h values and the alpha_first grid (docs/model.md §6)."""
    uav, half_m = scenario.uav, scenario.area.side_m / 2
    xs = axis_lattice(uav.start_m[0], uav.step_m[0], -half_m, half_m)
    ys = axis_lattice(uav.start_m[1], uav.step_m[1], -half_m, half_m)
    hs = axis_lattice(uav.start_m[2], uav.step_m[2], uav.min_height_m, uav.max_height_m)
    return xs, ys, hs, share_lattice(scenario)


def grid_points(*axes: FloatArray) -> FloatArray:
    """Every point (P, D) of the axes' product, in lattice order (the last axis fastest)."""
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, len(axes))


def snr_scale(scenario: Scenario) -> float:
    """P_T G / sigma^2 (the uplink's P_u G / sigma^2): a gain's SNR per unit gain."""
    radio = scenario.radio
    return scenario.sender_power_w * radio.antenna_gain / radio.noise_w


def point_geometry(env: NetworkBatch, layout: int, points_m: FloatArray, users_m: FloatArray
                   ) -> LinkGeometry:
    """The links (P, N) from each of ``points_m`` (P, 3) to the users ``users_m`` (N, 2),
    through environment ``layout``'s buildings."""
    users = np.broadcast_to(users_m, (len(points_m), *users_m.shape))
    return env.geometry(points_m, users, layout=layout)


def point_gains(env: NetworkBatch, layout: int, points_m: FloatArray, users_m: FloatArray
                ) -> FloatArray:
    """The deterministic gains (P, N) planning uses from each of ``points_m`` (P, 3) to the
    users ``users_m`` (N, 2) (:func:`point_geometry`)."""
    geometry = point_geometry(env, layout, points_m, users_m)
    return deterministic_gain(env.channel, env.scenario.channel.los, geometry)


def outside_buildings(env: NetworkBatch, layout: int, points_m: FloatArray,
                      values: FloatArray) -> FloatArray:
    """``values`` (P,) at ``points_m`` (P, 3), -inf at those inside a building of environment
    ``layout`` (a UAV never stands there)."""
    if env.city is None:
        return values
    inside = inside_buildings(points_m[None], env.city.environment(layout))[0]
    return np.where(inside, -np.inf, values)


def bound_gains(env: NetworkBatch, corners_m: FloatArray, users_m: FloatArray,
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


# ---- the best share -------------------------------------------------------------------------

def best_on_grid(grid: Iterable[float], value_of: Callable[[float], FloatArray],
                 start: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The largest value over the ``grid`` (elementwise, each value ``value_of(share)``) and
    the share giving it, the smallest of equal ones; ``start`` where no share beats -inf."""
    best = np.full(np.shape(start), -np.inf)
    chosen = np.asarray(start, dtype=np.float64)
    for share in grid:
        value = value_of(share)
        better = value > best
        best = np.where(better, value, best)
        chosen = np.where(better, share, chosen)
    return best, chosen


def best_shares_on_grid(gain_first: FloatArray, gain_second: FloatArray, alphas: FloatArray,
                        scenario: Scenario, snr_scale: float) -> tuple[FloatArray, FloatArray]:
    """Per cluster: the grid alpha_first maximising its sum rate under R_min by trying every
    one (exact for any SIC residual, docs/model.md §13; ties to the smallest), and that sum
    rate; NaN and -inf where no grid alpha meets R_min."""
    residual, bandwidth_hz = scenario.radio.sic_residual, scenario.radio.bandwidth_hz
    min_rate_bps = scenario.min_rate_bps

    def sum_rate(alpha: float) -> FloatArray:
        sinr_first, sinr_second = noma.cluster_sinr(alpha, gain_first, gain_second, snr_scale,
                                                    residual)
        rate_first = noma.rate_bps(sinr_first, bandwidth_hz)
        rate_second = noma.rate_bps(sinr_second, bandwidth_hz)
        feasible = (rate_first >= min_rate_bps) & (rate_second >= min_rate_bps)
        return np.where(feasible, rate_first + rate_second, -np.inf)

    rate, alpha = best_on_grid(alphas, sum_rate, np.full(gain_first.shape, np.nan))
    return alpha, rate


def best_shares(gain_first: FloatArray, gain_second: FloatArray, alphas: FloatArray,
                scenario: Scenario, snr_scale: float) -> tuple[FloatArray, FloatArray]:
    """:func:`best_shares_on_grid` in closed form under perfect SIC (the sum rate rises with
    the strong user's share, docs/model.md §6: the largest share the weak user's R_min allows,
    and its neighbours on the grid against rounding at the constraint's edge), by trying every
    grid alpha under imperfect SIC (docs/model.md §13)."""
    if scenario.radio.sic_residual:
        return best_shares_on_grid(gain_first, gain_second, alphas, scenario, snr_scale)
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


POINTS_PER_SHARE_BLOCK = 256
"""Lattice points valued at once against every share vector of a cluster of M > 2."""


UPLINK_MAX_VECTORS = 200_000
"""The most transmit-share vectors of a cluster the uplink's oracle tries at each point."""


def share_vectors(scenario: Scenario) -> tuple[FloatArray, FloatArray]:
    """Every component vector (V, C) the actions reach in a cluster of M users (the grid on
    each component, lattice order: the last fastest) and the shares (V, M) each gives: the
    downlink's M - 1 components and their split (docs/model.md §15), or the uplink's M
    transmit shares, themselves (§17)."""
    components = grid_points(*[share_lattice(scenario)] * scenario.shares_per_cluster)
    return components, components if scenario.uplink else noma.member_shares(components)


def best_uplink_vectors(gain: FloatArray, betas: FloatArray, scenario: Scenario,
                        snr_scale: float, others_bps: FloatArray | None = None
                        ) -> tuple[NDArray[np.intp], FloatArray]:
    """Per point and uplink cluster of M users with gains ``gain`` (P, M) (one UAV: no
    interference; else each divided by its interference plus noise over sigma^2): the index
    into ``betas`` (V, M) of the transmit shares maximising the cluster's sum rate under
    R_min, and that sum rate (P,) (docs/model.md §17; ``snr_scale`` = P_u G / sigma^2). With
    perfect SIC and R_min = 0 the sum rate is W log2(1 + sum_i a_i), rising with every share:
    the vector of the largest shares, found without trying the others; else every vector is
    tried (ties to the first; index 0 and -inf where none meets R_min). ``others_bps`` (V,)
    (best response of several UAVs, §9): what each vector leaves the other UAVs' clusters on
    the block (their sum rate, -inf where one misses R_min), added before the best is
    chosen (every vector then tried) and included in the value returned."""
    residual, bandwidth_hz = scenario.radio.sic_residual, scenario.radio.bandwidth_hz
    min_se = scenario.reward.min_se
    if not residual and not min_se and others_bps is None:
        top = int(np.argmax(betas.sum(axis=1)))        # every share at its largest
        received = snr_scale * betas[top] * gain
        rate = bandwidth_hz * np.log2(1.0 + received.sum(axis=1))
        return np.full(len(gain), top, dtype=np.intp), rate
    index = np.zeros(len(gain), dtype=np.intp)
    rate = np.full(len(gain), -np.inf)
    for start in range(0, len(gain), POINTS_PER_SHARE_BLOCK):
        block = slice(start, start + POINTS_PER_SHARE_BLOCK)
        received = snr_scale * betas[None] * gain[block, None, :]            # (b, V, M)
        order = noma.sic_order(received, received)
        ordered = np.take_along_axis(received, order, axis=-1)
        heard = noma.heard_shares(ordered[..., ::-1], residual)[..., ::-1]
        spectral = np.log2(1.0 + ordered / (heard + 1.0))
        total = spectral.sum(axis=2)
        total[(spectral < min_se).any(axis=2)] = -np.inf
        if others_bps is not None:
            total = bandwidth_hz * total + others_bps
        best = np.argmax(total, axis=1)
        index[block] = best
        value = total[np.arange(len(best)), best]
        rate[block] = value if others_bps is not None else bandwidth_hz * value
    return index, rate


def best_share_vectors(gain: FloatArray, shares: FloatArray, scenario: Scenario,
                       snr_scale: float) -> tuple[NDArray[np.intp], FloatArray]:
    """Per point and cluster of M users with gains ``gain`` (P, M) (one UAV: no
    interference): the index into ``shares`` (V, M) of the share vector maximising the
    cluster's sum rate under R_min, trying every one (exact for any SIC residual; ties to the
    first), and that sum rate (P,); index 0 and -inf where none meets R_min. The SIC order is
    the gains' (:func:`~adaptsky.sim.noma.sic_order`), so member p of the order hears the
    shares before it and the residual of those after it (docs/model.md §15)."""
    residual, bandwidth_hz = scenario.radio.sic_residual, scenario.radio.bandwidth_hz
    min_se = scenario.reward.min_se
    size = gain.shape[1]
    order = noma.sic_order(gain, gain)                                      # (P, M)
    index = np.zeros(len(gain), dtype=np.intp)
    rate = np.full(len(gain), -np.inf)
    codes = np.ravel_multi_index(order.T, (size,) * size)   # one number per order
    for code in np.unique(codes):
        rows = np.flatnonzero(codes == code)
        permutation = order[rows[0]]
        ordered = shares[:, permutation]                                    # (V, M)
        heard = noma.heard_shares(ordered, residual)
        snr = snr_scale * np.take_along_axis(gain[rows], order[rows], axis=1)   # (P_o, M)
        for start in range(0, len(rows), POINTS_PER_SHARE_BLOCK):
            block = slice(start, start + POINTS_PER_SHARE_BLOCK)
            a = snr[block, None, :]                                          # (b, 1, M)
            spectral = np.log2(1.0 + ordered * a / (heard * a + 1.0))        # (b, V, M)
            total = spectral.sum(axis=2)
            total[(spectral < min_se).any(axis=2)] = -np.inf
            best = np.argmax(total, axis=1)
            found = rows[block]
            index[found] = best
            rate[found] = bandwidth_hz * total[np.arange(len(best)), best]
    return index, rate


def either_share(alphas: FloatArray) -> FloatArray:
    """Every share either user of a cluster may hold: the grid and its complement."""
    return np.unique(np.concatenate([alphas, 1.0 - alphas]))


# ---- exhaustive search ------------------------------------------------------------------------

def lattice_chunks(points_m: FloatArray, per_chunk: int = POINTS_PER_CHUNK
                   ) -> Iterator[tuple[FloatArray, float]]:
    """``points_m`` (P, 3) in chunks of ``per_chunk``, each with the share searched after it."""
    for start in range(0, len(points_m), per_chunk):
        chunk = points_m[start:start + per_chunk]
        yield chunk, (start + len(chunk)) / len(points_m)


def best_in_chunks(chunks: Iterable[tuple[FloatArray, float]], values: PointValues,
                   start: Best, on_chunk: Callable[[float], None] | None = None) -> Best:
    """The exhaustive search: every point of the ``chunks`` (points (P, 3), the share searched
    after them) valued by ``values``; the best point that beats ``start`` (the first of equal
    ones), else ``start``. ``on_chunk`` hears the share searched after each chunk."""
    best = start
    for points, searched in chunks:
        total, shares = values(points)
        top = int(np.argmax(total))
        if total[top] > best.value:
            best = Best(float(total[top]), points[top], shares[top])
        if on_chunk is not None:
            on_chunk(searched)
    return best


# ---- branch and bound -------------------------------------------------------------------------

class LatticeBoxes:
    """Lattice axes (x, y, h) cut into boxes of :data:`BOX` points: every box's low and high
    corners (M, 3), the box of a point, and a box's points (branch and bound)."""

    def __init__(self, axes: Sequence[FloatArray]) -> None:
        self.axes = list(axes)
        self.starts = [np.arange(0, len(axis), size) for axis, size in zip(self.axes, BOX,
                                                                            strict=True)]
        self.index = grid_points(*[np.arange(len(s)) for s in self.starts])   # (i, j, k)
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
        ranked = from_largest(bound)
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
            found.append(grid_points(*ranges))
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


def from_largest(bound: FloatArray) -> NDArray[np.intp]:
    """The items from the largest ``bound`` down, equal bounds in their order."""
    return np.argsort(-bound, kind="stable")


def every_point(values: PointValues) -> Valuation:
    """Branch and bound's valuation that values every point of a batch with ``values``."""
    def valuation(points_m: FloatArray, best: float) -> tuple[FloatArray, FloatArray, int]:
        total, shares = values(points_m)
        return total, shares, len(points_m)
    return valuation


def branch_and_bound(bound: FloatArray, ranked: NDArray[np.intp],
                     points_of: Callable[[NDArray[np.intp]], FloatArray], values: Valuation,
                     start: Best, *, beat: float = -np.inf, first_alone: bool = False,
                     per_batch: int = POINTS_PER_BATCH // int(np.prod(BOX)),
                     on_batch: Callable[[int, int], None] | None = None) -> tuple[Best, int]:
    """Branch and bound over items (boxes, or points) with upper bounds ``bound``: batches of
    ``per_batch`` of the ``ranked`` items (``first_alone``: the first alone, its value starting
    the pruning), each item kept where its bound exceeds both ``beat`` and the best so far,
    their points (``points_of``) valued by ``values``, from ``start``, until a batch after the
    first has no item left (``ranked`` falls, but for at most its first item). The best (the
    first of equal values) and the points valued; ``on_batch`` hears, after each batch that
    valued a point, where it began in ``ranked`` and the points valued so far."""
    best = start
    starts = ([0, *range(1, len(ranked), per_batch)] if first_alone
              else list(range(0, len(ranked), per_batch)))
    valued = 0
    for begin, end in zip(starts, [*starts[1:], len(ranked)], strict=True):
        batch = ranked[begin:end]
        batch = batch[bound[batch] > max(beat, best.value)]
        if not len(batch):
            if begin > 0:
                break                                   # no later item can do better
            continue
        points = points_of(batch)
        if not len(points):
            continue
        total, shares, count = values(points, best.value)
        if not count:
            continue
        valued += count
        top = int(np.argmax(total))
        if total[top] > best.value:
            best = Best(float(total[top]), points[top], shares[top])
        if on_batch is not None:
            on_batch(begin, valued)
    return best, valued


# ---- best responses and steps ---------------------------------------------------------------

Respond = Callable[[int, int, float], Best]
"""One UAV's response: (round, UAV, the value to beat) to its best (value, point, shares)."""


def response_rounds(respond: Respond, uav_m: FloatArray, alpha_first: FloatArray,
                    value: float, rounds: int) -> tuple[float, int, bool]:
    """Rounds of best responses from the configuration ``uav_m`` (U, 3), ``alpha_first``
    (U, K) worth ``value``, updated in place: each UAV in turn takes its response where it
    gains, until a round gains at most :data:`RELATIVE_TOLERANCE` relative, or ``rounds``
    rounds. The value, the rounds run and whether the last gained that little."""
    for round_index in range(rounds):
        before = value
        for u in range(len(uav_m)):
            found = respond(round_index, u, value)
            if found.value > value:
                value = found.value
                uav_m[u], alpha_first[u] = found.point_m, found.shares
        if value - before <= RELATIVE_TOLERANCE * abs(before):
            return value, round_index + 1, True
    return value, rounds, False


def walking_env(scenario: Scenario, users_m: FloatArray, seed: int) -> NetworkBatch:
    """The environment of a per-step search on the layouts ``users_m`` (L, N, 2), reset: its
    users move and its draws fall as under a policy with the same ``seed``."""
    env = NetworkBatch(scenario, num_envs=len(users_m), seed=seed, users_m=users_m)
    env.reset()
    return env


def each_step(env: NetworkBatch, steps: int,
              held: Callable[[], tuple[FloatArray, FloatArray]],
              search: Callable[[int, int, FloatArray], None],
              on_step: Callable[[int], None] | None = None) -> FloatArray:
    """The per-step driver: ``steps`` steps of ``env``, each holding the configuration
    ``held()`` (UAVs (L, U, 3) or (L, 3), shares) while the users move, then ``search(step,
    layout, users_m)`` on every layout at that step's user positions (N, 2) and clusters;
    ``on_step`` hears the steps done. The users' positions (T, L, N, 2)."""
    positions = np.zeros((steps, *env.users_m.shape))
    for step in range(steps):
        env.hold_step(*held())          # the users move; the clusters are the step's
        positions[step] = env.users_m
        for layout in range(len(positions[step])):
            search(step, layout, positions[step, layout])
        if on_step is not None:
            on_step(step + 1)
    return positions
