"""The DQN of algorithm 1 as an :class:`~adaptsky.algos.protocol.Algorithm`: epsilon-greedy
actions, n-step rows into the replay memories, a TD update per step once they hold a batch,
hard or soft target copies (docs/model.md §4, docs/agent.md for the extensions)."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from adaptsky.algos.device_step import describe
from adaptsky.algos.dqn.device_step import DeviceStep
from adaptsky.algos.dqn.stacked import StackedDqn
from adaptsky.algos.replay import StackedReplay
from adaptsky.algos.returns import NStepWindow
from adaptsky.algos.schedule import epsilon
from adaptsky.arrays import Tree
from adaptsky.scenario.agents import BdqAgent, DqnAgent


class DqnLearner:
    """Networks, Adam, replay memories and n-step windows of S members on ``device``;
    ``rngs[s]`` draws member s's exploration and replay samples."""

    def __init__(self, config: DqnAgent | BdqAgent, observation_size: int, num_actions: int,
                 seeds: list[int], rngs: list[np.random.Generator], device: Any = "cpu",
                 graphs: bool | None = None) -> None:
        self.config, self.rngs = config, rngs
        self.size, self.num_actions = len(seeds), num_actions
        self.agent = self._networks(observation_size, seeds, device)
        self.memory = StackedReplay(self.size, config.memory_size, observation_size,
                                    self.agent.device, self.agent.action_width,
                                    self.agent.values)
        self.device_step = DeviceStep(self.agent, self.memory, config.batch_size, graphs)
        self.window = NStepWindow(config.n_step, config.gamma)
        self.epsilon = config.epsilon_start
        self.reward_parts = self.agent.values
        self._reward_scale = np.array(config.reward_scale)
        self._terminated = np.zeros(self.size, dtype=bool)  # T is a truncation

    def _networks(self, observation_size: int, seeds: list[int], device: Any) -> StackedDqn:
        """The stacked networks of the members."""
        assert isinstance(self.config, DqnAgent)
        return StackedDqn(self.config, observation_size, self.num_actions, seeds, device)

    def begin_episode(self, global_step: int) -> None:
        self.window.restart()
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

    def observe(self, observations: NDArray[np.float32], actions: NDArray[np.int64],
                rewards: NDArray[np.float64], next_observations: NDArray[np.float32]) -> None:
        """Store the step's n-step row (rewards (S,), or (S, G) parts of the reward where the
        networks learn G values, scaled by ``reward_scale``)."""
        ready = self.window.push(observations, self.agent.stored_actions(actions),
                                 rewards * self._reward_scale, next_observations)
        if ready is not None:
            self.memory.add(*ready, self._terminated)

    def update(self) -> None:
        """One TD update (eq. 12) of every member once the memories hold a batch."""
        batch_size = self.config.batch_size
        if self.memory.size >= batch_size:
            self.device_step.update(self.memory.sample_index(batch_size, self.rngs))

    def end_episode(self, episodes_before: int) -> None:
        """Alg. 1: a hard target copy when the episode count is a multiple of delta (unless
        the target is soft)."""
        config = self.config
        if config.target_tau == 0 and episodes_before % config.target_update_episodes == 0:
            self.agent.sync_target()

    def take_mean_loss(self) -> NDArray[np.float64] | None:
        updated = self.agent.updates > 0
        losses = self.agent.take_mean_loss()
        return losses if updated else None

    def take_stats(self) -> dict[str, NDArray[np.float64]]:
        """The learning rate now (``lr``, the same for every member; an epsilon-greedy
        policy has no entropy to report)."""
        return {"lr": np.full(self.size, self.agent.learning_rate())}

    def device_name(self) -> str:
        return describe(self.agent.device)

    def checkpoint(self, member: int) -> Tree:
        return {"agent": self.agent.state_arrays(member),
                "replay": {**self.memory.arrays(member), "position": self.memory.position}}

    def restore(self, member: int, checkpoint: Tree) -> None:
        self.agent.load_state_arrays(member, checkpoint["agent"])
        replay = dict(checkpoint["replay"])
        position = int(replay.pop("position"))
        self.memory.load(member, replay, position)

    def policy(self, member: int) -> Tree:
        return self.agent.policy_arrays(member)
