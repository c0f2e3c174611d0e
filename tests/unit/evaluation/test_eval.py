"""adaptsky eval and adaptsky baseline end to end."""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np
import pytest

from adaptsky.scenario import load_scenario
from adaptsky.scenario.toml_writer import dumps
from adaptsky.training import api
from adaptsky_cli.cli.main import main
from tests.conftest import SCENARIOS


def coarse_scenario(tmp_path: Path, name: str = "coarse", **agent: object) -> Path:
    """nyc_mmwave on a 2 m lattice up to 100 m, so the oracle takes a fraction of a second."""
    data = load_scenario(SCENARIOS / "nyc_mmwave.toml").model_dump(mode="json")
    data["name"] = name
    data["uav"] |= {"step_m": [2.0, 2.0, 2.0], "max_height_m": 100.0}
    data["agent"] |= {"hidden_sizes": [32, 32], "batch_size": 32, "memory_size": 2000, **agent}
    data["train"] |= {"episodes": 4, "steps": 100}
    path = tmp_path / f"{name}.toml"
    path.write_text(dumps(data))
    return path


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    tmp_path = tmp_path_factory.mktemp("eval")
    dueling, _ = api.train(scenario_path=coarse_scenario(tmp_path), out=tmp_path / "dn.h5",
                           seeds=[0], workers=1, quiet=True)
    plain, _ = api.train(scenario_path=coarse_scenario(tmp_path, "plain", dueling=False),
                         out=tmp_path / "dqn.h5", seeds=[0], workers=1, quiet=True)
    return tmp_path, dueling, plain


def _eval(run, out, *extra):
    return main(["eval", "--checkpoint", str(run), "--layouts", "20", "--steps", "150",
                 "--out", str(out), *extra])


def test_eval_on_20_random_layouts(runs, capsys):
    tmp_path, run, plain = runs
    out = tmp_path / "e1.h5"
    assert _eval(run, out, "--compare", f"soa,oracle,random,{plain}") == 0
    captured = capsys.readouterr()
    for name in ("policy", "soa", "oracle", "random", "dqn.h5"):
        assert name in captured.out
    assert "% of the oracle" in captured.out and "s per layout" in captured.out
    assert f"eval file: {out}" in captured.err
    with h5py.File(out, "r") as f:
        assert f.attrs["kind"] == "adaptsky-eval" and f.attrs["layouts"] == 20
        assert f["layouts_m"].shape == (20, 4, 2)
        for name in ("policy", "soa", "oracle", "random", "dqn.h5"):
            group = f[f"methods/{name}"]
            for metric in ("mean_sum_rate_bps", "steady_sum_rate_bps", "fairness",
                           "min_user_se", "satisfied_share"):
                assert group[metric].shape == (20,)
            assert group["final_uav_m"].shape == (20, 3)
        assert f["methods/policy/trajectory/uav_m"].shape == (150, 20, 3)
        assert f["methods/policy/trajectory/rate_bps"].shape == (150, 20, 4)
        results = json.loads(f["results_json"][()])
    oracle_rates = np.array(results["methods"]["oracle"]["layouts"]["mean_sum_rate_bps"])
    for name in ("policy", "soa", "random", "dqn.h5"):
        steady = np.array(results["methods"][name]["layouts"]["steady_sum_rate_bps"])
        assert np.all(steady <= oracle_rates * (1 + 1e-12)), name
    share = results["comparison"]["soa"]["beats_share"]
    assert 0 <= share <= 1


def test_same_arguments_give_identical_numbers(runs, capsys):
    tmp_path, run, _ = runs
    outputs = []
    for name in ("a", "b"):
        assert _eval(run, tmp_path / f"{name}.h5", "--compare", "soa,random", "--json") == 0
        captured = capsys.readouterr()
        outputs.append(json.loads(captured.out))      # --json: nothing else on stdout
        assert outputs[-1].pop("eval_file") == str(tmp_path / f"{name}.h5")
    assert outputs[0] == outputs[1]


def test_default_layout_is_the_training_layout(runs, capsys):
    tmp_path, run, _ = runs
    code = main(["eval", "--checkpoint", str(run), "--steps", "50", "--json",
                 "--out", str(tmp_path / "train_layout.h5")])
    assert code == 0
    results = json.loads(capsys.readouterr().out)
    assert results["layouts_m"] == [[[4.0, 15.0], [-44.0, -49.0], [-5.0, 21.0], [47.0, 49.0]]]


def test_eval_scenario_with_other_user_count_is_refused(runs, capsys, tmp_path):
    _, run, _ = runs
    six = tmp_path / "six.toml"
    six.write_text('name = "six"\n[users]\ncount = 6\n')
    assert main(["eval", "--checkpoint", str(run), "--scenario", str(six),
                 "--out", str(tmp_path / "x.h5")]) == 1
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and "trained for 4 users" in lines[0] and "has 6" in lines[0]
    assert not (tmp_path / "x.h5").exists()


def test_damaged_checkpoint_is_refused(runs, capsys, tmp_path):
    _, run, _ = runs
    damaged = tmp_path / "damaged.h5"
    damaged.write_bytes(run.read_bytes()[:5000])
    assert main(["eval", "--checkpoint", str(damaged), "--out", str(tmp_path / "y.h5")]) == 1
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"{damaged}: ")


def test_baseline_command(capsys, tmp_path):
    path = coarse_scenario(tmp_path)
    assert main(["baseline", str(path), "--method", "oracle", "--json"]) == 0
    results = json.loads(capsys.readouterr().out)
    best = results["optimum"][0]
    assert best["uav_m"][2] == 10.0
    assert results["methods"]["oracle"]["summary"]["mean_sum_rate_bps"] == pytest.approx(
        sum(best["rate_bps"]))
    assert main(["baseline", str(path), "--method", "soa", "--layouts", "3", "--steps",
                 "10"]) == 0
    assert "3 uniform layouts" in capsys.readouterr().out
    assert main(["baseline", str(path), "--method", "best"]) == 2
    assert "--method: unknown method 'best'" in capsys.readouterr().err
