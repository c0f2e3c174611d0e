"""Baselines where the users walk and where LoS is drawn (issue 35, docs/evaluation.md):
every rollout moves the users with the policy's draws, SoA's rates are taken at each step's
positions (checked against docs/model.md §1 and §6 by hand), the searches refuse moving users
in one line; best response and OMA under sampled LoS search the expected gains and take their
rates under the LoS draws; ``eval`` and ``baseline`` take ``--set``."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from adaptsky.evaluation.api import eval_layouts, run_baseline
from adaptsky.references.searched import SAMPLED_LOS_NOTE, searched_scenario
from adaptsky.rollouts import several_uavs
from adaptsky.rollouts.genie import GENIE_NOTE
from adaptsky.rollouts.rollout import random_policy, rollout
from adaptsky.scenario import load_scenario
from adaptsky.scenario.toml_writer import dumps
from adaptsky.store.eval_file import read_eval_trajectory
from adaptsky_cli.cli.main import main
from tests.conftest import SUB6_RADIO, TINY_RUN_ARGS, make_scenario
from tests.helpers.evaluation import small_two_uavs

SPEED_M = 3.0
STEPS = 40


def _walking(**sections):
    """The paper's mmWave scenario (training layout, listed pairs) with users that walk 3 m
    per step and a minimum SE of 1 bit/s/Hz, so that SoA gives every weak user power."""
    return make_scenario(users={"speed_m_per_step": SPEED_M}, reward={"min_se": 1.0},
                         **sections)


def _snr(uav_m, user_m):
    """P_T G g / sigma^2 at mmWave, LoS (docs/model.md §2): 20 dBm, 8 x 8 antennas,
    g = 10^-6.4 d^-2, -84 dBm of noise; users on the ground."""
    d2 = (uav_m[0] - user_m[0]) ** 2 + (uav_m[1] - user_m[1]) ** 2 + uav_m[2] ** 2
    return 0.1 * 64 * 10**-6.4 / d2 / 10 ** ((-84.0 - 30) / 10)


def _soa_by_hand(home_m, users_m):
    """SoA's rates (N,), bit/s, with its plan made once at the home positions ``home_m`` and
    its rates taken at ``users_m``: UAV at the home centroid at 50 m; in each listed pair the
    weak user (smaller gain at home) gets alpha_w = (2^r - 1)/2^r (1 + 1/snr_w) for r = 1
    (docs/model.md §6); SIC by the gains at ``users_m`` (§1)."""
    uav = (*np.mean(home_m, axis=0), 50.0)
    threshold = 2.0**1.0
    rates = []
    for first, second in ((0, 1), (2, 3)):
        snr_home = [_snr(uav, home_m[i]) for i in (first, second)]
        weak = (first, second)[int(snr_home[1] < snr_home[0])]
        alpha_w = min(1.0, (threshold - 1) / threshold * (1 + 1 / min(snr_home)))
        share = {weak: alpha_w, ({first, second} - {weak}).pop(): 1 - alpha_w}
        snr_now = {i: _snr(uav, users_m[i]) for i in (first, second)}
        strong = first if snr_now[first] >= snr_now[second] else second
        for i in (first, second):
            if i == strong:
                sinr = share[i] * snr_now[i]
            else:
                sinr = share[i] * snr_now[i] / (share[strong] * snr_now[i] + 1)
            rates.append((i, 2e9 * math.log2(1 + sinr)))
    return np.array([rate for _, rate in sorted(rates)])


def test_soa_follows_walking_users_with_the_policys_draws():
    scenario = _walking()
    users_m = eval_layouts(scenario, None)
    soa = run_baseline(scenario, "soa", STEPS, users_m).trace
    walked = rollout(scenario, random_policy(32, 5), STEPS, users_m).users_m
    assert soa.users_m is not None and soa.users_m.shape == (STEPS, 1, 4, 2)
    # the same headings step by step: the users are where the policy's users are
    assert np.array_equal(soa.users_m, walked)
    steps_m = np.linalg.norm(np.diff(soa.users_m[:, 0], axis=0), axis=-1)
    assert steps_m.max() == pytest.approx(SPEED_M) and steps_m.min() > 0   # they walk
    # SoA holds its plan; its rates change as the users move, by the scalar formula
    assert np.all(soa.uav_m[:, 0] == soa.uav_m[0, 0])
    assert soa.sum_rate_bps[:, 0].std() > 1e-3 * soa.sum_rate_bps[:, 0].mean()
    for t in (0, 7, STEPS - 1):
        expected = _soa_by_hand(users_m[0], soa.users_m[t, 0])
        assert soa.rate_bps[t, 0] == pytest.approx(expected, rel=1e-9)


def test_every_rollout_of_several_uavs_moves_the_users_alike(tmp_path):
    scenario = load_scenario(small_two_uavs(tmp_path, users={"speed_m_per_step": 1.0}))
    users_m = eval_layouts(scenario, 2)
    soa = run_baseline(scenario, "soa", 10, users_m).trace
    randomly = run_baseline(scenario, "random", 10, users_m).trace
    assert soa.users_m.shape == (10, 2, 4, 2)
    assert np.array_equal(soa.users_m, randomly.users_m)
    assert not np.array_equal(soa.users_m[0], soa.users_m[-1])
    assert np.ptp(soa.sum_rate_bps, axis=0).min() > 0


def test_static_users_keep_no_track_and_soa_is_constant():
    scenario = make_scenario(reward={"min_se": 1.0})
    soa = run_baseline(scenario, "soa", 5, eval_layouts(scenario, None)).trace
    assert soa.users_m is None
    assert np.all(soa.rate_bps == soa.rate_bps[0])


@pytest.mark.parametrize(("method", "uavs"), [("oma", 1), ("oma", 2)])
def test_the_searches_refuse_walking_users_in_one_line(method, uavs, tmp_path, capsys):
    # OMA finds one configuration for the home positions; the oracle and best response follow
    # the users step by step (test_genie.py, test_step_response.py)
    path = tmp_path / "walk.toml"
    path.write_text(dumps(_walking(uav={"count": uavs}).model_dump(mode="json")))
    assert main(["baseline", str(path), "--method", method]) == 1
    assert capsys.readouterr().err.strip().splitlines() == [
        f"scenario 'test': users.speed_m_per_step is 3 m (the users move); {method} searches "
        "one configuration for the users' home positions and cannot follow moving users yet; "
        "compare with soa or random, or evaluate with --set users.speed_m_per_step=0"]
    # --set makes the users stand: the search then runs
    assert main(["baseline", str(path), "--method", method, "--steps", "1", "--json",
                 "--set", "users.speed_m_per_step=0"]) == 0
    assert json.loads(capsys.readouterr().out)["methods"][method]["summary"]


@pytest.mark.parametrize("method", ["oracle", "best-response"])
def test_one_uavs_oracle_follows_walking_users_step_by_step(method, tmp_path, capsys):
    path = tmp_path / "walk.toml"
    path.write_text(dumps(_walking().model_dump(mode="json")))
    assert main(["baseline", str(path), "--method", method, "--steps", "4", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["methods"][method]["note"] == GENIE_NOTE


def test_a_mobility_model_is_refused_by_oma_and_set_static_in_one_key(tmp_path, capsys):
    scenario = _walking().model_dump(mode="json")
    scenario["users"]["speed_m_per_step"] = 0.0
    scenario["users"]["mobility"] = {"model": "random-waypoint", "speed_min_mps": 1.0,
                                     "speed_max_mps": 2.0}
    path = tmp_path / "waypoint.toml"
    path.write_text(dumps(scenario))
    assert main(["baseline", str(path), "--method", "oma"]) == 1
    assert "users.mobility.model is 'random-waypoint' (the users move)" in (
        capsys.readouterr().err)
    assert main(["baseline", str(path), "--method", "oma", "--steps", "1", "--json",
                 "--set", 'users.mobility={model="static"}']) == 0
    assert json.loads(capsys.readouterr().out)["methods"]["oma"]["summary"]


def test_best_response_under_sampled_los_searches_the_expected_gains(tmp_path):
    scenario = load_scenario(small_two_uavs(tmp_path, channel={"los": "sampled"}))
    users_m = eval_layouts(scenario, None)
    expected = searched_scenario(scenario)
    assert expected.channel.los == "expected" and searched_scenario(expected) is expected
    found = several_uavs.best_response(expected, users_m)
    result = run_baseline(scenario, "best-response", 30, users_m)
    assert result.details["note"] == SAMPLED_LOS_NOTE
    trace = result.trace
    assert trace.rate_bps.shape[0] == 30          # held for every step, not one
    assert np.all(trace.uav_m == found.uav_m[None])
    assert trace.los is not None and 0 < trace.los.mean() < 1   # LoS drawn every step
    assert trace.sum_rate_bps.std() > 0


def _sub6_gain(uav_m, user_m, los):
    """Al-Hourani's gain at 2 GHz (docs/model.md §2): free space times 10^(-eta/10), eta 1 dB
    in LoS and 20 dB in NLoS; users on the ground."""
    d = math.dist(uav_m, (*user_m, 0.0))
    return (299792458.0 / (4 * math.pi * 2e9 * d)) ** 2 * 10 ** (-(1.0 if los else 20.0) / 10)


def test_oma_under_sampled_los_takes_its_rates_under_the_draws():
    scenario = make_scenario(
        radio=SUB6_RADIO, channel={"model": "sub6-al-hourani", "los": "sampled"},
        area={"side_m": 20.0}, users={"positions_m": [[-8.0, -6.0], [-3.0, -9.0],
                                                      [7.0, 8.0], [2.0, 4.0]]},
        uav={"start_m": [0.0, 0.0, 12.0], "min_height_m": 10.0, "max_height_m": 16.0,
             "step_m": [2.0, 2.0, 2.0], "power_step": 0.1})
    users_m = eval_layouts(scenario, None)
    result = run_baseline(scenario, "oma", 25, users_m)
    assert result.details["note"] == SAMPLED_LOS_NOTE
    trace = result.trace
    assert trace.rate_bps.shape == (25, 1, 4) and np.all(trace.alpha == 0.5)
    assert 0 < trace.los.mean() < 1
    snr_scale = 1.0 / 10 ** ((-88.0 - 30) / 10)       # P_T = 1 W, G = 1, -88 dBm
    for t in range(25):
        for i in range(4):
            g = _sub6_gain(trace.uav_m[t, 0], users_m[0, i], trace.los[t, 0, i])
            assert trace.rate_bps[t, 0, i] == pytest.approx(
                25e6 * math.log2(1 + snr_scale * g), rel=1e-9)


def test_baseline_best_response_on_two_uavs_sub6_is_labelled(tmp_path, capsys):
    path = small_two_uavs(tmp_path, channel={"los": "sampled"})
    assert main(["baseline", str(path), "--method", "best-response", "--steps", "5"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    assert f"best-response: {SAMPLED_LOS_NOTE}" in text
    assert main(["baseline", str(path), "--method", "oma", "--steps", "5", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["methods"]["oma"]["note"] == SAMPLED_LOS_NOTE


def test_eval_and_baseline_take_set(tmp_path, capsys):
    scenario = make_scenario(radio=SUB6_RADIO, channel={"model": "sub6-al-hourani",
                                                         "los": "sampled"})
    path = tmp_path / "sampled.toml"
    path.write_text(dumps(scenario.model_dump(mode="json")))
    run = tmp_path / "run.h5"
    assert main(["train", str(path), "--out", str(run), *TINY_RUN_ARGS]) == 0
    capsys.readouterr()
    # the oracle needs deterministic gains: refused as trained, run with --set
    assert main(["eval", str(run), "--compare", "oracle", "--steps", "3"]) == 1
    assert "channel.los is 'sampled'" in capsys.readouterr().err
    out = tmp_path / "eval.h5"
    assert main(["eval", str(run), "--compare", "oracle,soa", "--steps", "3", "--json",
                 "--out", str(out), "--set", "channel.los=expected"]) == 0
    results = json.loads(capsys.readouterr().out)
    assert results["los"] == "expected" and 'los = "expected"' in results["scenario_toml"]
    assert results["methods"]["oracle"]["summary"]["mean_sum_rate_bps"] > 0
    assert read_eval_trajectory(out, "soa", 0)["rate_bps"].shape == (3, 4)
    assert main(["baseline", str(path), "--method", "oracle", "--steps", "1", "--json",
                 "--set", "channel.los=expected"]) == 0
    assert json.loads(capsys.readouterr().out)["los"] == "expected"
    # a bad --set is one line, exit 1
    assert main(["baseline", str(path), "--method", "soa", "--set", "channel.los=never"]) == 1
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and "channel.los" in lines[0] and "with --set" in lines[0]


def test_an_eval_file_of_walking_users_keeps_their_track(tmp_path, capsys):
    path = tmp_path / "walk.toml"
    path.write_text(dumps(_walking().model_dump(mode="json")))
    run = tmp_path / "run.h5"
    assert main(["train", str(path), "--out", str(run), *TINY_RUN_ARGS]) == 0
    out = tmp_path / "eval.h5"
    assert main(["eval", str(run), "--compare", "soa,random", "--steps", "6", "--out",
                 str(out), "--json"]) == 0
    capsys.readouterr()
    tracks = {label: read_eval_trajectory(out, label, 0)["users_m"]
              for label in ("policy", "soa", "random")}
    assert tracks["policy"].shape == (6, 4, 2)
    assert np.array_equal(tracks["policy"], tracks["soa"])
    assert np.array_equal(tracks["policy"], tracks["random"])
