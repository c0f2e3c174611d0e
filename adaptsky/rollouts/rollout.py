"""Rollouts over L layouts at once: a policy stepping from the episode start, or a fixed
configuration held (baselines). Both give a time-major :class:`Trace`."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from adaptsky.arrays import Tree
from adaptsky.scenario.models import Scenario
from adaptsky.sim.actions import ActionSet
from adaptsky.sim.batch import NetworkState, NomaUavBatch
from adaptsky.sim.observation import observation_size

Policy = Callable[[NDArray[np.float32]], NDArray[np.int64]]
Tick = Callable[[int], None]
FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class Trace:
    """Per step and layout: rates (T, L, N), UAV positions (T, L, 3), power shares (T, L, N)."""

    rate_bps: FloatArray
    uav_m: FloatArray
    alpha: FloatArray

    @property
    def sum_rate_bps(self) -> FloatArray:
        return self.rate_bps.sum(axis=-1)

    @classmethod
    def of(cls, states: list[NetworkState]) -> Trace:
        return cls(np.array([s.rate_bps for s in states]), np.array([s.uav_m for s in states]),
                   np.array([s.alpha for s in states]))


def _env(scenario: Scenario, users_m: FloatArray, seed: int) -> NomaUavBatch:
    return NomaUavBatch(scenario, num_envs=len(users_m), seed=seed, users_m=users_m)


def rollout(scenario: Scenario, policy: Policy, steps: int, users_m: FloatArray,
            seed: int = 0, on_step: Tick | None = None) -> Trace:
    """Run ``policy`` for ``steps`` steps from the episode start, with no time limit;
    ``on_step`` hears the number of steps done after each."""
    env = _env(scenario, users_m, seed)
    obs, _ = env.reset()
    states = []
    for step in range(steps):  # the batch core reports truncation but never enforces it
        obs, _, _, state = env.step(policy(obs))
        states.append(state)
        if on_step is not None:
            on_step(step + 1)
    return Trace.of(states)


def hold(scenario: Scenario, uav_m: FloatArray, alpha_first: FloatArray, steps: int,
         users_m: FloatArray, seed: int = 0, on_step: Tick | None = None) -> Trace:
    """Keep every UAV at ``uav_m`` (L, 3) with shares ``alpha_first`` (L, K) for ``steps``
    steps (LoS drawn every step for ``los = "sampled"``)."""
    env = _env(scenario, users_m, seed)
    env.reset()
    states = []
    for step in range(steps):
        states.append(env.evaluate_at(uav_m, alpha_first))
        if on_step is not None:
            on_step(step + 1)
    return Trace.of(states)


def random_policy(num_actions: int, seed: int = 0) -> Policy:
    rng = np.random.default_rng(seed)
    return lambda obs: rng.integers(0, num_actions, size=len(obs))


def greedy_policy(scenario: Scenario, checkpoint: Tree) -> Policy:
    """argmax_a Q(s, a) of a checkpoint's policy network."""
    from adaptsky.algos.stacked import StackedDqn  # torch: imported only to evaluate

    num_actions = ActionSet(scenario.num_clusters, scenario.uav.actions).count
    agent = StackedDqn(scenario.agent, observation_size(scenario.num_users), num_actions,
                       seeds=[0])
    agent.load_state_arrays(0, checkpoint["agent"])
    return lambda observations: agent.greedy(observations[None])[0]
