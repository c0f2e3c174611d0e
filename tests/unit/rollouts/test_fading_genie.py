"""The per-step oracle for users that move under the built-in fading (docs/model.md §6 and
§11): against brute force straight through held rollouts (every lattice point and share held
through the same draws, the best at each step), branch and bound against every point valued,
its bound on |h|^2 against a dense scan of eq. 11.1, at least every policy at every step, and
its place in the evaluation."""

import itertools
import math

import numpy as np
import pytest

from adaptsky.evaluation.api import run_baseline
from adaptsky.rollouts.fading_genie import (
    FADING_GENIE_NOTE,
    largest_power_gain,
    per_step_fading_oracle,
    step_fading_oracle,
)
from adaptsky.rollouts.rollout import hold
from adaptsky.rollouts.search import LatticeBoxes, lattice
from adaptsky.sim.layout import user_layouts
from adaptsky.sim.network import NetworkBatch
from tests.conftest import SUB6_RADIO, make_scenario
from tests.helpers.genie import assert_at_least_every_policy

WALK = {"model": "gauss-markov", "mean_speed_mps": 1.5, "heading_sigma_deg": 30.0}
RICIAN = {"model": "rician", "k0_db": 0.0, "k90_db": 15.0, "correlation": 0.9}
RAYLEIGH = {"model": "rayleigh"}
SMALL_BOX = {"x_m": 1.0, "y_m": 3.0, "width_m": 2.0, "depth_m": 1.0, "height_m": 11.0}
LARGE_BOX = {"x_m": 6.0, "y_m": -4.0, "width_m": 6.0, "depth_m": 4.0, "height_m": 25.0}
STEPS = 5


def _scenario(fading: dict, buildings: dict | None, users: int, side_m: float,
              heights_m: tuple[float, float], step_m: float, power_step: float):
    channel = {"model": "sub6-al-hourani", "los": "geometric" if buildings else "always",
               "fading": fading}
    world = {"world": {"buildings": "listed", "building": [buildings]}} if buildings else {}
    return make_scenario(users={"count": users, "positions_m": None, "mobility": WALK},
                         area={"side_m": side_m},
                         uav={"start_m": [0.0, 0.0, heights_m[0] + 2 * step_m],
                              "min_height_m": heights_m[0], "max_height_m": heights_m[1],
                              "step_m": [step_m] * 3, "power_step": power_step},
                         reward={"min_se": 0.0}, radio=SUB6_RADIO, channel=channel, **world)


def _small(fading: dict, buildings: bool):
    """x, y in {-2, 0, 2}, heights 10-16 m, alpha 0.1 ... 0.9: a lattice to hold whole."""
    return _scenario(fading, SMALL_BOX if buildings else None, 2, 8.0, (10.0, 16.0), 2.0, 0.1)


def _large(fading: dict, buildings: bool):
    """A 40 m area, heights 10-30 m at 2 m, alpha step 0.05: 3 x 3 x 2 boxes."""
    return _scenario(fading, LARGE_BOX if buildings else None, 4, 40.0, (10.0, 30.0), 2.0,
                     0.05)


@pytest.mark.parametrize(("fading", "buildings", "seed"), [
    (RICIAN, False, 0), (RICIAN, True, 3), (RAYLEIGH, True, 5)])
def test_the_per_step_oracle_equals_brute_force_over_held_rollouts(fading, buildings, seed):
    scenario = _small(fading, buildings)
    users_m = user_layouts(scenario, 1, layout_seed=7)
    xs, ys, hs, alphas = lattice(scenario)
    city = NetworkBatch(scenario, 1, users_m=users_m).city
    best = np.zeros(STEPS)
    for x, y, h, alpha in itertools.product(xs, ys, hs, alphas):
        if city is not None and (city.footprints_m[0, 0] <= x <= city.footprints_m[0, 1]
                                 and city.footprints_m[0, 2] <= y <= city.footprints_m[0, 3]
                                 and h <= SMALL_BOX["height_m"]):
            continue                                    # no UAV inside the building
        trace = hold(scenario, np.array([[x, y, h]]), np.array([[alpha]]), STEPS, users_m,
                     seed)
        best = np.maximum(best, trace.sum_rate_bps[:, 0])
    found = per_step_fading_oracle(scenario, users_m, STEPS, seed)
    np.testing.assert_allclose(found.objective_bps[:, 0], best, rtol=1e-12)
    assert len(np.unique(best)) == STEPS                # the draws change every step


@pytest.mark.parametrize(("fading", "buildings"), [
    (RICIAN, False), (RICIAN, True), (RAYLEIGH, False)])
def test_branch_and_bound_is_every_point_valued_at_every_step(fading, buildings):
    scenario = _large(fading, buildings)
    users_m = NetworkBatch(scenario, 2).users_m
    found = per_step_fading_oracle(scenario, users_m, STEPS, seed=1)
    env = NetworkBatch(scenario, 2, seed=1, users_m=users_m)
    env.reset()
    radio = scenario.radio
    snr = radio.tx_power_w * radio.antenna_gain / radio.noise_w
    total = LatticeBoxes(lattice(scenario)[:3]).count
    for step in range(STEPS):
        env.hold_step(np.broadcast_to(scenario.uav.start_m, (2, 3)),
                      np.full((2, 2), scenario.uav.start_alpha))
        np.testing.assert_array_equal(env.users_m, found.users_m[step])
        scattered = env.step_scattered()[:, :, 0]
        for layout in range(2):
            exhaustive = step_fading_oracle(env, layout, env.users_m[layout],
                                            scattered[:, layout], None, snr)
            assert exhaustive[3] == total
            assert found.objective_bps[step, layout] == pytest.approx(exhaustive[0],
                                                                      rel=1e-12, abs=0)
    assert found.points_valued.max() < total                  # it pruned


def test_the_bound_on_the_power_gain_is_the_largest_over_k():
    """Eq. 11.1, |h|^2 = ((sqrt K + Re s)^2 + (Im s)^2) / (K + 1), scanned over sqrt K."""
    rng = np.random.default_rng(11)
    for _ in range(200):
        real, imag = rng.normal(0, 1.2, 2)
        low, high = sorted(rng.uniform(0, 6, 2))
        scan = max(((u + real) ** 2 + imag ** 2) / (u * u + 1)
                   for u in np.linspace(low, high, 20001))
        found = float(largest_power_gain(np.array(low), np.array(high), np.array(real),
                                         np.array(real * real + imag * imag)))
        assert scan <= found * (1 + 1e-12)
        assert found == pytest.approx(scan, rel=1e-6)
    # a hand case: s = 1 (a = r = 1): the stationary point is u = 1, |h|^2 = 4 / 2 = 2
    assert float(largest_power_gain(np.array(0.0), np.array(3.0), np.array(1.0),
                                    np.array(1.0))) == pytest.approx(2.0, rel=1e-12)
    assert math.isclose(((1 + 1) ** 2) / 2, 2.0)


def test_the_per_step_oracle_is_at_least_every_policy_at_every_step():
    scenario = _large(RICIAN, buildings=True)
    users_m = NetworkBatch(scenario, 2).users_m
    found = per_step_fading_oracle(scenario, users_m, 12, seed=2)
    assert_at_least_every_policy(found, scenario, users_m, 12, seed=2)


def test_the_evaluation_takes_it_for_the_oracle_of_moving_users_under_fading():
    scenario = _small(RICIAN, buildings=False)
    users_m = user_layouts(scenario, 2, layout_seed=4)
    found = per_step_fading_oracle(scenario, users_m, STEPS, seed=2)
    for method in ("oracle", "best-response"):
        result = run_baseline(scenario, method, STEPS, users_m, seed=2)
        assert result.details["note"] == FADING_GENIE_NOTE
        np.testing.assert_allclose(result.details["objective_bps"],
                                   found.objective_bps.mean(axis=0), rtol=1e-12)
        # its trace holds each step's configuration under that step's draws
        np.testing.assert_allclose(result.trace.sum_rate_bps, found.objective_bps,
                                   rtol=1e-12)
