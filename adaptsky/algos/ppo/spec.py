"""PPO's torch-free half (:class:`~adaptsky.algos.protocol.AlgorithmSpec`): its head for a
scenario, its part of a checkpoint (docs/file-format.md: ``agent/policy``, ``agent/critic``,
``agent/optimizer``), its memory estimate, and the builders of its learner and of a greedy
policy, which import torch only when called."""

from __future__ import annotations

from typing import Any, ClassVar

from adaptsky.algos.ppo.parameters import critic_shapes, policy_shapes
from adaptsky.algos.protocol import Algorithm, LayoutCheck, Node, Policy
from adaptsky.algos.shared.checkpoint import ADAM_STEP, FLOAT32, check_adam, check_weights
from adaptsky.algos.shared.set_layout import set_encoder_of
from adaptsky.algos.shared.shapes import HeadShape, observation_size_of, parameter_count
from adaptsky.arrays import Field, Tree
from adaptsky.errors import ScenarioError
from adaptsky.scenario.agents import PpoAgent
from adaptsky.scenario.models import Scenario
from adaptsky.sim.actions import DENSE_MODES, ActionSet

# /seeds/<S>/checkpoint/agent/reward_norm/: the running statistics of the return (norm_reward)
REWARD_NORM = (Field("mean", "float", ()), Field("var", "float", ()),
               Field("count", "float", ()))


def _config(scenario: Scenario) -> PpoAgent:
    agent = scenario.agent
    assert isinstance(agent, PpoAgent), f"not a PPO agent: {agent.algorithm}"
    return agent


def head_kind(scenario: Scenario) -> str:
    """The head ``agent.action_head`` names ('auto': dense, or gaussian for continuous)."""
    kind = _config(scenario).action_head
    if kind == "auto":
        return "gaussian" if scenario.uav.actions == "continuous" else "dense"
    return kind


def head_of(scenario: Scenario) -> HeadShape:
    """The actor's head for ``scenario``'s actions."""
    kind = head_kind(scenario)
    if kind == "gaussian":
        components = sum(3 + k for k in scenario.shares_of_uavs)
        return HeadShape("gaussian", components, components=components)
    actions = ActionSet.of(scenario)
    if kind == "dense":
        return HeadShape("dense", actions.count)
    branches = (actions.base,) * actions.num_components
    return HeadShape("branches", sum(branches), branches=branches)


class PpoSpec:
    """PPO, stacked over seeds (``adaptsky.algos.ppo``)."""

    name = "ppo"
    action_kinds = (*DENSE_MODES, "continuous")
    min_uavs = 1
    checkpoint_members = ("agent",)
    config_keys = ("hidden_sizes", "envs_per_seed", "action_head")
    fields = (ADAM_STEP, *REWARD_NORM)
    remedies: ClassVar[dict[str, str]] = {
        "rollout": "lower agent.envs_per_seed, train.steps or the number of seeds",
        "networks and optimizer": "lower agent.hidden_sizes or the number of seeds",
        "batch activations": "raise agent.minibatches or lower agent.hidden_sizes",
    }

    def check_scenario(self, scenario: Scenario, source: str) -> None:
        """One line where ``agent.action_head`` does not fit ``uav.actions``."""
        kind, actions = _config(scenario).action_head, scenario.uav.actions
        continuous = actions == "continuous"
        if kind == "auto" or (kind == "gaussian") == continuous:
            return
        fits = "'gaussian' (or 'auto')" if continuous else "'dense' or 'branches' (or 'auto')"
        raise ScenarioError([f"{source}: agent.action_head: '{kind}' does not fit "
                             f"uav.actions = '{actions}'; it takes {fits}"])

    def envs_per_member(self, scenario: Scenario) -> int:
        return _config(scenario).envs_per_seed

    def head(self, scenario: Scenario) -> HeadShape:
        """The actor's head."""
        return head_of(scenario)

    def inputs(self, scenario: Scenario) -> tuple[int, int | None]:
        """The actor's inputs and the critic's where they differ (None: the actor's)."""
        return observation_size_of(scenario), None

    def rows_per_env(self, scenario: Scenario) -> int:
        """Rollout rows per environment (MAPPO: one per UAV)."""
        return 1

    def shapes(self, scenario: Scenario) -> tuple[dict[str, tuple[int, ...]],
                                                  dict[str, tuple[int, ...]]]:
        """The policy's and the critic's parameters, torch-named and shaped."""
        (actor, critic), hidden = self.inputs(scenario), _config(scenario).hidden_sizes
        encoder = set_encoder_of(scenario)
        return (policy_shapes(actor, hidden, self.head(scenario), encoder),
                critic_shapes(critic or actor, hidden, encoder))

    # ---- the checkpoint -------------------------------------------------------------------

    def check_policy(self, check: LayoutCheck, group: Node, scenario: Scenario) -> None:
        check_weights(check, group, self.shapes(scenario)[0])

    def check_checkpoint(self, check: LayoutCheck, group: Node, scenario: Scenario,
                         episodes_done: int) -> None:
        """``agent``: ``policy``, ``critic`` and ``optimizer`` (step, exp_avg, exp_avg_sq)."""
        agent = check.group(group, "agent")
        normalised = _config(scenario).norm_reward
        check.exact_members(agent, ("policy", "critic", "optimizer",
                                    *(("reward_norm",) if normalised else ())))
        policy, critic = self.shapes(scenario)
        check_weights(check, check.group(agent, "policy"), policy)
        check_weights(check, check.group(agent, "critic"), critic)
        check_adam(check, check.group(agent, "optimizer"), {**policy, **critic})
        if normalised:
            norm = check.group(agent, "reward_norm")
            check.exact_members(norm, [field.name for field in REWARD_NORM])
            for field in REWARD_NORM:
                check.dataset(norm, field, {})

    def policy_of(self, checkpoint: Tree) -> Tree:
        return checkpoint["agent"]["policy"]

    # ---- memory ---------------------------------------------------------------------------

    def memory_parts(self, scenario: Scenario, seeds: int, workers: int) -> dict[str, float]:
        """The rollout (T S E R rows of inputs and five numbers, twice: as collected and
        per member), networks and optimizer (parameters, gradients, two moments, a
        checkpoint's copy), and a minibatch's activations, forward and backward."""
        agent = _config(scenario)
        actor, critic = self.inputs(scenario)
        policy, critic_params = self.shapes(scenario)
        params = float(parameter_count(policy) + parameter_count(critic_params))
        samples = scenario.train.steps * agent.envs_per_seed * self.rows_per_env(scenario)
        head = self.head(scenario).width
        hidden = float(sum(agent.hidden_sizes))
        return {
            "rollout": 2 * seeds * samples * (actor + (critic or 0) + 5 + head) * FLOAT32,
            "networks and optimizer": 6 * seeds * params * FLOAT32,
            "batch activations": seeds * (samples / agent.minibatches)
            * 4 * (actor + (critic or actor) + 2 * hidden + head) * FLOAT32,
        }

    # ---- builders (torch) -----------------------------------------------------------------

    def build(self, scenario: Scenario, seeds: list[int], rngs: list[Any],
              observation_size: int, num_actions: int, device: Any = "cpu",
              graphs: bool | None = None) -> Algorithm:
        from adaptsky.algos.ppo.learner import PpoLearner  # torch

        train = scenario.train
        return PpoLearner(_config(scenario), head_of(scenario), observation_size, seeds,
                          rngs, train.steps, train.episodes, device,
                          encoder=set_encoder_of(scenario))  # type: ignore[return-value]

    def greedy_policy(self, scenario: Scenario, policy: Tree) -> Policy:
        from adaptsky.algos.ppo.stacked import StackedActorCritic
        from adaptsky.algos.shared.heads import ActionHead  # torch

        agent, head = _config(scenario), head_of(scenario)
        net = StackedActorCritic(observation_size_of(scenario), agent.hidden_sizes, head,
                                 [0], agent.activation, encoder=set_encoder_of(scenario))
        net.load_policy(0, policy)
        actions = ActionHead(head)
        return lambda observations: actions.env_actions(actions.mode(
            net.host_actor(observations[None].astype("float32"))))[0]


PPO = PpoSpec()
