"""The DQN's torch-free half (:class:`~adaptsky.algos.protocol.AlgorithmSpec`): its part of a
checkpoint (docs/file-format.md), its memory estimate, and the builders of its learner and of
a greedy policy, which import torch only when called."""

from __future__ import annotations

from typing import Any, ClassVar

from adaptsky.algos.dqn.parameters import network_shapes
from adaptsky.algos.protocol import Algorithm, LayoutCheck, Node, Policy
from adaptsky.algos.shared.checkpoint import (
    FLOAT32,
    REPLAY,
    check_replay,
    check_weights,
    replay_network_parts,
    replay_rows,
)
from adaptsky.algos.shared.set_layout import set_encoder_of
from adaptsky.algos.shared.shapes import observation_size_of
from adaptsky.arrays import Field, Tree
from adaptsky.scenario.agents import DqnAgent
from adaptsky.scenario.models import Scenario
from adaptsky.sim.actions import DENSE_MODES, ActionSet, count_estimate

# /seeds/<S>/checkpoint/agent/optimizer/state/<i>/ for the i-th network parameter P_i
ADAM_STATE = (Field("step", "float", ()), Field("exp_avg", "float", ("P",)),
              Field("exp_avg_sq", "float", ("P",)))


def _config(scenario: Scenario) -> DqnAgent:
    agent = scenario.agent
    assert isinstance(agent, DqnAgent), f"not a DQN agent: {agent.algorithm}"
    return agent


def network(scenario: Scenario) -> dict[str, tuple[int, ...]]:
    """The Q-network's parameters of ``scenario``, named and shaped as torch names them."""
    agent = _config(scenario)
    actions = ActionSet.of(scenario).count
    return network_shapes(observation_size_of(scenario), actions, agent.hidden_sizes,
                          agent.dueling, encoder=set_encoder_of(scenario))


class DqnSpec:
    """The dueling (or plain) DQN of sec. IV, stacked over seeds (``adaptsky.algos.dqn``)."""

    name = "dqn"
    action_kinds = DENSE_MODES
    min_uavs = 1
    checkpoint_members = ("agent", "replay")
    config_keys = ("hidden_sizes", "dueling", "memory_size", "batch_size")
    fields = (*REPLAY, *ADAM_STATE)
    remedies: ClassVar[dict[str, str]] = {
        "replay": "lower agent.memory_size or the number of seeds",
        "networks and optimizer": "lower agent.hidden_sizes, users or the number of seeds",
        "dueling head": "fewer users (the action space doubles per cluster) or "
                        "agent.dueling = false",
        "batch activations": "lower agent.batch_size or agent.hidden_sizes",
    }

    def check_scenario(self, scenario: Scenario, source: str) -> None:
        """Nothing beyond the action kind."""

    def envs_per_member(self, scenario: Scenario) -> int:
        return 1  # one environment per seed: step, store, update

    # ---- the checkpoint -------------------------------------------------------------------

    replay_fields = REPLAY

    def network(self, scenario: Scenario) -> dict[str, tuple[int, ...]]:
        """The network's parameters of ``scenario``, named and shaped as torch names them."""
        return network(scenario)

    def replay_fields_of(self, scenario: Scenario) -> tuple[Field, ...]:
        """The replay's fields in a checkpoint of ``scenario``."""
        return self.replay_fields

    def replay_symbols(self, scenario: Scenario) -> dict[str, int]:
        """The sizes the replay's fields name, but R."""
        return {"O": observation_size_of(scenario)}

    def check_policy(self, check: LayoutCheck, group: Node, scenario: Scenario) -> None:
        """A stored policy network: every parameter of :meth:`network`, nothing else."""
        check_weights(check, group, self.network(scenario))

    def check_checkpoint(self, check: LayoutCheck, group: Node, scenario: Scenario,
                         episodes_done: int) -> None:
        """``agent`` (policy, target, Adam state) and ``replay`` (rows and write position)."""
        agent = check.group(group, "agent")
        check.exact_members(agent, ("policy", "target", "optimizer"), extra_ok=("torch_rng",))
        shapes = self.network(scenario)
        for name in ("policy", "target"):
            check_weights(check, check.group(agent, name), shapes)
        rows, _ = replay_rows(scenario, episodes_done, scenario.agent.n_step)
        optimizer = check.group(agent, "optimizer")
        check.attr(optimizer, "param_groups_json", "json")
        check.exact_members(optimizer, ("state",))
        state = check.group(optimizer, "state")
        updates = rows >= scenario.agent.batch_size
        if len(state) or updates:  # torch kept no Adam state before the first update
            check.exact_members(state, map(str, range(len(shapes))))
            for index, shape in enumerate(shapes.values()):
                moments = check.group(state, str(index))
                check.exact_members(moments, [field.name for field in ADAM_STATE])
                for field in ADAM_STATE:
                    check.dataset(moments, field, {}, shape if field.shape else ())
        check_replay(check, group, scenario, episodes_done, self.replay_fields_of(scenario),
                     self.replay_symbols(scenario), scenario.agent.n_step)

    def policy_of(self, checkpoint: Tree) -> Tree:
        return checkpoint["agent"]["policy"]

    # ---- memory ---------------------------------------------------------------------------

    def memory_parts(self, scenario: Scenario, seeds: int, workers: int) -> dict[str, float]:
        """Replay, networks and optimizer, batch activations (:func:`replay_network_parts`),
        and the dueling head's fixed (1 + A) x A matrix and its build copy (measured: 22 users
        peak at 2.4 GB, estimated 2.6 GB)."""
        agent = _config(scenario)
        actions = count_estimate(scenario.shares_per_uav, scenario.uav.actions,
                             scenario.uav.count)
        head = actions + 1 if agent.dueling else actions
        parts = replay_network_parts(scenario, seeds, workers, head, action_columns=1)
        return {
            "replay": parts["replay"],
            "networks and optimizer": parts["networks and optimizer"],
            "dueling head": 2 * (actions + 1) * actions * FLOAT32 if agent.dueling else 0.0,
            "batch activations": parts["batch activations"],
        }

    # ---- builders (torch) -----------------------------------------------------------------

    def build(self, scenario: Scenario, seeds: list[int], rngs: list[Any],
              observation_size: int, num_actions: int, device: Any = "cpu",
              graphs: bool | None = None) -> Algorithm:
        from adaptsky.algos.dqn.learner import DqnLearner  # torch

        return DqnLearner(_config(scenario), observation_size, num_actions, seeds, rngs,
                          device, graphs, set_encoder_of(scenario))

    def greedy_policy(self, scenario: Scenario, policy: Tree) -> Policy:
        from adaptsky.algos.dqn.stacked import StackedDqn  # torch

        num_actions = ActionSet.of(scenario).count
        agent = StackedDqn(_config(scenario), observation_size_of(scenario),
                           num_actions, seeds=[0], encoder=set_encoder_of(scenario))
        agent.load_policy(0, policy)
        return lambda observations: agent.greedy(observations[None])[0]


DQN = DqnSpec()
