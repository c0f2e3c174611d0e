"""NOMA clusters of M users (docs/model.md §15): the simulator's rates against a plain scalar
formula with loops for M = 2, 3, 4 with and without the SIC residual, for one UAV and two;
the shares of the components; near-far dealing; actions that carry M - 1 shares per cluster;
and the refusals of what does not run on them yet."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from adaptsky.sim import noma
from adaptsky.sim.actions import ActionSet
from adaptsky.sim.layout import cluster_users
from adaptsky.sim.network import NetworkBatch
from adaptsky_cli.cli.main import main
from tests.conftest import ROOT, make_scenario
from tests.helpers.cli import one_line, refusal_of_scenario
from tests.helpers.scalar_models import (
    BANDWIDTH_HZ,
    assert_oracle_is,
    brute_force_lattice,
    clusters_of,
    listed_clusters_env,
    scalar_chain_network,
    scalar_shares,
    small_lattice,
)

RADIO = {"thermal_noise_dbm": -79.0}
USERS_M = [[-30.0, 10.0], [25.0, -40.0], [5.0, 5.0], [45.0, 35.0], [-10.0, -45.0],
           [38.0, 2.0], [-48.0, -20.0], [12.0, 30.0], [-22.0, 40.0], [30.0, 30.0],
           [0.0, -15.0], [-40.0, 44.0]]


@pytest.mark.parametrize("size", [2, 3, 4])
@pytest.mark.parametrize("sic_residual", [0.0, 0.05, 1.0])
def test_one_uav_rates_match_the_scalar_formula(size, sic_residual):
    env = listed_clusters_env(USERS_M, size, {**RADIO, "sic_residual": sic_residual})
    uav_m = [12.0, -7.0, 40.0]
    components = np.random.default_rng(size).uniform(0.05, 0.95, (12 // size, size - 1))
    state = env.evaluate_at(np.array([uav_m]), components.reshape(1, -1))
    clusters = clusters_of(env)
    assert clusters == [[tuple(range(k * size, (k + 1) * size)) for k in range(12 // size)]]
    _, _, sinr, rate = scalar_chain_network([uav_m], USERS_M, clusters, [components.tolist()],
                                            "full", sic_residual=sic_residual)
    assert state.rate_bps[0] == pytest.approx(rate, rel=1e-12)
    shares = [share for c in components.tolist() for share in scalar_shares(c)]
    assert state.alpha[0] == pytest.approx(shares, rel=1e-14)
    assert state.rate_bps[0] / BANDWIDTH_HZ == pytest.approx(
        [math.log2(1 + value) for value in sinr], rel=1e-12)
    # the strongest of each cluster (the largest gain: one UAV) decodes every other member
    gain = state.gain[0]
    strongest = [max(cluster, key=lambda i: gain[i]) for cluster in clusters[0]]
    assert np.flatnonzero(state.strong[0]).tolist() == sorted(strongest)


@pytest.mark.parametrize("sic_residual", [0.0, 0.02])
def test_two_uavs_rates_match_the_scalar_formula(sic_residual):
    users_m = [[2 * x, 2 * y] for x, y in USERS_M]
    scenario = make_scenario(
        area={"side_m": 200.0}, radio={**RADIO, "sic_residual": sic_residual},
        users={"positions_m": users_m, "association": "listed", "cluster_size": 3,
               "uav": [0, 1] * 6, "pairing": "listed"},
        uav={"count": 2, "start_m": [0.0, 0.0, 50.0], "min_separation_m": 10.0})
    env = NetworkBatch(scenario, seed=0)
    uav_m = np.array([[[-30.0, 20.0, 40.0], [40.0, 10.0, 60.0]]])
    components = np.array([[[0.25, 0.7, 0.5, 0.1], [0.9, 0.4, 0.3, 0.6]]])
    state = env.evaluate_at(uav_m, components)
    clusters = clusters_of(env)
    assert clusters == [[(0, 2, 4), (6, 8, 10)], [(1, 3, 5), (7, 9, 11)]]
    per_cluster = [[c[:2], c[2:]] for c in components[0].tolist()]
    _, interference, _, rate = scalar_chain_network(uav_m[0], users_m, clusters, per_cluster,
                                                    "full", sic_residual=sic_residual)
    assert state.interference_w[0] == pytest.approx(interference, rel=1e-12)
    assert state.rate_bps[0] == pytest.approx(rate, rel=1e-12)


def test_the_chain_of_two_is_the_pair_rule():
    """M = 2 through the chain gives eq. 2's numbers: bit for bit with perfect SIC."""
    rng = np.random.default_rng(3)
    gain = 10 ** rng.uniform(-12, -8, (500, 2))
    gain[:50, 1] = gain[:50, 0]                       # ties: the first member is strong
    alpha = rng.uniform(0.01, 0.99, 500)
    first_strong = noma.is_strong(gain[:, 0], gain[:, 1], gain[:, 0], gain[:, 1], True)
    for residual in (0.0, 0.1):
        pair = np.stack([noma.user_sinr(alpha, 1 - alpha, gain[:, 0], first_strong, 1e11,
                                        residual),
                         noma.user_sinr(1 - alpha, alpha, gain[:, 1], ~first_strong, 1e11,
                                        residual)], axis=1)
        chain = noma.chain_sinr(noma.member_shares(alpha[:, None]), gain, gain, 1e11, residual)
        if residual:
            np.testing.assert_allclose(chain, pair, rtol=1e-15)
        else:
            assert np.array_equal(chain, pair)


def test_shares_of_components():
    shares = noma.member_shares(np.array([[0.5, 0.5, 0.5], [0.2, 0.25, 0.75]]))
    np.testing.assert_allclose(shares, [[0.5, 0.25, 0.125, 0.125], [0.2, 0.2, 0.45, 0.15]],
                               rtol=1e-15)


def test_near_far_deals_a_snake():
    # gains rank the users 4 > 0 > 5 > 2 > 1 > 3; K = 2 clusters of 3
    gains = np.array([[9.0, 2.0, 3.0, 1.0, 10.0, 5.0]])
    members = cluster_users(gains, "near-far", 3)
    # round 0: ranks 0, 1 (users 4, 0); round 1 backwards: ranks 3, 2 (users 2, 5);
    # round 2: ranks 4, 5 (users 1, 3)
    assert members.tolist() == [[[4, 2, 1], [0, 5, 3]]]
    assert cluster_users(gains, "listed", 3).tolist() == [[[0, 1, 2], [3, 4, 5]]]
    first, second = cluster_users(gains, "near-far", 2)[..., 0], cluster_users(
        gains, "near-far", 2)[..., 1]
    assert first.tolist() == [[4, 0, 5]] and second.tolist() == [[3, 1, 2]]


def test_dense_actions_carry_m_minus_one_shares_per_cluster():
    scenario = make_scenario(users={"positions_m": USERS_M, "pairing": "listed",
                                    "cluster_size": 4}, uav={"power_step": 0.05})
    actions = ActionSet.of(scenario)
    assert actions.num_components == 3 + 3 * 3 and actions.count == 2 ** 12
    env = NetworkBatch(scenario, seed=0)
    env.reset()
    directions = np.array([1, -1, 1] + [1, -1, 1] * 3)
    env.step(np.array([actions.encode(directions)]))
    expected = 0.5 + 0.05 * directions[3:]
    np.testing.assert_allclose(env.alpha_first[0], expected, rtol=1e-15)
    assert env.state.alpha[0] == pytest.approx(
        [s for k in range(3) for s in scalar_shares(expected[3 * k:3 * k + 3])], rel=1e-14)


@pytest.mark.parametrize(("users", "words"), [
    ({"count": 7, "cluster_size": 3}, "users.count: 7 users; NOMA clusters of cluster_size = 3 "
                                      "users need a multiple of 3"),
    ({"positions_m": USERS_M[:8], "cluster_size": 3},
     "8 users given; NOMA clusters of cluster_size = 3 users need a multiple of 3"),
    ({"count": 12, "cluster_size": 9}, "users.cluster_size: Input should be less than or equal "
                                       "to 8"),
])
def test_sizes_that_do_not_divide_are_one_line(tmp_path, capsys, users, words):
    body = "\n".join(f"{key} = {value!r}" for key, value in users.items())
    assert words in refusal_of_scenario(tmp_path, capsys, f"[users]\n{body}")


def test_groups_of_several_uavs_that_do_not_divide_are_one_line(tmp_path, capsys):
    line = refusal_of_scenario(tmp_path, capsys, "[users]\ncount = 12\ncluster_size = 4\n"
                               "[uav]\ncount = 2")
    assert ("12 users do not split into 2 equal groups of a multiple of users.cluster_size = 4"
            in line)


@pytest.mark.parametrize("method", ["soa", "tracking", "centroid"])
def test_references_of_pairs_refuse_clusters_of_three_in_one_line(capsys, method):
    scenario = ROOT / "scenarios" / "three_user_clusters_mmwave.toml"
    assert main(["baseline", str(scenario), "--method", method]) == 1
    line = one_line(capsys)
    assert f"users.cluster_size: '{method}' plans or searches NOMA pairs only" in line


def test_random_runs_on_clusters_of_three(capsys):
    scenario = ROOT / "scenarios" / "three_user_clusters_mmwave.toml"
    assert main(["baseline", str(scenario), "--method", "random", "--steps", "20"]) == 0
    assert "random: outage" in capsys.readouterr().out


def _brute_force_oracle(scenario, users_m):
    """The best objective over every lattice point and every share component vector of
    every cluster, with scalar loops (docs/model.md §15; one UAV, LoS always)."""
    from tests.helpers.scalar_models import ANTENNA_GAIN, NOISE_W, TX_POWER_W

    size, step = scenario.cluster_size, scenario.uav.power_step
    grid = [round(step * i, 12) for i in range(1, round(1 / step))]
    s, eps = TX_POWER_W * ANTENNA_GAIN / NOISE_W, scenario.radio.sic_residual

    def spectral(components, g):
        shares, ses = scalar_shares(components), []
        for j in range(size):
            heard = sum(shares[m] if (g[m], -m) > (g[j], -j) else eps * shares[m]
                        for m in range(size) if m != j)
            ses.append(math.log2(1 + shares[j] * s * g[j] / (heard * s * g[j] + 1)))
        return ses

    return brute_force_lattice(scenario, users_m, spectral,
                               list(itertools.product(grid, repeat=size - 1)))


@pytest.mark.parametrize("bounded", [True, False])
@pytest.mark.parametrize(("sic_residual", "min_se"), [(0.0, 0.0), (0.05, 0.0), (0.0, 1.5)])
def test_the_oracle_of_clusters_of_three_equals_brute_force(monkeypatch, sic_residual, min_se,
                                                             bounded):
    """By branch and bound (the built-in model declares monotone gains) and by valuing every
    point (a model that declares nothing)."""
    from adaptsky.rollouts import cluster_oracle as module
    from adaptsky.rollouts.cluster_oracle import cluster_oracle

    if not bounded:
        monkeypatch.setattr(module, "declares_monotone_gains", lambda model: False)

    users_m = [[-15.0, 10.0], [12.0, -18.0], [3.0, 4.0], [18.0, 16.0], [-8.0, -19.0],
               [10.0, 0.0]]
    scenario = small_lattice(users_m, {**RADIO, "sic_residual": sic_residual}, min_se,
                             cluster_size=3)
    assert_oracle_is(cluster_oracle(scenario, np.array([users_m])),
                     _brute_force_oracle(scenario, users_m))


def test_the_gymnasium_env_of_clusters_of_three_passes_the_checker():
    from gymnasium.utils.env_checker import check_env

    from adaptsky.envs.gym_env import NomaUavEnv
    from adaptsky.scenario.loading import load_scenario

    env = NomaUavEnv(load_scenario(ROOT / "scenarios" / "three_user_clusters_mmwave.toml"))
    assert env.observation_space.shape == (4 * 6 + 1,)
    assert env.action_space.n == 2 ** (3 + 2 * 2)
    check_env(env, skip_render_check=True)


def test_oma_of_clusters_of_three_equals_brute_force():
    """Each user of a cluster of three on a third of the band with a third of the power,
    R_i = (W/3) log2(1 + P_T G g_i / sigma^2), at the best lattice point."""
    from adaptsky.rollouts.several_uavs import best_oma
    from tests.helpers.scalar_models import ANTENNA_GAIN, NOISE_W, TX_POWER_W, scalar_gain

    users_m = [[-15.0, 10.0], [12.0, -18.0], [3.0, 4.0], [18.0, 16.0], [-8.0, -19.0],
               [10.0, 0.0]]
    scenario = small_lattice(users_m, RADIO, 0.5, cluster_size=3)
    found = best_oma(scenario, np.array([users_m]))
    s = TX_POWER_W * ANTENNA_GAIN / NOISE_W
    best = -math.inf
    for x in range(-20, 21, 10):
        for y in range(-20, 21, 10):
            for h in range(10, 51, 10):
                rates = [BANDWIDTH_HZ / 3 * math.log2(1 + s * scalar_gain([x, y, h], user,
                                                                           "always"))
                         for user in users_m]
                if min(rates) >= 0.5 * BANDWIDTH_HZ:
                    best = max(best, sum(rates))
    assert_oracle_is(found, best)


def test_oma_runs_on_the_shipped_clusters_of_three(capsys):
    scenario = ROOT / "scenarios" / "three_user_clusters_mmwave.toml"
    assert main(["baseline", str(scenario), "--method", "oma", "--steps", "3"]) == 0
    assert "OMA" in capsys.readouterr().out
