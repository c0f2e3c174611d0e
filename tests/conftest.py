"""Shared fixtures: scenarios built in memory from the paper's defaults."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from adaptsky.scenario import Scenario, parse_scenario

ROOT = Path(__file__).resolve().parents[1]
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
