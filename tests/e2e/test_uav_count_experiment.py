"""An experiment of the ``uav-count`` kind (E4's) end to end on small scenarios: one and two
UAVs over 20 m x 20 m, one run each, trained, evaluated against SoA per UAV, best response
and OMA on each group's own layout, and reported (figure, CSV, report.md rows checked against
the eval files by the plain formulas)."""

from __future__ import annotations

import csv

import numpy as np
import pytest

from adaptsky.scenario.toml_writer import dumps
from adaptsky.store.eval_file import read_eval_metrics
from adaptsky_cli.cli.main import main


def _scenario(count: int) -> dict:
    users = [[-8.0, 6.0], [-3.0, -7.0], [-9.0, -2.0], [-5.0, 8.0],
             [7.0, 5.0], [9.0, -8.0], [4.0, -1.0], [8.0, 9.0]][:4 * count]
    return {"name": f"small{count}", "area": {"side_m": 20.0},
            "users": {"positions_m": users, "pairing": "near-far"},
            "uav": {"count": count, "start_m": [0.0, 0.0, 15.0], "min_height_m": 10.0,
                    "max_height_m": 20.0},
            "reward": {"w_rate": 10.0},
            "agent": {"algorithm": "bdq", "hidden_sizes": [16, 16], "batch_size": 16,
                      "memory_size": 200, "user_order": "clusters"},
            "train": {"episodes": 3, "steps": 10, "eval_every": 1, "eval_steps": 20}}


EXPERIMENT = """id = "small-e4"
title = "two sizes"
[[groups]]
name = "u1"
label = "BDQ, 1 UAV"
scenario = "one.toml"
runs = 1
[[groups]]
name = "u2"
label = "BDQ, 2 UAVs"
scenario = "two.toml"
runs = 1
[evaluation]
policy = "u1"
also = ["u2"]
steps = 30
baselines = ["soa", "best-response", "oma"]
policies = ["last", "best"]
[figure]
kind = "uav-count"
[[claims]]
text = "share of best response"
quantity = "pct_of_best_response"
[[claims]]
text = "NOMA over OMA"
quantity = "noma_over_oma_pct"
"""


@pytest.fixture(scope="module")
def reproduced(tmp_path_factory):
    folder = tmp_path_factory.mktemp("uav_count")
    (folder / "one.toml").write_text(dumps(_scenario(1)))
    (folder / "two.toml").write_text(dumps(_scenario(2)))
    (folder / "e.toml").write_text(EXPERIMENT)
    out = folder / "out"
    assert main(["reproduce", str(folder / "e.toml"), "--out", str(out), "--workers", "1",
                 "--quiet"]) == 0
    return out


def test_each_group_has_its_own_baselines_and_the_report_reads_them(reproduced):
    out = reproduced
    report = (out / "report.md").read_text()
    assert (out / "small-e4.png").stat().st_size > 10_000
    for group, uavs in (("u1", 1), ("u2", 2)):
        best = read_eval_metrics(out / "evals" / f"best-response-{group}.h5")[1]
        oma = read_eval_metrics(out / "evals" / f"oma-{group}.h5")[1]
        best_bps = float(np.mean(next(iter(best.values()))["mean_sum_rate_bps"]))
        oma_bps = float(np.mean(next(iter(oma.values()))["mean_sum_rate_bps"]))
        assert best_bps > oma_bps > 0
        gain = 100 * (best_bps - oma_bps) / oma_bps
        row = f"best response, {uavs} UAV" + ("s" if uavs > 1 else "")
        assert f"| {row} | {gain:+.1f}% |" in report.replace(" | - | -", "").replace(
            "|  |  | ", "| ")
        for policy, suffix in (("last", ""), ("best", "-best")):
            mine = next(iter(read_eval_metrics(out / "evals" / f"{group}-seed0{suffix}.h5")[
                1].values()))
            share = 100 * float(np.mean(mine["steady_sum_rate_bps"])) / best_bps
            label = f"BDQ, {uavs} UAV{'s' if uavs > 1 else ''}, {policy} policy"
            assert f"| {label} | {share:.1f}% | 100.0% |" in report
    with open(out / "small-e4.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert {row["uavs"] for row in rows} == {"1", "2"}
    assert {row["method"] for row in rows} >= {"SoA per UAV", "best response",
                                               "OMA (best found)", "BDQ, last policy"}
