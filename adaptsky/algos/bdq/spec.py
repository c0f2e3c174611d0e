"""The BDQ's torch-free half (:class:`~adaptsky.algos.protocol.AlgorithmSpec`): the DQN's
checkpoint layout (docs/file-format.md) with a branching head (``advantage`` of D b rows) and
a replay that stores a sub-action per branch (``actions`` (R, D)); its memory estimate; the
builders of its learner and of a greedy policy, which import torch only when called."""

from __future__ import annotations

from typing import Any, ClassVar

from adaptsky.algos.bdq.groups import value_groups
from adaptsky.algos.dqn.parameters import network_shapes
from adaptsky.algos.dqn.spec import ADAM_STATE, DqnSpec
from adaptsky.algos.protocol import Algorithm, Policy
from adaptsky.algos.shared.checkpoint import REPLAY, replay_network_parts
from adaptsky.algos.shared.set_layout import set_encoder_of
from adaptsky.algos.shared.shapes import observation_size_of
from adaptsky.arrays import Field, Tree
from adaptsky.scenario.agents import BdqAgent
from adaptsky.scenario.models import Scenario
from adaptsky.sim.actions import ActionSet

# /seeds/<S>/checkpoint/replay/actions: the sub-action of each of the D branches per row
BRANCH_ACTIONS = Field("actions", "int", ("R", "D"))
# /seeds/<S>/checkpoint/replay/rewards where the branches learn G > 1 parts (the BDQ's
# reward_split "per-uav" or "difference" with several UAVs): G parts per row
REWARD_PARTS = Field("rewards", "float", ("R", "G"))


def _config(scenario: Scenario) -> BdqAgent:
    agent = scenario.agent
    assert isinstance(agent, BdqAgent), f"not a BDQ agent: {agent.algorithm}"
    return agent


def action_set(scenario: Scenario) -> ActionSet:
    """The action components (branches) and their sub-actions of ``scenario``."""
    return ActionSet.of(scenario)


def reward_groups(scenario: Scenario) -> int:
    """G of a scenario's BDQ (:func:`value_groups`)."""
    return value_groups(_config(scenario), action_set(scenario))


class BdqSpec(DqnSpec):
    """The branching dueling Q-network, stacked over seeds (``adaptsky.algos.bdq``)."""

    name = "bdq"
    config_keys = ("hidden_sizes", "memory_size", "batch_size")
    replay_fields = tuple(BRANCH_ACTIONS if field.name == "actions" else field
                          for field in REPLAY)
    fields = (*replay_fields, *ADAM_STATE)
    remedies: ClassVar[dict[str, str]] = {
        "replay": "lower agent.memory_size or the number of seeds",
        "networks and optimizer": "lower agent.hidden_sizes, users or the number of seeds",
        "batch activations": "lower agent.batch_size or agent.hidden_sizes",
    }

    def network(self, scenario: Scenario) -> dict[str, tuple[int, ...]]:
        """Torso, ``value`` (G: 1, or one per UAV) and ``advantage`` (D b: the branches one
        after another)."""
        actions = action_set(scenario)
        return network_shapes(observation_size_of(scenario),
                              actions.num_components * actions.base,
                              _config(scenario).hidden_sizes, dueling=True,
                              values=reward_groups(scenario),
                              encoder=set_encoder_of(scenario))

    def replay_fields_of(self, scenario: Scenario) -> tuple[Field, ...]:
        """The replay's fields: rewards (R, G) where the branches learn G > 1 parts."""
        if reward_groups(scenario) == 1:
            return self.replay_fields
        return tuple(REWARD_PARTS if field.name == "rewards" else field
                     for field in self.replay_fields)

    def replay_symbols(self, scenario: Scenario) -> dict[str, int]:
        return {"O": observation_size_of(scenario),
                "D": action_set(scenario).num_components, "G": reward_groups(scenario)}

    def memory_parts(self, scenario: Scenario, seeds: int, workers: int) -> dict[str, float]:
        """:func:`replay_network_parts` with a head of G + D b outputs and D action columns,
        and G - 1 more reward columns (no large head matrix: M is (G + D b) x D b)."""
        actions = action_set(scenario)
        groups = reward_groups(scenario)
        head = groups + actions.num_components * actions.base
        return replay_network_parts(scenario, seeds, workers, head,
                                    actions.num_components + groups - 1)

    def build(self, scenario: Scenario, seeds: list[int], rngs: list[Any],
              observation_size: int, num_actions: int, device: Any = "cpu",
              graphs: bool | None = None) -> Algorithm:
        from adaptsky.algos.bdq.learner import BdqLearner  # torch

        actions = action_set(scenario)
        assert num_actions == actions.count, (num_actions, actions.count)
        return BdqLearner(_config(scenario), observation_size, actions, seeds, rngs, device,
                          graphs, set_encoder_of(scenario))

    def greedy_policy(self, scenario: Scenario, policy: Tree) -> Policy:
        from adaptsky.algos.bdq.stacked import StackedBdq  # torch

        agent = StackedBdq(_config(scenario), observation_size_of(scenario),
                           action_set(scenario), seeds=[0], encoder=set_encoder_of(scenario))
        agent.load_policy(0, policy)
        return lambda observations: agent.greedy(observations[None])[0]


BDQ = BdqSpec()
