"""What a new user trips on in scenario files (issue 22): a misspelt key names the closest
one, a run file given as a scenario says so, names in any script, and ``scenario show`` writes
TOML a person would (pairs on one line, ``2e9``) that reads back as it was."""

from __future__ import annotations

import tomllib
from pathlib import Path

import h5py
import numpy as np
import pytest

from adaptsky.errors import ScenarioError
from adaptsky.experiment.plan import load_experiment, plan_experiment, shipped_experiments
from adaptsky.scenario import load_scenario, parse_scenario
from adaptsky.scenario.toml_writer import dumps
from adaptsky_cli.cli.main import main
from tests.conftest import SCENARIOS


def _refused(data: dict) -> list[str]:
    with pytest.raises(ScenarioError) as error:
        parse_scenario({"name": "typo", **data}, "typo.toml")
    return error.value.lines


# ---- item 7: did you mean --------------------------------------------------------------------

@pytest.mark.parametrize(("data", "line"), [
    ({"radio": {"thermal_nosie_dbm": -90.0}},
     "typo.toml: radio.thermal_nosie_dbm: unknown key; did you mean 'thermal_noise_dbm'?"),
    ({"radoi": {}}, "typo.toml: radoi: unknown key; did you mean 'radio'?"),
    ({"agent": {"learning_rate": 1e-3, "batchsize": 64}},
     "typo.toml: agent.batchsize: unknown key; did you mean 'batch_size'?"),
    ({"channel": {"model": "sub6-al-hourani", "params": {"excess_loss_los": 2.0}}},
     "typo.toml: channel.params.excess_loss_los: unknown key; did you mean "
     "'excess_loss_los_db'?"),
])
def test_a_misspelt_key_names_the_closest_key_in_the_same_line(data, line):
    assert line in _refused(data)


def test_a_key_like_none_is_only_unknown():
    assert _refused({"radio": {"zzz": 1}}) == ["typo.toml: radio.zzz: unknown key"]


def test_overrides_get_the_suggestion_too(tmp_path, capsys):
    path = tmp_path / "s.toml"
    path.write_text('name = "s"\n')
    assert main(["train", str(path), "--set", "reward.w_rat=2", "--quiet"]) == 1
    assert capsys.readouterr().err.strip().splitlines() == [
        f"{path} with --set: reward.w_rat: unknown key; did you mean 'w_rate'?"]


# ---- item 8: a run file given as a scenario ---------------------------------------------------

def test_a_run_file_given_as_a_scenario_says_so_and_suggests_resume(tmp_path, capsys):
    run = tmp_path / "x.h5"
    with h5py.File(run, "w") as file:
        file.create_dataset("big", data=np.zeros(1 << 18))  # larger than a scenario may be
    line = (f"{run}: cannot read scenario file: it is an HDF5 file (an adaptsky run or eval "
            f"file), not TOML; to continue the run: adaptsky train --resume {run}")
    with pytest.raises(ScenarioError) as error:
        load_scenario(run)
    assert error.value.lines == [line]
    assert main(["train", str(run), "--quiet"]) == 1
    assert capsys.readouterr().err.strip().splitlines() == [line]


# ---- item 10: names in any script -------------------------------------------------------------

@pytest.mark.parametrize("name", ["ラン_ü", "Ελληνικά-1", "дрон.v2", "نموذج", "u\u0308ber",
                                  "東京" * 21])
def test_names_in_any_script_are_safe_file_names(name):
    assert parse_scenario({"name": name}).name == name


@pytest.mark.parametrize("name", ["a/b", "a\\b", "ラン/ü", ".ラン", "a\u202eb", "a\u200bb",
                                  "a\tb", "a\x7fb", "a b", "a\u3000b", "a:b", "a*b", "..",
                                  "東京" * 22, "𝔘" * 33, "x" * 65, "_x"])
def test_separators_controls_and_leading_dots_stay_refused(name):
    (line,) = _refused({"name": name})
    assert line.startswith("typo.toml: name: not a safe file name: use 1 to 64 letters or "
                           "digits of any script")


# ---- item 13: scenario show ------------------------------------------------------------------

def _shipped_configs() -> list[tuple[str, dict]]:
    """Every shipped scenario and every run of the shipped experiments, resolved."""
    configs = [(path.name, load_scenario(path).model_dump(mode="json"))
               for path in sorted(SCENARIOS.glob("*.toml"))]
    for name in shipped_experiments():
        experiment, path = load_experiment(name)
        plan = plan_experiment(experiment, path, Path("/nonexistent"), runs=1)
        configs += [(f"{name}:{run.name}", run.config) for run in plan.runs]
    return configs


def _without_none(value):
    if isinstance(value, dict):
        return {k: _without_none(v) for k, v in value.items() if v is not None}
    return value


def test_show_round_trips_every_shipped_scenario():
    configs = _shipped_configs()
    assert len(configs) > 6
    for name, config in configs:
        text = dumps(config)
        assert tomllib.loads(text) == _without_none(config), name
        again = parse_scenario(tomllib.loads(text), name).model_dump(mode="json")
        assert again == config, name


def test_show_writes_pairs_on_one_line_and_numbers_as_people_do(capsys):
    assert main(["scenario", "show", str(SCENARIOS / "sub6_al_hourani.toml")]) == 0
    text = capsys.readouterr().out
    assert ("positions_m = [[4.0, 15.0], [-44.0, -49.0], [-5.0, 21.0], [47.0, 49.0]]\n"
            in text)
    assert "start_m = [0.0, 0.0, 50.0]\n" in text and "carrier_hz = 2e9\n" in text
    assert "bandwidth_hz = 5e7\n" in text and "w_gain = 1e7\n" in text
    assert "2000000000.0" not in text and max(map(len, text.splitlines())) <= 100


def test_long_arrays_keep_one_pair_per_line_and_pack_numbers():
    users = [[float(i), -float(i)] for i in range(20)]
    text = dumps({"users": {"positions_m": users}, "train": {"seeds": list(range(300))}})
    lines = text.splitlines()
    assert "    [3.0, -3.0]," in lines and len(lines) < 50
    assert max(map(len, lines)) <= 100
    assert tomllib.loads(text) == {"users": {"positions_m": users},
                                   "train": {"seeds": list(range(300))}}
