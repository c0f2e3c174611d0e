"""An experiment of the ``energy-front`` kind (E5's) end to end on a small scenario: one UAV
with hover actions and 0.1 s steps, the reward's energy weight swept over two values, one
run each, trained, evaluated with the oracle and SoA, and reported: the report's energy
efficiency, its ratio to the unweighted run and its sum-rate share against the eval files by
the plain formulas, the bound against the oracle over the least power by hand, and the
experiment refused without a w_energy sweep that holds 0."""

from __future__ import annotations

import csv
import math

import numpy as np
import pytest

from adaptsky.experiment.plan import load_experiment
from adaptsky.scenario.toml_writer import dumps
from adaptsky.store.eval_file import read_eval_metrics
from adaptsky_cli.cli.main import main
from tests.helpers.scalar_models import scalar_power_w

SCENARIO = {"name": "small_energy", "area": {"side_m": 20.0},
            "users": {"positions_m": [[-8.0, 6.0], [-3.0, -7.0], [7.0, 5.0], [9.0, -8.0]]},
            "uav": {"start_m": [0.0, 0.0, 15.0], "min_height_m": 10.0, "max_height_m": 20.0,
                    "actions": "with-hover", "step_s": 0.1},
            "reward": {"w_rate": 10.0},
            "agent": {"hidden_sizes": [16, 16], "batch_size": 16, "memory_size": 200},
            "train": {"episodes": 3, "steps": 20, "eval_every": 1, "eval_steps": 20}}

EXPERIMENT = """id = "small-e5"
title = "energy front"
[[groups]]
name = "energy"
label = "DQN"
scenario = "energy.toml"
runs = 1
[groups.sweep]
key = "reward.w_energy"
values = [0.0, 50.0]
[evaluation]
policy = "energy"
steps = 120
baselines = ["soa", "oracle"]
policies = ["last"]
[figure]
kind = "energy-front"
[[claims]]
text = "energy efficiency"
quantity = "energy_efficiency_bpj"
[[claims]]
text = "ratio"
quantity = "ee_ratio_vs_unweighted"
[[claims]]
text = "share"
quantity = "sum_rate_pct_of_unweighted"
[[claims]]
text = "still"
quantity = "still_share_pct"
"""


@pytest.fixture(scope="module")
def reproduced(tmp_path_factory):
    folder = tmp_path_factory.mktemp("energy_front")
    (folder / "energy.toml").write_text(dumps(SCENARIO))
    (folder / "e.toml").write_text(EXPERIMENT)
    out = folder / "out"
    assert main(["reproduce", str(folder / "e.toml"), "--out", str(out), "--workers", "1",
                 "--quiet"]) == 0
    return out


def _metrics(path):
    return next(iter(read_eval_metrics(path)[1].values()))


def test_the_report_measures_the_front_against_the_eval_files(reproduced):
    out = reproduced
    report = (out / "report.md").read_text()
    assert (out / "small-e5.png").stat().st_size > 10_000
    runs = {w: _metrics(out / "evals" / f"energy-w_energy-{w}-seed0.h5")
            for w in ("0", "50")}
    base_rate = float(runs["0"]["steady_sum_rate_bps"][0])
    base_ee = float(runs["0"]["steady_energy_efficiency_bpj"][0])
    rate = float(runs["50"]["steady_sum_rate_bps"][0])
    ee = float(runs["50"]["steady_energy_efficiency_bpj"][0])
    assert f"| DQN, w_e = 50 | {ee / 1e6:.1f} Mbit/J |" in report
    assert f"| DQN, w_e = 50 | {ee / base_ee:.3f}x |" in report
    assert f"| DQN, w_e = 50 | {100 * rate / base_rate:.1f}% |" in report
    oracle = _metrics(out / "evals" / "oracle-0.h5")
    # the oracle hovers: P(0) plus two transmitters of 0.1 W, every step
    hover_w = scalar_power_w(0.0) + 0.2
    assert float(oracle["steady_power_w"][0]) == pytest.approx(hover_w, rel=1e-12)
    assert float(oracle["steady_still_share"][0]) == 1.0
    oracle_bps = float(oracle["steady_sum_rate_bps"][0])
    assert float(oracle["steady_energy_efficiency_bpj"][0]) == pytest.approx(
        oracle_bps / hover_w, rel=1e-12)
    # the bound: the oracle's sum rate over the least power of a step (10 m/s along an axis)
    bound = oracle_bps / (scalar_power_w(10.0) + 0.2)
    assert f"reach on this layout is {bound / 1e6:.1f} Mbit/J" in report
    with open(out / "small-e5.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert [row["policy"] for row in rows] == ["last", "last", "oracle", "soa"]
    assert math.isclose(float(rows[1]["ee_mean_bpj"]), ee, rel_tol=1e-12)
    # each step's power in the trajectory: the eval's energy is their sum
    steps = runs["50"]
    assert np.isfinite(steps["energy_j"]).all()


def test_an_energy_front_needs_a_w_energy_sweep_with_zero(tmp_path, capsys):
    (tmp_path / "energy.toml").write_text(dumps(SCENARIO))
    path = tmp_path / "e.toml"
    path.write_text(EXPERIMENT.replace("values = [0.0, 50.0]", "values = [1.0, 50.0]"))
    assert main(["reproduce", str(path), "--out", str(tmp_path / "o"), "--quiet"]) == 1
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "swept over reward.w_energy with 0 among" in err
    assert load_experiment  # the shipped e5 loads
    experiment = load_experiment("e5")[0]
    assert experiment.figure.kind == "energy-front"
