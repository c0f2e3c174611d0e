"""The BDQ as an off-policy learner: the DQN's learner (epsilon-greedy
actions, n-step rows into the replay memories, a TD update per step, target copies) over
branching networks. Exploring draws a dense action uniformly, that is every branch's sub-action
uniformly; the replay stores the sub-action of every branch."""

from __future__ import annotations

from typing import Any

import numpy as np

from adaptsky.algos.bdq.stacked import StackedBdq
from adaptsky.algos.dqn.learner import DqnLearner
from adaptsky.algos.shared.set_layout import SetEncoder
from adaptsky.scenario.agents import BdqAgent, DqnAgent
from adaptsky.sim.actions import ActionSet


class BdqLearner(DqnLearner):
    """Branching networks, Adam, replay memories and n-step windows of S members; actions are
    indices of the dense action set ``action_set`` (the environment's)."""

    def __init__(self, config: BdqAgent, observation_size: int, action_set: ActionSet,
                 seeds: list[int], rngs: list[np.random.Generator], device: Any = "cpu",
                 graphs: bool | None = None, encoder: SetEncoder | None = None) -> None:
        self.action_set = action_set
        super().__init__(config, observation_size, action_set.count, seeds, rngs, device,
                         graphs, encoder)
        self.reward_split = config.reward_split

    def _networks(self, observation_size: int, seeds: list[int], device: Any) -> StackedBdq:
        config: DqnAgent | BdqAgent = self.config
        assert isinstance(config, BdqAgent)
        return StackedBdq(config, observation_size, self.action_set, seeds, device,
                          self.encoder)
