"""The per-step oracle for users that move (docs/model.md §6): branch and bound against the
exhaustive search at every step (every point valued), and at least every policy's objective at
every step, over the same draws."""

import numpy as np
import pytest

from adaptsky.evaluation.api import run_baseline
from adaptsky.rollouts.genie import GENIE_NOTE, per_step_oracle, step_oracle
from adaptsky.rollouts.objective import constrained_sum_rate
from adaptsky.rollouts.search import LatticeBoxes, lattice
from adaptsky.sim.network import NetworkBatch
from tests.conftest import SUB6_RADIO, make_scenario
from tests.helpers.genie import assert_at_least_every_policy

WALK = {"model": "gauss-markov", "mean_speed_mps": 2.0, "heading_sigma_deg": 30.0}
BOX = {"x_m": 6.0, "y_m": -4.0, "width_m": 6.0, "depth_m": 4.0, "height_m": 25.0}


def _moving(min_se=0.0, los="always", model="mmwave-nyc", residual=0.0, buildings=False):
    """A 40 m area, heights 10-30 m, alpha step 0.05, four users walking."""
    channel = {"model": model, "los": los}
    sections = {"radio": {**(SUB6_RADIO if model != "mmwave-nyc" else {}),
                          "sic_residual": residual}}
    if buildings:
        channel["los"] = "geometric"
        sections["world"] = {"buildings": "listed", "building": [BOX]}
    return make_scenario(users={"count": 4, "positions_m": None, "mobility": WALK},
                         area={"side_m": 40.0},
                         uav={"start_m": [0.0, 0.0, 20.0], "min_height_m": 10.0,
                              "max_height_m": 30.0, "power_step": 0.05},
                         reward={"min_se": min_se}, channel=channel, **sections)


@pytest.mark.parametrize(("min_se", "los", "model", "residual", "buildings"), [
    (0.0, "always", "mmwave-nyc", 0.0, False),
    (1.0, "always", "mmwave-nyc", 0.0, False),
    (0.0, "expected", "sub6-al-hourani", 0.0, False),
    (0.5, "expected", "sub6-al-hourani", 0.05, False),
    (0.0, "always", "sub6-al-hourani", 0.0, True),
])
def test_branch_and_bound_is_the_exhaustive_search_at_every_step(min_se, los, model, residual,
                                                                  buildings):
    scenario = _moving(min_se, los, model, residual, buildings)
    users_m = NetworkBatch(scenario, 2).users_m
    found = per_step_oracle(scenario, users_m, 8, seed=1)
    env = NetworkBatch(scenario, 2, seed=1, users_m=users_m)
    env.reset()
    radio = scenario.radio
    snr = radio.tx_power_w * radio.antenna_gain / radio.noise_w
    total = LatticeBoxes(lattice(scenario)[:3]).count
    for step in range(8):
        env.hold_step(np.broadcast_to(scenario.uav.start_m, (2, 3)),
                      np.full((2, 2), scenario.uav.start_alpha))
        np.testing.assert_array_equal(env.users_m, found.users_m[step])
        for layout in range(2):
            # every point valued, in lattice order: the oracle's search (the same values up
            # to the last bits numpy's vector loops give a point at another array position)
            exhaustive = step_oracle(env, layout, env.users_m[layout], None, snr)
            assert exhaustive[3] == total
            assert found.objective_bps[step, layout] == pytest.approx(exhaustive[0],
                                                                      rel=1e-12, abs=0)
    assert found.points_valued.max() < total                 # it pruned


def test_the_per_step_oracle_is_at_least_every_policy_at_every_step():
    scenario = _moving(min_se=0.5)
    users_m = NetworkBatch(scenario, 3).users_m
    found = per_step_oracle(scenario, users_m, 25, seed=2)
    assert_at_least_every_policy(found, scenario, users_m, 25, seed=2)


def test_the_evaluation_runs_it_for_moving_users_and_says_what_it_is():
    scenario = _moving()
    users_m = NetworkBatch(scenario, 1).users_m
    method = run_baseline(scenario, "oracle", 10, users_m, seed=0)
    assert method.details["note"] == GENIE_NOTE
    assert method.trace.rate_bps.shape[0] == 10
    found = per_step_oracle(scenario, users_m, 10, seed=0)
    per_step = constrained_sum_rate(method.trace.rate_bps, scenario.min_rate_bps)
    np.testing.assert_allclose(per_step, found.objective_bps, rtol=1e-12)
