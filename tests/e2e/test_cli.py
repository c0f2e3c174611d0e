"""The command line: one clear line and exit 1 for every kind of bad scenario, plugin
listing (broken plugins included), the example third-party plugin."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from adaptsky.scenario import load_scenario
from adaptsky.sim.network import NetworkBatch
from adaptsky_cli.cli.main import main
from tests.conftest import SCENARIOS
from tests.helpers.cli import ADAPTSKY
from tests.helpers.plugins import fake_distribution

MALFORMED = {
    "wrong_type": ('name = "x"\n[area]\nside_m = "big"\n', "area.side_m",
                   "valid number"),
    "unknown_key": ('name = "x"\n[radio]\nbandwith_hz = 1e6\n', "radio.bandwith_hz",
                    "unknown key"),
    "odd_user_count": ('name = "x"\n[users]\npositions_m = [[0, 0], [1, 1], [2, 2]]\n',
                       "users.positions_m", "even count"),
    "negative_bandwidth": ('name = "x"\n[radio]\nbandwidth_hz = -5.0\n', "radio.bandwidth_hz",
                           "greater than 0"),
    "unknown_plugin": ('name = "x"\n[channel]\nmodel = "nope"\n', "channel.model",
                       "unknown channel model 'nope'"),
    "bad_plugin_params": ('name = "x"\n[channel]\nmodel = "mmwave-nyc"\n[channel.params]\n'
                          'exponent_los = -2.0\n', "channel.params.exponent_los",
                          "greater than 0"),
    "invalid_toml": ('name = "x"\n[area\nside_m = 1\n', "invalid TOML", "line 2"),
}


@pytest.mark.parametrize("case", sorted(MALFORMED))
def test_malformed_scenario_gives_one_line_and_exit_1(case, tmp_path, capsys):
    text, field, message = MALFORMED[case]
    path = tmp_path / f"{case}.toml"
    path.write_text(text)
    for command in (["scenario", "validate"], ["scenario", "show"]):
        assert main([*command, str(path)]) == 1
        captured = capsys.readouterr()
        lines = captured.err.strip().splitlines()
        assert len(lines) == 1, lines
        assert lines[0].startswith(f"{path}: {field}")
        assert message in lines[0]
        assert "Traceback" not in captured.err and captured.out == ""


def test_missing_file(tmp_path, capsys):
    assert main(["scenario", "show", str(tmp_path / "none.toml")]) == 1
    assert "cannot read scenario file: No such file" in capsys.readouterr().err


def test_installed_command_prints_no_traceback(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text(MALFORMED["unknown_plugin"][0])
    done = subprocess.run([str(ADAPTSKY), "scenario", "validate", str(path)],
                          capture_output=True, text=True, check=False)
    assert done.returncode == 1
    assert done.stderr.strip().count("\n") == 0 and "Traceback" not in done.stderr
    assert done.stdout == ""


def test_validate_accepts_every_shipped_scenario(capsys):
    paths = [str(p) for p in sorted(SCENARIOS.glob("*.toml"))]
    assert main(["scenario", "validate", *paths]) == 0
    assert capsys.readouterr().out.count("ok  ") == len(paths)


def test_show_prints_resolved_toml(capsys):
    assert main(["scenario", "show", str(SCENARIOS / "nyc_mmwave.toml")]) == 0
    out = capsys.readouterr().out
    assert "[channel.params]\nlos_c = 9.6117" in out
    assert "epsilon_decay_steps = 200.0" in out


def test_plugins_list_and_show(capsys):
    assert main(["plugins", "list", "--json"]) == 0
    plugins = {p["name"]: p for p in json.loads(capsys.readouterr().out)}
    assert plugins["mmwave-nyc"]["status"] == "ok"
    assert plugins["uma-av"]["package"] == "adaptsky-example-channel"
    assert main(["plugins", "show", "sub6-al-hourani", "--json"]) == 0
    shown = json.loads(capsys.readouterr().out)
    assert shown["params"]["theta0_deg"]["default"] == 15.0
    assert "deg" in shown["params"]["theta0_deg"]["description"]
    assert main(["plugins", "show", "nope"]) == 1
    assert "unknown channel model 'nope'" in capsys.readouterr().err


def test_a_plugin_is_imported_when_used_or_listed_only(tmp_path):
    # every installed plugin was imported and called when a run needed one model
    fake_distribution(tmp_path, "probe-channel", "import sys\nsys.stdout.write('IMPORTED')\n")
    env = {**os.environ, "PYTHONPATH": str(tmp_path)}
    code = ("from adaptsky.channels.registry import get_model_class, names; "
            "get_model_class('mmwave-nyc'); print(' '.join(names()))")
    used = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env=env, check=False)
    assert used.stdout == "mmwave-nyc probe-channel sub6-al-hourani uma-av\n", used.stderr
    trained = subprocess.run([str(ADAPTSKY), "scenario", "validate",
                              str(SCENARIOS / "nyc_mmwave.toml")], capture_output=True,
                             text=True, env=env, check=False)
    assert trained.returncode == 0 and "IMPORTED" not in trained.stdout, trained
    listed = subprocess.run([str(ADAPTSKY), "plugins", "list"], capture_output=True,
                            text=True, env=env, check=False)
    assert listed.stdout.startswith("IMPORTED"), listed.stdout


def test_a_name_registered_by_two_packages_is_broken_and_neither_is_imported(tmp_path):
    for package in ("first-pkg", "second-pkg"):
        module = package.replace("-", "_")
        (tmp_path / f"{module}.py").write_text("import sys\nsys.stdout.write('IMPORTED')\n")
        info = tmp_path / f"{module}-0.3.dist-info"
        info.mkdir()
        (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {package}\nVersion: 0.3\n")
        (info / "entry_points.txt").write_text(
            f"[adaptsky.channel_models]\ntwice = {module}:Model\n")
    listed = subprocess.run([str(ADAPTSKY), "plugins", "list", "--json"], capture_output=True,
                            text=True, env={**os.environ, "PYTHONPATH": str(tmp_path)},
                            check=False)
    assert "IMPORTED" not in listed.stdout
    twice = {p["name"]: p for p in json.loads(listed.stdout)}["twice"]
    assert twice["status"] == "broken"
    assert twice["error"] in ("name 'twice' is registered by both first-pkg and second-pkg",
                              "name 'twice' is registered by both second-pkg and first-pkg")


def test_a_broken_plugin_is_listed_and_breaks_nothing_else(tmp_path):
    fake_distribution(tmp_path, "broken-channel", "import no_such_module\n")
    env = {**os.environ, "PYTHONPATH": str(tmp_path)}
    run = lambda *args: subprocess.run([str(ADAPTSKY), *args], capture_output=True,  # noqa: E731
                                       text=True, env=env, check=False)
    listed = run("plugins", "list", "--json")
    assert listed.returncode == 0
    plugins = {p["name"]: p for p in json.loads(listed.stdout)}
    assert plugins["broken-channel"]["status"] == "broken"
    assert "No module named 'no_such_module'" in plugins["broken-channel"]["error"]
    assert plugins["mmwave-nyc"]["status"] == "ok"
    assert run("scenario", "validate", str(SCENARIOS / "nyc_mmwave.toml")).returncode == 0
    scenario = tmp_path / "uses_broken.toml"
    scenario.write_text('name = "x"\n[channel]\nmodel = "broken-channel"\n')
    failed = run("scenario", "validate", str(scenario))
    assert failed.returncode == 1
    assert failed.stderr.strip() == (f"{scenario}: channel.model: channel model 'broken-channel' "
                                     "(broken-channel) is broken: ModuleNotFoundError: No module "
                                     "named 'no_such_module'")


def test_example_third_party_plugin_validates_and_steps(tmp_path):
    path = tmp_path / "uma.toml"
    path.write_text(textwrap.dedent("""\
        name = "uma"
        [radio]
        tx_power_dbm = 30.0
        bandwidth_hz = 20e6
        thermal_noise_dbm = -101.0
        antennas_uav = 1
        antennas_ue = 1
        [channel]
        model = "uma-av"
        los = "sampled"
        [channel.params]
        carrier_hz = 2e9
        """))
    assert main(["scenario", "validate", str(path)]) == 0
    env = NetworkBatch(load_scenario(path), num_envs=4, seed=0)
    env.reset()
    for _ in range(5):
        _, reward, _, state = env.step(np.arange(4))
    assert np.all(np.isfinite(reward)) and np.all(state.sum_rate_bps > 0)
