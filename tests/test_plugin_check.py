"""The plugin contract's checks: check_channel_model, the structural part at discovery, and
``adaptsky plugins check``/``list`` on installed (fake) distributions."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import textwrap
import tomllib
from pathlib import Path

import numpy as np
import pytest

from adaptsky_cli.channels import ChannelModel, ChannelParams
from adaptsky_cli.channels.checker import check_channel_model, structural_problems
from adaptsky_cli.channels.registry import discover
from tests.test_cli import ADAPTSKY, _fake_distribution


class Good(ChannelModel):
    description = "free space at 28 GHz, always LoS"

    def los_probability(self, geometry):
        return np.ones(geometry.shape)

    def gain_los(self, geometry):
        return (299_792_458.0 / (4 * np.pi * 28e9 * geometry.distance_m)) ** 2

    def gain_nlos(self, geometry):
        return 0.1 * self.gain_los(geometry)


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


MISSING = """\
    import numpy as np
    from adaptsky_cli.channels import ChannelModel

    class Model(ChannelModel):
        description = "forgets gain_nlos"
        def los_probability(self, geometry):
            return np.ones(geometry.shape)
        def gain_los(self, geometry):
            return 1.0 / geometry.distance_m ** 2
    """
WRONG_SHAPE = textwrap.dedent(MISSING) + """\
    def gain_nlos(self, geometry):
        return 0.1 / geometry.distance_m[:, 0] ** 2
"""


def _run(tmp_path, *args, columns: int = 80):
    env = {**os.environ, "PYTHONPATH": str(tmp_path), "COLUMNS": str(columns)}
    return subprocess.run([str(ADAPTSKY), *args], capture_output=True, text=True, env=env,
                          check=False)


def test_installed_plugins_are_checked_at_discovery_and_by_plugins_check(tmp_path):
    _fake_distribution(tmp_path, "missing-method", MISSING)
    _fake_distribution(tmp_path, "wrong-shape", WRONG_SHAPE)
    listed = {p["name"]: p for p in json.loads(_run(tmp_path, "plugins", "list",
                                                    "--json").stdout)}
    assert listed["missing-method"]["status"] == "broken"
    assert listed["missing-method"]["error"] == (
        "missing_method:Model: method: gain_nlos() is not implemented (abstract in "
        "ChannelModel)")
    assert listed["wrong-shape"]["status"] == "ok"  # declared right: only a call shows it
    for name, rule in (("missing-method", "method: gain_nlos()"),
                       ("wrong-shape", "shape: gain_nlos() returned shape (6,)")):
        checked = _run(tmp_path, "plugins", "check", name)
        assert checked.returncode == 1
        lines = checked.stderr.strip().splitlines()
        assert lines[0].startswith(f"{name}: {rule}"), lines
    ok = _run(tmp_path, "plugins", "check", "mmwave-nyc")
    assert ok.returncode == 0 and ok.stdout.startswith("ok  mmwave-nyc")


def test_plugins_list_keeps_a_broken_plugins_error_whole_at_80_columns(tmp_path):
    _fake_distribution(tmp_path, "broken-channel", "import no_such_module_with_a_long_name\n")
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


def _guide_blocks(language: str) -> list[str]:
    text = (Path(__file__).parent.parent / "docs" / "plugins.md").read_text()
    return re.findall(rf"```{language}\n(.*?)```", text, flags=re.DOTALL)


def test_the_guides_free_space_plugin_works_as_written(tmp_path):
    """docs/plugins.md section 5 and 7, as a plugin author copies them: the module, its
    pyproject's entry point, a scenario using it, and the guide's test file."""
    module = next(b for b in _guide_blocks("python") if b.startswith('"""Free-space channel'))
    tests = next(b for b in _guide_blocks("python") if "def test_matches_friis" in b)
    pyproject = tomllib.loads(next(b for b in _guide_blocks("toml") if "[project]" in b))
    channel = next(b for b in _guide_blocks("toml") if 'model = "free-space"' in b)
    package = tmp_path / "adaptsky_free_space"
    package.mkdir()
    (package / "__init__.py").write_text("")
    (package / "free_space.py").write_text(module)
    (tmp_path / "test_free_space.py").write_text(tests)
    info = tmp_path / "adaptsky_free_space-0.1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: adaptsky-free-space\n"
                                   "Version: 0.1.0\n")
    points = pyproject["project"]["entry-points"]["adaptsky.channel_models"]
    (info / "entry_points.txt").write_text(
        "[adaptsky.channel_models]\n" + "".join(f"{k} = {v}\n" for k, v in points.items()))
    listed = {p["name"]: p for p in json.loads(_run(tmp_path, "plugins", "list",
                                                    "--json").stdout)}
    assert listed["free-space"]["status"] == "ok", listed["free-space"]
    checked = _run(tmp_path, "plugins", "check", "free-space")
    assert checked.returncode == 0, checked.stderr
    scenario = tmp_path / "free.toml"
    scenario.write_text('name = "free"\n' + channel
                        + "[train]\nepisodes = 2\nsteps = 10\neval_every = 0\n")
    trained = _run(tmp_path, "train", str(scenario), "--out", str(tmp_path / "free.h5"),
                   "--quiet")
    assert trained.returncode == 0, trained.stderr
    env = {**os.environ, "PYTHONPATH": str(tmp_path)}
    guide_tests = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
                                  str(tmp_path / "test_free_space.py")], capture_output=True,
                                 text=True, env=env, cwd=tmp_path, check=False)
    assert guide_tests.returncode == 0, guide_tests.stdout[-2000:]
    assert "4 passed" in guide_tests.stdout
