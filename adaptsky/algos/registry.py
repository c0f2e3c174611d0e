"""The algorithms ``[agent] algorithm`` can name, by name: each one's torch-free
:class:`~adaptsky.algos.protocol.AlgorithmSpec`."""

from __future__ import annotations

from adaptsky.algos.bdq.spec import BDQ
from adaptsky.algos.dqn.spec import DQN
from adaptsky.algos.protocol import AlgorithmSpec
from adaptsky.errors import ScenarioError
from adaptsky.scenario.models import Scenario

ALGORITHMS: dict[str, AlgorithmSpec] = {DQN.name: DQN, BDQ.name: BDQ}


def algorithm_named(name: str) -> AlgorithmSpec:
    """The algorithm ``name``; a KeyError names the algorithms there are."""
    if name not in ALGORITHMS:
        raise KeyError(f"unknown algorithm '{name}'; choose from {', '.join(ALGORITHMS)}")
    return ALGORITHMS[name]


def algorithm_of(scenario: Scenario) -> AlgorithmSpec:
    """The algorithm of a scenario's ``[agent]`` section."""
    return algorithm_named(scenario.agent.algorithm)


def check_actions(scenario: Scenario, source: str) -> None:
    """A one-line :class:`ScenarioError` where the scenario's algorithm does not learn its
    ``uav.actions``: continuous controls are for the Gymnasium env and outside learners."""
    spec, kind = algorithm_of(scenario), scenario.uav.actions
    if kind in spec.action_kinds:
        return
    kinds = " or ".join(f"'{name}'" for name in spec.action_kinds)
    raise ScenarioError([
        f"{source}: uav.actions: agent.algorithm '{spec.name}' learns {kinds} actions, not "
        f"'{kind}'; continuous controls are for the Gymnasium env adaptsky/NomaUav-v0 and "
        f"outside learners (e.g. Stable-Baselines3) for now, adaptsky's learners for them "
        f"come later"])
