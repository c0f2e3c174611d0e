"""The rates stage for NOMA clusters of M > 2 users (docs/model.md §15): index arrays made once
per association, then every cluster's SIC chain at once (:func:`adaptsky.sim.noma.chain_sinr`).

Clusters of two keep their own, older path (:func:`adaptsky.sim.interference.sic_rates`), whose
floating-point operations every number of the paper's model comes from; for M = 2 the two give
the same values.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from adaptsky.sim import noma
from adaptsky.sim.association import Association

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]


def downlink_sinr(gains: FloatArray, noise_plus_w: FloatArray | None, components: FloatArray,
                  *, power_w: float, noise_w: float, sic_residual: float = 0.0,
                  order: IntArray | None = None
                  ) -> tuple[FloatArray, FloatArray, IntArray, FloatArray]:
    """The downlink's SIC chains (docs/model.md §15): every member's SINR (..., C, M) from its
    gain ``gains`` (..., C, M), the interference plus noise it hears ``noise_plus_w`` (W; None:
    noise alone) and its cluster's M - 1 components (..., C, M - 1); also its effective gain,
    the order (by :func:`~adaptsky.sim.noma.sic_order`, or ``order`` where given) and its
    share."""
    if noise_plus_w is None:
        effective, snr_scale = gains, power_w / noise_w
    else:
        effective, snr_scale = gains / noise_plus_w, power_w / noise_plus_w
    shares = noma.member_shares(components)
    if order is None:
        order = noma.sic_order(effective, gains)
    sinr = noma.chain_sinr(shares, gains, effective, snr_scale, sic_residual, order)
    return sinr, effective, order, shares


def uplink_sinr(received_w: FloatArray, interference_w: FloatArray | None, *, noise_w: float,
                sic_residual: float = 0.0) -> tuple[FloatArray, IntArray]:
    """The uplink's SIC chains (docs/model.md §17): every member's SINR (..., C, M) from the
    power its UAV receives of it ``received_w`` (..., C, M) and of the other UAVs' users on
    its block (W; None: none), and the order, strongest received first: member k hears the
    members decoded after it and ``sic_residual`` of those decoded before."""
    order = noma.sic_order(received_w, received_w)
    ordered = np.take_along_axis(received_w, order, axis=-1)
    # decoded after (interference) and before (their residual): the downlink's sums, mirrored
    heard = noma.in_member_order(
        noma.heard_shares(ordered[..., ::-1], sic_residual)[..., ::-1], order)
    if interference_w is not None:    # heard + I + sigma^2, summed in that order
        heard = heard + interference_w
    return received_w / (heard + noise_w), order


@dataclass(frozen=True)
class Chain:
    """Where a batch's clusters of M users are, for B layouts with C clusters in all.

    ``members`` (B, C, M): every cluster's users as flat positions of a (B, N) array;
    ``components`` (B, C, M - 1), the uplink's (B, C, M): its power components' flat
    positions in the configuration
    (B, U, W), W = 3 + S_max; ``places`` (B, N): each user's flat position in a (B, C M)
    array of the clusters' members (the way back to user order)."""

    members: IntArray
    components: IntArray
    places: IntArray

    @classmethod
    def of(cls, association: Association, width: int, per_cluster: int | None = None
           ) -> Chain:
        """The index arrays of ``association``'s clusters in configurations of ``width``
        3 + S_max per UAV, ``per_cluster`` components a cluster (M - 1: the downlink's
        shares; M: the uplink's transmit shares)."""
        members = association.members                                  # (B, U, K_max, M)
        num_layouts, num_uavs, _, size = members.shape
        per_cluster = size - 1 if per_cluster is None else per_cluster
        num_users = association.serving_uav.shape[1]
        # the clusters that exist, UAV by UAV (a UAV with fewer than K_max has padding)
        uav, cluster = np.nonzero(association.has_cluster)
        rows = np.arange(num_layouts)[:, None, None]
        flat_members = rows * num_users + members[:, uav, cluster]      # (B, C, M)
        slots = 3 + cluster[:, None] * per_cluster + np.arange(per_cluster)  # (C, per_cluster)
        components = rows * (num_uavs * width) + (uav * width)[:, None] + slots
        places = np.empty((num_layouts, num_users), dtype=np.intp)
        local = members[:, uav, cluster]                                # users of each layout
        places[np.repeat(np.arange(num_layouts), local[0].size), local.reshape(-1)] = (
            np.arange(local.size))
        return cls(flat_members, components, places)

    def rates(self, gain: FloatArray, interference_w: FloatArray | None, config: FloatArray,
              out: FloatArray | None = None, *, power_w: float, noise_w: float,
              bandwidth_hz: float | FloatArray, sic_residual: float = 0.0,
              estimate: tuple[FloatArray, FloatArray | None] | None = None
              ) -> tuple[FloatArray, NDArray[np.bool_], FloatArray]:
        """Every user's rate (B, N), whether it decodes every other member of its cluster
        (the strongest of its SIC chain), and its share, from its serving gain ``gain``
        (B, N), the interference it hears (W; None: none) and the configuration; the shares
        also go into ``out[0]`` (the observation's alpha_i) where given. ``estimate``: the
        estimated gains and interference (B, N) that decide the order instead (docs/model.md
        §16); a member that must remove a truly stronger member's message gets rate 0."""
        gains = gain.take(self.members)                                  # (B, C, M)
        noise_plus = (None if interference_w is None
                      else interference_w.take(self.members) + noise_w)
        order = None
        if estimate is not None:
            gains_hat = estimate[0].take(self.members)
            order = noma.sic_order(gains_hat if estimate[1] is None else
                                   gains_hat / (estimate[1].take(self.members) + noise_w),
                                   gains_hat)
        sinr, effective, order, shares = downlink_sinr(
            gains, noise_plus, config.take(self.components), power_w=power_w, noise_w=noise_w,
            sic_residual=sic_residual, order=order)
        if estimate is not None:
            sinr = np.where(noma.undecodable(effective, order), 0.0, sinr)
        rate = noma.rate_bps(sinr.take(self.places), bandwidth_hz)
        alpha = shares.take(self.places)
        if out is not None:
            out[0] = alpha
        return rate, noma.first_in_order(order).take(self.places), alpha

    def uplink_rates(self, gains: FloatArray, gain: FloatArray, config: FloatArray,
                     cross: NDArray[np.bool_] | None, serving: IntArray, *, power_w: float,
                     noise_w: float, bandwidth_hz: float | FloatArray,
                     sic_residual: float = 0.0
                     ) -> tuple[FloatArray, NDArray[np.bool_], FloatArray, FloatArray | None]:
        """The uplink (docs/model.md §17): every user's rate (B, N), whether its UAV decodes
        it first in its cluster, its transmit share beta_i and the other UAVs' users' power
        its UAV hears on its block (W; None without ``cross``), from every link's gain
        ``gains`` (B, U, N), each
        user's serving gain ``gain`` (B, N), the configuration (each member's beta) and
        ``cross`` (B, N, N): whether user j sends on user i's block to another UAV (None: no
        interference); ``serving`` (B, N) each user's UAV; ``power_w`` = P_u G. The UAV
        decodes from the strongest received signal down: member k hears the members decoded
        after it, ``sic_residual`` of those decoded before, and the interference."""
        beta = config.take(self.components)                              # (B, C, M)
        share = beta.take(self.places)                                  # (B, N)
        received = power_w * share * gain                                # (B, N), W
        interference = None
        if cross is not None:   # user j's power at user i's UAV: p_j G g_{u(i), j}
            at_uav = gains[np.arange(len(gains))[:, None], serving]       # (B, N, N)
            interference = np.where(cross, power_w * share[:, None, :] * at_uav, 0.0).sum(-1)
        sinr, order = uplink_sinr(
            received.take(self.members),
            None if interference is None else interference.take(self.members),
            noise_w=noise_w, sic_residual=sic_residual)
        rate = noma.rate_bps(sinr.take(self.places), bandwidth_hz)
        return rate, noma.first_in_order(order).take(self.places), share, interference


@dataclass(frozen=True)
class LayoutClusters:
    """One layout's clusters of M users, to value P configurations of it at once (the
    searches): ``members`` (C, M) their users, ``components`` (C, m) each cluster's power
    components as positions in a row of every UAV's S_max components (m = M - 1 in the
    downlink, M in the uplink), ``places`` (N,) each user's position among the C M members,
    ``serving`` (N,) each user's UAV and ``cross`` (N, N) whether user j sends on user i's
    block to another UAV (the uplink under full reuse; else None)."""

    members: IntArray
    components: IntArray
    places: IntArray
    serving: IntArray
    cross: NDArray[np.bool_] | None

    @classmethod
    def of(cls, association: Association, layout: int, shares_per_uav: int,
           per_cluster: int, cross: bool) -> LayoutClusters:
        """Layout ``layout`` of ``association``; ``cross``: whether users of other UAVs on a
        block interfere (the uplink under full reuse)."""
        uav, cluster = np.nonzero(association.has_cluster)
        members = association.members[layout, uav, cluster]                   # (C, M)
        components = ((uav * shares_per_uav)[:, None] + cluster[:, None] * per_cluster
                      + np.arange(per_cluster))
        places = np.empty(members.size, dtype=np.intp)
        places[members.reshape(-1)] = np.arange(members.size)
        serving = association.serving_uav[layout]
        block = association.cluster[layout]
        sends_across = ((block[:, None] == block[None, :])
                        & (serving[:, None] != serving[None, :])) if cross else None
        return cls(members, components, places, serving, sends_across)

    def rates(self, gain: FloatArray, interference_w: FloatArray | None, shares: FloatArray,
              *, power_w: float, noise_w: float, bandwidth_hz: float,
              sic_residual: float = 0.0) -> FloatArray:
        """The downlink: every user's rate (P, N) from its serving gain (P, N), the
        interference it hears (W, (P, N); None: none) and every UAV's components (P, U S)."""
        noise_plus = None if interference_w is None else interference_w[:, self.members] + noise_w
        sinr = downlink_sinr(gain[:, self.members], noise_plus, shares[:, self.components],
                             power_w=power_w, noise_w=noise_w, sic_residual=sic_residual)[0]
        return noma.rate_bps(sinr.reshape(len(sinr), -1)[:, self.places], bandwidth_hz)

    def user_shares(self, shares: FloatArray) -> FloatArray:
        """Every user's component (..., N) (the uplink's transmit share) from every UAV's
        (..., U S)."""
        beta = shares[..., self.components]                                   # (..., C, M)
        return beta.reshape(*beta.shape[:-2], -1)[..., self.places]

    def uplink_rates(self, gains: FloatArray, shares: FloatArray, *, power_w: float,
                     noise_w: float, bandwidth_hz: float, sic_residual: float = 0.0
                     ) -> FloatArray:
        """The uplink: every user's rate (P, N) from every link's gain (P, U, N) and every
        UAV's transmit shares (P, U S); ``power_w`` = P_u G."""
        share = self.user_shares(shares)                                       # (P, N)
        users = np.arange(len(self.serving))
        at_uav = gains[:, self.serving]                     # (P, N, N): g_{u(i), j}
        received = power_w * share * at_uav[:, users, users]
        interference = None
        if self.cross is not None:   # user j's power at user i's UAV: p_j G g_{u(i), j}
            interference = np.where(self.cross, power_w * share[:, None, :] * at_uav,
                                    0.0).sum(-1)[:, self.members]
        sinr = uplink_sinr(received[:, self.members], interference, noise_w=noise_w,
                           sic_residual=sic_residual)[0]
        return noma.rate_bps(sinr.reshape(len(sinr), -1)[:, self.places], bandwidth_hz)
