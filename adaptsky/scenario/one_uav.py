"""The guard of code that simulates exactly one UAV (``NomaUavBatch``, the paper's
environment): a scenario of several UAVs goes to ``MultiUavBatch`` (``network_batch``,
docs/model.md §9), never silently to one UAV."""

from __future__ import annotations

from adaptsky.errors import ScenarioError
from adaptsky.scenario.models import Scenario


def require_one_uav(scenario: Scenario, source: str) -> None:
    """A :class:`ScenarioError` line for a scenario of several UAVs (``source``: its file)."""
    count = scenario.uav.count
    if count > 1:
        raise ScenarioError([f"{source}: uav.count: {count} UAVs: NomaUavBatch simulates one "
                             "UAV; several run on MultiUavBatch (adaptsky.sim.multi_batch."
                             "network_batch chooses, docs/model.md §9)"])
