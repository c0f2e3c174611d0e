"""Gymnasium environments over the batched simulation: ``adaptsky/NomaUav-v0`` and its native
vector env, for one UAV or several (docs/model.md §9), both on
:class:`~adaptsky.sim.network.NetworkBatch`.

Action Space
    One UAV, by default: ``Discrete(2^(3+K))`` (``actions = "paper"``) or ``Discrete(3^(3+K))``
    (``"with-hover"``); see :mod:`adaptsky.sim.actions` for the encoding. Several UAVs, by
    default: ``MultiDiscrete([base] * U (3 + K_u))``, one sub-action per component (x, y, h,
    alpha_1 .. alpha_K of UAV 0, then UAV 1, ...); ``action_space="discrete"`` gives the dense
    index over them up to 2^16 actions, ``"multi-discrete"`` also serves one UAV
    (:mod:`adaptsky.envs.action_spaces`). Continuous actions (``actions = "continuous"``):
    ``Box([-1, 1]^D, float32)``, component j scaled onto its step, refused outside the box
    or where not a number (:mod:`adaptsky.sim.controls`).
Observation Space
    One UAV: ``Box`` of shape (4 N + 1,), float32: per user [dx, dy, alpha, g], then h; scaling
    in :mod:`adaptsky.sim.observation`. Several: ``Box`` of shape (5 N + 3 U,): per user
    [dx, dy, alpha, g, I] to its serving UAV, then every UAV's [x, y, h]
    (:class:`adaptsky.sim.observation.MultiObserver`). Its bounds are finite and hold every
    observation: g between the weakest and strongest gain the scenario's geometry allows
    (:mod:`adaptsky.sim.gain_bounds`; docs/environment.md, "Observation bounds").
Rewards
    Eq. 13 with the scenario's ``[reward]`` weights, over all users.
Starting State
    Every UAV at its start position, every cluster's first user at ``uav.start_alpha``; users
    at their layout positions (``users.placement = "fresh"``: a new uniform layout at every
    reset, drawn from the environment's ``np_random``, unless ``users_m`` fixes it).
Episode End
    Truncation after ``max_episode_steps`` steps (default ``train.steps``); the network has no
    terminal state.
Arguments
    ``scenario``: a path to a scenario file or a :class:`Scenario` (default: the shipped
    ``nyc_mmwave.toml``); ``users_m``: optional layout override (N, 2) (vector env:
    (B, N, 2)); ``render_mode``: ``None``, ``"ansi"`` (a text summary of the state) or,
    single env only, ``"rgb_array"`` (the picture of the episode so far,
    :mod:`adaptsky.drawing`);
    ``actions``: the action kind, ``"paper"``, ``"with-hover"`` or ``"continuous"``, in
    place of the scenario's ``uav.actions`` (None: the scenario's);
    ``action_space``: ``None`` (the default above), ``"discrete"`` or ``"multi-discrete"``
    (dense kinds), ``"box"`` (continuous);
    ``max_episode_steps``: the time limit, a whole number >= 1 (None: ``train.steps``;
    ``adaptsky eval`` runs 1000 steps, docs/environment.md, "Episodes");
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
from pydantic import ValidationError

from adaptsky.drawing.episode import EpisodeBuffer
from adaptsky.envs.action_spaces import action_space_kind, gym_action_space, to_dense
from adaptsky.envs.observations import AgentView, observation_bounds_of
from adaptsky.envs.registration import register_envs
from adaptsky.scenario import Scenario, load_scenario
from adaptsky.shipped_files import default_scenario_path
from adaptsky.sim.controls import CONTROLS
from adaptsky.sim.layout import uniform_layouts, user_layouts
from adaptsky.sim.network import NetworkBatch, NetworkState

RENDER_MODES = ["ansi", "rgb_array"]
VECTOR_RENDER_MODES = ["ansi"]
# nominal frames per second of a rendered episode (the model has no time per step): a video
# of a 300-step episode (RecordVideo) lasts 15 s
RENDER_FPS = 20
INFO_KEYS = ("uav_m", "alpha", "gain", "los", "p_los", "rate_bps", "sum_rate_bps", "fairness",
             "energy_j")
# several UAVs: also the interference every user hears (W)
MULTI_INFO_KEYS = (*INFO_KEYS[:3], "interference_w", *INFO_KEYS[3:])
MAX_EPISODE_STEPS = 10**9
"""The largest ``max_episode_steps``, as for ``train.steps``."""


def resolve_scenario(scenario: Scenario | str | Path | None, actions: str | None = None
                     ) -> Scenario:
    """The scenario (None: the shipped default) with ``actions`` for its ``uav.actions``."""
    if scenario is None:
        scenario = default_scenario_path()
    scenario = scenario if isinstance(scenario, Scenario) else load_scenario(scenario)
    return with_actions(scenario, actions)


def with_actions(scenario: Scenario, actions: str | None) -> Scenario:
    """``scenario`` with the action kind ``actions`` (None: its own), validated again; a
    ValueError of one line for an unknown kind or one the scenario does not allow."""
    if actions is None or actions == scenario.uav.actions:
        return scenario
    if actions not in CONTROLS:
        allowed = ", ".join(repr(kind) for kind in CONTROLS)
        raise ValueError(f"actions {actions!r} is not an action kind; allowed: None, {allowed}")
    data = scenario.model_dump()
    data["uav"]["actions"] = actions
    try:
        return Scenario.model_validate(data)
    except ValidationError as error:
        first = error.errors(include_url=False)[0]
        field = ".".join(str(part) for part in first["loc"])
        where = f"{field}: " if field else ""       # a rule of the whole scenario names none
        message = first["msg"].removeprefix("Value error, ")
        raise ValueError(f"actions={actions!r}: {where}{message}") from None


def observation_space(scenario: Scenario, batch: NetworkBatch) -> spaces.Box:
    """The ``Box`` of one environment's observation: finite bounds from the scenario."""
    low, high = observation_bounds_of(scenario, batch.gain_bounds())
    return spaces.Box(low, high, dtype=np.float32)


def episode_steps(scenario: Scenario, max_episode_steps: object) -> int:
    """The time limit of an episode: ``max_episode_steps``, checked to be a whole number
    from 1 to 10^9, or ``train.steps`` for None."""
    if max_episode_steps is None:
        return scenario.train.steps
    if isinstance(max_episode_steps, bool) or not isinstance(max_episode_steps,
                                                             int | np.integer) \
            or not 1 <= max_episode_steps <= MAX_EPISODE_STEPS:
        raise ValueError(f"max_episode_steps must be a whole number from 1 to "
                         f"{MAX_EPISODE_STEPS:_} (None: train.steps, "
                         f"{scenario.train.steps}), got {max_episode_steps!r}")
    return int(max_episode_steps)


def _check_render_mode(render_mode: str | None, modes: list[str]) -> str | None:
    if render_mode is not None and render_mode not in modes:
        allowed = ", ".join(["None", *(repr(mode) for mode in modes)])
        raise ValueError(f"render_mode {render_mode!r} is not supported; allowed: {allowed}")
    return render_mode


def render_text(batch: NetworkBatch, index: int, max_steps: int) -> str:
    """Environment ``index``'s state in a few lines of text (``render_mode="ansi"``), in an
    episode of ``max_steps`` steps."""
    state = batch.state
    if state is None:
        return "not reset yet\n"
    positions = np.reshape(state.uav_m[index], (-1, 3))
    names = ["UAV"] if len(positions) == 1 else [f"UAV {u}" for u in range(len(positions))]
    uavs = "  ".join(f"{name} x={x:.1f} y={y:.1f} h={h:.1f} m"
                     for name, (x, y, h) in zip(names, positions, strict=True))
    rates = " ".join(f"{rate / 1e6:.1f}" for rate in state.rate_bps[index])
    alphas = " ".join(f"{alpha:.2f}" for alpha in state.alpha[index])
    return (f"step {batch.t}/{max_steps}  {uavs}  "
            f"sum rate {state.sum_rate_bps[index] / 1e6:.1f} Mbit/s  "
            f"fairness {state.fairness[index]:.3f}\n"
            f"  rates Mbit/s: {rates}\n  alpha: {alphas}\n")


class NomaUavEnv(gym.Env[np.ndarray, np.int64 | np.ndarray]):
    """The scenario's UAVs serving one layout (B = 1)."""

    metadata: ClassVar[dict[str, Any]] = {"render_modes": RENDER_MODES, "render_fps": RENDER_FPS}

    def __init__(self, scenario: Scenario | str | Path | None = None,
                 users_m: np.ndarray | None = None, render_mode: str | None = None,
                 layout_index: int = 0, action_space: str | None = None,
                 max_episode_steps: int | None = None, actions: str | None = None) -> None:
        self.render_mode = _check_render_mode(render_mode, RENDER_MODES)
        self.scenario = resolve_scenario(scenario, actions)
        self.max_episode_steps = episode_steps(self.scenario, max_episode_steps)
        if layout_index < 0:
            raise ValueError(f"layout_index must be >= 0, got {layout_index}")
        if users_m is None:
            layouts = user_layouts(self.scenario, layout_index + 1)[layout_index:]
        elif layout_index:
            raise ValueError("give users_m or layout_index, not both")
        else:
            layouts = np.asarray(users_m, dtype=np.float64)[None]
        self.action_kind = action_space_kind(self.scenario, action_space)
        self.batch = NetworkBatch(self.scenario, num_envs=1, users_m=layouts,
                                  view=AgentView.of(self.scenario))
        self._fresh = users_m is None and self.scenario.users.placement == "fresh"
        self.observation_space = observation_space(self.scenario, self.batch)
        self.action_space = gym_action_space(self.batch.controls, self.action_kind)
        self._episode: EpisodeBuffer | None = None  # rgb_array: the episode so far
        self._picture: Any = None                    # rgb_array: its EpisodeFigure

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None
              ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        if self._fresh:
            self.batch.set_layouts(uniform_layouts(self.scenario, self.np_random, 1))
        obs, state = self.batch.reset(seed=seed)
        self._record(state)
        return obs[0], state.for_env(0)

    def step(self, action: np.int64 | np.ndarray
             ) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """One step; ``action`` a dense index, the sub-actions (D,) of the MultiDiscrete
        space or the point (D,) of the Box."""
        if self.batch.t >= self.max_episode_steps:
            raise RuntimeError("episode is over: call reset()")
        if self.action_kind == "discrete":
            actions = np.array([action])
        elif self.action_kind == "box":
            actions = np.asarray(action)[None]
        else:
            actions = to_dense(self.batch.actions, np.asarray(action)[None])
        obs, reward, _, state = self.batch.step(actions)  # (the batch's limit is train.steps)
        self._record(state)
        truncated = self.batch.t >= self.max_episode_steps
        return obs[0], float(reward[0]), False, truncated, state.for_env(0)

    def _record(self, state: NetworkState) -> None:
        """Keep the step's positions, shares, rates and LoS states for ``rgb_array``."""
        if self.render_mode != "rgb_array":
            return
        if self._episode is None:
            batch = self.batch
            self._episode = EpisodeBuffer(self.max_episode_steps + 1, batch.num_uavs,
                                          batch.num_users,
                                          with_los=self.scenario.channel.los in (
                                              "sampled", "geometric"))
        if self.batch.t == 0:
            self._episode.clear()
        self._episode.record(state.uav_m[0], state.alpha[0], state.rate_bps[0], state.los[0],
                             state.energy_j[0] / self.scenario.uav.step_s,
                             users_m=self.batch.users_m[0])

    def render(self) -> str | np.ndarray | None:
        """``render_mode="ansi"``: the state as text; ``"rgb_array"``: the picture of the
        episode so far, (H, W, 3) uint8 (the figure of ``adaptsky show``, one figure kept
        and its artists moved from call to call); nothing without a render mode."""
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode; give render_mode='ansi' "
                            "or 'rgb_array'")
            return None
        if self.render_mode == "rgb_array":
            return self._frame()
        return render_text(self.batch, 0, self.max_episode_steps)

    def _frame(self) -> np.ndarray:
        from adaptsky.drawing.episode_figure import EpisodeFigure  # matplotlib: when asked

        if self._episode is None or self._episode.rows == 0:
            raise RuntimeError("call reset() before render()")
        serving, cluster = self.batch.roles()
        city = self.batch.city
        episode = self._episode.episode(
            self.batch.users_m[0].copy(), serving[0], cluster[0], first_step=0,
            label=self.scenario.name, buildings_m=None if city is None else np.column_stack(
                [city.footprints_m, city.heights_m[0]]))
        if self._picture is not None and EpisodeFigure.fits(self._picture.blocks[0].episode,
                                                            episode):
            self._picture.update([episode])
        else:  # the first frame, or a new layout (users.placement = "fresh")
            self._picture = EpisodeFigure([episode], side_m=self.scenario.area.side_m,
                                          steps=self.max_episode_steps + 1)
        self._picture.show(episode.steps - 1)
        return self._picture.rgb()


class NomaUavVectorEnv(VectorEnv):
    """B networks (each of the scenario's UAVs) over B layouts, stepped together with numpy
    (no sub-processes); actions (B,) dense indices, (B, D) sub-actions or (B, D) points of
    the Box.

    Autoreset mode is next-step (set explicitly): all B episodes end together, and the step
    after the end resets every environment and returns the first observation, reward 0.
    ``reset(seed=[s_0, .., s_B-1])`` gives environment i the generator of
    ``NomaUavEnv(layout_index=i).reset(seed=s_i)``; an int seed seeds one generator that all
    B share (one draw per step for all of them, the fastest).
    """

    metadata: ClassVar[dict[str, Any]] = {
        "autoreset_mode": AutoresetMode.NEXT_STEP, "render_modes": VECTOR_RENDER_MODES,
        "render_fps": RENDER_FPS}

    def __init__(self, scenario: Scenario | str | Path | None = None, num_envs: int = 1,
                 users_m: np.ndarray | None = None, render_mode: str | None = None,
                 action_space: str | None = None, max_episode_steps: int | None = None,
                 actions: str | None = None) -> None:
        self.render_mode = _check_render_mode(render_mode, VECTOR_RENDER_MODES)
        self.scenario = resolve_scenario(scenario, actions)
        self.max_episode_steps = episode_steps(self.scenario, max_episode_steps)
        self.num_envs = num_envs
        self.action_kind = action_space_kind(self.scenario, action_space)
        self.batch = NetworkBatch(self.scenario, num_envs=num_envs, users_m=users_m,
                                  view=AgentView.of(self.scenario))
        self._fresh = users_m is None and self.scenario.users.placement == "fresh"
        self._info_keys = MULTI_INFO_KEYS if self.batch.num_uavs > 1 else INFO_KEYS
        self.single_observation_space = observation_space(self.scenario, self.batch)
        self.single_action_space = gym_action_space(self.batch.controls, self.action_kind)
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.action_space = batch_space(self.single_action_space, num_envs)
        self._needs_reset = True
        self._all_envs = np.ones(num_envs, dtype=bool)

    def _info(self, state: NetworkState) -> dict[str, Any]:
        """Every key with its mask ``_key`` (which environments have it: all), as
        Gymnasium's vector envs give them."""
        info: dict[str, Any] = {}
        for key in self._info_keys:
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
        if self.action_kind == "multi-discrete":
            actions = to_dense(self.batch.actions, np.asarray(actions))
        obs, reward, _, state = self.batch.step(np.asarray(actions))  # (limit: train.steps)
        truncated = self.batch.t >= self.max_episode_steps
        self._needs_reset = truncated
        return obs, reward, terminated, np.full(self.num_envs, truncated), self._info(state)

    def render(self) -> tuple[str, ...] | None:
        """Every environment's state as text for ``render_mode="ansi"``."""
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode; give render_mode='ansi'")
            return None
        return tuple(render_text(self.batch, index, self.max_episode_steps)
                     for index in range(self.num_envs))


register_envs()  # importing the environments makes gymnasium.make("adaptsky/NomaUav-v0") work
