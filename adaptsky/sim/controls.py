"""Action kinds as adapters onto the controls of a step (docs/model.md §3 and §9).

A step's controls are, per UAV, a move (delta_x, delta_y, delta_h), m, each axis at most
``uav.step_m``, and per cluster a change of its first user's share of at most
``uav.power_step``; the step clips the result to the feasible set. An adapter turns a batch of
one action kind's actions into the configuration (B, U, 3 + K) before that clip
(:meth:`Controls.targets`), after checking them (:meth:`Controls.checked`), and describes
its actions without Gymnasium (kind, D components, index count or box bounds), so that the
environments build their spaces from it:

- ``"paper"``, ``"with-hover"`` (:class:`DenseControls`): a dense index (B,) of the
  directions d in {-1, +1} or {-1, 0, +1} of every component (:class:`ActionSet`), times the
  step sizes: a table lookup, or a decoding of the digits for large sets;
- ``"continuous"`` (:class:`ContinuousControls`): a point (B, D) of [-1, 1]^D, component j
  times its step size (a delta_j); with ``uav.power = "absolute"`` a cluster's component sets
  the share itself, alpha = delta_alpha + (1 - 2 delta_alpha) (a + 1) / 2.

The D components are x, y, h, cluster 1 .. K_u of UAV 0, then those of UAV 1, ... A new
action kind is one class with this protocol and an entry in :data:`CONTROLS`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal, Protocol

import numpy as np
from numpy.typing import NDArray

from adaptsky.scenario.models import Scenario
from adaptsky.sim.actions import TABLE_MAX_ACTIONS, ActionSet

FloatArray = NDArray[np.float64]
ActionForm = Literal["index", "box"]
BOX_LOW, BOX_HIGH = -1.0, 1.0
"""The bounds of every component of a continuous action."""


@dataclass(frozen=True)
class Components:
    """Where an action's D components act, for B environments of U UAVs.

    ``clusters``: K_u of every UAV; ``step`` (D,): delta_x, delta_y, delta_h (m) and
    delta_alpha K_u times, for every UAV; ``slots`` (D,): where the components sit in the
    flattened (U (3 + K),) configuration (None: in order, every UAV with K clusters);
    ``config_shape``: (B, U, 3 + K), K = K_max.
    """

    clusters: tuple[int, ...]
    step: FloatArray
    slots: NDArray[np.intp] | None
    config_shape: tuple[int, int, int]

    @classmethod
    def of(cls, scenario: Scenario, num_envs: int) -> Components:
        # a UAV's share components: K_u for pairs, K_u (M - 1) for clusters of M (§15)
        uav, k = scenario.uav, scenario.shares_per_uav
        clusters = scenario.shares_of_uavs
        # one UAV's steps, then every UAV's: the components of an action in order
        step = np.concatenate([np.concatenate([np.array(uav.step_m, dtype=np.float64),
                                               np.full(k_u, uav.power_step)])
                               for k_u in clusters])
        # where UAVs serve different numbers of clusters, the configuration's slots of the
        # components (a UAV with fewer than K_max has unused share slots no action moves)
        slots = None
        if len(set(clusters)) > 1:
            slots = np.concatenate([u * (3 + k) + np.arange(3 + k_u)
                                    for u, k_u in enumerate(clusters)])
        return cls(clusters, step, slots, (num_envs, uav.count, 3 + k))

    @property
    def num_components(self) -> int:
        """D = sum_u (3 + K_u)."""
        return len(self.step)

    def components_of(self, uav: int) -> int:
        """3 + K_u, the components of UAV ``uav``."""
        return 3 + self.clusters[uav]

    def shares(self) -> NDArray[np.bool_]:
        """(D,): which components are cluster shares (the others are x, y, h)."""
        return np.concatenate([np.arange(3 + k_u) >= 3 for k_u in self.clusters])

    def placed(self, values: FloatArray) -> FloatArray:
        """``values`` (..., D) written into their slots of the configuration
        (..., U, 3 + K), 0 in the unused slots."""
        shape = self.config_shape
        width = shape[1] * shape[2]
        if self.slots is not None:
            flat = np.zeros((*values.shape[:-1], width))
            flat[..., self.slots] = values
            values = flat
        return values.reshape(*values.shape[:-1], shape[1], shape[2])


class Controls(Protocol):
    """An action kind's adapter (module docstring)."""

    kind: str
    """The ``uav.actions`` it serves."""
    form: ActionForm
    """``"index"``: one integer in [0, count) per environment; ``"box"``: D floats in
    [BOX_LOW, BOX_HIGH]."""
    components: Components

    @property
    def num_components(self) -> int:
        """D."""
        ...

    def components_of(self, uav: int) -> int:
        """3 + K_u of UAV ``uav``."""
        ...

    def checked(self, actions: NDArray[np.generic]) -> NDArray[np.generic]:
        """``actions`` of B environments as an array, after checking them: a ValueError of
        one line for a wrong shape, a value outside the kind's actions or not a number."""
        ...

    def targets(self, config: FloatArray, actions: NDArray[np.generic]) -> FloatArray:
        """The configuration (B, U, 3 + K) that checked ``actions`` aim at from ``config``,
        before the clip to the feasible set."""
        ...


@dataclass(frozen=True)
class DenseControls:
    """``"paper"`` and ``"with-hover"``: the dense index of :class:`ActionSet` (docs/model.md
    §3). ``moves`` (A, U, 3 + K): the change of the configuration by each of the A actions
    (None for sets over ``TABLE_MAX_ACTIONS``, decoded instead)."""

    kind: str
    action_set: ActionSet
    count: int
    components: Components
    moves: FloatArray | None
    form: ActionForm = "index"

    @classmethod
    def of(cls, scenario: Scenario, num_envs: int) -> DenseControls:
        action_set = ActionSet.of(scenario)
        components = Components.of(scenario, num_envs)
        moves = None
        if action_set.count <= TABLE_MAX_ACTIONS:
            moves = components.placed(action_set.table() * components.step)
        return cls(scenario.uav.actions, action_set, action_set.count, components, moves)

    @property
    def num_components(self) -> int:
        return self.components.num_components

    def components_of(self, uav: int) -> int:
        return self.components.components_of(uav)

    def checked(self, actions: NDArray[np.integer]) -> NDArray[np.integer]:
        """``actions`` (B,) as an array, after checking their shape and range."""
        actions = np.asarray(actions)
        num_envs = self.components.config_shape[0]
        if actions.shape != (num_envs,):
            raise ValueError(f"expected {num_envs} actions, got shape {actions.shape}")
        count = self.count
        if actions.dtype.kind in "iu" and num_envs <= 16:   # cheaper than two reductions
            values = actions.tolist()
            valid = min(values) >= 0 and max(values) < count
        else:
            valid = bool(actions.min() >= 0 and actions.max() < count)
        if not valid:
            raise ValueError(f"actions must lie in [0, {count})")
        return actions

    def changes(self, actions: NDArray[np.integer]) -> FloatArray:
        """Checked actions (B,) as changes (B, U, 3 + K) of the configuration."""
        if self.moves is not None and actions.dtype.kind in "iu":
            return self.moves.take(actions, axis=0)
        components = self.components
        return components.placed(self.action_set.decode(actions) * components.step)

    def targets(self, config: FloatArray, actions: NDArray[np.integer]) -> FloatArray:
        return config + self.changes(actions)


@dataclass(frozen=True)
class ContinuousControls:
    """``"continuous"``: a point a of [-1, 1]^D per environment (docs/model.md §3). Component
    j moves its axis by a_j delta_j (m) or changes its share by a_j delta_alpha; with
    ``absolute`` (``uav.power = "absolute"``) a share component sets the share itself,
    alpha = delta_alpha + (1 - 2 delta_alpha) (a + 1) / 2, from delta_alpha at a = -1 to
    1 - delta_alpha at a = +1. ``shares`` (D,): the share components, ``share_slots`` their
    slots of the flattened configuration; ``power_step``: delta_alpha.

    Actions are refused, not clipped, outside [-1, 1] (``gymnasium.wrappers.ClipAction``
    clips them for a learner whose actions may leave the box), and where not a number.
    """

    components: Components
    absolute: bool
    shares: NDArray[np.bool_]
    share_slots: NDArray[np.intp]
    power_step: float
    share_span: float
    kind: str = "continuous"
    form: ActionForm = "box"

    @classmethod
    def of(cls, scenario: Scenario, num_envs: int) -> ContinuousControls:
        components = Components.of(scenario, num_envs)
        shares = components.shares()
        slots = np.arange(len(shares)) if components.slots is None else components.slots
        step = scenario.uav.power_step
        # the components' span: [delta, 1 - delta], the uplink's [delta, 1] (docs/model.md §17)
        span = 1 - step if scenario.uplink else 1 - 2 * step
        return cls(components, scenario.uav.power == "absolute", shares, slots[shares], step,
                   span)

    @property
    def num_components(self) -> int:
        return self.components.num_components

    def components_of(self, uav: int) -> int:
        return self.components.components_of(uav)

    def checked(self, actions: NDArray[np.floating]) -> FloatArray:
        """``actions`` (B, D) as float64, after checking their shape, that they are numbers
        and that they lie in [-1, 1]."""
        actions = np.asarray(actions)
        shape = (self.components.config_shape[0], self.num_components)
        if actions.shape != shape or actions.dtype.kind not in "iuf":
            raise ValueError(f"expected continuous actions of shape {shape} (numbers in "
                             f"[-1, 1]), got shape {actions.shape} of {actions.dtype}")
        actions = actions.astype(np.float64)
        if not np.isfinite(actions).all():
            raise ValueError("continuous actions must be finite numbers in [-1, 1], got NaN "
                             "or infinity")
        if actions.size and (actions.min() < BOX_LOW or actions.max() > BOX_HIGH):
            raise ValueError(f"continuous actions must lie in [-1, 1], got values from "
                             f"{actions.min():g} to {actions.max():g} (clip them, e.g. "
                             f"gymnasium.wrappers.ClipAction)")
        return actions

    def targets(self, config: FloatArray, actions: FloatArray) -> FloatArray:
        values = actions * self.components.step
        if not self.absolute:
            return config + self.components.placed(values)
        # x, y, h move; every share its component names is set
        shares = self.shares
        alpha = self.power_step + self.share_span * (actions[:, shares] + 1) / 2
        values[:, shares] = 0.0
        target = config + self.components.placed(values)
        target.reshape(len(target), -1)[:, self.share_slots] = alpha
        return target


CONTROLS: dict[str, Callable[[Scenario, int], Controls]] = {
    "paper": DenseControls.of,
    "with-hover": DenseControls.of,
    "continuous": ContinuousControls.of,
}
"""The adapter of every ``uav.actions`` kind, by name."""


def controls_of(scenario: Scenario, num_envs: int) -> Controls:
    """The adapter of ``scenario``'s ``uav.actions`` for ``num_envs`` environments."""
    return CONTROLS[scenario.uav.actions](scenario, num_envs)
