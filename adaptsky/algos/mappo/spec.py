"""MAPPO's and IPPO's torch-free half (:class:`~adaptsky.algos.protocol.AlgorithmSpec`): PPO's
checkpoint (``agent/policy``, ``agent/critic``, ``agent/optimizer``; docs/file-format.md) over
the shared actor's inputs L + U and the critic's (U L + U centralised, L + U local), each UAV's
head, its memory estimate, and the builders of its learner and of a greedy policy."""

from __future__ import annotations

from typing import Any

from adaptsky.algos.ppo.spec import PpoSpec
from adaptsky.algos.protocol import Algorithm, Policy
from adaptsky.algos.shared.shapes import HeadShape, local_input_size
from adaptsky.arrays import Tree
from adaptsky.errors import ScenarioError
from adaptsky.scenario.agents import MappoAgent
from adaptsky.scenario.models import Scenario
from adaptsky.sim.actions import DENSE_MODES, ActionSet


def _config(scenario: Scenario) -> MappoAgent:
    agent = scenario.agent
    assert isinstance(agent, MappoAgent), f"not a MAPPO agent: {agent.algorithm}"
    return agent


def uav_components(scenario: Scenario) -> int:
    """D = 3 + K, one UAV's components (every UAV has K clusters: check_scenario)."""
    return 3 + scenario.shares_per_uav


def uav_head(scenario: Scenario) -> tuple[HeadShape, int | None]:
    """One UAV's head (``agent.action_head``, 'auto': dense, gaussian for continuous
    controls) and b^D, its number of moves (None for continuous controls)."""
    kind, components = _config(scenario).action_head, uav_components(scenario)
    if scenario.uav.actions == "continuous":
        return HeadShape("gaussian", components, components=components), None
    base = ActionSet.of(scenario).base
    if kind == "branches":
        return HeadShape("branches", base * components, branches=(base,) * components), \
            base**components
    return HeadShape("dense", base**components), base**components


def input_sizes(scenario: Scenario) -> tuple[int, int]:
    """The actor's inputs L + U and the critic's: U L + U (MAPPO), L + U (IPPO)."""
    local, num_uavs = local_input_size(scenario), scenario.uav.count
    centralised = _config(scenario).algorithm == "mappo"
    return local + num_uavs, (num_uavs * local if centralised else local) + num_uavs


class MappoSpec(PpoSpec):
    """MAPPO (centralised critic) or IPPO (local critic), by ``name``."""

    action_kinds = (*DENSE_MODES, "continuous")
    min_uavs = 2
    config_keys = ("hidden_sizes", "envs_per_seed", "action_head", "reward_split")

    def __init__(self, name: str) -> None:
        self.name = name

    def check_scenario(self, scenario: Scenario, source: str) -> None:
        """One line where the scenario has one UAV, UAVs of unequal clusters (one actor, one
        head) or an ``action_head`` that does not fit ``uav.actions``."""
        uavs = scenario.uav.count
        if uavs < 2:
            raise ScenarioError([f"{source}: agent.algorithm: '{self.name}' acts per UAV and "
                                 f"needs uav.count >= 2, got {uavs}; for one UAV choose "
                                 f"'ppo'"])
        clusters = scenario.clusters_of_uavs
        if len(set(clusters)) > 1:
            raise ScenarioError([f"{source}: users.uav: '{self.name}' shares one actor among "
                                 f"the UAVs, which needs as many clusters on each; the UAVs "
                                 f"have {', '.join(map(str, clusters))}"])
        super().check_scenario(scenario, source)

    def head(self, scenario: Scenario) -> HeadShape:
        return uav_head(scenario)[0]

    def inputs(self, scenario: Scenario) -> tuple[int, int | None]:
        """L + U, and U L + U for MAPPO's critic (IPPO's reads the actor's rows)."""
        actor, critic = input_sizes(scenario)
        return actor, critic if _config(scenario).algorithm == "mappo" else None

    def rows_per_env(self, scenario: Scenario) -> int:
        return scenario.uav.count

    def build(self, scenario: Scenario, seeds: list[int], rngs: list[Any],
              observation_size: int, num_actions: int, device: Any = "cpu",
              graphs: bool | None = None) -> Algorithm:
        from adaptsky.algos.mappo.learner import MappoLearner  # torch

        head, per_uav = uav_head(scenario)
        actor, critic = self.inputs(scenario)
        train = scenario.train
        return MappoLearner(_config(scenario), head, scenario.uav.count, per_uav, actor,
                            critic, seeds, rngs, train.steps, train.episodes,
                            device)  # type: ignore[return-value]

    def greedy_policy(self, scenario: Scenario, policy: Tree) -> Policy:
        from adaptsky.algos.mappo.rows import actor_rows, joint_actions
        from adaptsky.algos.ppo.stacked import StackedActorCritic
        from adaptsky.algos.shared.heads import ActionHead  # torch

        agent, (head, per_uav) = _config(scenario), uav_head(scenario)
        actor, critic = self.inputs(scenario)
        num_uavs = scenario.uav.count
        net = StackedActorCritic(actor, agent.hidden_sizes, head, [0], agent.activation,
                                 critic_size=critic)
        net.load_policy(0, policy)
        actions = ActionHead(head)

        def greedy(observations: Any) -> Any:
            rows = actor_rows(observations[None].astype("float32"), num_uavs)
            return joint_actions(actions.env_actions(actions.mode(net.host_actor(rows))),
                                 num_uavs, per_uav)[0]
        return greedy


MAPPO = MappoSpec("mappo")
IPPO = MappoSpec("ippo")
