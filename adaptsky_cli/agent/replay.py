"""A numpy ring-buffer replay memory returning typed batches.

``terminated`` (a true terminal state: no bootstrap) is kept apart from time-limit
truncation, which is not stored at all: a truncated transition still bootstraps from its
next observation.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray


class Batch(NamedTuple):
    observations: NDArray[np.float32]
    actions: NDArray[np.int64]
    rewards: NDArray[np.float32]
    next_observations: NDArray[np.float32]
    terminated: NDArray[np.bool_]


class ReplayMemory:
    """Fixed-capacity memory; the oldest transitions are overwritten first."""

    FIELDS = ("observations", "actions", "rewards", "next_observations", "terminated")

    def __init__(self, capacity: int, observation_size: int) -> None:
        self.capacity = capacity
        self.observations = np.zeros((capacity, observation_size), dtype=np.float32)
        self.actions = np.zeros(capacity, dtype=np.int64)
        self.rewards = np.zeros(capacity, dtype=np.float32)
        self.next_observations = np.zeros((capacity, observation_size), dtype=np.float32)
        self.terminated = np.zeros(capacity, dtype=np.bool_)
        self.position = 0
        self.size = 0

    def __len__(self) -> int:
        return self.size

    def add(self, observation: np.ndarray, action: int, reward: float,
            next_observation: np.ndarray, terminated: bool) -> None:
        i = self.position
        self.observations[i] = observation
        self.actions[i] = action
        self.rewards[i] = reward
        self.next_observations[i] = next_observation
        self.terminated[i] = terminated
        self.position = (i + 1) % self.capacity
        self.size = min(self.size + 1, self.capacity)

    def sample(self, batch_size: int, rng: np.random.Generator) -> Batch:
        """``batch_size`` transitions drawn uniformly with replacement."""
        index = rng.integers(0, self.size, size=batch_size)
        return Batch(*(getattr(self, name)[index] for name in self.FIELDS))

    def arrays(self) -> dict[str, np.ndarray]:
        """The stored rows of every field in storage order (for checkpoints)."""
        return {name: getattr(self, name)[: self.size] for name in self.FIELDS}

    def load(self, arrays: dict[str, np.ndarray], position: int) -> None:
        """Refill from :meth:`arrays` output and the write ``position`` saved with it."""
        size = len(arrays["actions"])
        if size > self.capacity or not 0 <= position < self.capacity:
            raise ValueError(f"{size} transitions at {position} do not fit a memory of "
                             f"{self.capacity}")
        for name in self.FIELDS:
            getattr(self, name)[:size] = arrays[name]
        self.size = size
        self.position = position
