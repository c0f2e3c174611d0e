"""Best response at every step for several UAVs and users that move (docs/model.md §9): each
UAV's bounded response is the exhaustive one, on static users it reaches at least today's best
response, and the evaluation runs it and says what it is."""

import numpy as np
import pytest

from adaptsky.evaluation.api import run_baseline
from adaptsky.rollouts.several_uavs import best_response
from adaptsky.rollouts.step_response import (
    STEP_RESPONSE_NOTE,
    StepResponseSearch,
    per_step_response,
)
from adaptsky.sim.network import NetworkBatch
from tests.conftest import SUB6_RADIO, make_scenario

WALK = {"model": "random-waypoint", "speed_min_mps": 1.0, "speed_max_mps": 3.0}


def _two(los="always", model="mmwave-nyc", min_se=0.0, mobility=None, residual=0.0):
    """Two UAVs, eight users in 60 m, heights 10-30 m, alpha step 0.05, full reuse."""
    radio = {**(SUB6_RADIO if model != "mmwave-nyc" else {}), "reuse": "full",
             "sic_residual": residual}
    users = {"count": 8, "positions_m": None}
    if mobility:
        users["mobility"] = mobility
    return make_scenario(users=users, area={"side_m": 60.0}, radio=radio,
                         uav={"count": 2, "start_m": [0.0, 0.0, 20.0], "min_height_m": 10.0,
                              "max_height_m": 30.0, "power_step": 0.05,
                              "min_separation_m": 10.0},
                         reward={"min_se": min_se}, channel={"model": model, "los": los})


@pytest.mark.parametrize(("los", "model", "min_se", "residual"), [
    ("always", "mmwave-nyc", 0.0, 0.0), ("always", "mmwave-nyc", 0.5, 0.0),
    ("expected", "sub6-al-hourani", 0.0, 0.05)])
def test_the_bounded_response_is_the_exhaustive_one(los, model, min_se, residual):
    scenario = _two(los, model, min_se, residual=residual)
    env = NetworkBatch(scenario, 2, seed=0)
    env.reset()
    rng = np.random.default_rng(1)
    for layout in range(2):
        search = StepResponseSearch(env, layout, env.users_m[layout])
        for _ in range(3):
            uav_m = np.column_stack([rng.uniform(-25, 25, (2, 2)), rng.uniform(10, 30, 2)])
            alpha = rng.choice(search.alphas, (2, 2))
            for u in range(2):
                exhaustive = search.respond(u, uav_m, alpha)
                bounded, valued = search.respond_bounded(u, uav_m, alpha, -np.inf)
                assert bounded.value == pytest.approx(exhaustive.value, rel=1e-12)
                total = len(search.planes[u]) * len(search.heights[u])
                assert valued <= total


def test_on_static_users_it_reaches_at_least_todays_best_response():
    scenario = _two()
    users_m = NetworkBatch(scenario, 2).users_m
    today = best_response(scenario, users_m)
    stepped = per_step_response(scenario, users_m, 2, seed=0)
    assert np.all(stepped.objective_bps[0] >= today.objective_bps * (1 - 1e-12))
    # standing users: the second step starts where the first ended, and stays
    assert np.all(stepped.objective_bps[1] >= stepped.objective_bps[0] * (1 - 1e-12))


def test_the_evaluation_runs_it_for_moving_users_and_says_what_it_is():
    scenario = _two(mobility=WALK)
    users_m = NetworkBatch(scenario, 1).users_m
    method = run_baseline(scenario, "best-response", 6, users_m, seed=3)
    assert method.details["note"] == STEP_RESPONSE_NOTE
    assert method.trace.uav_m.shape == (6, 1, 2, 3)
    assert method.metrics["mean_sum_rate_bps"][0] > 0
