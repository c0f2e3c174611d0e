"""Shared fixtures: scenarios built in memory from the paper's defaults, and the tiny trained
run every test that needs *a* run file reads (tests/README.md)."""

from __future__ import annotations

import hashlib
import os
import shutil
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from adaptsky.scenario import Scenario, parse_scenario
from tests.helpers.schedule import (  # noqa: F401  (hooks: longest files first, times)
    pytest_runtest_protocol,
    pytest_xdist_make_scheduler,
)

ROOT = Path(__file__).resolve().parents[1]
# no test reads or writes the user's search cache (docs/training.md); its own tests point it
# at a folder of theirs
os.environ["ADAPTSKY_CACHE_DIR"] = "off"
SCENARIOS = ROOT / "scenarios"

# sec. V-B: the training layout, clusters (1, 2) and (3, 4)
TRAINING_LAYOUT_M = [(4.0, 15.0), (-44.0, -49.0), (-5.0, 21.0), (47.0, 49.0)]

SUB6_RADIO = {"tx_power_dbm": 30.0, "bandwidth_hz": 50e6, "thermal_noise_dbm": -88.0,
              "noise_figure_db": 0.0, "antennas_uav": 1, "antennas_ue": 1}


def deep_update(base: dict[str, Any], update: dict[str, Any]) -> dict[str, Any]:
    merged = dict(base)
    for key, value in update.items():
        if isinstance(value, dict) and isinstance(merged.get(key), dict):
            merged[key] = deep_update(merged[key], value)
        else:
            merged[key] = value
    return merged


def make_scenario(**sections: Any) -> Scenario:
    """A validated scenario: the paper's mmWave defaults updated by ``sections``."""
    return parse_scenario(deep_update({"name": "test"}, sections), "test")


@pytest.fixture
def mmwave() -> Scenario:
    return make_scenario()


@pytest.fixture
def sub6() -> Scenario:
    return make_scenario(radio=SUB6_RADIO, channel={"model": "sub6-al-hourani"})


# the tiny run: the paper's scenario and network, 2 seeds, 2 episodes of 5 steps
TINY_RUN_ARGS = ["--seeds", "0,1", "--episodes", "2", "--steps", "5", "--workers", "1",
                 "--quiet"]


@pytest.fixture(scope="session")
def tiny_run(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    """One small real run file, trained once per session in this process: nyc_mmwave.toml
    (the paper's network), seeds 0 and 1, 2 episodes of 5 steps, one worker. Shared: read it,
    never change it; a test that damages, extends or resumes a run uses ``tiny_run_copy``.
    The session fails at its end if a test changed it."""
    from adaptsky_cli.cli.main import main

    path = tmp_path_factory.mktemp("tiny_run") / "run.h5"
    assert main(["train", str(SCENARIOS / "nyc_mmwave.toml"), *TINY_RUN_ARGS,
                 "--out", str(path)]) == 0
    digest = hashlib.sha256(path.read_bytes()).hexdigest()
    yield path
    assert hashlib.sha256(path.read_bytes()).hexdigest() == digest, (
        f"{path}: a test changed the shared tiny run; use tiny_run_copy")


@pytest.fixture
def tiny_run_copy(tiny_run: Path, tmp_path: Path) -> Path:
    """A copy of the tiny run in this test's tmp_path, to change as the test likes."""
    return Path(shutil.copyfile(tiny_run, tmp_path / "tiny-run.h5"))
