"""``adaptsky reproduce`` of a learning-curves experiment swept over a scenario key that no
figure kind knows (the users' speed): one curve, one CSV series, one row per claim and one
SoA and oracle per swept value, each over that value's seeds alone (issue 35, item 6)."""

from __future__ import annotations

import csv
from pathlib import Path

import h5py
import numpy as np
import pytest

from adaptsky.store.eval_file import read_eval_metrics
from adaptsky_cli.cli.main import main
from tests.helpers.reproduce import SMALL_AGENT, last_mean, write_experiment

KEY = "users.speed_m_per_step"


def test_a_two_value_sweep_draws_two_curves_and_fills_two_rows(tmp_path):
    experiment = write_experiment(tmp_path / "experiments", f"""
id = "speed"
title = "tiny speed sweep"
[[groups]]
name = "agent"
scenario = "../scenarios/sub6_al_hourani_released_code.toml"
runs = 2
set = [{", ".join(SMALL_AGENT)}]
[groups.sweep]
key = "{KEY}"
values = [0.0, 2.0]
[evaluation]
policy = "agent"
steps = 30
baselines = ["soa", "oracle"]
[figure]
kind = "learning-curves"
[[claims]]
text = "sum rate"
quantity = "sum_rate_bps"
[[claims]]
text = "gain"
quantity = "gain_vs_soa_pct"
""")
    out = tmp_path / "out"
    assert main(["reproduce", str(experiment), "--out", str(out), "--episodes", "4",
                 "--steps", "20", "--workers", "2", "--quiet"]) == 0
    runs = {value: [out / "runs" / f"agent-speed_m_per_step-{value}-seed{s}.h5" for s in (0, 1)]
            for value in ("0", "2")}
    with (out / "speed.csv").open(newline="") as handle:
        rows = list(csv.DictReader(handle))
    labels = [f"agent, {KEY} = 0", f"agent, {KEY} = 2"]
    assert list(rows[0]) == ["episode", *(f"{label}_{c}" for label in labels
                                          for c in ("mean", "low", "high", "runs"))]
    report = (out / "report.md").read_text()
    for label, (value, paths) in zip(labels, runs.items(), strict=True):
        # window 1 of 4 episodes: the last row is the mean of the two runs' last episodes
        last = [last_episode(path) for path in paths]
        assert float(rows[-1][f"{label}_mean"]) == pytest.approx(np.mean(last), rel=1e-12)
        assert rows[-1][f"{label}_runs"] == "2"
        rates = [last_mean(path) for path in paths]
        _, methods = read_eval_metrics(out / "evals" / f"soa-{value}.h5")
        soa = float(np.mean(next(iter(methods.values()))["mean_sum_rate_bps"]))
        gains = [100 * (rate - soa) / soa for rate in rates]
        assert (f"| {label} | {np.mean(rates) / 1e6:.2f} Mbit/s ± {np.std(rates) / 1e6:.2f} "
                "Mbit/s (n = 2) |") in report
        assert (f"| {label} | {np.mean(gains):+.1f}% ± {np.std(gains):.1f}% (n = 2) |"
                in report)
        assert f"SoA on the training layout at {KEY} = {value}: {soa / 1e6:.2f} Mbit/s" in report
    # the two values were trained apart: their curves differ
    assert rows[-1][f"{labels[0]}_mean"] != rows[-1][f"{labels[1]}_mean"]
    # the oracle follows walking users step by step (the per-step oracle): reachable at both
    assert "left out: oracle" not in report
    assert f"power split) at {KEY} = 0: " in report
    assert f"power split) at {KEY} = 2: " in report



def last_episode(path: Path) -> float:
    """A run file's sum rate in its last episode."""
    with h5py.File(path, "r") as file:
        group = next(iter(file["seeds"].values()))
        done = int(group.attrs["episodes_done"])
        return float(group["episodes"]["sum_rate_bps"][done - 1])
