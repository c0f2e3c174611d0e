"""The service metrics of docs/model.md §14 (outage, the least user rate, the 5th percentile)
against a hand-computed example, and where every evaluation reports them: the eval JSON, the
eval file, the CSV and the printed lines."""

import csv
import json

import h5py
import numpy as np
import pytest

from adaptsky.errors import AdaptskyError
from adaptsky.rollouts.metrics import service_metrics
from adaptsky.scenario import parse_scenario
from adaptsky_cli.cli.main import main


def test_the_service_metrics_of_a_hand_computed_example():
    # two steps, one layout, four users, W = 10 Hz: spectral efficiencies
    # step 1: 1.0, 0.5, 3.0, 2.0; step 2: 0.0, 4.0, 0.8, 1.2
    rates = np.array([[[10.0, 5.0, 30.0, 20.0]], [[0.0, 40.0, 8.0, 12.0]]])
    metrics = service_metrics(rates, 10.0, outage_se=1.0)
    # below 1 bit/s/Hz (1.0 itself is not): 0.5, 0.0, 0.8 -> 3 of 8 user-steps
    assert metrics["outage_share"].tolist() == [0.375]
    # the least rate of each step, 5 and 0, averaged
    assert metrics["mean_least_rate_bps"].tolist() == [2.5]
    # sorted 0, 5, 8, 10, 12, 20, 30, 40: rank 0.05 (8 - 1) = 0.35 -> 0 + 0.35 (5 - 0)
    assert metrics["p5_rate_bps"] == pytest.approx([1.75], rel=1e-12)
    # a stricter threshold puts more user-steps in outage: 1.0 and 1.2 too below 1.5
    assert service_metrics(rates, 10.0, outage_se=1.5)["outage_share"].tolist() == [0.625]


def test_layouts_are_kept_apart():
    rates = np.array([[[10.0, 5.0], [1.0, 2.0]], [[0.0, 40.0], [3.0, 4.0]]])   # (T, L, N)
    metrics = service_metrics(rates, 1.0, outage_se=2.5)
    assert metrics["outage_share"].tolist() == [0.25, 0.5]
    assert metrics["mean_least_rate_bps"].tolist() == [2.5, 2.0]
    assert metrics["p5_rate_bps"] == pytest.approx([np.percentile([10, 5, 0, 40], 5),
                                                    np.percentile([1, 2, 3, 4], 5)])


def test_a_bad_outage_threshold_is_one_line():
    with pytest.raises(AdaptskyError, match="outage_se"):
        parse_scenario({"name": "t", "metrics": {"outage_se": -1.0}}, "t.toml")


def test_every_evaluation_reports_them(tiny_run, tmp_path, capsys):
    out, table = tmp_path / "eval.h5", tmp_path / "eval.csv"
    assert main(["eval", "--checkpoint", str(tiny_run), "--compare", "soa", "--steps", "12",
                 "--out", str(out), "--csv", str(table), "--json"]) == 0
    results = json.loads(capsys.readouterr().out)
    for method in ("policy", "soa"):
        summary = results["methods"][method]["summary"]
        layouts = results["methods"][method]["layouts"]
        assert 0.0 <= summary["outage_share"] <= 1.0
        assert summary["p5_rate_bps"] <= summary["mean_sum_rate_bps"]
        assert layouts["outage_share"][0] == pytest.approx(summary["outage_share"])
    rows = list(csv.DictReader(table.read_text().splitlines()))
    assert float(rows[0]["mean_least_rate_bps"]) == pytest.approx(
        results["methods"]["policy"]["layouts"]["mean_least_rate_bps"][0])
    with h5py.File(out) as f:
        names = []
        f.visit(names.append)
        assert any(name.endswith("p5_rate_bps") for name in names)
    assert main(["eval", "--checkpoint", str(tiny_run), "--steps", "12"]) == 0
    assert "policy: outage " in capsys.readouterr().out
