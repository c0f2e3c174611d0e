"""Evaluation layouts (``eval --layouts``, training's held-out layouts) place the users anew
and keep how they move and stand: a mobility model was dropped before."""

from __future__ import annotations

from pathlib import Path

import pytest

from adaptsky.scenario.loading import load_scenario, parse_scenario
from adaptsky.scenario.variants import eval_scenario
from adaptsky.sim.state import users_move

SCENARIOS = Path(__file__).resolve().parents[3] / "scenarios"


@pytest.mark.parametrize("name", ["moving_users_sub6", "moving_users_fading_sub6",
                                  "two_uavs_moving_mmwave"])
def test_a_mobility_model_stays_on_evaluation_layouts(name):
    scenario = load_scenario(SCENARIOS / f"{name}.toml")
    layouts = eval_scenario(scenario, 4, 3)
    assert scenario.users.mobility.model != "static" and users_move(layouts)
    assert layouts.users.mobility == scenario.users.mobility
    assert (layouts.users.placement, layouts.users.layout_seed, layouts.users.pairing) == (
        "uniform", 3, "near-far")
    assert layouts.users.positions_m is None and layouts.num_users == scenario.num_users


def test_the_users_height_and_the_older_walk_stay():
    scenario = load_scenario(SCENARIOS / "nyc_mmwave.toml")
    data = scenario.model_dump(mode="json")
    data["users"] |= {"height_m": 1.5, "speed_m_per_step": 2.0}
    layouts = eval_scenario(parse_scenario(data, "t"), 2, 0)
    assert layouts.users.height_m == 1.5 and layouts.users.speed_m_per_step == 2.0
