"""``adaptsky.train(scenario=...)``: a ``Scenario`` in memory trains as the same scenario from
a file, bit for bit, into a run file that keeps its TOML text, and that ``resume``,
``inspect`` and ``eval`` take as any other."""

from __future__ import annotations

from pathlib import Path

import pytest

import adaptsky
from adaptsky.scenario import load_scenario, parse_scenario
from adaptsky.scenario.loading import parse_toml
from adaptsky.scenario.toml_writer import dumps
from adaptsky.store.run_file import RunReader
from adaptsky_cli.cli.main import main
from tests.helpers.training import assert_same_curves, curves, small_scenario

SHORT = {"seeds": [0, 1], "episodes": 2, "steps": 20, "workers": 1, "quiet": True}


@pytest.fixture(scope="module")
def scenario_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return small_scenario(tmp_path_factory.mktemp("scenario"))


def test_in_memory_trains_the_numbers_of_the_file(scenario_file, tmp_path):
    scenario = load_scenario(scenario_file)
    from_memory, _ = adaptsky.train(scenario=scenario, out=tmp_path / "memory.h5", **SHORT)
    from_file, _ = adaptsky.train(scenario_path=scenario_file, out=tmp_path / "file.h5",
                                  **SHORT)
    from_path, _ = adaptsky.train(scenario=str(scenario_file), out=tmp_path / "path.h5",
                                  **SHORT)
    assert_same_curves(curves(from_memory), curves(from_file))
    assert_same_curves(curves(from_path), curves(from_file))
    with RunReader(from_memory) as run:
        text = run.scenario_text
    assert text == dumps(scenario.model_dump(mode="json"))
    assert parse_scenario(parse_toml(text, "stored"), "stored") == scenario


def test_a_run_trained_in_memory_resumes_inspects_and_evaluates(scenario_file, tmp_path,
                                                                  capsys):
    scenario = load_scenario(scenario_file)
    straight, _ = adaptsky.train(scenario=scenario, out=tmp_path / "straight.h5", **SHORT)
    stopped, _ = adaptsky.train(scenario=scenario, out=tmp_path / "stopped.h5",
                                checkpoint_every=1, **SHORT | {"episodes": 1})
    adaptsky.resume(run_path=stopped, episodes=2, workers=1, quiet=True)
    assert_same_curves(curves(stopped), curves(straight))
    capsys.readouterr()
    assert main(["inspect", str(stopped)]) == 0
    assert main(["eval", "--checkpoint", str(stopped), "--steps", "5", "--compare", "",
                 "--out", str(tmp_path / "eval.h5")]) == 0


def test_train_takes_one_scenario(scenario_file, tmp_path):
    with pytest.raises(TypeError, match="one of scenario= and scenario_path="):
        adaptsky.train(out=tmp_path / "none.h5", **SHORT)
    with pytest.raises(TypeError, match="one of scenario= and scenario_path="):
        adaptsky.train(scenario=load_scenario(scenario_file), scenario_path=scenario_file,
                       out=tmp_path / "both.h5", **SHORT)
