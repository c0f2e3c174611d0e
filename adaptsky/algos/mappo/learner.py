"""MAPPO and IPPO as on-policy learners: PPO's learner
(:mod:`adaptsky.algos.ppo.learner`, every detail the same) over U rows per environment, one per
UAV (:mod:`adaptsky.algos.mappo.rows`): the rollout keeps every UAV's actor inputs, action,
log pi, value and reward; GAE runs per UAV; the minibatches draw from all UAVs' rows, so the
one actor learns from every UAV's steps. The reward is the team's (eq. 13) for every UAV, or
with ``agent.reward_split`` each UAV's own part."""

from __future__ import annotations

from typing import Any

import numpy as np

from adaptsky.algos.mappo.rows import actor_rows, critic_rows, joint_actions
from adaptsky.algos.ppo.learner import PpoLearner
from adaptsky.algos.shared.shapes import HeadShape
from adaptsky.scenario.agents import MappoAgent


class MappoLearner(PpoLearner):
    """PPO over the UAVs of S members of E environments each (module docstring); ``per_uav``
    b^D, the actions of one UAV (None for continuous controls)."""

    def __init__(self, config: MappoAgent, head: HeadShape, num_uavs: int, per_uav: int | None,
                 actor_size: int, critic_size: int | None, seeds: list[int],
                 rngs: list[np.random.Generator], steps: int, episodes: int,
                 device: Any = "cpu") -> None:
        self.agents, self.per_uav = num_uavs, per_uav
        self.centralised = config.algorithm == "mappo"
        self.reward_parts = 1 if config.reward_split == "team" else num_uavs
        self.reward_split = config.reward_split
        super().__init__(config, head, actor_size, seeds, rngs, steps, episodes, device,
                         critic_size)

    def _inputs(self, observations: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        return (actor_rows(observations, self.agents),
                critic_rows(observations, self.agents) if self.centralised else None)

    def _joint(self, actions: np.ndarray) -> np.ndarray:
        return joint_actions(actions, self.agents, self.per_uav)

    def _row_rewards(self, rewards: np.ndarray) -> np.ndarray:
        """The team's reward (S E,) for every UAV, or the UAVs' parts (S E, U) as they are."""
        rewards = np.asarray(rewards)
        if rewards.ndim == 1:
            rewards = np.repeat(rewards[:, None], self.agents, axis=1)
        return rewards.reshape(self.size, self.rows)
