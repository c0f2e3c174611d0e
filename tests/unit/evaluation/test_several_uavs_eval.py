"""Evaluation of several UAVs: ``baseline`` with SoA per UAV, best response, OMA and random,
``eval --compare`` of a trained two-UAV run, the eval file's searches, the oracle refused;
best response and OMA for one UAV."""

from __future__ import annotations

import json
import re
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from adaptsky.evaluation.api import eval_layouts, run_baseline
from adaptsky.rollouts import several_uavs
from adaptsky.rollouts.oracle import oracle
from adaptsky.scenario import load_scenario
from adaptsky.sim.network import NetworkBatch
from adaptsky.store.eval_file import read_eval_metrics
from adaptsky.training import api
from adaptsky_cli.cli.main import main
from tests.helpers.evaluation import small_two_uavs


def _lines(capsys) -> list[str]:
    return capsys.readouterr().err.strip().splitlines()


@pytest.mark.parametrize("method", ["soa", "best-response", "oma", "random"])
def test_baseline_of_two_uavs(method, tmp_path, capsys):
    path = small_two_uavs(tmp_path)
    started_s = time.process_time()
    assert main(["baseline", str(path), "--method", method, "--layouts", "2", "--steps", "5",
                 "--json"]) == 0
    spent_s = time.process_time() - started_s
    results = json.loads(capsys.readouterr().out)
    assert results["uavs"] == 2
    entry = results["methods"][method]
    assert np.array(entry["layouts"]["final_uav_m"]).shape == (2, 2, 3)
    assert all(rate > 0 for rate in entry["layouts"]["mean_sum_rate_bps"])
    if method in ("best-response", "oma"):
        assert set(entry["search"]) == {"objective_bps", "rounds", "converged"}
        assert len(entry["search"]["rounds"]) == 2
        assert 0 < 2 * entry["seconds_per_layout"] <= spent_s   # process time, 2 layouts
        found = results["found"]
        assert np.array(found[0]["uav_m"]).shape == (2, 3)
        assert sum(found[1]["rate_bps"]) == pytest.approx(
            entry["layouts"]["mean_sum_rate_bps"][1], rel=1e-12)
        assert entry["search"]["objective_bps"][1] <= sum(found[1]["rate_bps"]) * (1 + 1e-12)
    assert main(["baseline", str(path), "--method", method, "--steps", "3"]) == 0
    text = capsys.readouterr().out
    assert method in text and ("rounds" in text) == (method in ("best-response", "oma"))


def test_the_oracle_is_refused_for_two_uavs_in_one_line(tmp_path, capsys):
    path = small_two_uavs(tmp_path)
    assert main(["baseline", str(path), "--method", "oracle"]) == 1
    assert _lines(capsys) == ["--method: the oracle is defined for one UAV; use best-response "
                              "(scenario 'two' has 2 UAVs)"]


def test_the_oracle_needs_deterministic_gains(tmp_path, capsys):
    # best response and OMA search sampled LoS on its expected gains
    # (test_moving_users_and_sampled_los.py); the oracle, a bound, refuses it
    path = small_two_uavs(tmp_path, "one", uavs=1, channel={"los": "sampled"})
    assert main(["baseline", str(path), "--method", "oracle"]) == 1
    assert _lines(capsys) == ["scenario 'one': channel.los is 'sampled'; the oracle needs "
                              "deterministic gains: los = 'always' or 'expected', without "
                              "fading"]


def test_soa_per_uav_is_held_with_the_true_interference(tmp_path):
    scenario = load_scenario(small_two_uavs(tmp_path))
    users_m = eval_layouts(scenario, None)
    uav_m, alpha = several_uavs.soa_per_uav(scenario, users_m)
    result = run_baseline(scenario, "soa", 3, users_m)
    state = NetworkBatch(scenario, 1, users_m=users_m).evaluate_at(uav_m, alpha)
    assert result.trace.uav_m.shape == (3, 1, 2, 3)
    assert np.array_equal(result.trace.rate_bps[-1], state.rate_bps)
    assert state.interference_w.max() > 0


def test_one_uav_best_response_is_the_oracle_and_oma_runs(tmp_path):
    scenario = load_scenario(small_two_uavs(tmp_path, "one", uavs=1))
    users_m = eval_layouts(scenario, 3)
    best = run_baseline(scenario, "best-response", 5, users_m)
    exact = oracle(scenario, users_m)
    assert best.trace.uav_m.shape == (1, 3, 3)
    assert np.array_equal(best.trace.uav_m[0], exact.uav_m)
    assert np.array_equal(best.trace.rate_bps[0], exact.rate_bps)
    assert best.details["rounds"].tolist() == [1, 1, 1] and best.details["converged"].all()
    oma = run_baseline(scenario, "oma", 5, users_m)
    assert oma.trace.uav_m.shape == (1, 3, 3) and oma.trace.rate_bps.shape == (1, 3, 4)
    assert np.all(oma.trace.alpha == 0.5)


@pytest.fixture(scope="module")
def two_uav_run(tmp_path_factory) -> Path:
    tmp_path = tmp_path_factory.mktemp("several_uavs_eval")
    run, _ = api.train(scenario_path=small_two_uavs(tmp_path), out=tmp_path / "two.h5", seeds=[0],
                       workers=1, quiet=True)
    return run


def test_eval_of_a_two_uav_run_against_the_searches(two_uav_run, tmp_path, capsys):
    out = tmp_path / "eval.h5"
    started_s = time.process_time()
    assert main(["eval", str(two_uav_run), "--layouts", "3", "--steps", "20", "--compare",
                 "soa,best-response,oma,random", "--out", str(out)]) == 0
    spent_s = time.process_time() - started_s
    captured = capsys.readouterr()
    for name in ("policy", "soa", "best-response", "oma", "random"):
        assert name in captured.out
    text = " ".join(captured.out.split())  # (lines fold at the terminal's width)
    assert re.search(r"best-response: [\d.]+ rounds per layout on average \(at most \d+\), "
                     r"converged on 3 of 3 layouts; [\d.]+ s per layout", text)
    assert "% of best response on average" in text and "best-response search" in text
    with h5py.File(out, "r") as f:
        assert f["methods/policy/trajectory/uav_m"].shape == (20, 3, 2, 3)
        assert f["methods/soa/trajectory/uav_m"].shape == (20, 3, 2, 3)
        assert f["methods/best-response/trajectory/uav_m"].shape == (1, 3, 2, 3)
        assert f["methods/policy/final_uav_m"].shape == (3, 2, 3)
        for name in ("best-response", "oma"):
            search = f[f"methods/{name}/search"]
            assert search["rounds"].shape == search["converged"].shape == (3,)
            assert search["converged"].dtype == np.bool_
            assert search["objective_bps"].attrs["units"] == "bit/s"
            assert 0 < 3 * search.attrs["seconds_per_layout"] <= spent_s   # 3 layouts
        assert "search" not in f["methods/soa"]
        results = json.loads(f["results_json"][()])
    assert results["uavs"] == 2 and "policy_steady_pct_of_best_response" in results
    _, methods = read_eval_metrics(out)
    assert set(methods) == {"policy", "soa", "best-response", "oma", "random"}
    assert "search" not in methods["oma"]
    # inspect prints the same table again
    assert main(["inspect", str(out)]) == 0
    shown = " ".join(capsys.readouterr().out.split())
    assert "best-response" in shown and "oma: " in shown and "% of best response" in shown


def test_eval_refuses_the_oracle_and_one_uav_scenarios(two_uav_run, tmp_path, capsys):
    assert main(["eval", str(two_uav_run), "--compare", "oracle", "--out",
                 str(tmp_path / "e.h5")]) == 1
    assert _lines(capsys) == ["--compare: the oracle is defined for one UAV; use "
                              "best-response (scenario 'two' has 2 UAVs)"]
    one = small_two_uavs(tmp_path, "one", uavs=1)
    assert main(["eval", str(two_uav_run), "--scenario", str(one), "--out",
                 str(tmp_path / "e.h5")]) == 1
    assert _lines(capsys) == [f"{two_uav_run}: the policy was trained for 2 UAVs but the "
                              "evaluation scenario 'one' has 1"]
    assert not (tmp_path / "e.h5").exists()


def test_a_damaged_search_is_refused(two_uav_run, tmp_path, capsys):
    out = tmp_path / "eval.h5"
    assert main(["eval", str(two_uav_run), "--steps", "5", "--compare", "oma", "--out",
                 str(out), "--json"]) == 0
    capsys.readouterr()
    with h5py.File(out, "r+") as f:
        del f["methods/oma/search/rounds"]
        f["methods/oma/search/rounds"] = np.array([1.5])
    assert main(["inspect", str(out)]) == 1
    assert _lines(capsys) == [f"{out}: damaged eval file (methods/oma/search/rounds is not "
                              "one number per layout)"]


def test_eval_refuses_a_one_uav_policy_on_two_uavs_in_one_line(tiny_run, tmp_path, capsys):
    two = small_two_uavs(tmp_path)
    assert main(["eval", "--checkpoint", str(tiny_run), "--scenario", str(two),
                 "--steps", "2", "--out", str(tmp_path / "e.h5")]) == 1
    assert _lines(capsys) == [f"{tiny_run}: the policy was trained for one UAV but the "
                              "evaluation scenario 'two' has 2"]


@pytest.mark.parametrize("uavs", [2, 3])
def test_the_searches_are_held_as_found(uavs, tmp_path):
    users = [[-8.0, -6.0], [-3.0, -9.0], [7.0, 8.0], [2.0, 4.0], [-6.0, 7.0], [8.0, -5.0]]
    scenario = load_scenario(small_two_uavs(tmp_path, uavs=uavs, area={"side_m": 10.0 * uavs},
                                   users={"count": 2 * uavs, "positions_m": users[:2 * uavs]}))
    users_m = eval_layouts(scenario, 2)
    best = run_baseline(scenario, "best-response", 7, users_m)
    found = several_uavs.best_response(scenario, users_m)
    # the environment's NOMA rates with the true interference are the search's own
    assert best.trace.uav_m.shape == (1, 2, uavs, 3)
    assert np.array_equal(best.trace.uav_m[0], found.uav_m)
    assert best.trace.rate_bps[0] == pytest.approx(found.rate_bps, rel=1e-9)
    assert best.details["objective_bps"] == pytest.approx(found.objective_bps, rel=1e-12)
    oma = run_baseline(scenario, "oma", 7, users_m)
    assert np.array_equal(oma.trace.rate_bps[0], several_uavs.best_oma(scenario,
                                                                       users_m).rate_bps)
    soa = run_baseline(scenario, "soa", 7, users_m)
    assert np.all(best.metrics["mean_sum_rate_bps"] >= soa.metrics["mean_sum_rate_bps"]
                  * (1 - 1e-12))
