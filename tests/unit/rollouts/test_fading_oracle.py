"""The oracle under the built-in fading (docs/model.md §11): the fixed position and shares with
the largest mean objective over the policy's own draws, against brute force straight through
held rollouts (every lattice point, every share), its own configuration held, and one line for
what it cannot serve."""

import itertools

import numpy as np
import pytest

from adaptsky.errors import AdaptskyError
from adaptsky.evaluation.api import run_baseline
from adaptsky.rollouts.fading_oracle import STATIC_CEILING_NOTE, fading_oracle
from adaptsky.rollouts.oracle import lattice
from adaptsky.rollouts.rollout import hold, random_policy, rollout
from adaptsky.sim.layout import user_layouts
from tests.conftest import SUB6_RADIO, make_scenario

STEPS = 6
BOX = {"x_m": 1.0, "y_m": 3.0, "width_m": 2.0, "depth_m": 1.0, "height_m": 11.0}


def _small(users: int, fading: dict, buildings: bool = False, **sections):
    """A reduced lattice (4 m area, x, y in {-2, 0, 2}, heights 10-16 m, alpha 0.1 ... 0.9),
    sub-6, the built-in fading; with ``buildings`` one box and geometric LoS."""
    world = ({"world": {"buildings": "listed", "building": [BOX]},
              "channel": {"model": "sub6-al-hourani", "los": "geometric", "fading": fading}}
             if buildings else
             {"channel": {"model": "sub6-al-hourani", "los": "always", "fading": fading}})
    return make_scenario(**{"area": {"side_m": 8.0}, "users": {"count": users},
                            "uav": {"start_m": [0.0, 0.0, 12.0], "min_height_m": 10.0,
                                    "max_height_m": 16.0, "step_m": [2.0, 2.0, 2.0],
                                    "power_step": 0.1},
                            "reward": {"min_se": 0.0}, "radio": SUB6_RADIO, **world,
                            **sections})


RICIAN = {"model": "rician", "k0_db": 0.0, "k90_db": 15.0, "correlation": 0.5}
RAYLEIGH = {"model": "rayleigh"}


def _held_mean(scenario, users_m, uav, alpha, seed):
    trace = hold(scenario, np.array([uav]), np.array([alpha]), STEPS, users_m, seed)
    return trace.sum_rate_bps.mean()


@pytest.mark.parametrize(("fading", "buildings", "seed"), [
    (RICIAN, False, 0), (RICIAN, True, 3), (RAYLEIGH, True, 5)])
def test_the_fading_oracle_equals_brute_force_over_held_rollouts(fading, buildings, seed):
    scenario = _small(2, fading, buildings)
    users_m = user_layouts(scenario, 1, layout_seed=7)
    xs, ys, hs, alphas = lattice(scenario)
    from adaptsky.sim.network import NetworkBatch
    city = NetworkBatch(scenario, 1, users_m=users_m).city
    best = 0.0
    for x, y, h in itertools.product(xs, ys, hs):
        if city is not None and (city.footprints_m[0, 0] <= x <= city.footprints_m[0, 1]
                                 and city.footprints_m[0, 2] <= y <= city.footprints_m[0, 3]
                                 and h <= BOX["height_m"]):
            continue                                    # no UAV inside the building
        for alpha in alphas:
            best = max(best, _held_mean(scenario, users_m, [x, y, h], [alpha], seed))
    found = fading_oracle(scenario, users_m, STEPS, seed)
    assert found.objective_bps[0] == pytest.approx(best, rel=1e-12)
    assert _held_mean(scenario, users_m, found.uav_m[0], found.alpha_first[0], seed) == (
        pytest.approx(found.objective_bps[0], rel=1e-12))


def test_two_clusters_every_share_pair_and_no_policy_above_the_ceiling():
    scenario = _small(4, RICIAN, buildings=True)
    users_m = user_layouts(scenario, 1, layout_seed=2)
    found = fading_oracle(scenario, users_m, STEPS, seed=1)
    ceiling = found.objective_bps[0] * (1 + 1e-12)
    _, _, _, alphas = lattice(scenario)
    at_found = [_held_mean(scenario, users_m, found.uav_m[0], pair, 1)
                for pair in itertools.product(alphas, repeat=2)]
    assert max(at_found) <= ceiling
    assert max(at_found) == pytest.approx(found.objective_bps[0], rel=1e-12)
    # a static policy elsewhere, and a moving one over the same draws
    rng = np.random.default_rng(0)
    xs, ys, hs, _ = lattice(scenario)
    for _ in range(20):
        point = [rng.choice(xs), rng.choice(ys), rng.choice(hs)]
        assert _held_mean(scenario, users_m, point, rng.choice(alphas, 2), 1) <= ceiling
    walk = rollout(scenario, random_policy(32, 4), STEPS, users_m, seed=1)
    assert walk.sum_rate_bps.mean() < ceiling * 1.5   # a moving policy may pass: only sane


def test_the_evaluation_labels_the_oracle_a_static_ceiling():
    scenario = _small(4, RICIAN, buildings=True)
    users_m = user_layouts(scenario, 2, layout_seed=4)
    method = run_baseline(scenario, "oracle", STEPS, users_m, seed=2)
    assert method.details["note"] == STATIC_CEILING_NOTE
    found = fading_oracle(scenario, users_m, STEPS, seed=2)
    assert method.details["objective_bps"] == pytest.approx(found.objective_bps, rel=1e-12)
    # its trace is the held configuration under the policy's own draws, every step
    assert method.trace.rate_bps.shape[0] == STEPS
    assert method.trace.sum_rate_bps.mean(axis=0) == pytest.approx(found.objective_bps,
                                                                   rel=1e-12)
    # best response of one UAV is the oracle itself
    response = run_baseline(scenario, "best-response", STEPS, users_m, seed=2)
    assert response.details["note"] == STATIC_CEILING_NOTE
    assert response.details["objective_bps"] == pytest.approx(found.objective_bps, rel=1e-12)


@pytest.mark.parametrize(("sections", "message"), [
    ({"reward": {"min_se": 1.0}}, "min_se is 1: under fading the oracle needs min_se = 0"),
])
def test_what_the_fading_oracle_cannot_serve_is_one_line(sections, message):
    scenario = _small(4, RICIAN, **sections)
    with pytest.raises(AdaptskyError, match=message):
        fading_oracle(scenario, user_layouts(scenario, 1), STEPS)
