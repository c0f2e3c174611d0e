"""SoA by hand from docs/model.md §6, and the oracle: the reference optimum of docs/model.md,
brute force on a reduced lattice, and never below any other method."""

import itertools
import math

import numpy as np
import pytest

from adaptsky.evaluation.api import run_baseline
from adaptsky.rollouts.objective import constrained_sum_rate
from adaptsky.rollouts.oracle import lattice, oracle
from adaptsky.rollouts.rollout import hold, random_policy, rollout
from adaptsky.rollouts.soa import soa_configuration
from adaptsky.scenario import load_scenario
from adaptsky.sim import noma
from adaptsky.sim.layout import user_layouts
from adaptsky.sim.network import NetworkBatch
from tests.conftest import SCENARIOS, SUB6_RADIO, make_scenario


def _mmwave_snr(uav, user, noise_dbm):
    """P_T G g / sigma^2 for 20 dBm, 8 x 8 antennas, g = 10^-6.4 d^-2 (eq. 5, LoS)."""
    d2 = (uav[0] - user[0]) ** 2 + (uav[1] - user[1]) ** 2 + uav[2] ** 2
    return 0.1 * 64 * 10**-6.4 / d2 / 10 ** ((noise_dbm - 30) / 10)


def test_soa_on_nyc_mmwave_by_hand():
    scenario = load_scenario(SCENARIOS / "nyc_mmwave.toml")
    env = NetworkBatch(scenario, seed=0)
    uav_m, alpha_first = soa_configuration(env)
    # centroid of (4, 15), (-44, -49), (-5, 21), (47, 49) at the start height: (0.5, 9, 50)
    assert uav_m[0].tolist() == [0.5, 9.0, 50.0]
    # R_min = 0: the weak users (2 and 4, far) get nothing, the strong ones all the power
    assert alpha_first[0].tolist() == [1.0, 1.0]
    state = hold(scenario, uav_m, alpha_first, 3, env.layouts_m).rate_bps[-1, 0]
    se_1 = math.log2(1 + _mmwave_snr((0.5, 9, 50), (4, 15), -84.0))
    se_3 = math.log2(1 + _mmwave_snr((0.5, 9, 50), (-5, 21), -84.0))
    assert state / 2e9 == pytest.approx([se_1, 0.0, se_3, 0.0], rel=1e-9, abs=1e-12)
    # docs/model.md §6: 12.6 bit/s/Hz with the released code's -79 dBm
    released = load_scenario(SCENARIOS / "nyc_mmwave_released_code.toml")
    result = run_baseline(released, "soa", 5, user_layouts(released, 1))
    assert result.metrics["mean_sum_rate_bps"][0] / 2e9 == pytest.approx(12.59, abs=0.005)


def test_soa_gives_the_weak_user_exactly_r_min():
    scenario = make_scenario(reward={"min_se": 1.5})
    env = NetworkBatch(scenario, seed=0)
    uav_m, alpha_first = soa_configuration(env)
    # docs/model.md §6 formula for the weak user 2 (at (-44, -49)), by hand
    b = _mmwave_snr(uav_m[0], (-44, -49), -84.0)
    alpha_weak = (2**1.5 - 1) / 2**1.5 * (1 + 1 / b)
    assert alpha_first[0, 0] == pytest.approx(1 - alpha_weak, rel=1e-12)
    rates = env.evaluate_at(uav_m, alpha_first).rate_bps[0] / 2e9
    assert rates[1] == pytest.approx(1.5, rel=1e-9) and rates[3] == pytest.approx(1.5, rel=1e-9)


def test_oracle_finds_specs_optimum_on_the_training_layout():
    # docs/model.md §6: about 21.2 bit/s/Hz at (0, 18, 10) for -79 dBm, min_se = 0
    scenario = load_scenario(SCENARIOS / "nyc_mmwave_released_code.toml")
    result = oracle(scenario, user_layouts(scenario, 1))
    assert result.objective_bps[0] / 2e9 == pytest.approx(21.2, abs=0.05)
    assert result.uav_m[0].tolist() == [0.0, 18.0, 10.0]
    assert result.rate_bps[0].sum() == pytest.approx(result.objective_bps[0], rel=1e-12)


def _small(min_se, los="always", model="mmwave-nyc", **radio):
    """A reduced lattice: 12 m area, heights 10-16 m, alpha grid 0.1 ... 0.9."""
    return make_scenario(area={"side_m": 12.0}, users={"positions_m": None, "count": 4},
                         uav={"start_m": [0.0, 0.0, 12.0], "min_height_m": 10.0,
                              "max_height_m": 16.0, "step_m": [2.0, 2.0, 2.0],
                              "power_step": 0.1},
                         reward={"min_se": min_se}, channel={"model": model, "los": los},
                         radio=radio)


def _brute_force(scenario, users_m):
    """Every lattice point and every combination of alpha grid values, straight through the
    environment's own rate computation."""
    xs, ys, hs, alphas = lattice(scenario)
    best = np.zeros(len(users_m))
    env = NetworkBatch(scenario, num_envs=len(users_m), users_m=users_m)
    combos = list(itertools.product(alphas, repeat=scenario.num_clusters))
    for x, y, h in itertools.product(xs, ys, hs):
        for combo in combos:
            uav = np.tile([x, y, h], (len(users_m), 1))
            state = env.evaluate_at(uav, np.tile(combo, (len(users_m), 1)))
            best = np.maximum(best, constrained_sum_rate(state.rate_bps, scenario.min_rate_bps))
    return best


@pytest.mark.parametrize(("min_se", "los", "model", "radio"), [
    (0.0, "always", "mmwave-nyc", {}),
    (2.0, "always", "mmwave-nyc", {}),
    (4.0, "always", "mmwave-nyc", {}),       # infeasible everywhere: objective 0
    (1.0, "expected", "sub6-al-hourani", SUB6_RADIO),
])
def test_closed_form_oracle_equals_brute_force(min_se, los, model, radio):
    scenario = _small(min_se, los, model, **radio)
    users_m = user_layouts(scenario, 4, layout_seed=11)
    result = oracle(scenario, users_m)
    expected = _brute_force(scenario, users_m)
    assert result.objective_bps == pytest.approx(expected, rel=1e-12, abs=0.0)
    # min_se 4 exceeds what the alpha grid allows a weak user (log2(1 + 0.9 / 0.1) = 3.32)
    assert np.all(expected == 0) if min_se == 4.0 else np.all(expected > 0)


@pytest.mark.parametrize(("layout_seed", "min_se"), [(1, 0.0), (2, 1.0), (3, 2.0)])
def test_oracle_is_never_below_any_other_method(layout_seed, min_se):
    scenario = _small(min_se)
    users_m = user_layouts(scenario, 6, layout_seed=layout_seed)
    ceiling = oracle(scenario, users_m).objective_bps * (1 + 1e-12)
    env = NetworkBatch(scenario, num_envs=6, users_m=users_m)
    soa = hold(scenario, *soa_configuration(env), 1, users_m)
    walk = rollout(scenario, random_policy(32, layout_seed), 200, users_m)
    rng = np.random.default_rng(layout_seed)
    xs, ys, hs, alphas = lattice(scenario)
    points = [env.evaluate_at(
        np.column_stack([rng.choice(xs, 6), rng.choice(ys, 6), rng.choice(hs, 6)]),
        rng.choice(alphas, (6, 2))).rate_bps for _ in range(200)]
    for rates in (soa.rate_bps, walk.rate_bps, np.array(points)):
        assert np.all(constrained_sum_rate(rates, scenario.min_rate_bps) <= ceiling)
    assert np.any(ceiling > 0)


def test_oracle_refuses_sampled_los():
    from adaptsky.errors import AdaptskyError
    scenario = make_scenario(channel={"los": "sampled"})
    with pytest.raises(AdaptskyError, match="deterministic gains"):
        oracle(scenario, user_layouts(scenario, 1))


def test_cluster_sum_rate_grows_with_the_strong_share():
    # the monotonicity the oracle's closed form rests on, checked numerically
    shares = np.linspace(0.01, 0.99, 99)
    first, second = noma.cluster_sinr(shares, np.full(99, 3e-10), np.full(99, 2e-11), 1e12)
    total = np.log2(1 + first) + np.log2(1 + second)
    assert np.all(np.diff(total) > 0)
