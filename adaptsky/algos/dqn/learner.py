"""The DQN of algorithm 1 as an off-policy learner (:mod:`adaptsky.algos.off_policy`):
epsilon-greedy actions, n-step rows into the replay memories, a TD update per step once they
hold a batch, hard or soft target copies (docs/model.md §4, docs/agent.md for the
extensions). Its networks and their update are :mod:`adaptsky.algos.dqn.stacked`."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from adaptsky.algos.dqn.device_step import DeviceStep
from adaptsky.algos.dqn.stacked import StackedDqn
from adaptsky.algos.off_policy import OffPolicyLearner
from adaptsky.algos.replay import StackedReplay
from adaptsky.algos.schedule import epsilon
from adaptsky.algos.shared.set_layout import SetEncoder
from adaptsky.scenario.agents import BdqAgent, DqnAgent


class DqnLearner(OffPolicyLearner):
    """Networks, Adam, replay memories and n-step windows of S members on ``device``;
    ``rngs[s]`` draws member s's exploration and replay samples."""

    def __init__(self, config: DqnAgent | BdqAgent, observation_size: int, num_actions: int,
                 seeds: list[int], rngs: list[np.random.Generator], device: Any = "cpu",
                 graphs: bool | None = None, encoder: SetEncoder | None = None) -> None:
        self.config, self.num_actions, self.encoder = config, num_actions, encoder
        agent = self._networks(observation_size, seeds, device)
        memory = StackedReplay(len(seeds), config.memory_size, observation_size, agent.device,
                               agent.action_width, agent.values)
        super().__init__(rngs, agent, memory, config.reward_scale, config.n_step, config.gamma)
        self.agent = agent
        self.losses.buffer("loss", agent.loss_sum)  # the update adds into it
        self.device_step = DeviceStep(agent, memory, config.batch_size, graphs)
        self.epsilon = config.epsilon_start
        self.reward_parts = agent.values

    def _networks(self, observation_size: int, seeds: list[int], device: Any) -> StackedDqn:
        """The stacked networks of the members."""
        assert isinstance(self.config, DqnAgent)
        return StackedDqn(self.config, observation_size, self.num_actions, seeds, device,
                          self.encoder)

    def begin_episode(self, global_step: int) -> None:
        super().begin_episode(global_step)
        self.agent.set_learning_rate(global_step)

    def act(self, observations: NDArray[np.float32], global_step: int) -> NDArray[np.int64]:
        """Epsilon-greedy per member (alg. 1 lines 5-6): one uniform draw, one more to
        explore."""
        config = self.config
        self.epsilon = eps = epsilon(global_step, config.epsilon_start, config.epsilon_end,
                                     config.epsilon_decay_steps)
        explore = [rng.random() < eps for rng in self.rngs]
        if not any(explore):
            return self.device_step.greedy(observations)
        greedy = None if all(explore) else self.device_step.greedy(observations)
        count = self.num_actions
        return np.array([rng.integers(count) if explores else greedy[index]  # type: ignore[index]
                         for index, (rng, explores) in enumerate(zip(self.rngs, explore,
                                                                     strict=True))],
                        dtype=np.int64)

    def greedy(self, observations: NDArray[np.float32]) -> NDArray[np.int64]:
        return self.agent.greedy(observations)

    def _stored_actions(self, actions: NDArray[Any]) -> NDArray[Any]:
        return self.agent.stored_actions(actions)

    def _due(self) -> bool:
        """Once the memories hold a batch."""
        return self.memory.size >= self.config.batch_size

    def _update(self) -> None:
        """One TD update (eq. 12) of every member."""
        self.device_step.update(self.memory.sample_index(self.config.batch_size, self.rngs))
        self.losses.added("loss")

    def end_episode(self, episodes_before: int) -> None:
        """Alg. 1: a hard target copy when the episode count is a multiple of delta (unless
        the target is soft)."""
        config = self.config
        if config.target_tau == 0 and episodes_before % config.target_update_episodes == 0:
            self.agent.sync_target()

    def take_stats(self) -> dict[str, NDArray[np.float64]]:
        """The learning rate now (``lr``, the same for every member; an epsilon-greedy
        policy has no entropy to report)."""
        return {"lr": np.full(self.size, self.agent.learning_rate())}
