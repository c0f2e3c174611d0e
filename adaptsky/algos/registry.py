"""The algorithms ``[agent] algorithm`` can name, by name: each one's torch-free
:class:`~adaptsky.algos.protocol.AlgorithmSpec`; and the size of what a scenario's learner
observes (:func:`observation_size_of`, its networks' input), the one thing of the learners'
inputs the trainer asks."""

from __future__ import annotations

from adaptsky.algos.bdq.spec import BDQ
from adaptsky.algos.dqn.spec import DQN
from adaptsky.algos.mappo.spec import IPPO, MAPPO
from adaptsky.algos.ppo.spec import PPO
from adaptsky.algos.protocol import AlgorithmSpec
from adaptsky.algos.sac.spec import SAC
from adaptsky.algos.shared.shapes import observation_size_of as observation_size_of
from adaptsky.errors import ScenarioError
from adaptsky.scenario.models import Scenario

ALGORITHMS: dict[str, AlgorithmSpec] = {DQN.name: DQN, BDQ.name: BDQ, PPO.name: PPO,
                                        SAC.name: SAC, MAPPO.name: MAPPO, IPPO.name: IPPO}


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
    ``uav.actions`` (the DQN and the BDQ: dense kinds only; PPO, MAPPO and IPPO: every kind;
    SAC: continuous controls only), or where its own settings do not fit them."""
    spec, kind = algorithm_of(scenario), scenario.uav.actions
    if kind not in spec.action_kinds:
        kinds = " or ".join(f"'{name}'" for name in spec.action_kinds)
        learners = ", ".join(f"'{other.name}'" for other in ALGORITHMS.values()
                             if kind in other.action_kinds
                             and scenario.uav.count >= other.min_uavs)
        raise ScenarioError([
            f"{source}: uav.actions: agent.algorithm '{spec.name}' learns {kinds} actions, "
            f"not '{kind}'; for '{kind}' choose agent.algorithm {learners}"])
    spec.check_scenario(scenario, source)
