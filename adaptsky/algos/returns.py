"""n-step returns (extension, ``agent.n_step``; docs/agent.md).

A stored row then holds s_t, a_t, the discounted sum r_t + gamma r_{t+1} + ... +
gamma^(n-1) r_{t+n-1} and s_{t+n}; its target bootstraps with gamma^n (eq. 12 with n steps).
The window restarts with every episode; the last n - 1 steps of an episode, which have fewer
than n rewards before the time limit, are not stored (n - 1 of T transitions), so every row
has the same horizon and the memory's layout is that of n = 1.
"""

from __future__ import annotations

from collections import deque

import numpy as np
from numpy.typing import NDArray

Transition = tuple[NDArray[np.float32], NDArray[np.int64], NDArray[np.float64],
                   NDArray[np.float32]]


class NStepWindow:
    """The last n transitions of every member (lockstep: one window for the stack)."""

    def __init__(self, n: int, gamma: float) -> None:
        self.n = n
        self._weights = gamma ** np.arange(n)
        self._pending: deque[Transition] = deque(maxlen=n)

    def restart(self) -> None:
        """Forget the window (a new episode)."""
        self._pending.clear()

    def push(self, observations: NDArray[np.float32], actions: NDArray[np.int64],
             rewards: NDArray[np.float64], next_observations: NDArray[np.float32]
             ) -> Transition | None:
        """Add one step of every member (S, ...); return the n-step transition that starts n - 1
        steps back once the window is full (observations, actions, returns, observations n
        steps later), else None. With n = 1 the step itself comes back unchanged."""
        if self.n == 1:
            return observations, actions, rewards, next_observations
        self._pending.append((observations, actions, rewards, next_observations))
        if len(self._pending) < self.n:
            return None
        first = self._pending[0]
        returns = np.tensordot(self._weights, np.stack([step[2] for step in self._pending]),
                               axes=1)
        return first[0], first[1], returns, next_observations
