"""Gymnasium environments over :class:`NomaUavBatch`: ``adaptsky/NomaUav-v0`` and its native
vector env.

Action Space
    ``Discrete(2^(3+K))`` (``actions = "paper"``) or ``Discrete(3^(3+K))`` (``"with-hover"``);
    see :mod:`adaptsky.sim.actions` for the encoding.
Observation Space
    ``Box`` of shape (4 N + 1,), float32: per user [dx, dy, alpha, g], then h; scaling in
    :mod:`adaptsky.sim.observation`. Its bounds are finite and hold every observation: g
    between the weakest and strongest gain the scenario's geometry allows
    (:mod:`adaptsky.sim.gain_bounds`; docs/environment.md, "Observation bounds").
Rewards
    Eq. 13 with the scenario's ``[reward]`` weights.
Starting State
    UAV at ``uav.start_m``, every cluster's first user at ``uav.start_alpha``; users at their
    layout positions (``users.placement = "fresh"``: a new uniform layout at every reset,
    drawn from the environment's ``np_random``, unless ``users_m`` fixes it).
Episode End
    Truncation after ``train.steps`` steps; the network has no terminal state.
Arguments
    ``scenario``: a path to a scenario file or a :class:`Scenario` (default: the shipped
    ``nyc_mmwave.toml``); ``users_m``: optional layout override (N, 2) (vector env:
    (B, N, 2)); ``render_mode``: ``None`` or ``"ansi"`` (a text summary of the state);
    single env: ``layout_index``, which of the scenario's layouts (for ``placement =
    "uniform"``: the i-th drawn, sub-environment i of the vector env); vector env:
    ``num_envs``.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from adaptsky.envs.registration import register_envs
from adaptsky.scenario import Scenario, load_scenario
from adaptsky.scenario.one_uav import require_one_uav
from adaptsky.shipped_files import default_scenario_path
from adaptsky.sim.batch import NetworkState, NomaUavBatch
from adaptsky.sim.layout import uniform_layouts, user_layouts
from adaptsky.sim.observation import observation_bounds

RENDER_MODES = ["ansi"]
# nominal frames per second of a rendered episode (the model has no time per step)
RENDER_FPS = 4
INFO_KEYS = ("uav_m", "alpha", "gain", "los", "p_los", "rate_bps", "sum_rate_bps", "fairness")


def _resolve(scenario: Scenario | str | Path | None) -> Scenario:
    if scenario is None:
        scenario = default_scenario_path()
    resolved = scenario if isinstance(scenario, Scenario) else load_scenario(scenario)
    require_one_uav(resolved, str(scenario) if not isinstance(scenario, Scenario)
                    else resolved.name)
    return resolved


def _spaces(scenario: Scenario, batch: NomaUavBatch) -> tuple[spaces.Box, spaces.Discrete]:
    low, high = observation_bounds(scenario, batch.gain_bounds())
    return spaces.Box(low, high, dtype=np.float32), spaces.Discrete(batch.actions.count)


def _check_render_mode(render_mode: str | None) -> str | None:
    if render_mode is not None and render_mode not in RENDER_MODES:
        allowed = ", ".join(["None", *(repr(mode) for mode in RENDER_MODES)])
        raise ValueError(f"render_mode {render_mode!r} is not supported; allowed: {allowed}")
    return render_mode


def render_text(batch: NomaUavBatch, index: int) -> str:
    """Environment ``index``'s state in a few lines of text (``render_mode="ansi"``)."""
    state = batch.state
    if state is None:
        return "not reset yet\n"
    x, y, h = state.uav_m[index]
    rates = " ".join(f"{rate / 1e6:.1f}" for rate in state.rate_bps[index])
    alphas = " ".join(f"{alpha:.2f}" for alpha in state.alpha[index])
    return (f"step {batch.t}/{batch.max_steps}  UAV x={x:.1f} y={y:.1f} h={h:.1f} m  "
            f"sum rate {state.sum_rate_bps[index] / 1e6:.1f} Mbit/s  "
            f"fairness {state.fairness[index]:.3f}\n"
            f"  rates Mbit/s: {rates}\n  alpha: {alphas}\n")


class NomaUavEnv(gym.Env[np.ndarray, np.int64]):
    """One UAV serving one layout (B = 1)."""

    metadata: ClassVar[dict[str, Any]] = {"render_modes": RENDER_MODES, "render_fps": RENDER_FPS}

    def __init__(self, scenario: Scenario | str | Path | None = None,
                 users_m: np.ndarray | None = None, render_mode: str | None = None,
                 layout_index: int = 0) -> None:
        self.render_mode = _check_render_mode(render_mode)
        self.scenario = _resolve(scenario)
        if layout_index < 0:
            raise ValueError(f"layout_index must be >= 0, got {layout_index}")
        if users_m is None:
            layouts = user_layouts(self.scenario, layout_index + 1)[layout_index:]
        elif layout_index:
            raise ValueError("give users_m or layout_index, not both")
        else:
            layouts = np.asarray(users_m, dtype=np.float64)[None]
        self.batch = NomaUavBatch(self.scenario, num_envs=1, users_m=layouts)
        self._fresh = users_m is None and self.scenario.users.placement == "fresh"
        self.observation_space, self.action_space = _spaces(self.scenario, self.batch)

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None
              ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        if self._fresh:
            self.batch.set_layouts(uniform_layouts(self.scenario, self.np_random, 1))
        obs, state = self.batch.reset(seed=seed)
        return obs[0], state.for_env(0)

    def step(self, action: np.int64) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        if self.batch.t >= self.batch.max_steps:
            raise RuntimeError("episode is over: call reset()")
        obs, reward, truncated, state = self.batch.step(np.array([action]))
        return obs[0], float(reward[0]), False, truncated, state.for_env(0)

    def render(self) -> str | None:
        """The state as text for ``render_mode="ansi"``; nothing without a render mode."""
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode; give render_mode='ansi'")
            return None
        return render_text(self.batch, 0)


class NomaUavVectorEnv(VectorEnv):
    """B UAVs over B layouts, stepped together with numpy (no sub-processes).

    Autoreset mode is next-step (set explicitly): all B episodes end together, and the step
    after the end resets every environment and returns the first observation, reward 0.
    ``reset(seed=[s_0, .., s_B-1])`` gives environment i the generator of
    ``NomaUavEnv(layout_index=i).reset(seed=s_i)``; an int seed seeds one generator that all
    B share (one draw per step for all of them, the fastest).
    """

    metadata: ClassVar[dict[str, Any]] = {
        "autoreset_mode": AutoresetMode.NEXT_STEP, "render_modes": RENDER_MODES,
        "render_fps": RENDER_FPS}

    def __init__(self, scenario: Scenario | str | Path | None = None, num_envs: int = 1,
                 users_m: np.ndarray | None = None, render_mode: str | None = None) -> None:
        self.render_mode = _check_render_mode(render_mode)
        self.scenario = _resolve(scenario)
        self.num_envs = num_envs
        self.batch = NomaUavBatch(self.scenario, num_envs=num_envs, users_m=users_m)
        self._fresh = users_m is None and self.scenario.users.placement == "fresh"
        self.single_observation_space, self.single_action_space = _spaces(self.scenario,
                                                                          self.batch)
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.action_space = batch_space(self.single_action_space, num_envs)
        self._needs_reset = True
        self._all_envs = np.ones(num_envs, dtype=bool)

    def _info(self, state: NetworkState) -> dict[str, Any]:
        """Every key with its mask ``_key`` (which environments have it: all), as
        Gymnasium's vector envs give them."""
        info: dict[str, Any] = {}
        for key in INFO_KEYS:
            info[key] = getattr(state, key)
            info[f"_{key}"] = self._all_envs.copy()
        return info

    def reset(self, *, seed: int | Sequence[int | None] | None = None,
              options: dict[str, Any] | None = None) -> tuple[np.ndarray, dict[str, Any]]:
        if isinstance(seed, list | tuple | np.ndarray):
            if len(seed) != self.num_envs:
                raise ValueError(f"seed must list {self.num_envs} seeds (one per environment), "
                                 f"got {len(seed)}")
            seed = [None if s is None else int(s) for s in seed]
            self._np_random, self._np_random_seed = gym.utils.seeding.np_random(seed[0])
        elif seed is not None:
            self._np_random, self._np_random_seed = gym.utils.seeding.np_random(seed)
        if self._fresh:
            self.batch.set_layouts(uniform_layouts(self.scenario, self.np_random, self.num_envs))
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

    def render(self) -> tuple[str, ...] | None:
        """Every environment's state as text for ``render_mode="ansi"``."""
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode; give render_mode='ansi'")
            return None
        return tuple(render_text(self.batch, index) for index in range(self.num_envs))


register_envs()  # importing the environments makes gymnasium.make("adaptsky/NomaUav-v0") work
