"""The energy in what inspect and eval print (docs/model.md §10): inspect's per-seed energy
and energy efficiency are the means of the stored learning curves over the last episodes;
eval's per-method summary averages the eval file's per-layout energy metrics, and its lines
name each method's energy efficiency and power; the hovering SoA's power is P(0) plus its
transmitters, by the scalar formula."""

from __future__ import annotations

import json

import numpy as np
import pytest

from adaptsky.store.eval_file import read_eval_metrics
from adaptsky.store.run_file import RunReader
from adaptsky_cli.cli.main import main
from tests.helpers.scalar_models import scalar_power_w
from tests.helpers.training import small_scenario


@pytest.fixture(scope="module")
def run_file(tmp_path_factory):
    folder = tmp_path_factory.mktemp("energy_reports")
    path = folder / "run.h5"
    assert main(["train", str(small_scenario(folder)), "--episodes", "3", "--steps", "40",
                 "--seeds", "0,1", "--workers", "1", "--quiet", "--out", str(path),
                 "--set", "uav.actions=with-hover", "--set", "uav.step_s=0.1"]) == 0
    return path


def test_inspect_reports_the_episodes_energy(run_file, capsys):
    capsys.readouterr()
    assert main(["inspect", str(run_file), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    with RunReader(run_file) as run:
        for seed in summary["seeds"]:
            curves = run.episodes(seed["seed"])
            assert seed["energy_j"] == pytest.approx(curves["energy_j"].mean(), rel=1e-12)
            assert seed["energy_efficiency_bpj"] == pytest.approx(
                curves["energy_efficiency_bpj"].mean(), rel=1e-12)
    efficiencies = [s["energy_efficiency_bpj"] for s in summary["seeds"]]
    assert summary["energy_efficiency_bpj"]["mean"] == pytest.approx(np.mean(efficiencies))
    assert main(["inspect", str(run_file)]) == 0
    assert "Mbit/J" in capsys.readouterr().out


def test_eval_reports_every_methods_energy(run_file, tmp_path, capsys):
    out = tmp_path / "e.h5"
    capsys.readouterr()
    assert main(["eval", str(run_file), "--steps", "120", "--out", str(out),
                 "--compare", "soa", "--json"]) == 0
    results = json.loads(capsys.readouterr().out)
    _, methods = read_eval_metrics(out)
    for name, entry in results["methods"].items():
        stored = methods[name]
        for key in ("energy_j", "steady_power_w", "steady_energy_efficiency_bpj"):
            assert entry["summary"][key] == pytest.approx(float(np.mean(stored[key])),
                                                          rel=1e-12)
    soa = results["methods"]["soa"]["summary"]
    assert soa["steady_power_w"] == pytest.approx(scalar_power_w(0.0) + 0.2, rel=1e-12)
    assert soa["steady_still_share"] == 1.0 and soa["steady_vertical_share"] == 0.0
    rate = soa["steady_sum_rate_bps"]
    assert soa["steady_energy_efficiency_bpj"] == pytest.approx(
        rate / (scalar_power_w(0.0) + 0.2), rel=1e-12)
    out.unlink()
    assert main(["eval", str(run_file), "--steps", "120", "--out", str(out),
                 "--compare", "soa"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    assert f"soa: {rate / (scalar_power_w(0.0) + 0.2) / 1e6:.1f} Mbit/J, 168.7 W" in text
