"""The BDQ's value groups (``agent.reward_split``, docs/agent.md): which branches share a value
and learn from one part of the reward."""

from __future__ import annotations

from adaptsky.scenario.agents import BdqAgent
from adaptsky.sim.actions import ActionSet


def value_groups(config: BdqAgent, actions: ActionSet) -> int:
    """G, the value outputs and reward parts: one per UAV with ``reward_split`` "per-uav" or
    "difference" (UAV u's 3 + K branches, one after another, are group u), else one."""
    return actions.num_uavs if config.reward_split != "team" else 1
