"""The device work of one training step of a DQN (or BDQ) stack: greedy actions, then the TD update.

On a CPU both are plain calls. On CUDA each is recorded once as a CUDA graph and replayed
every step (one launch instead of dozens of kernel launches: a small DQN is bound by launch
latency, not arithmetic). Per step only the observations (S x obs floats) and the sampled
indices (S x B) go to the device and the greedy actions (S) come back.
"""

from __future__ import annotations

import numpy as np
import torch

from adaptsky.algos.device_step import Graphed
from adaptsky.algos.dqn.stacked import StackedDqn
from adaptsky.algos.replay import StackedReplay


class DeviceStep:
    """Greedy actions and TD updates of ``agent`` over ``memory``, graphed on CUDA."""

    def __init__(self, agent: StackedDqn, memory: StackedReplay, batch_size: int,
                 graphs: bool | None = None) -> None:
        self.agent, self.memory = agent, memory
        device = agent.device
        self.graphs = device.type == "cuda" if graphs is None else graphs
        self.index = torch.zeros(agent.size, batch_size, dtype=torch.long, device=device)
        self.observations = torch.zeros(agent.size, 1, agent.observation_size, device=device)
        self._act: Graphed | None = None
        self._update: Graphed | None = None
        if self.graphs:
            self._host_index = torch.zeros(agent.size, batch_size, dtype=torch.long,
                                           pin_memory=True)
            self._host_obs = torch.zeros(agent.size, 1, agent.observation_size,
                                         pin_memory=True)

    def _greedy_body(self) -> torch.Tensor:
        return self.agent.device_greedy(self.observations).squeeze(-1)

    def _update_body(self) -> None:
        self.agent.update(*self.memory.gather(self.index))

    def greedy(self, observations: np.ndarray) -> np.ndarray:
        """The greedy action of every member for one observation each, (S, obs) -> (S,)."""
        if not self.graphs:
            return self.agent.greedy(observations[:, None, :])[:, 0]
        if self._act is None:
            self._act = Graphed(self._greedy_body, [])
        self._host_obs.numpy()[:, 0] = observations
        self.observations.copy_(self._host_obs, non_blocking=True)
        actions = self._act()
        assert actions is not None
        return actions.cpu().numpy()

    def update(self, index: np.ndarray) -> None:
        """One update of every member on the memory rows at ``index`` (S, B)."""
        if not self.graphs:
            self.index.copy_(torch.from_numpy(index))
            self._update_body()
            return
        if self._update is None:
            agent = self.agent
            self._update = Graphed(self._update_body, [
                agent.params, agent.grads, agent.exp_avg, agent.exp_avg_sq, agent.step,
                agent.loss_sum])
        self._host_index.numpy()[:] = index
        self.index.copy_(self._host_index, non_blocking=True)
        self._update()
