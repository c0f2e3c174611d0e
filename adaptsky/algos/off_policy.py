"""The off-policy family (the DQN, the BDQ, SAC; SB3's ``OffPolicyAlgorithm``): step, store,
update. What its learners share is here: the replay memories (:mod:`adaptsky.algos.replay`)
and the n-step window in front of them (:mod:`adaptsky.algos.returns`), the update cadence
(after every stored step, once the learner says an update is due), the checkpoint (the
networks' arrays and the member's replay rows) and the loss bookkeeping (per-member means
since they were last taken). A learner adds its networks, its exploration and its update.
"""

from __future__ import annotations

from typing import Any, Protocol

import numpy as np
import torch
from numpy.typing import NDArray

from adaptsky.algos.device_step import describe
from adaptsky.algos.replay import StackedReplay
from adaptsky.algos.returns import NStepWindow
from adaptsky.arrays import Tree


class RunningMeans:
    """Per-member sums (S,) of named quantities on the device since they were last taken, and
    how many were added (float64: a loss summed over many updates keeps its digits)."""

    def __init__(self, size: int, device: torch.device) -> None:
        self.size, self.device = size, device
        self.sums: dict[str, torch.Tensor] = {}
        self.counts: dict[str, int] = {}

    def buffer(self, name: str, sums: torch.Tensor | None = None) -> torch.Tensor:
        """The sums of ``name`` (S,): ``sums`` where given (an update that adds into its own
        buffer in place, as the DQN's recorded CUDA graph does), else zeros."""
        if name not in self.sums:
            self.sums[name] = (torch.zeros(self.size, dtype=torch.float64, device=self.device)
                               if sums is None else sums)
            self.counts[name] = 0
        return self.sums[name]

    def add(self, name: str, values: torch.Tensor) -> None:
        """Add one value per member (S,)."""
        self.buffer(name).add_(values.detach().double())
        self.counts[name] += 1

    def added(self, name: str) -> None:
        """One more value of ``name`` was added into its :meth:`buffer` by the update."""
        self.counts[name] += 1

    def take(self, name: str) -> NDArray[np.float64] | None:
        """The mean (S,) of ``name`` since it was last taken, then reset; None without one."""
        count = self.counts.get(name, 0)
        if not count:
            return None
        sums = self.sums[name]
        mean = sums.cpu().numpy() / count
        sums.zero_()
        self.counts[name] = 0
        return mean


class StackedNetworks(Protocol):
    """The networks of an off-policy learner's S members, as arrays per member."""

    device: torch.device

    def state_arrays(self, member: int) -> Any: ...

    def load_state_arrays(self, member: int, state: Any) -> None: ...

    def policy_arrays(self, member: int) -> dict[str, np.ndarray]: ...


class OffPolicyLearner:
    """The family's half of a learner of S members (module docstring): ``networks`` and their
    ``memory``; every stored reward multiplied by ``reward_scale`` and summed over an
    ``n_step`` window discounted by ``gamma``. A learner defines :meth:`_due` and
    :meth:`_update`, and where it stores actions apart from the environment's,
    :meth:`_stored_actions`."""

    reward_parts = 1
    reward_split = "team"

    def __init__(self, rngs: list[np.random.Generator], networks: StackedNetworks,
                 memory: StackedReplay, reward_scale: float, n_step: int = 1,
                 gamma: float = 1.0) -> None:
        self.rngs, self.size = rngs, len(rngs)
        self.networks, self.memory = networks, memory
        self.window = NStepWindow(n_step, gamma)
        self.losses = RunningMeans(self.size, networks.device)
        self._reward_scale = reward_scale
        self._terminated = np.zeros(self.size, dtype=bool)  # T is a truncation

    def begin_episode(self, global_step: int) -> None:
        """A new n-step window."""
        self.window.restart()

    def observe(self, observations: NDArray[np.float32], actions: NDArray[Any],
                rewards: NDArray[np.float64], next_observations: NDArray[np.float32]) -> None:
        """Store the step's (n-step) row, rewards scaled by ``reward_scale`` (never terminal:
        the time limit is a truncation), then the update when one is due."""
        ready = self.window.push(observations, self._stored_actions(actions),
                                 rewards * self._reward_scale, next_observations)
        if ready is not None:
            self.memory.add(*ready, self._terminated)
        if self._due():
            self._update()

    def _stored_actions(self, actions: NDArray[Any]) -> NDArray[Any]:
        """Actions as the replay memory stores them (the environment's, unless overridden)."""
        return actions

    def _due(self) -> bool:
        """Whether an update follows the step just stored."""
        raise NotImplementedError

    def _update(self) -> None:
        """The update(s) due after the step just stored."""
        raise NotImplementedError

    def end_episode(self, episodes_before: int) -> None:
        """Nothing: an off-policy learner learns per step (the DQN adds its target copy)."""

    def take_mean_loss(self) -> NDArray[np.float64] | None:
        """Each member's mean loss since the last call; None without an update since."""
        return self.losses.take("loss")

    # ---- checkpoints ----------------------------------------------------------------------

    def device_name(self) -> str:
        return describe(self.networks.device)

    def checkpoint(self, member: int) -> Tree:
        """The networks' arrays (``agent``) and the replay rows with their write position."""
        return {"agent": self.networks.state_arrays(member),
                "replay": {**self.memory.arrays(member), "position": self.memory.position}}

    def restore(self, member: int, checkpoint: Tree) -> None:
        self.networks.load_state_arrays(member, checkpoint["agent"])
        replay = dict(checkpoint["replay"])
        position = int(replay.pop("position"))
        self.memory.load(member, replay, position)

    def policy(self, member: int) -> Tree:
        return self.networks.policy_arrays(member)
