"""Scenarios derived from a scenario, each validated again as a file would be: the one way to
make a variant (a command line's ``[train]`` options, the evaluation layouts, a run's stored
evaluation settings)."""

from __future__ import annotations

from typing import Any

from adaptsky.scenario.loading import parse_scenario
from adaptsky.scenario.models import Scenario


def with_values(scenario: Scenario, section: str, values: dict[str, Any], source: str,
                replace: bool = False) -> Scenario:
    """``scenario`` with ``values`` set in ``[section]`` (with ``replace``, as the whole
    section), validated again; ``source`` names the variant in a validation error."""
    if not values:
        return scenario
    data = scenario.model_dump(mode="json")
    data[section] = dict(values) if replace else {**data[section], **values}
    return parse_scenario(data, source)


PLACEMENT_KEYS = ("positions_m", "count", "placement", "hotspots", "spread_m", "layout_seed",
                  "pairing", "association", "uav")
"""The [users] keys of where the users are and how they are grouped: evaluation layouts set
them anew; every other key (mobility, height, reassociation) stays."""


def eval_scenario(scenario: Scenario, layouts: int | None, layout_seed: int) -> Scenario:
    """The scenario on ``layouts`` uniform layouts (near-far pairing; listed serving UAVs kept),
    or as it is."""
    if layouts is None:
        return scenario
    kept = {key: value for key, value in scenario.users.model_dump(mode="json").items()
            if key not in PLACEMENT_KEYS}   # how users move, their height: as they were
    users = kept | {"count": scenario.num_users, "placement": "uniform",
                    "layout_seed": layout_seed, "pairing": "near-far"}
    if scenario.users.uav is not None:   # listed serving UAVs keep serving user i on any layout
        users |= {"association": "listed", "uav": list(scenario.users.uav)}
    return with_values(scenario, "users", users, "evaluation layouts", replace=True)
