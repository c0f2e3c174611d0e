"""The tracking baseline (docs/evaluation.md): each UAV at its full step toward its group's
current centroid at its own height, SoA's split there; checked by hand on static users, with
the policy's own moves of the users, and through the evaluation."""

import numpy as np
import pytest

from adaptsky.evaluation.api import run_baseline
from adaptsky.rollouts.rollout import random_policy, rollout
from adaptsky.rollouts.soa import soa_configuration
from adaptsky.rollouts.tracking import track
from adaptsky.sim.network import NetworkBatch
from tests.conftest import make_scenario

USERS = [[30.0, 10.0], [34.0, 14.0], [26.0, -2.0], [38.0, 2.0]]    # centroid (32, 6)


def test_tracking_flies_its_full_step_to_the_centroid_then_is_soa():
    scenario = make_scenario(users={"positions_m": USERS},
                             uav={"start_m": [0.0, 0.0, 40.0], "step_m": [2.0, 3.0, 1.0]})
    users_m = np.array([USERS])
    trace = track(scenario, 20, users_m)
    # x: 2 m a step for 16 steps; y: 3 m a step to 6 m in 2 steps; the height stays
    assert trace.uav_m[0, 0].tolist() == [2.0, 3.0, 40.0]
    assert trace.uav_m[1, 0].tolist() == [4.0, 6.0, 40.0]
    assert trace.uav_m[2, 0].tolist() == [6.0, 6.0, 40.0]
    assert trace.uav_m[15, 0].tolist() == [32.0, 6.0, 40.0]
    assert trace.uav_m[19, 0].tolist() == [32.0, 6.0, 40.0]
    # there it is SoA: the same position (at the start height) and the same split and rates
    soa_uav, _ = soa_configuration(NetworkBatch(scenario, 1, users_m=users_m))
    assert np.array_equal(trace.uav_m[-1], soa_uav)
    soa = run_baseline(scenario, "soa", 1, users_m)
    np.testing.assert_allclose(trace.rate_bps[-1], soa.trace.rate_bps[0], rtol=1e-12)
    # a step's energy is that of its move (docs/model.md §10): the first flies 3.6 m, the
    # last hovers
    hover_j = NetworkBatch(scenario, 1, users_m=users_m).hover_energy_j
    assert trace.energy_j[-1, 0] == pytest.approx(float(np.ravel(hover_j)[0]), rel=1e-12)
    assert abs(trace.energy_j[0, 0] - trace.energy_j[-1, 0]) > 1.0


def test_tracking_follows_moving_users_with_the_policys_draws():
    scenario = make_scenario(users={"count": 4, "positions_m": None, "mobility": {
        "model": "gauss-markov", "mean_speed_mps": 1.5, "heading_sigma_deg": 20.0}},
        area={"side_m": 100.0})
    users_m = NetworkBatch(scenario, 2).users_m
    tracked = track(scenario, 30, users_m, seed=5)
    walk = rollout(scenario, random_policy(32, 1), 30, users_m, seed=5)
    np.testing.assert_array_equal(tracked.users_m, walk.users_m)   # common random numbers
    # every step the UAV moves at most its step toward the centroid of the users it saw
    steps = np.abs(np.diff(tracked.uav_m, axis=0))
    assert steps[..., :2].max() <= 1.0 + 1e-12 and steps[..., 2].max() == 0


def test_tracking_is_a_baseline_of_every_evaluation():
    scenario = make_scenario(users={"count": 8, "positions_m": None,
                                    "mobility": {"model": "random-waypoint",
                                                 "speed_min_mps": 0.5, "speed_max_mps": 2.0}},
                             uav={"count": 2}, area={"side_m": 200.0})
    users_m = NetworkBatch(scenario, 1).users_m
    method = run_baseline(scenario, "tracking", 15, users_m, seed=2)
    assert method.trace.uav_m.shape == (15, 1, 2, 3)
    assert method.metrics["mean_sum_rate_bps"][0] > 0
    assert method.trace.users_m is not None
