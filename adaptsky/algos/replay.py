"""Replay memories of a stack of members: one ring buffer per member, on the training device.

A transition is one float32 row [s | s' | r | 1 - terminated | a], where a is one column (the
DQN's action index) or ``action_width`` columns (a branching agent's sub-action per branch),
and r one column or ``reward_width`` (the BDQ's reward per UAV, ``agent.reward_split``).
``terminated`` (a true terminal state: no bootstrap) is kept apart from time-limit truncation,
which is not stored at all: a truncated transition still bootstraps from its next observation.
Sampling indices are drawn on the host from each member's own generator; the rows are gathered
on the device.
"""

from __future__ import annotations

from typing import NamedTuple, TypeVar

import numpy as np
import torch
from numpy.typing import NDArray

Rows = TypeVar("Rows", torch.Tensor, np.ndarray)
"""Replay rows on the device (a batch) or on the host (a checkpoint's copy)."""


class Batch(NamedTuple):
    """A mini-batch per member, on the device: (S, B, obs) observations, (S, B) the rest but
    actions or rewards of more than one column, (S, B, width)."""

    observations: torch.Tensor
    actions: torch.Tensor
    rewards: torch.Tensor
    next_observations: torch.Tensor
    not_terminal: torch.Tensor


class StackedReplay:
    """S fixed-capacity memories; each overwrites its oldest transitions first."""

    def __init__(self, stack: int, capacity: int, observation_size: int,
                 device: torch.device, action_width: int = 1, reward_width: int = 1) -> None:
        self.capacity, self.obs_size = capacity, observation_size
        self.action_width, self.reward_width = action_width, reward_width
        self.width = 2 * observation_size + 1 + reward_width + action_width
        # the column of 1 - terminated; the rewards sit just before it
        self._alive = 2 * observation_size + reward_width
        self.rows = torch.zeros(stack, capacity, self.width, device=device)
        self._flat = self.rows.view(stack * capacity, self.width)
        self._host = self.rows.numpy() if device.type == "cpu" else None
        self._row = np.zeros((stack, self.width), dtype=np.float32)
        self._offsets = torch.arange(stack, device=device)[:, None] * capacity
        # members of a stack are in lockstep: one write position and one size for all
        self.position = 0
        self.size = 0

    def add(self, observations: NDArray[np.float32], actions: NDArray[np.integer],
            rewards: NDArray[np.floating], next_observations: NDArray[np.float32],
            terminated: NDArray[np.bool_]) -> None:
        """One transition per member, host arrays with leading axis S (actions and rewards
        (S,), or (S, width))."""
        n, alive = self.obs_size, self._alive
        row = self._row if self._host is None else self._host[:, self.position]
        row[:, :n] = observations
        row[:, n:2 * n] = next_observations
        if self.reward_width == 1:
            row[:, 2 * n] = rewards
        else:
            row[:, 2 * n:alive] = rewards
        row[:, alive] = ~terminated
        if self.action_width == 1:
            row[:, alive + 1] = actions
        else:
            row[:, alive + 1:] = actions
        if self._host is None:
            self.rows[:, self.position] = torch.from_numpy(row).to(self.rows.device)
        self.position = (self.position + 1) % self.capacity
        self.size = min(self.size + 1, self.capacity)

    def sample_index(self, batch_size: int, rngs: list[np.random.Generator]) -> NDArray[np.int64]:
        """(S, B) indices, uniform with replacement over the stored rows, each member's from
        its own generator: floor(u * size) for u uniform in [0, 1) (a third of the cost of
        ``Generator.integers`` at this size; the bias is below 2^-40)."""
        if len(rngs) == 1:
            uniform = rngs[0].random((1, batch_size))
        else:
            uniform = np.stack([rng.random(batch_size) for rng in rngs])
        uniform *= self.size
        return uniform.astype(np.int64)

    def gather(self, index: torch.Tensor) -> Batch:
        """The rows at ``index`` (S, B) (a device tensor) as a :class:`Batch`."""
        stack, batch = index.shape
        flat = index.view(-1) if stack == 1 else (index + self._offsets).view(-1)
        rows = self._flat.index_select(0, flat)
        observations, actions, rewards, next_observations, alive = self._fields(
            rows.view(stack, batch, self.width))
        return Batch(observations, actions.long(), rewards, next_observations, alive)

    def _fields(self, rows: Rows) -> tuple[Rows, Rows, Rows, Rows, Rows]:
        """Views of rows (..., width): observations, actions, rewards (a column, or
        ``action_width`` and ``reward_width`` columns), next observations, 1 - terminated."""
        n, alive = self.obs_size, self._alive
        actions = rows[..., -1] if self.action_width == 1 else rows[..., alive + 1:]
        rewards = rows[..., 2 * n] if self.reward_width == 1 else rows[..., 2 * n:alive]
        return rows[..., :n], actions, rewards, rows[..., n:2 * n], rows[..., alive]

    def arrays(self, member: int) -> dict[str, np.ndarray]:
        """A member's stored rows of every field in storage order (for checkpoints)."""
        observations, actions, rewards, next_observations, alive = self._fields(
            self.rows[member, :self.size].cpu().numpy())
        return {"observations": observations.copy(), "actions": actions.astype(np.int64),
                "rewards": rewards.copy(), "next_observations": next_observations.copy(),
                "terminated": alive == 0}

    def load(self, member: int, arrays: dict[str, np.ndarray], position: int) -> None:
        """Refill a member from :meth:`arrays` output and the write ``position`` saved with it
        (every member of a stack holds as many rows, written up to the same position)."""
        size = len(arrays["actions"])
        if size > self.capacity or not 0 <= position < self.capacity:
            raise ValueError(f"{size} transitions at {position} do not fit a memory of "
                             f"{self.capacity}")
        row = np.concatenate([np.asarray(arrays["observations"], np.float32),
                              np.asarray(arrays["next_observations"], np.float32),
                              np.asarray(arrays["rewards"], np.float32).reshape(
                                  size, self.reward_width),
                              ~np.asarray(arrays["terminated"], bool)[:, None],
                              np.asarray(arrays["actions"], np.float32).reshape(
                                  size, self.action_width)], axis=1)
        self.rows[member].zero_()
        self.rows[member, :size] = torch.from_numpy(row)
        self.size, self.position = size, position
