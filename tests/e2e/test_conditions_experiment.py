"""An experiment of the ``conditions`` kind (E6's) end to end on a small scenario: three SIC
residuals of one UAV over 20 m x 20 m, one run each, trained, evaluated against SoA, the oracle
and OMA on each group's layout, and reported (figure, CSV, report.md rows and the crossover
note checked against the eval files by the plain formulas)."""

from __future__ import annotations

import csv

import numpy as np
import pytest

from adaptsky.scenario.toml_writer import dumps
from adaptsky.store.eval_file import read_eval_metrics
from adaptsky_cli.cli.main import main

RESIDUALS = (0.0, 0.1, 1.0)

SCENARIO = {"name": "small", "area": {"side_m": 20.0},
            "users": {"positions_m": [[-8.0, 6.0], [-3.0, -7.0], [7.0, 5.0], [9.0, -8.0]],
                      "pairing": "near-far"},
            "uav": {"start_m": [0.0, 0.0, 15.0], "min_height_m": 10.0, "max_height_m": 20.0,
                    "step_m": [2.0, 2.0, 2.0], "power_step": 0.1},
            "reward": {"w_rate": 10.0},
            "agent": {"hidden_sizes": [16, 16], "batch_size": 16, "memory_size": 200},
            "train": {"episodes": 3, "steps": 10, "eval_every": 1, "eval_steps": 20}}


def _experiment() -> str:
    groups = "".join(
        f'[[groups]]\nname = "sic{i}"\nlabel = "epsilon = {eps:g}"\nscenario = "s.toml"\n'
        f'runs = 1\nset = ["radio.sic_residual={eps}"]\npanel = "imperfect SIC"\n'
        for i, eps in enumerate(RESIDUALS))
    also = ", ".join(f'"sic{i}"' for i in range(1, len(RESIDUALS)))
    return f"""id = "small-e6"
title = "conditions"
{groups}
[evaluation]
policy = "sic0"
also = [{also}]
steps = 30
baselines = ["soa", "oracle", "oma"]
policies = ["last"]
[figure]
kind = "conditions"
[[claims]]
text = "share of the bound"
quantity = "pct_of_bound"
[[claims]]
text = "the bound over OMA"
quantity = "bound_over_oma_pct"
"""


@pytest.fixture(scope="module")
def reproduced(tmp_path_factory):
    folder = tmp_path_factory.mktemp("conditions")
    (folder / "s.toml").write_text(dumps(SCENARIO))
    (folder / "e.toml").write_text(_experiment())
    out = folder / "out"
    assert main(["reproduce", str(folder / "e.toml"), "--out", str(out), "--workers", "1",
                 "--quiet"]) == 0
    return out


def _mean(path, key="mean_sum_rate_bps") -> float:
    return float(np.mean(next(iter(read_eval_metrics(path)[1].values()))[key]))


def test_each_condition_has_its_baselines_and_the_report_reads_them(reproduced):
    out = reproduced
    report = (out / "report.md").read_text()
    assert (out / "small-e6.png").stat().st_size > 10_000
    bounds = []
    for i, eps in enumerate(RESIDUALS):
        oracle = _mean(out / "evals" / f"oracle-sic{i}.h5")
        oma = _mean(out / "evals" / f"oma-sic{i}.h5")
        bounds.append(oracle)
        gain = 100 * (oracle - oma) / oma
        assert f"| oracle, epsilon = {eps:g} | {gain:+.1f}% |" in report.replace(
            " | - | -", "").replace("|  |  | ", "| ")
        policy = _mean(out / "evals" / f"sic{i}-seed0.h5", "steady_sum_rate_bps")
        assert f"| epsilon = {eps:g} | {100 * policy / oracle:.1f}% | 100.0% |" in report
        over_oma = 100 * (policy - oma) / oma
        assert f"epsilon = {eps:g}: policy {over_oma:+.1f}%, bound {gain:+.1f}%" in report
    # the residual costs the bound; OMA has no SIC and does not change
    assert bounds[0] > bounds[1] > bounds[2]
    omas = [_mean(out / "evals" / f"oma-sic{i}.h5") for i in range(len(RESIDUALS))]
    assert omas[0] == omas[1] == omas[2]
    # without any cancellation (epsilon = 1) NOMA no longer beats OMA: the note says where
    assert bounds[2] < omas[2]
    first = next(f"epsilon = {eps:g}" for eps, b, o in zip(RESIDUALS, bounds, omas, strict=True)
                 if b <= o)
    assert f"the bound no longer beats OMA from {first} on" in report
    assert "| claim | paper | policy | ours | reachable (bound) | per run |" in report
    with open(out / "small-e6.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert {row["condition"] for row in rows} == {f"epsilon = {eps:g}" for eps in RESIDUALS}
    assert {row["method"] for row in rows} == {"SoA", "oracle", "OMA (best found)",
                                               "agent, last policy"}
