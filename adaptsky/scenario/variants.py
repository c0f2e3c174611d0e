"""Scenarios derived from a scenario, validated as a file would be."""

from __future__ import annotations

from adaptsky.scenario.loading import parse_scenario
from adaptsky.scenario.models import Scenario


def eval_scenario(scenario: Scenario, layouts: int | None, layout_seed: int) -> Scenario:
    """The scenario on ``layouts`` uniform layouts (near-far pairing), or as it is."""
    if layouts is None:
        return scenario
    data = scenario.model_dump(mode="json")
    data["users"] = {"count": scenario.num_users, "placement": "uniform",
                     "layout_seed": layout_seed, "pairing": "near-far",
                     "speed_m_per_step": scenario.users.speed_m_per_step}
    return parse_scenario(data, "evaluation layouts")
