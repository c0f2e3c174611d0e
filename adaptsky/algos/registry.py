"""The algorithms ``[agent] algorithm`` can name, by name: each one's torch-free
:class:`~adaptsky.algos.protocol.AlgorithmSpec`."""

from __future__ import annotations

from adaptsky.algos.bdq.spec import BDQ
from adaptsky.algos.dqn.spec import DQN
from adaptsky.algos.protocol import AlgorithmSpec
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
