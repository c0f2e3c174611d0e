"""The simulation's explicit state and the first stages of its step (docs/model.md §3 and
§9), in the style of gymnax: :func:`step` is a pure function
``(state, actions, dynamics, headings) -> state'`` (the users' mobility, then the controls).

Several UAVs are an axis, not a loop: every UAV array has the UAV axis U after the
environments' axis B, for one UAV (U = 1) as for several.

A step's randomness (the users' headings) is drawn by the caller, which owns the generators,
and handed to :func:`step`; the geometry, channel, rates, reward and observation of the new
state are the later stages, called by :class:`adaptsky.sim.network.NetworkBatch`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from adaptsky.scenario.models import Scenario
from adaptsky.sim.actions import ActionSet
from adaptsky.sim.controls import Controls, DenseControls, controls_of
from adaptsky.sim.lattice import share_high

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class SimState:
    """Where everything is between two steps.

    ``config`` (B, U, 3 + K): every UAV's configuration [x_m, y_m, h_m, alpha_1 .. alpha_K],
    its position (m) and the power shares of its clusters' first users (the second user of
    cluster k has 1 - alpha_k, docs/model.md §1), K = K_max the most clusters of one UAV (a
    UAV with K_u < K_max leaves its last slots unused); one array, so that an action is a
    table lookup, an addition and a clip. ``users_m`` (B, N, 2): user positions [x, y], m.
    ``t``: steps since the episode started.

    A state is never changed in place: a step makes a new one, so views of it stay valid.
    """

    config: FloatArray
    users_m: FloatArray
    t: int

    @classmethod
    def of(cls, uav_m: FloatArray, alpha_first: FloatArray, users_m: FloatArray, t: int = 0
           ) -> SimState:
        """A state from UAV positions ``uav_m`` (B, U, 3), first users' shares
        ``alpha_first`` (B, U, K) and user positions ``users_m`` (B, N, 2) (all copied)."""
        config = np.concatenate([np.asarray(uav_m, dtype=np.float64),
                                 np.asarray(alpha_first, dtype=np.float64)], axis=-1)
        return cls(config, user_positions(users_m), t)

    @classmethod
    def _new(cls, config: FloatArray, users_m: FloatArray, t: int) -> SimState:
        """The state with these fields, made without the frozen dataclass's ``__init__``
        (which sets each field through ``object.__setattr__``): once per step, so its fields
        are written straight into the instance's ``__dict__``, the cheapest way."""
        state = object.__new__(cls)
        fields = state.__dict__
        fields["config"] = config
        fields["users_m"] = users_m
        fields["t"] = t
        return state

    @property
    def uav_m(self) -> FloatArray:
        """UAV positions (B, U, 3) [x, y, h], m (a view of the configuration)."""
        return self.config[..., :3]

    @property
    def alpha_first(self) -> FloatArray:
        """First users' power shares (B, U, K) (a view of the configuration)."""
        return self.config[..., 3:]

    @property
    def num_uavs(self) -> int:
        """U."""
        return self.config.shape[1]


def user_positions(users_m: FloatArray) -> FloatArray:
    """A copy of ``users_m`` (B, N, 2), m, laid out as x and y arrays (2, B, N): a (B, N, 2)
    view whose :func:`users_xy` is C-contiguous, the layout a step computes with."""
    return np.array(np.moveaxis(users_m, -1, 0), dtype=np.float64, order="C").transpose(1, 2, 0)


def users_move(scenario: Scenario) -> bool:
    """Whether the scenario's users move: a mobility model other than ``static``, or the
    older random walk ``users.speed_m_per_step`` > 0 (docs/model.md §3)."""
    return scenario.users.speed_m_per_step > 0 or scenario.users.mobility.model != "static"


def walk_step_m(scenario: Scenario) -> float:
    """The random walk's step, m: ``users.speed_m_per_step``, or ``mobility.speed_mps`` times
    ``uav.step_s`` for ``mobility.model = "random-walk"``; 0 for every other model."""
    mobility = scenario.users.mobility
    if mobility.model == "random-walk":
        return mobility.speed_mps * scenario.uav.step_s
    return scenario.users.speed_m_per_step


def users_xy(users_m: FloatArray) -> FloatArray:
    """User positions (B, N, 2) as x and y (2, B, N): a view."""
    return users_m.transpose(2, 0, 1)


@dataclass(frozen=True)
class Dynamics:
    """The rules of a step that do not change (docs/model.md §3) for B environments of U UAVs.

    ``controls``: the adapter of the scenario's action kind (:mod:`adaptsky.sim.controls`),
    which checks the actions and turns them into the configuration they aim at;
    ``config_low`` and ``config_high`` (B, U, 3 + K): the feasible set (alg. 1 line 7),
    |x|, |y| <= L/2, h_min <= h <= h_max, delta_alpha <= alpha <= 1 - delta_alpha, for
    ``num_envs`` B environments; users walk ``speed_m_per_step`` per step inside
    |x|, |y| <= ``half_side_m``.
    """

    controls: Controls
    config_low: FloatArray
    config_high: FloatArray
    num_envs: int
    speed_m_per_step: float
    half_side_m: float

    @classmethod
    def of(cls, scenario: Scenario, num_envs: int) -> Dynamics:
        """The dynamics of ``scenario`` for ``num_envs`` environments of its U UAVs, each with
        its K_u clusters."""
        uav, k = scenario.uav, scenario.shares_per_uav     # K (M - 1) share components
        half_m = scenario.area.side_m / 2
        power_step = uav.power_step
        config_shape = (num_envs, uav.count, 3 + k)
        low = np.concatenate([[-half_m, -half_m, uav.min_height_m], np.full(k, power_step)])
        high = np.concatenate([[half_m, half_m, uav.max_height_m],
                               np.full(k, share_high(scenario))])
        return cls(controls_of(scenario, num_envs),
                   np.broadcast_to(low, config_shape).copy(),
                   np.broadcast_to(high, config_shape).copy(), num_envs,
                   walk_step_m(scenario), half_m)

    @property
    def actions(self) -> ActionSet | None:
        """The dense action set (None for continuous controls)."""
        controls = self.controls
        return controls.action_set if isinstance(controls, DenseControls) else None

    def checked(self, actions: NDArray[np.generic]) -> NDArray[np.generic]:
        """``actions`` of the B environments as an array, after the adapter's checks of
        their shape and range (a ValueError of one line)."""
        return self.controls.checked(actions)

    def moved(self, config: FloatArray, actions: NDArray[np.generic]) -> FloatArray:
        """The configuration (B, U, 3 + K) after checked ``actions``: every UAV moved and
        every alpha changed (or set) by its action, clipped to the feasible set (alg. 1
        line 7)."""
        return np.minimum(np.maximum(self.controls.targets(config, actions), self.config_low),
                          self.config_high)

    def walked(self, users_m: FloatArray, headings_rad: FloatArray) -> FloatArray:
        """User positions (B, N, 2) after each walked ``speed_m_per_step`` along its heading
        (B, N), rad, clipped to the area."""
        moved = np.empty((2, *headings_rad.shape))     # x and y of every user
        np.cos(headings_rad, out=moved[0])
        np.sin(headings_rad, out=moved[1])
        moved *= self.speed_m_per_step
        moved += users_xy(users_m)
        half_m = self.half_side_m
        # np.clip(moved, -L/2, L/2)
        np.minimum(np.maximum(moved, -half_m, out=moved), half_m, out=moved)
        return moved.transpose(1, 2, 0)


def step(state: SimState, actions: NDArray[np.generic], dynamics: Dynamics,
         headings_rad: FloatArray | None = None) -> SimState:
    """The state after one step (docs/model.md §3): UAVs and shares moved by the checked
    ``actions`` (dense indices (B,) or continuous points (B, D)) and clipped
    (:meth:`Dynamics.moved`), users walked along ``headings_rad`` (B, N) where they move
    (None: they stand), the step count plus one."""
    users_m = state.users_m if headings_rad is None else dynamics.walked(state.users_m,
                                                                         headings_rad)
    return SimState._new(dynamics.moved(state.config, actions), users_m, state.t + 1)
