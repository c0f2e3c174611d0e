"""Baselines under the built-in fading (issue 37, docs/model.md §11, docs/evaluation.md): the
oracle, a bound, refuses random gains in one line; best response and OMA search the mean gains
(without fading) and hold what they found under the policy's own fading draws, labelled a
reference for static policies; every baseline sees the same draws as the policy (common
random numbers)."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

from adaptsky.errors import AdaptskyError
from adaptsky.evaluation.api import eval_layouts, run_baseline
from adaptsky.evaluation.baselines import (
    FADING_NOTE,
    SAMPLED_LOS_FADING_NOTE,
    searched_note,
    searched_scenario,
)
from adaptsky.rollouts import several_uavs
from adaptsky.rollouts.oracle import has_oracle, oracle
from adaptsky.rollouts.rollout import hold, random_policy, rollout
from adaptsky.scenario.toml_writer import dumps
from adaptsky.sim.network import NetworkBatch
from adaptsky_cli.cli.main import main
from tests.conftest import SUB6_RADIO, make_scenario

SMALL = {"radio": SUB6_RADIO, "area": {"side_m": 20.0},
         "users": {"positions_m": [[-8.0, -6.0], [-3.0, -9.0], [7.0, 8.0], [2.0, 4.0]]},
         "uav": {"start_m": [0.0, 0.0, 12.0], "min_height_m": 10.0, "max_height_m": 16.0,
                 "step_m": [2.0, 2.0, 2.0], "power_step": 0.1}}


def _small(los: str = "always", fading: dict | None = None):
    channel = {"model": "sub6-al-hourani", "los": los,
               "fading": fading or {"model": "rician", "correlation": 0.5}}
    return make_scenario(channel=channel, **SMALL)


def test_the_oracle_refuses_fading_in_one_line():
    scenario = _small()
    assert not has_oracle(scenario)
    with pytest.raises(AdaptskyError, match=re.escape(
            "scenario 'test': channel.fading.model is 'rician'; the oracle needs "
            "deterministic gains")):
        oracle(scenario, eval_layouts(scenario, None))


@pytest.mark.parametrize(("los", "note"), [("always", FADING_NOTE),
                                           ("sampled", SAMPLED_LOS_FADING_NOTE)])
def test_best_response_searches_the_mean_gains_and_holds_under_the_draws(los, note):
    scenario = _small(los)
    users_m = eval_layouts(scenario, None)
    searched = searched_scenario(scenario)
    assert searched.channel.fading.model == "none" and searched.channel.los in ("always",
                                                                                 "expected")
    assert searched_note(scenario) == note and searched_note(searched) is None
    found = several_uavs.best_response(searched, users_m)
    result = run_baseline(scenario, "best-response", 30, users_m, seed=4)
    assert result.details["note"] == note
    trace = result.trace
    assert trace.rate_bps.shape[0] == 30                       # held every step
    assert np.all(trace.uav_m == found.uav_m[:, 0][None])
    assert trace.sum_rate_bps.std() > 0                        # the gains fade
    # common random numbers: the rates are those of the held configuration under the
    # draws of seed 4, the policy's
    again = hold(scenario, found.uav_m[:, 0], found.alpha_first[:, 0], 30, users_m, seed=4)
    np.testing.assert_array_equal(trace.rate_bps, again.rate_bps)


def test_oma_holds_its_configuration_under_the_draws():
    scenario = _small(fading={"model": "rayleigh"})
    users_m = eval_layouts(scenario, None)
    result = run_baseline(scenario, "oma", 20, users_m)
    assert result.details["note"] == FADING_NOTE
    assert result.trace.rate_bps.shape == (20, 1, 4) and np.all(result.trace.alpha == 0.5)
    assert result.trace.sum_rate_bps.std() > 0


def test_random_and_soa_see_the_policys_fading_draws():
    """The random baseline is a rollout like the policy's: with the same seed and the same
    actions its rates are the policy's, fading and all."""
    scenario = _small()
    users_m = eval_layouts(scenario, None)
    count = NetworkBatch(scenario, 1).actions.count
    first = rollout(scenario, random_policy(count, 9), 25, users_m, seed=2)
    second = rollout(scenario, random_policy(count, 9), 25, users_m, seed=2)
    np.testing.assert_array_equal(first.rate_bps, second.rate_bps)
    soa = run_baseline(scenario, "soa", 25, users_m, seed=2)
    assert soa.trace.rate_bps.shape[0] == 25 and soa.trace.sum_rate_bps.std() > 0


def test_baseline_on_the_command_line_says_what_it_is(tmp_path, capsys):
    path = tmp_path / "f.toml"
    path.write_text(dumps(_small().model_dump()))
    assert main(["baseline", str(path), "--method", "best-response", "--steps", "5",
                 "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["methods"]["best-response"]["note"] == (
        FADING_NOTE)
    assert main(["baseline", str(path), "--method", "oracle", "--steps", "5"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "channel.fading.model is 'rician'" in err[0]
