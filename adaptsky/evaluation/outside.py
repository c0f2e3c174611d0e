"""``evaluate_policy``: a policy from outside adaptsky (a Stable-Baselines3 model, a rule written
by hand) evaluated as ``evaluate`` evaluates a run's policy (docs/evaluation.md, "Evaluating a
policy from outside adaptsky").

``act`` maps one observation of the Gymnasium env (``adaptsky/NomaUav-v0``: float32, the
scenario's scaling) to one action of the env's action space. It is rolled out greedily from
the episode start on every evaluation layout, one call per layout and step, with the LoS draws
of every method compared; the results, the eval file and the table are ``evaluate``'s, with a
record that names the policy instead of a run file.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from adaptsky.envs.action_spaces import (
    ActionSpaceKind,
    action_space_kind,
    gym_action_space,
    to_dense,
)
from adaptsky.evaluation.api import (
    EvaluationError,
    check_rollout_memory,
    checked_compared,
    compared_methods,
    eval_layouts,
    evaluation_base,
    results_json,
    rollouts,
)
from adaptsky.progress import Reporter
from adaptsky.rollouts.metrics import Method
from adaptsky.rollouts.rollout import Policy
from adaptsky.scenario import Scenario
from adaptsky.scenario.toml_writer import dumps
from adaptsky.scenario.variants import eval_scenario
from adaptsky.sim.actions import ActionSet
from adaptsky.sim.controls import controls_of
from adaptsky.store.eval_file import OUTSIDE, check_new_eval_file, write_eval

Act = Callable[[NDArray[np.float32]], Any]
"""One observation of the Gymnasium env (obs,) -> one action of its action space."""
MAX_LABEL_CHARS = 100


def evaluate_policy(act: Act, *, scenario_path: Path | str, compare_with: list[str] | None = None,
                    steps: int = 1000, out: Path | str | None = None, label: str = OUTSIDE,
                    layouts: int | None = None, layout_seed: int = 0,
                    action_space: str | None = None, policy: str = "best",
                    set_values: list[str] | None = None, progress: Reporter | None = None
                    ) -> tuple[dict[str, Any], list[Method]]:
    """Greedy rollouts of ``act`` for ``steps`` steps on the scenario's layout (or ``layouts``
    uniform ones from ``layout_seed``) next to ``compare_with`` (baselines, or run files with
    their ``policy``, best or last), as ``evaluate`` rolls out a run's policy; the results as
    JSON-able values and the methods (the policy first) with their traces.

    ``act`` takes one observation as the Gymnasium env gives it and returns one action of its
    space (``action_space``: ``None``, ``"discrete"``, ``"multi-discrete"`` or ``"box"``, as
    the env's argument); an action outside it is refused in one line. ``label`` names the
    policy in the results and the eval file, which is written atomically to ``out`` (None:
    no file). Every input is checked before the first rollout."""
    if not callable(act):
        raise EvaluationError(f"act: {type(act).__name__} is not callable; give a function from "
                              "an observation to an action")
    _check_label(label)
    if isinstance(steps, bool) or not isinstance(steps, int | np.integer) or steps < 1:
        raise EvaluationError(f"steps: must be a whole number >= 1, got {steps!r}")
    out_path = None if out is None else Path(out)
    if out_path is not None:
        check_new_eval_file(out_path)
    start = time.monotonic()
    source = Path(scenario_path)
    compared = compared_methods(compare_with or [])
    scenario = eval_scenario(evaluation_base(source, None, set_values), layouts, layout_seed)
    kind = _action_kind(scenario, action_space)
    others = checked_compared(scenario, compared, policy)
    check_rollout_memory(scenario, int(steps), layouts or 1, 1 + len(compared), str(source))
    users_m = eval_layouts(scenario, layouts)
    methods = rollouts(scenario, batch_policy(act, scenario, kind), compared, others,
                       int(steps), users_m, progress)
    results = results_json(methods, scenario, int(steps), layouts, layout_seed, users_m)
    results |= {"policy": {"policy": OUTSIDE, "label": label, "action_space": kind,
                           "path": None},
                "scenario_file": str(source.resolve()),
                "scenario_toml": dumps(scenario.model_dump(mode="json")),
                "compared_runs": {name: record for name, (_, record) in others.items()}}
    if out_path is not None:
        write_eval(out_path, results, methods,
                   provenance={"wall_time_s": time.monotonic() - start})
        results["eval_file"] = str(out_path)
    return results, methods


def batch_policy(act: Act, scenario: Scenario, kind: ActionSpaceKind) -> Policy:
    """``act`` as a policy of the batched rollouts: observations (L, obs) to the batch's
    actions (dense indices (L,), or points (L, D) of the Box), one call of ``act`` per layout
    with a copy of its observation; every action is checked to lie in the env's space of
    ``kind`` (a Box action as float32, as the env's space holds it)."""
    controls = controls_of(scenario, 1)
    space = gym_action_space(controls, kind)
    if kind == "box":
        expected = f"{controls.num_components} numbers in [-1, 1]"
    else:
        actions = ActionSet.of(scenario)
        expected = (f"an int from 0 to {actions.count - 1}" if kind == "discrete" else
                    f"{actions.num_components} integers from 0 to {actions.base - 1}")
    step = 0

    def policy(obs: NDArray[np.float32]) -> NDArray[np.int64] | NDArray[np.float32]:
        nonlocal step
        chosen = []
        for layout, row in enumerate(obs):
            action = act(row.copy())
            value = np.asarray(action) if isinstance(action, list | tuple) else action
            if kind == "box":
                value = _as_float32(value)
            if not space.contains(value):
                raise EvaluationError(
                    f"act returned {action!r} for layout {layout} at step {step}: not an action "
                    f"of the env's action space {space}; give {expected}")
            chosen.append(value)
        step += 1
        if kind == "discrete":
            return np.array([int(value) for value in chosen], dtype=np.int64)
        if kind == "box":
            return np.stack(chosen)
        return to_dense(actions, np.stack([np.asarray(value, dtype=np.int64)
                                           for value in chosen]))

    return policy


def _as_float32(value: object) -> object:
    """A number array ``value`` as float32 (what the env's Box holds), anything else as it
    is (for the space to refuse)."""
    if isinstance(value, np.ndarray | np.generic) and value.dtype.kind in "iuf":
        return np.asarray(value, dtype=np.float32)
    return value


def _action_kind(scenario: Scenario, action_space: str | None) -> ActionSpaceKind:
    try:
        return action_space_kind(scenario, action_space)
    except ValueError as error:
        raise EvaluationError(str(error)) from None


def _check_label(label: object) -> None:
    if not isinstance(label, str) or not label.strip() or "\n" in label or \
            len(label) > MAX_LABEL_CHARS:
        raise EvaluationError(f"label: must be one line of 1 to {MAX_LABEL_CHARS} characters "
                              f"naming the policy (e.g. 'sb3-ppo'), got {label!r}")
