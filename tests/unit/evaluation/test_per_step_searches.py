"""The per-step searches where the users move (issue 52, items 3 and 5, docs/evaluation.md):
best response at every step ends ``baseline`` and ``eval`` with their time per step and writes
its eval file; several UAVs with moving users and the built-in fading (or sampled LoS) get best
response at every step searched on the mean (expected) gains and valued under the policy's own
draws, labelled a reference; where one UAV's per-step oracle cannot apply, the refusal names
the true reason (a minimum rate, sampled LoS), not the moving users."""

from __future__ import annotations

import json
import re
import time

import h5py
import numpy as np
import pytest

from adaptsky.channels.contract import LinkGeometry
from adaptsky.errors import AdaptskyError
from adaptsky.evaluation.api import eval_layouts, run_baseline
from adaptsky.references.registry import resolve
from adaptsky.report.eval_table import oracle_line, search_lines
from adaptsky.rollouts.rollout import random_policy, rollout
from adaptsky.rollouts.step_response import STEP_RESPONSE_NOTE, per_step_response
from adaptsky.scenario import load_scenario
from adaptsky.scenario.variants import with_values
from adaptsky.sim.links import carrier_hz
from adaptsky.sim.network import NetworkBatch
from adaptsky.store.eval_file import read_eval_metrics
from adaptsky_cli.cli.main import main
from tests.conftest import SCENARIOS
from tests.helpers.evaluation import small_two_uavs
from tests.helpers.rates_reference import noma_rates

TWO_MOVING = SCENARIOS / "two_uavs_moving_mmwave.toml"
MOVING_FADING = SCENARIOS / "moving_users_fading_sub6.toml"
WALK = {"model": "random-waypoint", "speed_min_mps": 1.0, "speed_max_mps": 3.0}
RICIAN = {"model": "rician", "k0_db": 0.0, "k90_db": 15.0, "correlation": 0.9}
FADING_STEP_NOTE = ("best response at every step's user positions on the mean gains, without "
                    "fading (channel.fading.model = 'none': E|h|^2 = 1), from the previous "
                    "step's configuration, its rates under the policy's own fading draws: a "
                    "reference, not a bound")
SAMPLED_STEP_NOTE = ("best response at every step's user positions on the expected gains "
                     "(channel.los = 'expected'), from the previous step's configuration, its "
                     "rates under the policy's own LoS draws: a reference, not a bound")


def _text(out: str) -> str:
    return " ".join(out.split())   # (lines fold at the terminal's width)


def test_baseline_best_response_at_every_step_ends_with_its_time_per_step(capsys):
    assert main(["baseline", str(TWO_MOVING), "--method", "best-response", "--steps",
                 "1"]) == 0
    text = _text(capsys.readouterr().out)
    assert re.search(r"best-response: [\d.]+ rounds per layout on average \(at most \d+\), "
                     r"converged on 1 of 1 layouts; [\d.]+ s per step", text)
    assert not re.search(r"\bnan\b", text) and not re.search(r"\d s per layout", text)
    assert f"best-response: {STEP_RESPONSE_NOTE}" in text


def test_eval_against_best_response_at_every_step_writes_its_file(tmp_path, capsys):
    run = tmp_path / "two.h5"
    assert main(["train", str(TWO_MOVING), "--seeds", "0", "--episodes", "1", "--steps", "2",
                 "--workers", "1", "--quiet", "--out", str(run),
                 "--set", "agent.hidden_sizes=[16]", "--set", "agent.batch_size=8",
                 "--set", "agent.memory_size=100"]) == 0
    capsys.readouterr()
    out = tmp_path / "eval.h5"
    assert main(["eval", str(run), "--compare", "best-response", "--steps", "1", "--out",
                 str(out)]) == 0
    text = _text(capsys.readouterr().out)
    assert re.search(r"% of best response on average \(median [\d.]+%\); best-response "
                     r"search [\d.]+ s per step", text)
    with h5py.File(out, "r") as f:
        search = f["methods/best-response/search"]
        assert search.attrs["seconds_per_step"] > 0
        assert "seconds_per_layout" not in search.attrs
        assert search["rounds"].shape == search["converged"].shape == (1,)
        assert f["methods/best-response/trajectory/uav_m"].shape == (1, 1, 2, 3)
    _, methods = read_eval_metrics(out)
    assert methods["best-response"]["search_seconds_per_step"] > 0
    assert main(["inspect", str(out)]) == 0
    assert "s per step" in _text(capsys.readouterr().out)


def test_the_per_step_oracle_says_its_time_per_step_not_nan(tmp_path, capsys):
    run = tmp_path / "walk.h5"
    assert main(["train", str(SCENARIOS / "moving_users_sub6.toml"), "--seeds", "0",
                 "--episodes", "1", "--steps", "2", "--workers", "1", "--quiet", "--out",
                 str(run), "--set", "agent.hidden_sizes=[16]", "--set", "agent.batch_size=8",
                 "--set", "agent.memory_size=100"]) == 0
    capsys.readouterr()
    out = tmp_path / "eval.h5"
    assert main(["eval", str(run), "--compare", "oracle,best-response", "--steps", "2",
                 "--out", str(out), "--json"]) == 0
    results = json.loads(capsys.readouterr().out)
    for name in ("oracle", "best-response"):
        entry = results["methods"][name]
        assert entry["seconds_per_step"] > 0 and "seconds_per_layout" not in entry
    seconds = results["methods"]["oracle"]["seconds_per_step"]
    assert oracle_line(results).endswith(f"; oracle search {seconds:.2f} s per step")
    assert search_lines(results)[0].endswith(" s per step")
    with h5py.File(out, "r") as f:    # one UAV's best response is the per-step oracle
        assert f["methods/best-response/search"].attrs["seconds_per_step"] > 0


def test_a_reference_without_a_time_says_none():
    results = {"policy_steady_pct_of_oracle": {"mean": 80.0, "median": 81.0},
               "methods": {"oracle": {}}}
    assert oracle_line(results) == ("policy steady state: 80.0% of the oracle on average "
                                    "(median 81.0%)")


def _moving(tmp_path, **channel):
    """small_two_uavs with its four users walking (random waypoint) and ``channel``."""
    return load_scenario(small_two_uavs(tmp_path, users={"mobility": WALK}, channel=channel))


def _mean_gain_sum_rate(scenario, uav_m, alpha_first, users_m, home_m):
    """The sum rate (bit/s) on the mean gains (the LoS gains, E|h|^2 = 1) of UAVs ``uav_m``
    (U, 3) with shares ``alpha_first`` (U, K) and users at ``users_m`` (N, 2), the clusters
    those of the layout ``home_m``, composed plainly (tests/helpers/rates_reference.py)."""
    env = NetworkBatch(scenario, 1, users_m=home_m[None])
    uavs = len(uav_m)
    geometry = LinkGeometry.between(uav_m, np.broadcast_to(users_m, (uavs, *users_m.shape)),
                                    user_height_m=scenario.users.height_m,
                                    carrier_hz=carrier_hz(scenario))
    gain = env.channel.gain_los(geometry)[None]                              # (1, U, N)
    radio = scenario.radio
    return float(noma_rates(alpha_first[None], gain, env.association,
                            tx_power_w=radio.tx_power_w, antenna_gain=radio.antenna_gain,
                            noise_w=radio.noise_w, bandwidth_hz=radio.bandwidth_hz,
                            reuse=radio.reuse).rate_bps.sum())


def test_several_uavs_with_moving_users_and_fading_get_best_response_at_every_step(tmp_path):
    scenario = _moving(tmp_path, fading=RICIAN)
    users_m = eval_layouts(scenario, None)
    steps = 6
    started_s = time.process_time()
    method = run_baseline(scenario, "best-response", steps, users_m, seed=2)
    spent_s = time.process_time() - started_s
    assert method.details["note"] == FADING_STEP_NOTE
    trace = method.trace
    # the users walk as under a policy with the same seed (the same draws, fading and all)
    walked = rollout(scenario, random_policy(NetworkBatch(scenario, 1).actions.count, 5),
                     steps, users_m, seed=2).users_m
    np.testing.assert_array_equal(trace.users_m, walked)
    assert not np.array_equal(trace.users_m[0], trace.users_m[-1])
    # best response at every step, held step by step
    found = per_step_response(scenario, users_m, steps, seed=2)
    np.testing.assert_array_equal(trace.uav_m, found.uav_m)
    np.testing.assert_array_equal(found.users_m, trace.users_m)
    # searched on the mean gains: each step's objective is the sum rate there
    mean_gain = [_mean_gain_sum_rate(scenario, found.uav_m[t, 0], found.alpha_first[t, 0],
                                     found.users_m[t, 0], users_m[0]) for t in range(steps)]
    np.testing.assert_allclose(found.objective_bps[:, 0], mean_gain, rtol=1e-9)
    assert method.details["objective_bps"][0] == pytest.approx(np.mean(mean_gain), rel=1e-9)
    # valued under the fading draws: the rates are not those of the mean gains
    assert np.abs(trace.sum_rate_bps[:, 0] / mean_gain - 1).max() > 1e-3
    assert 0 < steps * method.details["seconds_per_step"] <= spent_s   # process time
    assert np.all(method.details["rounds"] >= 1)


def test_several_uavs_with_moving_users_and_sampled_los_get_it_too(tmp_path):
    scenario = _moving(tmp_path, los="sampled")
    users_m = eval_layouts(scenario, None)
    method = run_baseline(scenario, "best-response", 3, users_m, seed=1)
    assert method.details["note"] == SAMPLED_STEP_NOTE
    assert method.trace.uav_m.shape == (3, 1, 2, 3)
    assert method.metrics["mean_sum_rate_bps"][0] > 0


def test_the_eval_of_such_a_run_labels_it_a_reference(tmp_path, capsys):
    path = small_two_uavs(tmp_path, users={"mobility": WALK}, channel={"fading": RICIAN})
    run = tmp_path / "run.h5"
    assert main(["train", str(path), "--seeds", "0", "--episodes", "1", "--steps", "3",
                 "--workers", "1", "--quiet", "--out", str(run)]) == 0
    capsys.readouterr()
    assert main(["eval", str(run), "--compare", "best-response", "--steps", "3", "--out",
                 str(tmp_path / "e.h5")]) == 0
    text = _text(capsys.readouterr().out)
    assert f"best-response: {FADING_STEP_NOTE}" in text
    assert "% of best response on average" in text


def _refusal(scenario, method):
    with pytest.raises(AdaptskyError) as caught:
        resolve(method, scenario, "--compare")
    return str(caught.value)


@pytest.mark.parametrize("method", ["oracle", "best-response"])
def test_one_uav_under_fading_with_a_minimum_rate_is_refused_for_the_minimum_rate(method,
                                                                                 capsys):
    assert main(["baseline", str(MOVING_FADING), "--method", method, "--steps", "2",
                 "--set", "reward.min_se=1"]) == 1
    assert capsys.readouterr().err.strip().splitlines() == [
        "scenario 'moving_users_fading_sub6': the oracle under fading: reward.min_se is 1: "
        "under fading the oracle needs min_se = 0, where the clusters' shares are separable"]


@pytest.mark.parametrize("method", ["oracle", "best-response"])
def test_one_uav_with_moving_users_and_sampled_los_is_refused_for_the_sampled_los(method):
    scenario = load_scenario(SCENARIOS / "moving_users_sub6.toml")
    sampled = with_values(scenario, "channel", {"los": "sampled"}, "sampled")
    message = _refusal(sampled, method)
    name = "the oracle" if method == "oracle" else method
    assert message == (
        f"scenario 'moving_users_sub6': channel.los is 'sampled'; where the users move {name} "
        "of one UAV is the per-step oracle, an upper bound that needs deterministic LoS "
        "(channel.los = 'always', 'expected' or 'geometric'); compare with soa, tracking or "
        "random, or evaluate with --set channel.los=expected")
    assert "cannot follow moving users" not in message
    # under fading too, the reason is the LoS draws
    faded = load_scenario(MOVING_FADING)
    both = with_values(faded, "channel", {"los": "sampled"}, "both")
    assert _refusal(both, method) == ("scenario 'moving_users_fading_sub6': the oracle under "
                                      "fading: channel.los is 'sampled'")
