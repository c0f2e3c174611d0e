"""The environments' action spaces over the action kinds' adapters
(:mod:`adaptsky.sim.controls`).

``"discrete"``: ``Discrete(base^D)``, the dense index over all D = sum_u (3 + K_u) components;
``"multi-discrete"``: ``MultiDiscrete([base] * D)``, one sub-action per component in the dense
index's order (x, y, h, alpha_1 .. alpha_K of UAV 0, then UAV 1, ...). Sub-action v is the
component's digit of the dense index: direction 2 v - 1 (``paper``, base 2) or v - 1
(``with-hover``, base 3). ``"box"``: ``Box([-1, 1]^D, float32)``, the continuous actions
(``uav.actions = "continuous"``) in the same order, each scaled onto its step by the adapter.
"""

from __future__ import annotations

from typing import Literal, cast

import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray

from adaptsky.scenario import Scenario
from adaptsky.sim.actions import ActionSet
from adaptsky.sim.controls import BOX_HIGH, BOX_LOW, Controls, DenseControls

ActionSpaceKind = Literal["discrete", "multi-discrete", "box"]
ACTION_SPACES: tuple[ActionSpaceKind, ...] = ("discrete", "multi-discrete", "box")
DENSE_SPACES: tuple[ActionSpaceKind, ...] = ("discrete", "multi-discrete")
# The dense space of several UAVs grows as base^(U (3 + K_u)): three UAVs of two clusters have
# 2^15 actions, four 2^20. A dense Q head of 2^16 outputs over 256 hidden units already holds
# 16.8 M weights, so beyond that several UAVs take the MultiDiscrete space (a branching head's
# size grows with D, not base^D). One UAV keeps the paper's Discrete space at every size the
# scenario allows (at most 2^24), as before.
MAX_DISCRETE_ACTIONS = 2**16


def action_space_kind(scenario: Scenario, requested: str | None) -> ActionSpaceKind:
    """The action space to use: ``requested``, checked, or by default ``"box"`` for
    continuous actions, ``"discrete"`` for one UAV and ``"multi-discrete"`` for several."""
    continuous = scenario.uav.actions == "continuous"
    if requested is None:
        if continuous:
            return "box"
        return "discrete" if scenario.uav.count == 1 else "multi-discrete"
    if requested not in ACTION_SPACES:
        allowed = ", ".join(repr(kind) for kind in ACTION_SPACES)
        raise ValueError(f"action_space {requested!r} is not supported; allowed: None, {allowed}")
    if continuous != (requested == "box"):
        fits = "'box' (or None)" if continuous else "'discrete' or 'multi-discrete' (or None)"
        raise ValueError(f"action_space {requested!r} does not fit uav.actions = "
                         f"'{scenario.uav.actions}'; its action spaces: {fits}")
    if requested == "discrete" and scenario.uav.count > 1:
        count = ActionSet.of(scenario).count
        if count > MAX_DISCRETE_ACTIONS:
            raise ValueError(
                f"action_space 'discrete': {scenario.uav.count} UAVs have {count} dense actions, "
                f"more than {MAX_DISCRETE_ACTIONS} (2^16); use action_space='multi-discrete'")
    return cast(ActionSpaceKind, requested)


def multi_discrete(action_set: ActionSet, num_components: int | None = None
                   ) -> spaces.MultiDiscrete:
    """``MultiDiscrete`` of ``num_components`` (default: all of the set's) sub-actions."""
    count = action_set.num_components if num_components is None else num_components
    return spaces.MultiDiscrete(np.full(count, action_set.base, dtype=np.int64))


def per_component_kind(scenario: Scenario) -> ActionSpaceKind:
    """The space whose components split into per-UAV parts: ``"box"`` for continuous
    actions, else ``"multi-discrete"``."""
    return "box" if scenario.uav.actions == "continuous" else "multi-discrete"


def uav_action_space(space: spaces.MultiDiscrete | spaces.Box, num_components: int
                     ) -> spaces.MultiDiscrete | spaces.Box:
    """The first ``num_components`` components of a per-component ``space`` (of its
    kind): one UAV's part of it."""
    if isinstance(space, spaces.Box):
        return spaces.Box(BOX_LOW, BOX_HIGH, shape=(num_components,), dtype=np.float32)
    return spaces.MultiDiscrete(space.nvec[:num_components])


def gym_action_space(controls: Controls, kind: ActionSpaceKind
                     ) -> spaces.Discrete | spaces.MultiDiscrete | spaces.Box:
    """The space of one environment's action, of ``kind`` (:func:`action_space_kind`) over
    the adapter ``controls``."""
    if controls.form == "box":
        return spaces.Box(BOX_LOW, BOX_HIGH, shape=(controls.num_components,),
                          dtype=np.float32)
    assert isinstance(controls, DenseControls), controls
    action_set = controls.action_set
    return spaces.Discrete(action_set.count) if kind == "discrete" else multi_discrete(action_set)


def to_dense(action_set: ActionSet, sub_actions: NDArray[np.integer]) -> NDArray[np.int64]:
    """Dense indices (...,) of sub-actions (..., D), after checking their shape and range."""
    digits = np.asarray(sub_actions)
    components, base = action_set.num_components, action_set.base
    if digits.shape[-1:] != (components,) or digits.dtype.kind not in "iu":
        raise ValueError(f"a MultiDiscrete action must be {components} integers, got shape "
                         f"{digits.shape} of {digits.dtype}")
    if digits.size and (digits.min() < 0 or digits.max() >= base):
        raise ValueError(f"every sub-action must lie in [0, {base})")
    digits = digits.astype(np.int64)
    directions = 2 * digits - 1 if action_set.mode == "paper" else digits - 1
    return action_set.encode(directions)


def to_sub_actions(action_set: ActionSet, dense: NDArray[np.integer]) -> NDArray[np.int64]:
    """Inverse of :func:`to_dense`: the sub-actions (..., D) of dense indices (...,)."""
    directions = action_set.decode(dense)
    return (directions + 1) // 2 if action_set.mode == "paper" else directions + 1
