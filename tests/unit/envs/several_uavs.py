"""Scenarios of several UAVs for the environments' tests."""

from adaptsky.scenario import Scenario, load_scenario, parse_scenario
from tests.conftest import SCENARIOS, SUB6_RADIO, make_scenario

TWO_UAVS = SCENARIOS / "two_uavs_mmwave.toml"
USERS_M = [[-30.0, 10.0], [-10.0, -20.0], [-40.0, -35.0], [-5.0, 30.0], [30.0, 20.0],
           [40.0, -10.0]]
STARTS_M = [[-20.0, 0.0, 50.0], [25.0, 0.0, 50.0]]


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


def uneven(observation="scaled", user_order="listed", steps=10):
    """UAV 0 serves users 0-3 in clusters (0, 1) and (2, 3), UAV 1 users 4-5 in (4, 5);
    every link LoS (the paper's mmWave defaults), full reuse; sub-action 0, 1, 2 is -1, 0,
    +1."""
    return make_scenario(
        train={"steps": steps},
        users={"positions_m": USERS_M, "association": "listed", "uav": [0, 0, 0, 0, 1, 1],
               "pairing": "listed"},
        uav={"count": 2, "start_positions_m": STARTS_M, "actions": "with-hover"},
        agent={"observation": observation, "user_order": user_order})
