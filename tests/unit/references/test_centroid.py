"""The worked example of adding a reference (docs/evaluation.md#adding-a-reference): hovering
above the users' centroid at the best height."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from adaptsky.evaluation.api import eval_layouts, run_baseline
from adaptsky.references.registry import refusal
from adaptsky.rollouts.oracle import lattice
from adaptsky.scenario.loading import load_scenario
from adaptsky.scenario.variants import eval_scenario
from adaptsky.sim.network import NetworkBatch
from adaptsky_cli.cli.main import main

SCENARIOS = Path(__file__).resolve().parents[3] / "scenarios"


def test_it_hovers_above_the_centroid_at_the_lattice_height_of_the_best_sum_rate():
    scenario = eval_scenario(load_scenario(SCENARIOS / "nyc_mmwave.toml"), 2, 0)
    users_m = eval_layouts(scenario, 2)
    found = run_baseline(scenario, "centroid", 3, users_m)
    uav_m = found.trace.uav_m[-1]                                      # (L, 3)
    assert np.allclose(uav_m[:, :2], users_m.mean(axis=1), atol=1e-12)  # by hand: the mean
    assert np.isin(uav_m[:, 2], lattice(scenario)[2]).all()
    soa = run_baseline(scenario, "soa", 3, users_m)   # the same place at the start height
    assert np.all(found.metrics["mean_sum_rate_bps"] >= soa.metrics["mean_sum_rate_bps"])
    assert np.any(uav_m[:, 2] != scenario.uav.start_m[2])


def test_it_applies_to_every_scenario_of_pairs_and_each_uav_takes_its_group_centroid():
    for path in SCENARIOS.glob("*.toml"):
        scenario = load_scenario(path)
        refused = refusal("centroid", scenario)
        # SoA's split is for the downlink's pairs: clusters of three and the uplink are
        # refused (docs/model.md §15, §17)
        if scenario.uplink:
            assert "downlink only" in refused
        else:
            assert (refused is None if scenario.cluster_size == 2
                    else "NOMA pairs only" in refused)
    scenario = load_scenario(SCENARIOS / "two_uavs_mmwave.toml")
    users_m = eval_layouts(scenario, None)
    uav_m = run_baseline(scenario, "centroid", 2, users_m).trace.uav_m[-1, 0]   # (U, 3)
    serving = NetworkBatch(scenario, 1, users_m=users_m).association.serving_uav[0]
    for uav in range(2):
        assert np.allclose(uav_m[uav, :2], users_m[0, serving == uav].mean(axis=0))


def test_the_command_runs_it(capsys):
    assert main(["baseline", str(SCENARIOS / "nyc_mmwave.toml"), "--method", "centroid",
                 "--steps", "3"]) == 0
    assert "centroid" in capsys.readouterr().out
