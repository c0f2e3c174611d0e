"""Scalar re-implementations written straight from the paper (docs/model.md): the mmWave
NYC gain, the NOMA network of several UAVs with loops, the propulsion power."""

from __future__ import annotations

import math


def scalar_power_w(v: float) -> float:
    """P(V) = P0 (1 + 3V^2/U^2) + Pi (sqrt(1 + V^4/(4 v0^4)) - V^2/(2 v0^2))^(1/2)
    + d0 rho s A V^3 / 2, with W = 20, rho = 1.225, R = 0.4, A = 0.503, Omega = 300,
    U = 120, s = 0.05, d0 = 0.6, k = 0.1, delta = 0.012."""
    w, rho, radius, area, omega, tip, s, d0, k, delta = (
        20.0, 1.225, 0.4, 0.503, 300.0, 120.0, 0.05, 0.6, 0.1, 0.012)
    p0 = delta / 8 * rho * s * area * omega**3 * radius**3
    pi = (1 + k) * w**1.5 / math.sqrt(2 * rho * area)
    v0 = math.sqrt(w / (2 * rho * area))
    induced = math.sqrt(math.sqrt(1 + v**4 / (4 * v0**4)) - v**2 / (2 * v0**2))
    return p0 * (1 + 3 * v**2 / tip**2) + pi * induced + 0.5 * d0 * rho * s * area * v**3


TX_POWER_W = 0.1          # 20 dBm
ANTENNA_GAIN = 64         # 8 x 8
NOISE_W = 10 ** ((-79.0 - 30) / 10)
BANDWIDTH_HZ = 2e9


def scalar_gain(uav, user, los):
    """mmWave NYC (eq. 4-5): the LoS gain, or the expected one."""
    d = math.sqrt((uav[0] - user[0]) ** 2 + (uav[1] - user[1]) ** 2 + uav[2] ** 2)
    g_los, g_nlos = 10 ** -6.4 * d ** -2.0, 10 ** -7.2 * d ** -2.92
    if los == "always":
        return g_los
    theta = math.degrees(math.asin(uav[2] / d))
    p = 1 / (1 + 9.6117 * math.exp(-0.1581 * (theta - 9.6117)))
    return p * g_los + (1 - p) * g_nlos


def scalar_interference(gains, clusters, uav_and_cluster, reuse):
    """The downlink's I_i of every user (docs/model.md §9) with loops: P_T G times the gain
    from every other UAV that has a cluster on its subchannel k (full reuse; 0 otherwise);
    ``uav_and_cluster[i]`` is user i's (u, k)."""
    pg = TX_POWER_W * ANTENNA_GAIN
    interference = []
    for i in range(len(uav_and_cluster)):
        u, k = uav_and_cluster[i]
        total = 0.0
        if reuse == "full":
            for other in range(len(gains)):
                if other != u and k < len(clusters[other]):
                    total += pg * gains[other][i]
        interference.append(total)
    return interference


def scalar_network(uavs, users, serving, clusters, alpha_first, reuse, los="always",
                   sic_residual=0.0):
    """Gains, interference, strong flags, SINR and rates of docs/model.md §9 with loops.

    ``clusters[u]`` lists UAV u's clusters as (first, second) user pairs; alpha_first[u][k]
    is the share of cluster k's first user; ``sic_residual`` epsilon the share of its
    partner's signal the strong user keeps (docs/model.md §13)."""
    gains = [[scalar_gain(uav, user, los) for user in users] for uav in uavs]
    cluster_of = {}
    for u, pairs in enumerate(clusters):
        for k, (first, second) in enumerate(pairs):
            cluster_of[first] = (u, k, second, alpha_first[u][k])
            cluster_of[second] = (u, k, first, 1 - alpha_first[u][k])
    pg = TX_POWER_W * ANTENNA_GAIN
    strong, sinr, rate, oma = [], [], [], []
    interference = scalar_interference(gains, clusters, {i: place[:2] for i, place
                                                         in cluster_of.items()}, reuse)
    for i in range(len(users)):
        u, k, partner, alpha = cluster_of[i]
        c_i = gains[u][i] / (interference[i] + NOISE_W)
        c_p = gains[u][partner] / (interference[partner] + NOISE_W)
        is_strong = c_i > c_p
        strong.append(is_strong)
        signal = alpha * pg * gains[u][i]
        if is_strong:
            residual = sic_residual * (1 - alpha) * pg * gains[u][i]
            value = signal / (residual + interference[i] + NOISE_W)
        else:
            alpha_s = 1 - alpha
            value = signal / (alpha_s * pg * gains[u][i] + interference[i] + NOISE_W)
        sinr.append(value)
        rate.append(BANDWIDTH_HZ * math.log2(1 + value))
        oma.append(BANDWIDTH_HZ / 2 * math.log2(
            1 + pg * gains[u][i] / (interference[i] + NOISE_W)))
    return gains, interference, strong, sinr, rate, oma


def scalar_shares(components):
    """A cluster's M shares from its M - 1 components (docs/model.md §15), with a loop:
    member j takes c_j of what the members before it left, the last member the rest."""
    shares, left = [], 1.0
    for c in components:
        shares.append(left * c)
        left *= 1 - c
    return [*shares, left]


def scalar_chain_network(uavs, users, clusters, components, reuse, sic_residual=0.0):
    """Interference, SINR and rates of clusters of any size M (docs/model.md §15) with loops.

    ``clusters[u]`` lists UAV u's clusters, each a tuple of its M users in member order;
    ``components[u][k]`` the M - 1 share components of cluster k of UAV u. Each member is
    ranked by its effective gain g / (I + sigma^2), then its gain, then its place (the first
    listed is stronger); it hears the stronger members' shares and ``sic_residual`` of the
    weaker ones'."""
    gains = [[scalar_gain(uav, user, "always") for user in users] for uav in uavs]
    pg = TX_POWER_W * ANTENNA_GAIN
    place = {}
    for u, members_of in enumerate(clusters):
        for k, members in enumerate(members_of):
            shares = scalar_shares(components[u][k])
            for j, i in enumerate(members):
                place[i] = (u, k, j, shares[j])
    interference = scalar_interference(gains, clusters, {i: p[:2] for i, p in place.items()},
                                       reuse)
    sinr, rate = [], []
    for i in range(len(users)):
        u, k, j, alpha = place[i]
        key_i = (gains[u][i] / (interference[i] + NOISE_W), gains[u][i], -j)
        heard = 0.0
        for m in clusters[u][k]:
            if m == i:
                continue
            _, _, j_m, alpha_m = place[m]
            key_m = (gains[u][m] / (interference[m] + NOISE_W), gains[u][m], -j_m)
            heard += alpha_m if key_m > key_i else sic_residual * alpha_m
        value = alpha * pg * gains[u][i] / (heard * pg * gains[u][i] + interference[i]
                                            + NOISE_W)
        sinr.append(value)
        rate.append(BANDWIDTH_HZ * math.log2(1 + value))
    return gains, interference, sinr, rate


def scalar_uplink_network(uavs, users, clusters, betas, reuse, user_tx_power_w,
                          sic_residual=0.0):
    """Interference, SINR and rates of the uplink (docs/model.md §17) with loops.

    ``clusters[u]`` lists UAV u's clusters, each a tuple of its users; ``betas[i]`` user i's
    transmit share. User i sends beta_i P_u; its UAV receives p_i G g_{u,i}; the UAV decodes a
    cluster from the strongest received signal down (ties: the first listed), member k
    hearing those decoded after it, the residual of those before and the users of other UAVs
    on the same block under full reuse."""
    gains = [[scalar_gain(uav, user, "always") for user in users] for uav in uavs]
    pg = user_tx_power_w * ANTENNA_GAIN
    place = {}
    for u, members_of in enumerate(clusters):
        for k, members in enumerate(members_of):
            for j, i in enumerate(members):
                place[i] = (u, k, j)
    interference, sinr, rate = [], [], []
    for i in range(len(users)):
        u, k, _ = place[i]
        total = 0.0
        if reuse == "full":
            for other in range(len(users)):
                u_o, k_o, _ = place[other]
                if u_o != u and k_o == k:
                    total += betas[other] * pg * gains[u][other]
        interference.append(total)
    for i in range(len(users)):
        u, k, j = place[i]
        received = betas[i] * pg * gains[u][i]
        heard = 0.0
        for m in clusters[u][k]:
            if m == i:
                continue
            other = betas[m] * pg * gains[u][m]
            decoded_before = (other, -place[m][2]) > (received, -j)
            heard += sic_residual * other if decoded_before else other
        value = received / (heard + interference[i] + NOISE_W)
        sinr.append(value)
        rate.append(BANDWIDTH_HZ * math.log2(1 + value))
    return gains, interference, sinr, rate


def small_lattice(users_m, radio, min_se, **users):
    """A one-UAV scenario over 40 m x 40 m with a lattice of 10 m steps and heights 10-50 m,
    shares on a 0.1 grid, for the searches' brute-force checks."""
    from tests.conftest import make_scenario

    return make_scenario(
        area={"side_m": 40.0}, radio=radio, reward={"min_se": min_se},
        users={"positions_m": users_m, "pairing": "listed", **users},
        uav={"start_m": [0.0, 0.0, 50.0], "step_m": [10.0, 10.0, 10.0], "min_height_m": 10.0,
             "max_height_m": 50.0, "power_step": 0.1})


def assert_oracle_is(found, expected):
    """An oracle's result on one layout: its objective, and the simulator's sum rate at the
    configuration it names, equal to ``expected`` (> 0) to 1e-12."""
    import pytest

    assert expected > 0
    assert found.objective_bps[0] == pytest.approx(expected, rel=1e-12)
    assert found.rate_bps[0].sum() == pytest.approx(expected, rel=1e-12)


def brute_force_lattice(scenario, users_m, spectral, vectors):
    """The best objective over every lattice point of a :func:`small_lattice` scenario and
    every vector of ``vectors`` in every cluster (users listed in clusters of M), with scalar
    loops: ``spectral(vector, gains)`` gives the cluster's members' spectral efficiencies at
    those gains; a cluster's value is their sum times W where each meets the scenario's
    min SE, its best over the vectors."""
    uav, half_m, size = scenario.uav, scenario.area.side_m / 2, scenario.cluster_size
    min_se = scenario.reward.min_se
    best = 0.0
    for x in range(round(-half_m), round(half_m) + 1, round(uav.step_m[0])):
        for y in range(round(-half_m), round(half_m) + 1, round(uav.step_m[1])):
            for h in range(round(uav.min_height_m), round(uav.max_height_m) + 1,
                           round(uav.step_m[2])):
                total = 0.0
                for k in range(len(users_m) // size):
                    g = [scalar_gain([x, y, h], users_m[i], "always")
                         for i in range(k * size, (k + 1) * size)]
                    cluster_best = -math.inf
                    for vector in vectors:
                        ses = spectral(vector, g)
                        if min(ses) >= min_se:
                            cluster_best = max(cluster_best, sum(ses) * BANDWIDTH_HZ)
                    total += cluster_best
                best = max(best, total)
    return best


def clusters_of(env):
    """Every UAV's clusters in layout 0 of ``env`` as tuples of their members (the
    association's), the form the scalar networks above take."""
    members = env.association.members[0]
    return [[tuple(int(i) for i in cluster) for cluster in members[u] if cluster[0] >= 0]
            for u in range(len(members))]


def listed_clusters_env(users_m, size, radio):
    """A one-UAV network (seed 0) of the users ``users_m`` listed in clusters of ``size``,
    with ``radio``: the scalar formulas' checks of the rates."""
    from adaptsky.sim.network import NetworkBatch
    from tests.conftest import make_scenario

    scenario = make_scenario(users={"positions_m": users_m, "pairing": "listed",
                                    "cluster_size": size}, radio=radio)
    return NetworkBatch(scenario, seed=0)
