"""Shared settings a channel model honours (issue 22, item 2; docs/plugins.md, ``Supports``):
a scenario that sets one the model ignores or cannot model is refused in one line naming the
model and what it supports, for built-in and third-party models alike; ``plugins check``
checks the declaration; a model that declares nothing behaves as before."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from typing import ClassVar

import pytest
from pydantic import Field

from adaptsky.channels import ChannelParams, Supports, registry
from adaptsky.channels.checker import check_channel_model, structural_problems
from adaptsky.channels.registry import PluginInfo
from adaptsky.errors import ScenarioError
from adaptsky.scenario import load_scenario, parse_scenario
from adaptsky_cli.cli.main import main
from tests.conftest import SCENARIOS
from tests.helpers.plugins import UNDECLARED, Good, fake_distribution

HINT = "; give {key} a value it supports, or choose another model (adaptsky plugins list)"


def _refused(model: str, **sections: dict) -> list[str]:
    with pytest.raises(ScenarioError) as error:
        parse_scenario({"name": "s", "channel": {"model": model}, **sections}, "s.toml")
    return error.value.lines


@pytest.mark.parametrize(("model", "carrier_hz", "supports"), [
    ("mmwave-nyc", 3.5e9, "carriers of 28 GHz only"),           # ignored: 28 GHz physics
    ("sub6-al-hourani", 5e11, "carriers from 100 MHz to 100 GHz"),
    ("uma-av", 2e11, "carriers from 500 MHz to 100 GHz"),       # the example plugin
])
def test_a_carrier_the_model_does_not_model_is_refused_in_one_line(model, carrier_hz,
                                                                    supports):
    shown = f"{carrier_hz / 1e9:g} GHz"
    assert _refused(model, radio={"carrier_hz": carrier_hz}) == [
        f"s.toml: radio.carrier_hz: {shown}, but channel model '{model}' supports {supports}"
        + HINT.format(key="radio.carrier_hz")]


def test_the_carrier_a_model_declares_is_accepted_given_or_not():
    for radio in ({}, {"carrier_hz": 28e9}):
        scenario = parse_scenario({"name": "s", "radio": radio})
        assert scenario.radio.carrier_hz == 28e9


def test_every_shipped_scenario_still_validates_with_its_carrier():
    carriers = {path.name: load_scenario(path).radio.carrier_hz
                for path in SCENARIOS.glob("*.toml")}
    assert carriers == {name: 2e9 if "sub6" in name else 28e9 for name in carriers}


class Narrowband(Good):
    """A third-party model valid for 1-6 GHz and user antennas 1.5-22.5 m up."""

    contract_version = 2
    supports = Supports(carrier_hz=(1e9, 6e9), user_height_m=(1.5, 22.5))


class SingleCarrier(Good):
    contract_version = 2
    supports = Supports(carrier_hz=(3.5e9, 3.5e9))


@pytest.fixture
def registered():
    """Narrowband and SingleCarrier in this process's registry, for one test."""
    models = {"narrowband": Narrowband, "single-carrier": SingleCarrier}
    for name, model in models.items():
        registry._loaded[name] = PluginInfo(name, "tests", "0", f"tests:{name}", model)
    yield
    for name in models:
        registry._loaded.pop(name, None)


def test_third_party_declarations_take_the_same_rule(registered):
    assert _refused("narrowband", users={"height_m": 1.5}) == [
        "s.toml: radio.carrier_hz: 28 GHz (the default: radio.carrier_hz is not set), but "
        "channel model 'narrowband' supports carriers from 1 GHz to 6 GHz"
        + HINT.format(key="radio.carrier_hz")]
    assert _refused("narrowband", radio={"carrier_hz": 2e9}) == [
        "s.toml: users.height_m: 0 m, but channel model 'narrowband' supports user antenna "
        "heights from 1.5 m to 22.5 m" + HINT.format(key="users.height_m")]
    ok = parse_scenario({"name": "s", "channel": {"model": "narrowband"},
                         "radio": {"carrier_hz": 2e9}, "users": {"height_m": 1.5}})
    assert ok.radio.carrier_hz == 2e9
    # one declared carrier is the default where the scenario gives none
    single = parse_scenario({"name": "s", "channel": {"model": "single-carrier"}})
    assert single.radio.carrier_hz == 3.5e9


class Backwards(Good):
    contract_version = 2
    supports = Supports(carrier_hz=(6e9, 1e9))


class AsDict(Good):
    contract_version = 2
    supports: ClassVar = {"carrier_hz": (1e9, 6e9)}


class OldWithSupports(Good):  # contract 1: declares no contract_version
    supports = Supports(carrier_hz=(28e9, 28e9))


class CarrierParams(ChannelParams):
    carrier_hz: float = Field(2e9, ge=1e8, le=1e11, description="carrier frequency f_c, Hz")


class DefaultOutside(Good):
    contract_version = 2
    Params = CarrierParams
    supports = Supports(carrier_hz=(3e9, 4e9))


@pytest.mark.parametrize(("model", "problem"), [
    (Backwards, "supports: carrier_hz = (6000000000.0, 1000000000.0) is not a range (low, "
                "high) of finite numbers with 0 < low <= high"),
    (AsDict, "supports: must be a Supports(...) declaration, not dict"),
    (OldWithSupports, "contract: supports is a contract-2 declaration; declare "
                      "contract_version = 2 in the class to use it"),
    (DefaultOutside, "supports: the carrier_hz parameter's default, 2e+09 Hz, is outside the "
                     "model's carriers from 3 GHz to 4 GHz"),
])
def test_a_declaration_that_cannot_hold_makes_the_model_broken(model, problem):
    assert structural_problems(model) == [problem]
    assert check_channel_model(model) == [problem]


def test_the_checker_runs_inside_the_declaration():
    assert check_channel_model(Narrowband) == []
    assert check_channel_model(Narrowband, carrier_hz=3.5e9) == []
    assert check_channel_model(Narrowband, carrier_hz=28e9) == [
        "carrier: carrier_hz = 2.8e+10 Hz is outside what the model supports (carriers from 1 "
        "GHz to 6 GHz)"]


def _cli(tmp_path, *args: str) -> subprocess.CompletedProcess:
    """``adaptsky ARGS`` with the fake distributions of ``tmp_path`` installed."""
    path = os.pathsep.join(filter(None, [str(tmp_path), os.environ.get("PYTHONPATH")]))
    return subprocess.run([sys.executable, "-m", "adaptsky_cli", *args], capture_output=True,
                          text=True, env={**os.environ, "PYTHONPATH": path, "COLUMNS": "200"},
                          check=False)


IGNORES_CARRIER = """\
    import numpy as np
    from adaptsky.channels import ChannelModel

    class Model(ChannelModel):
        description = "free space at 28 GHz whatever the carrier"
        contract_version = 2
        def los_probability(self, geometry):
            return np.ones(geometry.shape)
        def gain_los(self, geometry):
            return (299_792_458.0 / (4 * np.pi * 28e9 * geometry.distance_m)) ** 2
        def gain_nlos(self, geometry):
            return 0.1 * self.gain_los(geometry)
    """


def test_plugins_check_reports_declarations_and_models_that_declare_nothing(tmp_path):
    fake_distribution(tmp_path, "old-channel", UNDECLARED)
    fake_distribution(tmp_path, "fixed-carrier", IGNORES_CARRIER)
    old = _cli(tmp_path, "plugins", "check", "old-channel")  # contract 1, as before
    assert old.returncode == 0, old.stderr
    assert old.stdout.splitlines() == [
        "ok  old-channel: follows plugin contract 1 (f_c 28 GHz, users on the ground, no "
        "fading hook, parameters: defaults)",
        "note: old-channel declares no contract_version and is taken as contract 1 (users on "
        "the ground, no fading); declare contract_version = 2 (docs/plugins.md, contract "
        "versions)"]
    ignores = _cli(tmp_path, "plugins", "check", "fixed-carrier")
    assert ignores.returncode == 0, ignores.stderr
    assert ignores.stdout.splitlines()[1].startswith(
        "note: fixed-carrier: its gains are the same at 2 and 28 GHz: it ignores "
        "radio.carrier_hz")
    mmwave = _cli(tmp_path, "plugins", "check", "mmwave-nyc")
    assert mmwave.stdout.strip().endswith("supports carriers of 28 GHz only)")
    assert _cli(tmp_path, "plugins", "check", "mmwave-nyc", "--carrier-hz", "3.5e9"
                ).stderr.strip().splitlines() == [
        "mmwave-nyc: carrier: carrier_hz = 3.5e+09 Hz is outside what the model supports "
        "(carriers of 28 GHz only)"]


def test_plugins_show_says_what_a_model_supports(capsys):
    assert main(["plugins", "show", "mmwave-nyc"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    assert ("supports carriers of 28 GHz only, any bandwidths, any user antenna heights"
            in text)
    assert main(["plugins", "show", "uma-av", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["supports"] == {
        "carrier_hz": [5e8, 1e11], "bandwidth_hz": None, "user_height_m": None}


def test_validate_refuses_the_silently_ignored_carrier_of_the_issue(tmp_path, capsys):
    path = tmp_path / "x.toml"
    path.write_text(textwrap.dedent("""\
        name = "x"
        [radio]
        carrier_hz = 3.5e9
        """))
    assert main(["scenario", "validate", str(path)]) == 1
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith(f"{path}: radio.carrier_hz: 3.5 GHz, but channel model 'mmwave-nyc' "
                           "supports carriers of 28 GHz only")
