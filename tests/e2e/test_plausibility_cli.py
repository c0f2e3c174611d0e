"""Issue 35, item 7, on the command line: a scenario with a value far outside what UAV networks
use prints one ``adaptsky: warning: FILE: key = value ...`` line on stderr naming the unit,
once, and the command goes on (exit 0); shipped scenarios print none."""

from __future__ import annotations

from pathlib import Path

import pytest

from adaptsky_cli.cli import plausibility
from adaptsky_cli.cli.main import main
from tests.conftest import SCENARIOS

EXPERIMENTS = SCENARIOS.parent / "experiments"

WARNING = ("adaptsky: warning: {path}: radio.bandwidth_hz = 50 Hz is far below what UAV "
           "networks use (10 kHz .. 10 GHz); the unit is Hz: if 50 is in MHz, write 5e7 "
           "(50 MHz)")


@pytest.fixture(autouse=True)
def _fresh_process(monkeypatch):
    """Each test a fresh command: nothing printed before."""
    monkeypatch.setattr(plausibility, "_printed", set())


@pytest.fixture
def narrow(tmp_path: Path) -> Path:
    path = tmp_path / "narrow.toml"
    path.write_text('name = "narrow"\n[radio]\nbandwidth_hz = 50.0\n')
    return path


@pytest.mark.parametrize("command", ["validate", "show"])
def test_scenario_commands_warn_on_stderr_and_succeed(narrow, command, capsys):
    assert main(["scenario", command, str(narrow)]) == 0
    captured = capsys.readouterr()
    assert captured.err.splitlines() == [WARNING.format(path=narrow)]
    assert "warning" not in captured.out
    assert ("ok  " in captured.out) if command == "validate" else (
        "bandwidth_hz = 50.0" in captured.out)


def test_validate_of_the_shipped_scenarios_warns_nothing(capsys):
    files = [str(path) for path in sorted(SCENARIOS.glob("*.toml"))]
    assert main(["scenario", "validate", *files]) == 0
    assert capsys.readouterr().err == ""


def test_train_warns_before_it_starts(narrow, tmp_path, capsys):
    """The warning comes before any work: here the run stops at once on its output (a
    folder), which is its own line."""
    assert main(["train", str(narrow), "--out", str(tmp_path)]) == 1
    lines = capsys.readouterr().err.splitlines()
    assert lines[0] == WARNING.format(path=narrow)
    assert "is a folder" in lines[-1]


def test_a_set_value_is_checked_and_each_line_is_printed_once(capsys):
    path = SCENARIOS / "nyc_mmwave.toml"
    for _ in range(2):
        plausibility.warn_scenario_file(path, ["radio.tx_power_dbm=0.5"])
    (line,) = capsys.readouterr().err.splitlines()
    assert line.startswith(f"adaptsky: warning: {path} with --set: radio.tx_power_dbm = 0.5 dBm")
    assert "the unit is dBm" in line


def test_a_file_that_does_not_load_says_nothing_here(tmp_path, capsys):
    """The command itself reports it, in its own words."""
    plausibility.warn_scenario_file(tmp_path / "missing.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text('name = "bad"\n[radio]\nbandwidth_hz = -1.0\n')
    plausibility.warn_scenario_file(bad)
    assert capsys.readouterr().err == ""


def test_an_experiment_warns_for_its_scenarios_with_every_override(tmp_path, capsys):
    (tmp_path / "odd.toml").write_text('name = "odd"\n')
    shipped = (EXPERIMENTS / "e4.toml").read_text()  # its evaluation, figure and claims
    groups = shipped.index("[[groups]]"), shipped.index("[evaluation]")
    experiment = tmp_path / "odd-experiment.toml"
    experiment.write_text(
        shipped[:groups[0]] + '[[groups]]\nname = "u1"\nlabel = "g"\nscenario = "odd.toml"\n'
        'runs = 1\nset = ["users.speed_m_per_step=60"]\n\n' + shipped[groups[1]:]
        .replace('also = ["u2", "u3", "u4"]\n', ""))
    plausibility.warn_experiment(str(experiment), ["radio.bandwidth_hz=50"])
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 3  # the bandwidth; the speed per second and per area side
    assert ["users.speed_m_per_step = 60 m per step" in line for line in lines] == [
        False, True, True]
    assert all(line.startswith(f"adaptsky: warning: {tmp_path / 'odd.toml'} with --set: ")
               for line in lines)
    plausibility.warn_experiment("all")  # the shipped experiments: plausible
    assert capsys.readouterr().err == ""
