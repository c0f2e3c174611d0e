"""What runs today: training, evaluation, baselines and the environments simulate one UAV.
The physics of several (docs/model.md §9) is a library layer (``adaptsky.sim``) not yet wired
into them, so they refuse ``uav.count > 1`` rather than run one UAV silently."""

from __future__ import annotations

from adaptsky.errors import ScenarioError
from adaptsky.scenario.models import Scenario


def require_one_uav(scenario: Scenario, source: str) -> None:
    """A :class:`ScenarioError` line for a scenario of several UAVs (``source``: its file)."""
    count = scenario.uav.count
    if count > 1:
        raise ScenarioError([f"{source}: uav.count: {count} UAVs: several UAVs are not trained "
                             "or evaluated yet (issue 23), only modelled (docs/model.md §9); "
                             "use uav.count = 1"])
