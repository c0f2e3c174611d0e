"""``--set section.key=value``: parsing, applying, validation like the file, the run file's
record."""

from __future__ import annotations

import json

import h5py
import pytest

from adaptsky.errors import ScenarioError
from adaptsky.scenario.overrides import apply_overrides, parse_value
from adaptsky_cli.cli.main import main
from tests.conftest import SCENARIOS


@pytest.mark.parametrize(("text", "value"), [
    ("1.5", 1.5), ("3", 3), ("true", True), ("[0, 1]", [0, 1]), ('"x y"', "x y"),
    ("sampled", "sampled"), ("1e-4", 1e-4), ("mmwave-nyc", "mmwave-nyc")])
def test_values_are_toml_or_plain_strings(text, value):
    assert parse_value(text) == value


def test_overrides_apply_in_order_to_a_copy():
    data = {"reward": {"min_se": 0.0}, "name": "a"}
    result = apply_overrides(data, ["reward.min_se=1.5", "channel.params.carrier_hz=3e9",
                                    "reward.min_se=2"], "f.toml")
    assert result == {"reward": {"min_se": 2}, "name": "a",
                      "channel": {"params": {"carrier_hz": 3e9}}}
    assert data == {"reward": {"min_se": 0.0}, "name": "a"}


@pytest.mark.parametrize(("item", "message"), [
    ("noequals", "expected section.key=value"),
    ("name.x=1", "name is a value, not a table"),
    ("reward..min_se=1", "expected section.key=value")])
def test_malformed_overrides_are_one_line(item, message):
    with pytest.raises(ScenarioError) as error:
        apply_overrides({"name": "a"}, [item], "f.toml")
    assert len(error.value.lines) == 1 and message in error.value.lines[0]


def test_train_records_overrides_and_validates_them(tmp_path, capsys):
    out = tmp_path / "run.h5"
    code = main(["train", str(SCENARIOS / "nyc_mmwave.toml"), "--episodes", "1", "--steps",
                 "5", "--out", str(out), "--quiet", "--set", "reward.min_se=1.5",
                 "--set", "channel.los=sampled"])
    assert code == 0
    with h5py.File(out, "r") as file:
        assert json.loads(file["overrides"][()]) == ["reward.min_se=1.5", "channel.los=sampled"]
        config = json.loads(file["config"][()])
    assert config["reward"]["min_se"] == 1.5 and config["channel"]["los"] == "sampled"
    capsys.readouterr()
    assert main(["inspect", str(out), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["overrides"] == ["reward.min_se=1.5",
                                                                "channel.los=sampled"]
    for item, message in (("agent.lr=abc", "agent.lr: Input should be a valid number"),
                          ("agent.nope=1", "agent.nope: unknown key"),
                          ("reward.min_se=-1", "reward.min_se: Input should be greater")):
        code = main(["train", str(SCENARIOS / "nyc_mmwave.toml"), "--out",
                     str(tmp_path / "bad.h5"), "--set", item])
        lines = capsys.readouterr().err.strip().splitlines()
        assert code == 1 and len(lines) == 1, lines
        assert "nyc_mmwave.toml with --set: " + message in lines[0]
        assert not (tmp_path / "bad.h5").exists()
