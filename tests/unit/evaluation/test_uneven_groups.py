"""Two UAVs serving groups of different sizes (``users.uav = [0, 0, 0, 0, 1, 1]``: two
clusters and one, docs/model.md §9): a short training of the dense DQN and of the BDQ, and an
evaluation against every baseline that applies, all with finite numbers."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from adaptsky.scenario import load_scenario
from adaptsky.scenario.toml_writer import dumps
from adaptsky.training import api
from adaptsky_cli.cli.main import main
from tests.conftest import SCENARIOS


def uneven(tmp_path: Path, algorithm: str) -> Path:
    """two_uavs_mmwave.toml with 6 users, UAV 0 serving four and UAV 1 two, on a 20 m area
    with a coarse lattice (every search a fraction of a second)."""
    data = load_scenario(SCENARIOS / "two_uavs_mmwave.toml").model_dump(mode="json")
    data["name"] = f"uneven_{algorithm}"
    data["area"]["side_m"] = 20.0
    data["users"] |= {"count": 6, "association": "listed", "uav": [0, 0, 0, 0, 1, 1],
                      "positions_m": [[-8.0, -6.0], [-3.0, -9.0], [-7.0, 5.0], [-2.0, 8.0],
                                      [7.0, 8.0], [2.0, 4.0]]}
    data["uav"] |= {"start_m": [0.0, 0.0, 12.0], "min_height_m": 10.0, "max_height_m": 16.0,
                    "step_m": [2.0, 2.0, 2.0], "power_step": 0.1}
    data["agent"] = {"algorithm": algorithm, "hidden_sizes": [16], "batch_size": 8,
                     "memory_size": 200}
    data["train"] |= {"episodes": 2, "steps": 10, "eval_every": 0}
    path = tmp_path / f"{data['name']}.toml"
    path.write_text(dumps(data))
    return path


def _finite(values: object) -> bool:
    if isinstance(values, dict):
        return all(_finite(value) for value in values.values())
    if isinstance(values, list):
        return all(_finite(value) for value in values)
    return not isinstance(values, float) or math.isfinite(values)


@pytest.mark.parametrize("algorithm", ["dqn", "bdq"])
def test_training_and_evaluation_of_uneven_groups_are_finite(algorithm, tmp_path, capsys):
    run, _ = api.train(scenario_path=uneven(tmp_path, algorithm), out=tmp_path / "run.h5",
                       seeds=[0], workers=1, quiet=True)
    assert main(["inspect", str(run), "--json"]) == 0
    assert _finite(json.loads(capsys.readouterr().out))
    assert main(["eval", "--checkpoint", str(run), "--layouts", "2", "--steps", "5",
                 "--compare", "soa,best-response,oma,random", "--out",
                 str(tmp_path / "eval.h5"), "--json"]) == 0
    results = json.loads(capsys.readouterr().out)
    assert set(results["methods"]) == {"policy", "soa", "best-response", "oma", "random"}
    assert _finite(results)
    for entry in results["methods"].values():
        assert all(rate > 0 for rate in entry["layouts"]["mean_sum_rate_bps"])
    # the pictures of the policy's episode and of the baselines draw every UAV's groups
    for source, name in ((tmp_path / "eval.h5", "eval.png"), (run, "run.png")):
        assert main(["show", str(source), "--out", str(tmp_path / name)]) == 0
        assert (tmp_path / name).stat().st_size > 0
