"""SAC's torch-free half (:class:`~adaptsky.algos.protocol.AlgorithmSpec`): its part of a
checkpoint (docs/file-format.md: ``agent/actor``, ``agent/q1``, ``agent/q2``, their targets
``agent/q1_target`` and ``agent/q2_target``, ``agent/alpha``, the three Adam states, and the
DQN's ``replay`` with D float action columns), its memory estimate, and the builders of its
learner and of a greedy policy, which import torch only when called."""

from __future__ import annotations

from typing import Any, ClassVar

from adaptsky.algos.protocol import Algorithm, LayoutCheck, Node, Policy
from adaptsky.algos.sac.parameters import (
    Q_NETWORKS,
    TEMPERATURE_SHAPES,
    actor_shapes,
    critic_shapes,
    q_shapes,
)
from adaptsky.algos.shared.checkpoint import (
    ADAM_STEP,
    FLOAT32,
    REPLAY,
    check_adam,
    check_replay,
    check_weights,
    replay_network_parts,
)
from adaptsky.algos.shared.set_layout import set_encoder_of
from adaptsky.algos.shared.shapes import observation_size_of, parameter_count
from adaptsky.arrays import Field, Tree
from adaptsky.scenario.agents import SacAgent
from adaptsky.scenario.models import Scenario
from adaptsky.sim.controls import Components

# /seeds/<S>/checkpoint/replay/actions: the D components of each stored action, in [-1, 1]
CONTROL_ACTIONS = Field("actions", "float", ("R", "D"))
OPTIMIZERS = ("actor_optimizer", "q_optimizer", "alpha_optimizer")


def _config(scenario: Scenario) -> SacAgent:
    agent = scenario.agent
    assert isinstance(agent, SacAgent), f"not a SAC agent: {agent.algorithm}"
    return agent


def components(scenario: Scenario) -> int:
    """D, the components of a continuous action of ``scenario``."""
    return Components.of(scenario, 1).num_components


class SacSpec:
    """Soft actor-critic, stacked over seeds (``adaptsky.algos.sac``)."""

    name = "sac"
    action_kinds = ("continuous",)
    min_uavs = 1
    checkpoint_members = ("agent", "replay")
    config_keys = ("hidden_sizes", "memory_size", "batch_size")
    replay_fields = tuple(CONTROL_ACTIONS if field.name == "actions" else field
                          for field in REPLAY)
    fields = (*replay_fields, ADAM_STEP)
    remedies: ClassVar[dict[str, str]] = {
        "replay": "lower agent.memory_size or the number of seeds",
        "networks and optimizer": "lower agent.hidden_sizes or the number of seeds",
        "batch activations": "lower agent.batch_size or agent.hidden_sizes",
    }

    def check_scenario(self, scenario: Scenario, source: str) -> None:
        """Nothing beyond the action kind."""

    def envs_per_member(self, scenario: Scenario) -> int:
        return 1  # one environment per seed: step, store, update

    def shapes(self, scenario: Scenario) -> dict[str, dict[str, tuple[int, ...]]]:
        """The parameters of the actor, each Q network and the temperature, torch-named and
        shaped, by checkpoint group."""
        obs, hidden = observation_size_of(scenario), _config(scenario).hidden_sizes
        count, encoder = components(scenario), set_encoder_of(scenario)
        return {"actor": actor_shapes(obs, hidden, count, encoder),
                **{q: q_shapes(q, obs, hidden, count, encoder) for q in Q_NETWORKS},
                "alpha": TEMPERATURE_SHAPES}

    # ---- the checkpoint -------------------------------------------------------------------

    def check_policy(self, check: LayoutCheck, group: Node, scenario: Scenario) -> None:
        check_weights(check, group, self.shapes(scenario)["actor"])

    def check_checkpoint(self, check: LayoutCheck, group: Node, scenario: Scenario,
                         episodes_done: int) -> None:
        """``agent`` (actor, Q networks and targets, alpha, three Adam states) and ``replay``
        (rows and write position)."""
        agent = check.group(group, "agent")
        shapes = self.shapes(scenario)
        targets = {f"{q}_target": shapes[q] for q in Q_NETWORKS}
        check.exact_members(agent, (*shapes, *targets, *OPTIMIZERS))
        for name, params in {**shapes, **targets}.items():
            check_weights(check, check.group(agent, name), params)
        critics = {name: shape for q in Q_NETWORKS for name, shape in shapes[q].items()}
        for name, params in zip(OPTIMIZERS, (shapes["actor"], critics, shapes["alpha"]),
                                strict=True):
            check_adam(check, check.group(agent, name), params)
        check_replay(check, group, scenario, episodes_done, self.replay_fields,
                     {"O": observation_size_of(scenario), "D": components(scenario)})

    def policy_of(self, checkpoint: Tree) -> Tree:
        return checkpoint["agent"]["actor"]

    # ---- memory ---------------------------------------------------------------------------

    def memory_parts(self, scenario: Scenario, seeds: int, workers: int) -> dict[str, float]:
        """The replay (the DQN's, D action columns); networks and optimizer (the actor and the
        Q networks: parameters, gradients, two Adam moments, the targets, a checkpoint's
        copy); a batch's activations, forward and backward, of the actor's three passes and
        the Q networks' six."""
        agent = _config(scenario)
        obs, count = observation_size_of(scenario), components(scenario)
        encoder = set_encoder_of(scenario)
        actor = float(parameter_count(actor_shapes(obs, agent.hidden_sizes, count, encoder)))
        critics = float(parameter_count(critic_shapes(obs, agent.hidden_sizes, count,
                                                      encoder)))
        hidden = float(sum(agent.hidden_sizes))
        return {
            "replay": replay_network_parts(scenario, seeds, workers, 1.0, count)["replay"],
            "networks and optimizer": seeds * (5 * actor + 6 * critics) * FLOAT32,
            "batch activations": seeds * agent.batch_size * 2 * FLOAT32
            * (3 * (obs + hidden + 3 * count) + 6 * (obs + count + hidden + 1)),
        }

    # ---- builders (torch) -----------------------------------------------------------------

    def build(self, scenario: Scenario, seeds: list[int], rngs: list[Any],
              observation_size: int, num_actions: int, device: Any = "cpu",
              graphs: bool | None = None) -> Algorithm:
        from adaptsky.algos.sac.learner import SacLearner  # torch

        assert num_actions == components(scenario), (num_actions, components(scenario))
        return SacLearner(_config(scenario), observation_size, num_actions, seeds, rngs,
                          device, set_encoder_of(scenario))  # type: ignore[return-value]

    def greedy_policy(self, scenario: Scenario, policy: Tree) -> Policy:
        from adaptsky.algos.sac.stacked import host_greedy  # torch
        from adaptsky.algos.shared.stacked import StackedParameters

        count, encoder = components(scenario), set_encoder_of(scenario)
        shapes = actor_shapes(observation_size_of(scenario), _config(scenario).hidden_sizes,
                              count, encoder)
        actor = StackedParameters(shapes, [policy])
        return lambda observations: host_greedy(  # type: ignore[return-value]
            actor, observations[None].astype("float32"), count, encoder)[0]


SAC = SacSpec()
"""SAC (Haarnoja et al. 2018) stacked over seeds, for continuous controls (docs/agent.md)."""
