"""Baselines under the built-in fading (issue 37, docs/model.md §11, docs/evaluation.md): the
oracle, a bound, refuses random gains in one line; best response and OMA search the mean gains
(without fading) and hold what they found under the policy's own fading draws, best response
with each cluster's share the one of the largest mean sum rate over those draws (checked by
brute force with the scalar formulas of docs/model.md §1), labelled a reference for static
policies; every baseline sees the same draws as the policy (common random numbers)."""

from __future__ import annotations

import json
import math
import re

import numpy as np
import pytest

from adaptsky.errors import AdaptskyError
from adaptsky.evaluation.api import eval_layouts, run_baseline
from adaptsky.references.searched import searched_note, searched_scenario
from adaptsky.rollouts import several_uavs
from adaptsky.rollouts.fading_oracle import STATIC_CEILING_NOTE
from adaptsky.rollouts.mean_shares import mean_best_shares
from adaptsky.rollouts.oracle import has_oracle, oracle
from adaptsky.rollouts.rollout import hold, random_policy, rollout
from adaptsky.scenario.toml_writer import dumps
from adaptsky.sim.lattice import share_lattice
from adaptsky.sim.network import NetworkBatch
from adaptsky_cli.cli.main import main
from tests.conftest import SUB6_RADIO, make_scenario

FADING_NOTE = ("searched on the mean gains, without fading (channel.fading.model = 'none': "
               "E|h|^2 = 1), each cluster's share then the one of the largest mean sum rate over "
               "the policy's own fading draws there, its rates under the policy's own fading "
               "draws: a reference for static policies, not a bound")
SAMPLED_NOTE = ("searched on the expected gains without fading (channel.los = 'expected', "
                "channel.fading.model = 'none'), each cluster's share then the one of the "
                "largest mean sum rate over the policy's own LoS and fading draws there, its "
                "rates under the policy's own LoS and fading draws: a reference for static "
                "policies, not a bound")
OMA_NOTE = ("searched on the mean gains, without fading (channel.fading.model = 'none': "
            "E|h|^2 = 1), its rates under the policy's own fading draws: a reference for "
            "static policies, not a bound")
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


def test_best_response_of_one_uav_under_fading_is_the_static_ceiling():
    # where the fading oracle applies (one UAV, LoS not sampled, R_min = 0) best response is
    # the oracle itself (tests/unit/rollouts/test_fading_oracle.py)
    scenario = _small()
    result = run_baseline(scenario, "best-response", 30, eval_layouts(scenario, None), seed=4)
    assert result.details["note"] == STATIC_CEILING_NOTE
    assert searched_note(scenario) == FADING_NOTE     # what several UAVs' best response says


@pytest.mark.parametrize(("los", "note"), [("sampled", SAMPLED_NOTE)])
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
    # draws of seed 4, the policy's; the shares chosen for them do at least as well as the
    # shares searched on the mean gains
    shares = mean_best_shares(scenario, found.uav_m[:, 0], found.alpha_first[:, 0], 30,
                              users_m, seed=4)
    again = hold(scenario, found.uav_m[:, 0], shares, 30, users_m, seed=4)
    np.testing.assert_array_equal(trace.rate_bps, again.rate_bps)
    as_searched = hold(scenario, found.uav_m[:, 0], found.alpha_first[:, 0], 30, users_m,
                       seed=4)
    assert trace.sum_rate_bps.mean() >= as_searched.sum_rate_bps.mean()


def _spec_cluster_mean_bps(gains_first, gains_second, share, snr_scale, bandwidth_hz):
    """A cluster's mean sum rate over steps, straight from docs/model.md §1 (eqs. 2-3): the
    user with the larger gain (the first on a tie) is strong and cancels the other;
    SINR_s = a_s s g_s, SINR_w = a_w s g_w / (a_s s g_w + 1)."""
    total = 0.0
    for g1, g2 in zip(gains_first, gains_second, strict=True):
        a1, a2 = share, 1 - share
        if g1 >= g2:
            sinr1, sinr2 = a1 * snr_scale * g1, a2 * snr_scale * g2 / (a1 * snr_scale * g2 + 1)
        else:
            sinr1, sinr2 = a1 * snr_scale * g1 / (a2 * snr_scale * g1 + 1), a2 * snr_scale * g2
        total += bandwidth_hz * (math.log2(1 + sinr1) + math.log2(1 + sinr2))
    return total / len(gains_first)


def test_the_shares_maximise_each_clusters_mean_sum_rate_over_the_draws():
    """One UAV, R_min = 0: each cluster's share is the lattice share of the largest mean sum
    rate over the policy's own draws at the held position, by brute force with the scalar
    formulas of docs/model.md §1 on the draws' gains."""
    scenario = _small(fading={"model": "rayleigh"})
    users_m = eval_layouts(scenario, None)
    steps, seed = 12, 3
    found = several_uavs.best_response(searched_scenario(scenario), users_m)
    uav_m, searched_shares = found.uav_m[:, 0], found.alpha_first[:, 0]
    shares = mean_best_shares(scenario, uav_m, searched_shares, steps, users_m, seed)
    env = NetworkBatch(scenario, 1, seed=seed, users_m=users_m)
    env.reset()
    gains = np.array([env.hold_step(uav_m, searched_shares).gain[0]
                      for _ in range(steps)])                        # (T, N): the draws
    radio, lattice = scenario.radio, share_lattice(scenario)
    snr_scale = radio.tx_power_w * radio.antenna_gain / radio.noise_w
    for k in range(scenario.num_clusters):
        first, second = env.first_user[0, k], env.second_user[0, k]
        means = [_spec_cluster_mean_bps(gains[:, first], gains[:, second], share, snr_scale,
                                        radio.bandwidth_hz) for share in lattice]
        assert shares[0, k] == lattice[int(np.argmax(means))], (k, means)


def test_with_a_minimum_rate_the_shares_stay_as_searched_and_say_so():
    scenario = make_scenario(reward={"min_se": 0.5},
                             channel={"model": "sub6-al-hourani",
                                      "fading": {"model": "rayleigh"}}, **SMALL)
    users_m = eval_layouts(scenario, None)
    found = several_uavs.best_response(searched_scenario(scenario), users_m)
    result = run_baseline(scenario, "best-response", 5, users_m, seed=1)
    assert "(its shares as searched: a minimum rate couples the clusters)" in (
        result.details["note"])
    again = hold(scenario, found.uav_m[:, 0], found.alpha_first[:, 0], 5, users_m, seed=1)
    np.testing.assert_array_equal(result.trace.rate_bps, again.rate_bps)


def test_oma_holds_its_configuration_under_the_draws():
    scenario = _small(fading={"model": "rayleigh"})
    users_m = eval_layouts(scenario, None)
    result = run_baseline(scenario, "oma", 20, users_m)
    assert result.details["note"] == OMA_NOTE
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
        STATIC_CEILING_NOTE)
    assert main(["baseline", str(path), "--method", "oracle", "--steps", "5", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["methods"]["oracle"]["note"] == (
        STATIC_CEILING_NOTE)
    strict = tmp_path / "strict.toml"
    strict.write_text(dumps(make_scenario(reward={"min_se": 1.0}, channel={
        "model": "sub6-al-hourani", "fading": {"model": "rician"}}, **SMALL).model_dump()))
    assert main(["baseline", str(strict), "--method", "oracle", "--steps", "5"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "under fading the oracle needs min_se = 0" in err[0]
