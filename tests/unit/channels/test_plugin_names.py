"""A misspelt channel-model name gets "did you mean" (difflib, a letter or two off) wherever
it is given: ``plugins show``, ``plugins check``, a scenario's ``[channel] model``, a
``--set``; a name close to none keeps the list alone."""

from __future__ import annotations

from pathlib import Path

import pytest

from adaptsky.channels import registry
from adaptsky.errors import PluginError
from adaptsky_cli.cli.main import main
from tests.helpers.cli import one_line


def installed() -> str:
    names = registry.names()
    assert {"mmwave-nyc", "sub6-al-hourani"} <= set(names)
    return ", ".join(names)


@pytest.mark.parametrize(("typed", "meant"), [
    ("mmwave-nyk", "mmwave-nyc"), ("sub6-alhourani", "sub6-al-hourani"),
    ("mmwave_nyc", "mmwave-nyc"), ("Sub6-Al-Hourani", "sub6-al-hourani")])
@pytest.mark.parametrize("command", [["plugins", "show"], ["plugins", "check"]])
def test_plugins_commands_say_the_name_meant(command, typed, meant, capsys):
    assert main([*command, typed]) == 1
    assert one_line(capsys) == (f"unknown channel model '{typed}'; did you mean '{meant}'? "
                                f"(installed: {installed()})")


def test_a_name_close_to_none_keeps_the_list(capsys):
    assert main(["plugins", "show", "free-space"]) == 1
    assert one_line(capsys) == f"unknown channel model 'free-space'; installed: {installed()}"
    with pytest.raises(PluginError, match=r"^unknown channel model 'nope'; installed: "):
        registry.get_model_class("nope")


def test_a_scenario_naming_a_misspelt_model(tmp_path: Path, capsys):
    scenario = tmp_path / "typo.toml"
    scenario.write_text('name = "typo"\n[channel]\nmodel = "mmwave-nyk"\n')
    assert main(["scenario", "validate", str(scenario)]) == 1
    assert one_line(capsys) == (f"{scenario}: channel.model: unknown channel model "
                                "'mmwave-nyk'; did you mean 'mmwave-nyc'? (installed: "
                                f"{installed()})")
    assert main(["train", str(scenario), "--episodes", "1", "--steps", "2", "--quiet",
                 "--out", str(tmp_path / "typo.h5")]) == 1
    assert "did you mean 'mmwave-nyc'?" in one_line(capsys)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["typo.toml"]
