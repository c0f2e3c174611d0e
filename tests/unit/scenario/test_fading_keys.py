"""``[channel.fading]`` (issue 37, docs/model.md §11): off by default, its models' own keys
filled in, and each setting that cannot work or would be ignored refused in one line naming
the file, the key, what is wrong and what is allowed."""

from __future__ import annotations

import tomllib

import pytest

from adaptsky.errors import ScenarioError
from adaptsky.scenario import parse_scenario
from adaptsky.scenario.toml_writer import dumps
from adaptsky_cli.cli.main import main


def _parsed(channel: dict):
    return parse_scenario({"name": "f", "channel": channel}, "f.toml")


def _refused(channel: dict) -> list[str]:
    with pytest.raises(ScenarioError) as error:
        _parsed(channel)
    return error.value.lines


def test_fading_is_off_by_default_and_a_rician_model_takes_our_defaults():
    fading = _parsed({}).channel.fading
    assert (fading.model, fading.k0_db, fading.k90_db, fading.correlation) == (
        "none", None, None, None)
    rician = _parsed({"fading": {"model": "rician"}}).channel.fading
    assert (rician.k0_db, rician.k90_db, rician.correlation) == (0.0, 15.0, 0.0)
    rayleigh = _parsed({"fading": {"model": "rayleigh", "correlation": 0.5}}).channel.fading
    assert (rayleigh.k0_db, rayleigh.correlation) == (None, 0.5)


@pytest.mark.parametrize("fading", [{}, {"model": "rician", "k0_db": -3.0, "correlation": 0.9},
                                    {"model": "rayleigh"}])
def test_a_resolved_scenario_reads_back_as_it_was(fading):
    scenario = _parsed({"fading": fading})
    assert parse_scenario(tomllib.loads(dumps(scenario.model_dump())), "again") == scenario


@pytest.mark.parametrize(("channel", "line"), [
    ({"los": "expected", "fading": {"model": "rician"}},
     "f.toml: channel.fading.model: 'rician' with channel.los = 'expected' is ambiguous (the "
     "expected gain mixes the LoS and NLoS gains, and only one of them would fade); use "
     "channel.los = 'always' or 'sampled', or channel.fading.model = 'none'"),
    ({"fading": {"model": "rayleigh", "k0_db": 3.0}},
     "f.toml: channel.fading: k0_db given with model = 'rayleigh', which ignores it "
     "('rayleigh' reads correlation only; 'rician' reads k0_db, k90_db and correlation); "
     "remove it or choose another model"),
    ({"fading": {"k90_db": 3.0, "correlation": 0.2}},
     "f.toml: channel.fading: k90_db, correlation given with model = 'none', which ignores "
     "them ('none' reads none of them; 'rician' reads k0_db, k90_db and correlation); remove "
     "them or choose another model"),
    ({"fading": {"model": "rician", "correlation": 1.0}},
     "f.toml: channel.fading.correlation: correlation rho = 1 lies outside [0, 1): 0 draws "
     "every step anew, values near 1 fade slowly, 1 would never change (got 1.0)"),
    ({"fading": {"model": "rician", "correlation": -0.1}},
     "f.toml: channel.fading.correlation: correlation rho = -0.1 lies outside [0, 1): 0 draws "
     "every step anew, values near 1 fade slowly, 1 would never change (got -0.1)"),
    ({"fading": {"model": "rician", "k0_db": 50.0}},
     "f.toml: channel.fading.k0_db: Input should be less than or equal to 40 (got 50.0)"),
    ({"fading": {"model": "nakagami"}},
     "f.toml: channel.fading.model: Input should be 'none', 'rayleigh' or 'rician' "
     "(got 'nakagami')"),
    ({"fading": {"model": "rician", "k_db": 3.0}},
     "f.toml: channel.fading.k_db: unknown key; did you mean 'k0_db'?"),
])
def test_settings_that_cannot_work_or_would_be_ignored_are_one_line(channel, line):
    assert _refused(channel) == [line]


def test_a_plugin_that_draws_its_own_fading_refuses_the_built_in_one():
    channel = {"model": "uma-av", "params": {"shadowing": True},
               "fading": {"model": "rayleigh"}}
    assert _refused(channel) == [
        "f.toml: channel.fading.model: 'rayleigh', but channel model 'uma-av' draws its own "
        "fading with these channel.params; every link would fade twice: set "
        "channel.fading.model = 'none', or turn the model's fading off in channel.params "
        "(adaptsky plugins show uma-av)"]
    # its fading off: the built-in one applies
    _parsed({"model": "uma-av", "fading": {"model": "rayleigh"}})


def test_the_command_line_says_it_in_one_line_with_exit_code_1(tmp_path, capsys):
    path = tmp_path / "f.toml"
    path.write_text('name = "f"\n[channel]\nlos = "expected"\n[channel.fading]\n'
                    'model = "rayleigh"\n')
    assert main(["scenario", "validate", str(path)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"{path}: channel.fading.model: 'rayleigh'")


@pytest.mark.parametrize("key", ["k0_db", "k90_db", "correlation"])
@pytest.mark.parametrize("value", [1e308, -1e3, float("nan"), float("inf"), "12", True])
def test_odd_numbers_are_one_line_naming_the_key(key, value):
    lines = _refused({"fading": {"model": "rician", key: value}})
    assert len(lines) == 1 and lines[0].startswith(f"f.toml: channel.fading.{key}: "), lines
