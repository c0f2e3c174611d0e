"""Subclassing a built-in channel model (docs/plugins.md section 9): the guide's module, as
written, installed as a package with the entry point the guide names, is a working plugin
(listed, checked, shown, validated, trained with), its numbers are the built-in's with the
override, and the two pitfalls the guide names are refused as it says."""

from __future__ import annotations

import json
import math
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from adaptsky_builtin_channels.mmwave_nyc import MmWaveNyc, MmWaveNycParams

from adaptsky.channels import LinkGeometry
from adaptsky.channels.checker import call_problems, check_channel_model, structural_problems
from tests.helpers.plugins import guide_block

ROOT = Path(__file__).resolve().parents[3]
GUIDE = ROOT / "docs" / "plugins.md"
ADAPTSKY = Path(sys.executable).with_name("adaptsky")


def entry_point() -> tuple[str, str]:
    """The name and target section 9 registers."""
    found = re.search(r'`(mmwave-nyc-dense) = "([\w.]+:\w+)"`', GUIDE.read_text())
    assert found, "docs/plugins.md section 9 names no entry point"
    return found.group(1), found.group(2)


@pytest.fixture
def installed(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """The guide's module as ``my_channels/dense.py``, installed on ``tmp_path`` as pip would
    leave it (a dist-info folder with the entry point); importable here too."""
    name, target = entry_point()
    assert target == "my_channels.dense:DenseNyc"
    package = tmp_path / "my_channels"
    package.mkdir()
    (package / "__init__.py").write_text("")
    (package / "dense.py").write_text(guide_block("subclass"))
    info = tmp_path / "my_channels-0.1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: my-channels\nVersion: 0.1.0\n")
    (info / "entry_points.txt").write_text(f"[adaptsky.channel_models]\n{name} = {target}\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    return tmp_path


def adaptsky(root: Path, *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([str(ADAPTSKY), *args], capture_output=True, text=True, cwd=root,
                          env={**os.environ, "PYTHONPATH": str(root)}, check=False,
                          timeout=300)


def geometry() -> LinkGeometry:
    uav_m = np.array([[0.0, 0.0, 30.0], [10.0, 5.0, 120.0]])
    users_m = np.array([[[0.0, 0.0], [40.0, 30.0], [-150.0, 80.0]]] * 2)
    return LinkGeometry.between(uav_m, users_m, carrier_hz=28e9)


def test_the_subclass_draws_the_builtins_numbers_with_its_override(installed):
    from my_channels.dense import DenseNyc, DenseNycParams

    geo, base = geometry(), MmWaveNyc()
    model = DenseNyc()
    assert check_channel_model(DenseNyc) == []
    assert check_channel_model(DenseNyc, DenseNycParams(nlos_extra_loss_db=40.0)) == []
    np.testing.assert_array_equal(model.gain_los(geo), base.gain_los(geo))  # inherited
    # 6 dB by default: a factor 10^-0.6 = 0.2512 on every NLoS gain
    np.testing.assert_allclose(model.gain_nlos(geo), base.gain_nlos(geo) * 10 ** -0.6,
                               rtol=1e-12)
    # the inherited formula of eq. 4 with the new default C = 12 (Y as the built-in's 0.1581)
    theta = geo.elevation_deg
    np.testing.assert_allclose(model.los_probability(geo),
                               1 / (1 + 12.0 * np.exp(-0.1581 * (theta - 12.0))), rtol=1e-12)
    # expected_gain (not overridden) combines the overrides
    p = model.los_probability(geo)
    np.testing.assert_allclose(model.expected_gain(geo), p * model.gain_los(geo)
                               + (1 - p) * model.gain_nlos(geo), rtol=1e-12)
    assert DenseNyc.supports == MmWaveNyc.supports and DenseNyc.contract_version == 3


def test_registered_listed_checked_and_trained(installed, tmp_path):
    listed = {p["name"]: p for p in json.loads(adaptsky(installed, "plugins", "list",
                                                        "--json").stdout)}
    dense = listed["mmwave-nyc-dense"]
    assert (dense["status"], dense["package"], dense["contract_version"]) == (
        "ok", "my-channels", 3)
    assert dense["description"].startswith("28 GHz mmWave, NYC path loss with an extra NLoS")
    assert listed["mmwave-nyc"]["status"] == "ok"  # the built-in is untouched
    checked = adaptsky(installed, "plugins", "check", "mmwave-nyc-dense", "--param",
                       "nlos_extra_loss_db=12")
    assert checked.returncode == 0, checked.stderr
    assert checked.stdout.startswith("ok  mmwave-nyc-dense: follows plugin contract 3")
    shown = json.loads(adaptsky(installed, "plugins", "show", "mmwave-nyc-dense",
                                "--json").stdout)["params"]
    assert shown["los_c"]["default"] == 12.0 and shown["los_c"]["limits"] == {"gt": 0,
                                                                              "le": 100.0}
    assert shown["nlos_extra_loss_db"]["limits"] == {"ge": 0.0, "le": 40.0}
    assert shown["exponent_nlos"]["default"] == 2.92  # inherited as it is
    scenario = tmp_path / "dense.toml"
    scenario.write_text('name = "dense"\n[channel]\nmodel = "mmwave-nyc-dense"\n'
                        "[channel.params]\nnlos_extra_loss_db = 10.0\nexponent_los = 2.1\n"
                        "[train]\nepisodes = 1\nsteps = 5\neval_every = 0\n")
    assert adaptsky(installed, "scenario", "validate", str(scenario)).returncode == 0
    out = tmp_path / "dense.h5"
    trained = adaptsky(installed, "train", str(scenario), "--seeds", "0", "--workers", "1",
                       "--quiet", "--out", str(out))
    assert trained.returncode == 0, trained.stderr
    inspected = adaptsky(installed, "inspect", str(out), "--json")
    assert inspected.returncode == 0, inspected.stderr
    summary = json.loads(inspected.stdout)
    assert summary["channel_model"] == "mmwave-nyc-dense"
    assert summary["plugins"] == {"mmwave-nyc-dense": {
        "package": "my-channels", "target": "my_channels.dense:DenseNyc", "version": "0.1.0"}}
    assert [s["episodes_done"] for s in summary["seeds"]] == [1]


def test_a_bare_default_override_is_refused_as_the_guide_says():
    class Bare(MmWaveNycParams):
        los_c: float = 12.0  # no Field: range and description gone

    class BareNyc(MmWaveNyc):
        Params = Bare
        description = "bare"

    assert structural_problems(BareNyc) == [
        "params: los_c has no description (say what it is and its unit)"]


def test_params_not_derived_from_the_builtins_break_the_class():
    from pydantic import Field

    from adaptsky.channels import ChannelParams

    class Fresh(ChannelParams):
        nlos_extra_loss_db: float = Field(6.0, ge=0.0, description="extra NLoS loss, dB")

    class FreshNyc(MmWaveNyc):
        Params = Fresh
        description = "fresh"

    assert structural_problems(FreshNyc) == []
    (failure,) = call_problems(FreshNyc)
    assert "__init__" in failure and "AttributeError" in failure, failure
    assert math.isclose(MmWaveNyc().params.los_c, 9.6117)  # the built-in keeps its own
