"""Rollouts of a policy over B layouts at once, and the policies to roll out."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from adaptsky_cli.agent.dqn import DqnAgent
from adaptsky_cli.env.batch import NomaUavBatch
from adaptsky_cli.env.observation import observation_size
from adaptsky_cli.scenario.models import Scenario
from adaptsky_cli.store.tree import Tree

Policy = Callable[[NDArray[np.float32]], NDArray[np.int64]]


def rollout(scenario: Scenario, policy: Policy, steps: int, num_envs: int = 1, seed: int = 0,
            users_m: NDArray[np.float64] | None = None) -> dict[str, NDArray]:
    """Run ``policy`` for ``steps`` steps from the episode start (no time limit); returns
    time-major arrays: ``sum_rate_bps`` (T, B), ``rate_bps`` (T, B, N), ``uav_m`` (T, B, 3)."""
    scenario = scenario.model_copy(update={"train": scenario.train.model_copy(
        update={"steps": steps})})
    env = NomaUavBatch(scenario, num_envs=num_envs, seed=seed, users_m=users_m)
    obs, _ = env.reset()
    sum_rates, rates, positions = [], [], []
    for _ in range(steps):
        obs, _, _, state = env.step(policy(obs))
        sum_rates.append(state.sum_rate_bps)
        rates.append(state.rate_bps)
        positions.append(state.uav_m)
    return {"sum_rate_bps": np.array(sum_rates), "rate_bps": np.array(rates),
            "uav_m": np.array(positions)}


def random_policy(num_actions: int, seed: int = 0) -> Policy:
    rng = np.random.default_rng(seed)
    return lambda obs: rng.integers(0, num_actions, size=len(obs))


def greedy_policy(scenario: Scenario, checkpoint: Tree) -> Policy:
    """argmax_a Q(s, a) of a checkpoint's policy network."""
    from adaptsky_cli.env.actions import ActionSet

    num_actions = ActionSet(scenario.num_clusters, scenario.uav.actions).count
    agent = DqnAgent(scenario.agent, observation_size(scenario.num_users), num_actions, seed=0)
    agent.load_state_arrays(checkpoint["agent"])
    return agent.greedy
