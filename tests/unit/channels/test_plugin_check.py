"""The plugin contract's checks: check_channel_model, the structural part at discovery, and
``adaptsky plugins check``/``list`` on installed (fake) distributions."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
import tomllib
from pathlib import Path

import numpy as np
import pytest

from adaptsky.channels import ChannelModel, ChannelParams
from adaptsky.channels.checker import check_channel_model, structural_problems
from adaptsky.channels.registry import discover
from tests.helpers.cli import ADAPTSKY
from tests.helpers.plugins import (
    GUIDE_BLOCKS,
    MISSING,
    UNDECLARED,
    Good,
    fake_distribution,
    guide_block,
    guide_blocks,
)


class MissingMethod(ChannelModel):
    description = "forgets gain_nlos"

    def los_probability(self, geometry):
        return np.ones(geometry.shape)

    def gain_los(self, geometry):
        return 1.0 / geometry.distance_m ** 2


class WrongShape(Good):
    def gain_los(self, geometry):
        return 1.0 / geometry.distance_m[:, 0] ** 2


class Grows(Good):
    def gain_nlos(self, geometry):
        return 1e-12 * geometry.distance_m


class OutOfRange(Good):
    def los_probability(self, geometry):
        return geometry.elevation_deg / 45.0  # up to 2


class GlobalDraws(Good):
    def sample_los(self, geometry, rng):
        return np.random.random(geometry.shape) < 0.5


class NoDescriptionParams(ChannelParams):
    carrier_hz: float = 28e9


class Undocumented(Good):
    Params = NoDescriptionParams


def test_a_model_that_follows_the_contract_passes():
    assert check_channel_model(Good) == []


@pytest.mark.parametrize("name", [name for name, info in discover().items()
                                  if info.status == "ok"])
def test_installed_models_pass(name):
    assert check_channel_model(discover()[name].model) == []


@pytest.mark.parametrize(("model", "line"), [
    (MissingMethod, "method: gain_nlos() is not implemented (abstract in ChannelModel)"),
    (WrongShape, "shape: gain_los() returned shape (6,) for links of shape (6, 5)"),
    (Grows, "monotone: gain_nlos() grows with distance at a UAV height of 10 m"),
    (OutOfRange, "range: los_probability() left [0, 1]"),
    (GlobalDraws, "generator: sample_los() drew from numpy's global generator"),
    (Undocumented, "params: carrier_hz has no description"),
    (int, "class: 'int' is not a ChannelModel subclass"),
])
def test_each_broken_rule_is_one_line_naming_it(model, line):
    failures = check_channel_model(model)
    assert any(failure.startswith(line) for failure in failures), failures
    assert all("\n" not in failure for failure in failures)


def test_structure_alone_calls_nothing():
    assert structural_problems(WrongShape) == []  # shapes need a call: not structural
    assert structural_problems(MissingMethod) == [
        "method: gain_nlos() is not implemented (abstract in ChannelModel)"]


WRONG_SHAPE = textwrap.dedent(MISSING) + """\
    def gain_nlos(self, geometry):
        return 0.1 / geometry.distance_m[:, 0] ** 2
"""


def _run(tmp_path, *args, columns: int = 80, pythonpath: str | None = None):
    env = {**os.environ, "PYTHONPATH": pythonpath or str(tmp_path), "COLUMNS": str(columns)}
    return subprocess.run([str(ADAPTSKY), *args], capture_output=True, text=True, env=env,
                          check=False)


def _installed(tmp_path, modules: dict[str, str]) -> dict[str, dict]:
    """Install each module text as a plugin distribution; ``plugins list --json`` by name."""
    for name, text in modules.items():
        fake_distribution(tmp_path, name, text)
    return {p["name"]: p for p in json.loads(_run(tmp_path, "plugins", "list", "--json").stdout)}


def test_installed_plugins_are_checked_at_discovery_and_by_plugins_check(tmp_path):
    listed = _installed(tmp_path, {"missing-method": MISSING, "wrong-shape": WRONG_SHAPE})
    assert listed["missing-method"]["status"] == "broken"
    assert listed["missing-method"]["error"] == (
        "missing_method:Model: method: gain_nlos() is not implemented (abstract in "
        "ChannelModel)")
    assert listed["wrong-shape"]["status"] == "broken"  # declared right: a call shows it
    assert listed["wrong-shape"]["error"] == (
        "wrong_shape:Model: shape: gain_nlos() returned shape (2,) for links of shape (2, 3)")
    for name, rule in (("missing-method", "method: gain_nlos()"),
                       ("wrong-shape", "shape: gain_nlos() returned shape (6,)")):
        checked = _run(tmp_path, "plugins", "check", name)
        assert checked.returncode == 1
        lines = checked.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith(f"{name}: {rule}"), lines
    ok = _run(tmp_path, "plugins", "check", "mmwave-nyc")
    assert ok.returncode == 0 and ok.stdout.startswith("ok  mmwave-nyc")


def test_plugins_list_keeps_a_broken_plugins_error_whole_at_80_columns(tmp_path):
    fake_distribution(tmp_path, "broken-channel", "import no_such_module_with_a_long_name\n")
    shown = _run(tmp_path, "plugins", "list", columns=80)
    assert shown.returncode == 0
    assert ("broken-channel: ModuleNotFoundError: No module named "
            "'no_such_module_with_a_long_name'") in shown.stdout.replace("\n", " ")
    assert max(len(line) for line in shown.stdout.splitlines()[:-1]) <= 80


def test_plugins_show_prints_types_and_limits(capsys):
    from adaptsky_cli.cli.main import main

    assert main(["plugins", "show", "mmwave-nyc", "--json"]) == 0
    params = json.loads(capsys.readouterr().out)["params"]
    # MmWaveNycParams: los_c is a float in (0, 100], intercept_los_db in [-200, 0]
    assert params["los_c"] == {"type": "float", "default": 9.6117,
                               "limits": {"gt": 0, "le": 100.0},
                               "description": "C of eq. 4 (environment), 1"}
    assert params["intercept_los_db"]["limits"] == {"ge": -200.0, "le": 0.0}
    assert main(["plugins", "show", "mmwave-nyc"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "los_c │ float │ 9.6117 │ > 0, <= 100" in text


def test_every_block_of_the_guide_is_one_the_tests_run():
    kinds = [[kind for kind, is_it in GUIDE_BLOCKS.items() if is_it(lang, text)]
             for lang, text in guide_blocks()]
    assert all(len(found) == 1 for found in kinds), kinds
    assert sorted(found[0] for found in kinds) == sorted(GUIDE_BLOCKS)
    assert guide_block("entry point").strip() in guide_block("pyproject")
    exec(guide_block("imports"), {})  # the contract's names import as the guide lists them


def _guide_package(root: Path, imports: str = "adaptsky.channels") -> Path:
    """The guide's free-space package as section 5 lays it out, installed on ``root`` as pip
    would leave it (a dist-info folder; ``pip install -e`` would need the network for
    hatchling), with the fading model of section 3 registered beside it; its code imports the
    contract from ``imports``."""
    def block(kind: str) -> str:
        return guide_block(kind).replace("adaptsky.channels", imports)

    project = root / "adaptsky-free-space"
    package = project / "adaptsky_free_space"
    package.mkdir(parents=True)
    layout = [line.split()[0] for line in block("layout").splitlines()[1:]]
    assert layout == ["pyproject.toml", "README.md", "adaptsky_free_space/__init__.py",
                      "adaptsky_free_space/free_space.py", "tests/test_free_space.py"]
    (project / "pyproject.toml").write_text(block("pyproject"))
    (project / "README.md").write_text("# adaptsky-free-space\n\nFriis free space.\n")
    (package / "__init__.py").write_text("")
    (package / "free_space.py").write_text(block("module"))
    (package / "fading.py").write_text(block("fading"))
    (project / "tests").mkdir()
    (project / "tests" / "test_free_space.py").write_text(block("tests"))
    pyproject = tomllib.loads(block("pyproject"))
    info = root / "adaptsky_free_space-0.1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: adaptsky-free-space\n"
                                   "Version: 0.1.0\n")
    points = {**pyproject["project"]["entry-points"]["adaptsky.channel_models"],
              "free-space-fading": "adaptsky_free_space.fading:FreeSpaceFading"}
    (info / "entry_points.txt").write_text(
        "[adaptsky.channel_models]\n" + "".join(f"{k} = {v}\n" for k, v in points.items()))
    return project


def test_a_plugin_written_against_adaptsky_cli_channels_works_unchanged(tmp_path):
    # the guide before the library moved to adaptsky/ told plugins to import adaptsky_cli.channels
    project = _guide_package(tmp_path, imports="adaptsky_cli.channels")
    assert "from adaptsky_cli.channels import" in (
        project / "adaptsky_free_space" / "free_space.py").read_text()
    pythonpath = f"{tmp_path}{os.pathsep}{project}"
    listed = {p["name"]: p for p in json.loads(_run(tmp_path, "plugins", "list", "--json",
                                                    pythonpath=pythonpath).stdout)}
    assert listed["free-space"]["status"] == "ok", listed["free-space"]
    checked = _run(tmp_path, "plugins", "check", "free-space", pythonpath=pythonpath)
    assert checked.returncode == 0, checked.stderr
    assert checked.stdout.startswith("ok  free-space: follows plugin contract 2"), checked.stdout
    result = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider"],
                            capture_output=True, text=True, cwd=project, check=False,
                            env={**os.environ, "PYTHONPATH": pythonpath})
    assert result.returncode == 0 and "4 passed" in result.stdout, result.stdout[-2000:]


def test_the_guides_free_space_plugin_works_as_written(tmp_path):
    """docs/plugins.md sections 5 to 7 as a plugin author copies them: the package, its
    pyproject's entry point, a scenario using it, section 6's commands and section 7's tests."""
    project = _guide_package(tmp_path)
    pythonpath = f"{tmp_path}{os.pathsep}{project}"
    listed = {p["name"]: p for p in json.loads(_run(tmp_path, "plugins", "list", "--json",
                                                    pythonpath=pythonpath).stdout)}
    assert listed["free-space"]["status"] == "ok", listed["free-space"]
    assert listed["free-space"]["contract_version"] == 2
    scenario = tmp_path / "my_scenario.toml"
    scenario.write_text(guide_block("scenario")
                        + "[train]\nepisodes = 2\nsteps = 10\neval_every = 0\n")
    ran = []
    for line in guide_block("commands").splitlines():
        command = line.split("#")[0].strip()
        if command.startswith("pip install"):
            continue  # _guide_package installed it
        if command.startswith("cd "):
            folder, _, command = command.removeprefix("cd ").partition(" && ")
            assert folder == "path/to/adaptsky-free-space" and command == "python -m pytest"
            result = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p",
                                     "no:cacheprovider"], capture_output=True, text=True,
                                    env={**os.environ, "PYTHONPATH": pythonpath}, cwd=project,
                                    check=False)
            assert result.returncode == 0, result.stdout[-2000:]
            assert "4 passed" in result.stdout
        else:
            words = command.replace("my_scenario.toml", str(scenario)).split()
            assert words[0] == "adaptsky", command
            result = _run(tmp_path, *words[1:], pythonpath=pythonpath)
            assert result.returncode == 0, (command, result.stderr)
        ran.append(command)
    assert len(ran) == 5
    trained = _run(tmp_path, "train", str(scenario), "--out", str(tmp_path / "free.h5"),
                   "--quiet", pythonpath=pythonpath)
    assert trained.returncode == 0, trained.stderr


def test_the_guides_fading_model_follows_the_contract_and_trains(tmp_path):
    """docs/plugins.md section 3's fading example, registered and checked, trained, and the
    oracle refused for it in one line."""
    _guide_package(tmp_path)
    pythonpath = f"{tmp_path}{os.pathsep}{tmp_path / 'adaptsky-free-space'}"
    checked = _run(tmp_path, "plugins", "check", "free-space-fading", pythonpath=pythonpath)
    assert checked.returncode == 0, checked.stderr
    scenario = tmp_path / "fading.toml"
    scenario.write_text('name = "fading"\n[channel]\nmodel = "free-space-fading"\n'
                        "[train]\nepisodes = 1\nsteps = 10\neval_every = 0\n")
    out = tmp_path / "fading.h5"
    assert _run(tmp_path, "train", str(scenario), "--out", str(out), "--quiet",
                pythonpath=pythonpath).returncode == 0
    refused = _run(tmp_path, "eval", "--checkpoint", str(out), "--compare", "oracle",
                   pythonpath=pythonpath)
    assert refused.returncode == 1
    assert refused.stderr.strip().splitlines() == [
        "scenario 'fading': channel model 'free-space-fading' draws per-step fading; the "
        "oracle needs deterministic gains: los = 'always' or 'expected', without fading"]


def test_plugins_check_takes_parameters_and_a_carrier():
    from_the_example = _run(Path("."), "plugins", "check", "uma-av", "--param",
                            "shadowing=true", "--carrier-hz", "3.5e9")
    assert from_the_example.returncode == 0, from_the_example.stderr
    assert from_the_example.stdout.strip() == (
        "ok  uma-av: follows plugin contract 2 (f_c 3.5 GHz, users on the ground and 1.5 m up, "
        "fading hook checked, parameters: shadowing=True)")
    for param, line in (("shadowing=3", "--param shadowing: Input should be a valid boolean"),
                        ("nope=1", "--param nope: unknown key"),
                        ("carrier_hz=3e9", "uma-av: carrier: carrier_hz = 3.5e+09 Hz differs "
                                           "from the parameters' carrier_hz = 3e+09 Hz; in a "
                                           "run they are one value")):
        refused = _run(Path("."), "plugins", "check", "uma-av", "--param", param,
                       "--carrier-hz", "3.5e9")
        assert refused.returncode == 1 and refused.stderr.strip().splitlines() == [line]
    refused = _run(Path("."), "plugins", "check", "uma-av", "--param", "carrier_hz")
    assert refused.returncode == 2 and refused.stderr.strip().splitlines() == [
        "adaptsky plugins check: --param: 'carrier_hz' is not KEY=VALUE; e.g. carrier_hz=3.5e9; "
        "see 'adaptsky plugins check --help'"]


def test_plugins_show_prints_the_contract_and_markup_free_text(capsys):
    from adaptsky_cli.cli.main import main

    assert main(["plugins", "show", "uma-av"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "plugin contract 2" in text and "[radio]" in text and "true, false" in text
    assert main(["plugins", "show", "uma-av", "--json"]) == 0
    shown = json.loads(capsys.readouterr().out)
    assert shown["contract_version"] == 2
    assert shown["params"]["shadowing"] == {
        "type": "bool", "default": False, "limits": {},
        "description": "lognormal shadow fading of TR 36.777, drawn every step; off: the mean "
                       "path loss"}


FUTURE = UNDECLARED + "    contract_version = 4\n"


def test_contract_versions_at_discovery_and_in_plugins_check(tmp_path):
    listed = _installed(tmp_path, {"old-channel": UNDECLARED, "future-channel": FUTURE})
    assert listed["old-channel"]["status"] == "ok"
    assert listed["old-channel"]["contract_version"] == 1
    assert listed["future-channel"]["status"] == "broken"
    assert listed["future-channel"]["error"] == (
        "future_channel:Model: contract: written for plugin contract 4; this adaptsky supports "
        "contracts 1, 2 and 3: upgrade adaptsky")
    assert listed["mmwave-nyc"]["contract_version"] == 3
    old = _run(tmp_path, "plugins", "check", "old-channel")
    assert old.returncode == 0
    assert old.stdout.splitlines()[0] == (
        "ok  old-channel: follows plugin contract 1 (f_c 28 GHz, users on the ground, no "
        "fading hook, parameters: defaults)")
    assert "declares no contract_version and is taken as contract 1" in old.stdout
    shown = _run(tmp_path, "plugins", "show", "old-channel")
    assert "plugin contract 1 (declares no contract_version)" in shown.stdout
    scenario = tmp_path / "old.toml"
    scenario.write_text('name = "old"\n[users]\ncount = 4\nheight_m = 1.5\n'
                        '[channel]\nmodel = "old-channel"\n')
    refused = _run(tmp_path, "scenario", "validate", str(scenario))
    assert refused.returncode == 1
    assert "users.height_m: channel model 'old-channel' follows plugin contract 1" in (
        refused.stdout + refused.stderr)


def test_the_guides_default_radio_is_the_built_in_ones():
    from adaptsky.channels.contract import ChannelModel
    from adaptsky.channels.registry import get_model_class

    names = {"ChannelModel": ChannelModel}
    exec(guide_block("default radio"), names)
    declared = dict(names["Sub6AlHourani"].default_radio)
    assert declared == dict(get_model_class("sub6-al-hourani").default_radio)
    # the paper's Table I, sub-6 column (docs/model.md §2)
    assert declared == {"carrier_hz": 2e9, "tx_power_dbm": 30.0, "bandwidth_hz": 50e6,
                        "thermal_noise_dbm": -88.0, "noise_figure_db": 0.0,
                        "antennas_uav": 1, "antennas_ue": 1}
