"""Gymnasium environments over :class:`NomaUavBatch`: ``adaptsky/NomaUav-v0`` and its native
vector env.

Action Space
    ``Discrete(2^(3+K))`` (``actions = "paper"``) or ``Discrete(3^(3+K))`` (``"with-hover"``);
    see :mod:`adaptsky_cli.env.actions` for the encoding.
Observation Space
    ``Box`` of shape (4 N + 1,), float32: per user [dx, dy, alpha, g], then h; scaling in
    :mod:`adaptsky_cli.env.observation`.
Rewards
    Eq. 13 with the scenario's ``[reward]`` weights.
Starting State
    UAV at ``uav.start_m``, every cluster's first user at ``uav.start_alpha``; users at their
    layout positions.
Episode End
    Truncation after ``train.steps`` steps; the network has no terminal state.
Arguments
    ``scenario``: a path to a scenario file or a :class:`Scenario`; ``users_m``: optional
    layout override (N, 2) (vector env: (B, N, 2)); vector env: ``num_envs``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from adaptsky_cli.env.batch import NetworkState, NomaUavBatch
from adaptsky_cli.env.observation import observation_bounds
from adaptsky_cli.scenario import Scenario, load_scenario


def _resolve(scenario: Scenario | str | Path) -> Scenario:
    return scenario if isinstance(scenario, Scenario) else load_scenario(scenario)


def _spaces(scenario: Scenario, batch: NomaUavBatch) -> tuple[spaces.Box, spaces.Discrete]:
    low, high = observation_bounds(scenario)
    return spaces.Box(low, high, dtype=np.float32), spaces.Discrete(batch.actions.count)


class NomaUavEnv(gym.Env[np.ndarray, np.int64]):
    """One UAV serving one layout (B = 1)."""

    metadata: ClassVar[dict[str, Any]] = {"render_modes": []}

    def __init__(self, scenario: Scenario | str | Path,
                 users_m: np.ndarray | None = None) -> None:
        self.scenario = _resolve(scenario)
        layouts = None if users_m is None else np.asarray(users_m, dtype=np.float64)[None]
        self.batch = NomaUavBatch(self.scenario, num_envs=1, users_m=layouts)
        self.observation_space, self.action_space = _spaces(self.scenario, self.batch)

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None
              ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        obs, state = self.batch.reset(seed=seed)
        return obs[0], state.for_env(0)

    def step(self, action: np.int64) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        if self.batch.t >= self.batch.max_steps:
            raise RuntimeError("episode is over: call reset()")
        obs, reward, truncated, state = self.batch.step(np.array([action]))
        return obs[0], float(reward[0]), False, truncated, state.for_env(0)


class NomaUavVectorEnv(VectorEnv):
    """B UAVs over B layouts, stepped together with numpy (no sub-processes).

    Autoreset mode is next-step (set explicitly): all B episodes end together, and the step
    after the end resets every environment and returns the first observation, reward 0.
    """

    metadata: ClassVar[dict[str, Any]] = {
        "autoreset_mode": AutoresetMode.NEXT_STEP, "render_modes": []}

    def __init__(self, scenario: Scenario | str | Path, num_envs: int = 1,
                 users_m: np.ndarray | None = None) -> None:
        self.scenario = _resolve(scenario)
        self.num_envs = num_envs
        self.batch = NomaUavBatch(self.scenario, num_envs=num_envs, users_m=users_m)
        self.single_observation_space, self.single_action_space = _spaces(self.scenario,
                                                                          self.batch)
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.action_space = batch_space(self.single_action_space, num_envs)
        self._needs_reset = True

    @staticmethod
    def _info(state: NetworkState) -> dict[str, Any]:
        return {key: getattr(state, key) for key in (
            "uav_m", "alpha", "gain", "los", "p_los", "rate_bps", "sum_rate_bps", "fairness")}

    def reset(self, *, seed: int | list[int] | None = None,
              options: dict[str, Any] | None = None) -> tuple[np.ndarray, dict[str, Any]]:
        if isinstance(seed, list):
            seed = seed[0]
        if seed is not None:
            self._np_random, _ = gym.utils.seeding.np_random(seed)
        obs, state = self.batch.reset(seed=seed)
        self._needs_reset = False
        return obs, self._info(state)

    def step(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                                 np.ndarray, dict[str, Any]]:
        terminated = np.zeros(self.num_envs, dtype=bool)
        if self._needs_reset:
            obs, info = self.reset()
            return obs, np.zeros(self.num_envs), terminated, terminated.copy(), info
        obs, reward, truncated, state = self.batch.step(np.asarray(actions))
        self._needs_reset = truncated
        return obs, reward, terminated, np.full(self.num_envs, truncated), self._info(state)
