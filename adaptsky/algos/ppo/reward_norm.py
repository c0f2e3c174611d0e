"""Rewards divided by a running standard deviation of the discounted return (CleanRL's PPO for
continuous actions, through Gymnasium's ``NormalizeReward`` and a clip; Huang et al. 2022,
detail "reward scaling"), per member over its rollout rows: eq. 13's rewards are hundreds a
step, a return tens of thousands, far beyond what a critic starting near 0 and a value clip
of 0.2 per rollout can follow (docs/agent.md, PPO)."""

from __future__ import annotations

import numpy as np

EPSILON = 1e-8
COUNT_START = 1e-4  # Gymnasium's RunningMeanStd


class RewardNormaliser:
    """Per member s: G_t = gamma G_{t-1} + r_t for every row (0 at an episode's start), the
    running mean and variance of every G_t seen (Chan et al.'s parallel update, a step's R rows
    at once, from mean 0, variance 1 and count 1e-4), and r_t / sqrt(var + 1e-8) clipped to
    [-clip, clip]."""

    def __init__(self, size: int, rows: int, gamma: float, clip: float = 10.0) -> None:
        self.gamma, self.clip = gamma, clip
        self.mean = np.zeros(size)
        self.var = np.ones(size)
        self.count = np.full(size, COUNT_START)
        self.returns = np.zeros((size, rows))

    def begin_episode(self) -> None:
        self.returns[...] = 0.0

    def __call__(self, rewards: np.ndarray) -> np.ndarray:
        """The normalised rewards (S, R) of one step's (S, R)."""
        self.returns = self.returns * self.gamma + rewards
        rows = self.returns.shape[1]
        batch_mean, batch_var = self.returns.mean(axis=1), self.returns.var(axis=1)
        delta = batch_mean - self.mean
        total = self.count + rows
        self.mean = self.mean + delta * rows / total
        self.var = (self.var * self.count + batch_var * rows
                    + delta * delta * self.count * rows / total) / total
        self.count = total
        scale = np.sqrt(self.var + EPSILON)[:, None]
        return np.clip(rewards / scale, -self.clip, self.clip)

    def state(self, member: int) -> dict[str, np.ndarray]:
        """Member ``member``'s running statistics (float64 scalars)."""
        return {name: np.array(getattr(self, name)[member])
                for name in ("mean", "var", "count")}

    def load(self, member: int, state: dict[str, np.ndarray]) -> None:
        for name in ("mean", "var", "count"):
            getattr(self, name)[member] = state[name]
