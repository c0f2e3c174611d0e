"""Scenarios of several UAVs for the environments' tests."""

from adaptsky.scenario import Scenario, load_scenario, parse_scenario
from tests.conftest import SCENARIOS, SUB6_RADIO

TWO_UAVS = SCENARIOS / "two_uavs_mmwave.toml"


def two_uavs(steps: int = 20, moving: bool = False, actions: str = "paper") -> Scenario:
    """two_uavs_mmwave.toml with ``steps`` steps and ``uav.actions = actions``; ``moving``:
    sub-6 GHz with sampled LoS and walking users, so that every step draws from the
    generator."""
    data = load_scenario(TWO_UAVS).model_dump(mode="json")
    data["train"]["steps"] = steps
    data["uav"]["actions"] = actions
    if moving:
        data["radio"] |= SUB6_RADIO
        data["channel"] = {"model": "sub6-al-hourani", "los": "sampled"}
        data["users"]["speed_m_per_step"] = 1.0
    return parse_scenario(data, "two_uavs")
