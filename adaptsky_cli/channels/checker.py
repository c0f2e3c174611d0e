"""The channel-model contract as checks (docs/plugins.md), like Gymnasium's ``check_env``.

:func:`structural_problems` is the cheap part (what the class declares; nothing is called):
the registry runs it at discovery, so a malformed class is listed ``broken`` with the reason.
:func:`check_channel_model` adds the behaviour on a fixed set of links: shapes, dtypes,
finite and positive gains, LoS probabilities in [0, 1], gains that fall with distance,
``expected_gain`` between the LoS and NLoS gains, and LoS draws that come from the generator
passed in and nothing else. Each failure is one line, ``rule: what was found``; a plugin's own
tests assert ``check_channel_model(MyModel) == []``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from pydantic import ValidationError

from adaptsky_cli.channels.contract import ChannelModel, ChannelParams, LinkGeometry

ARRAY_METHODS = ("los_probability", "gain_los", "gain_nlos", "expected_gain")
SHAPE = (6, 5)  # links the behaviour checks use: 6 UAVs (environments) x 5 users


def structural_problems(model: Any) -> list[str]:
    """What ``model`` (a class) declares against the contract, one line per problem."""
    if not (isinstance(model, type) and issubclass(model, ChannelModel)):
        return [f"class: {getattr(model, '__name__', model)!r} is not a ChannelModel subclass"]
    problems = [f"method: {name}() is not implemented (abstract in ChannelModel)"
                for name in sorted(getattr(model, "__abstractmethods__", ()))]
    params = model.Params
    if not (isinstance(params, type) and issubclass(params, ChannelParams)):
        return [*problems, "params: Params is not a ChannelParams subclass"]
    try:
        params()
    except ValidationError:
        problems.append("params: a Params field has no default (every parameter needs one)")
    for key, field in params.model_fields.items():
        if not field.description:
            problems.append(f"params: {key} has no description (say what it is and its unit)")
    if not isinstance(model.description, str) or not model.description.strip():
        problems.append("description: the class has no description (one line for plugins list)")
    return problems


def _links(seed: int = 0) -> LinkGeometry:
    """Random links: UAVs at 10-200 m over a 100 m square, users anywhere in it."""
    rng = np.random.default_rng(seed)
    uav_m = np.column_stack([rng.uniform(-50, 50, SHAPE[0]), rng.uniform(-50, 50, SHAPE[0]),
                             rng.uniform(10, 200, SHAPE[0])])
    return LinkGeometry.between(uav_m, rng.uniform(-50, 50, size=(SHAPE[0], SHAPE[1], 2)))


def _line(height_m: float) -> LinkGeometry:
    """One UAV at ``height_m`` and users on a line 0 to 140 m away on the ground."""
    horizontal_m = np.linspace(0.0, 140.0, 30)
    users_m = np.column_stack([horizontal_m, np.zeros_like(horizontal_m)])[None]
    return LinkGeometry.between(np.array([[0.0, 0.0, height_m]]), users_m)


def _call(failures: list[str], method: str, call: Callable[[], Any]) -> Any:
    try:
        return call()
    except Exception as error:  # the plugin's own code: any error is a finding
        failures.append(f"raises: {method}() raised {type(error).__name__}: {error}")
        return None


def _array(failures: list[str], method: str, value: Any, shape: tuple[int, ...]) -> bool:
    """Whether ``value`` is a float64 array of ``shape`` with finite numbers (else failures)."""
    if not isinstance(value, np.ndarray):
        failures.append(f"type: {method}() returned {type(value).__name__}, not a numpy array")
        return False
    if value.shape != shape:
        failures.append(f"shape: {method}() returned shape {value.shape} for links of shape "
                        f"{shape}")
        return False
    if value.dtype != np.float64:
        failures.append(f"dtype: {method}() returned {value.dtype}, not float64")
        return False
    if not np.isfinite(value).all():
        failures.append(f"finite: {method}() returned NaN or infinite values")
        return False
    return True


def check_channel_model(model: Any, params: ChannelParams | None = None) -> list[str]:
    """Every contract rule for the class ``model`` (with ``params``, default its defaults):
    one line per failure, an empty list when it passes."""
    failures = structural_problems(model)
    if failures:
        return failures
    instance = _call(failures, "__init__", lambda: model(params))
    if instance is None:
        return failures
    geometry = _links()
    values: dict[str, np.ndarray] = {}
    for method in ARRAY_METHODS:
        value = _call(failures, method, lambda m=method: getattr(instance, m)(geometry))
        if value is not None and _array(failures, method, value, SHAPE):
            values[method] = value
    p_los = values.get("los_probability")
    if p_los is not None and not ((p_los >= 0) & (p_los <= 1)).all():
        failures.append(f"range: los_probability() left [0, 1]: {p_los.min():.3g} to "
                        f"{p_los.max():.3g}")
    for method in ("gain_los", "gain_nlos"):
        gain = values.get(method)
        if gain is not None and not (gain > 0).all():
            failures.append(f"positive: {method}() returned gains <= 0 (min {gain.min():.3g}); "
                            "gains are linear power gains, > 0")
    if all(name in values for name in ("gain_los", "gain_nlos", "expected_gain")):
        low = np.minimum(values["gain_los"], values["gain_nlos"]) * (1 - 1e-9)
        high = np.maximum(values["gain_los"], values["gain_nlos"]) * (1 + 1e-9)
        expected = values["expected_gain"]
        if not ((expected >= low) & (expected <= high)).all():
            failures.append("expected: expected_gain() lies outside [gain_nlos, gain_los] "
                            "(it is P g_LoS + (1 - P) g_NLoS)")
    failures += _monotone(instance)
    failures += _sampling(instance, geometry)
    return failures


def _monotone(instance: ChannelModel) -> list[str]:
    """Gains must not grow as a user moves away at a fixed UAV height."""
    failures: list[str] = []
    for method in ("gain_los", "gain_nlos"):
        for height_m in (10.0, 60.0, 150.0):
            gain = _call(failures, method, lambda m=method, h=height_m: getattr(instance, m)(
                _line(h)))
            if gain is None or not _array(failures, method, gain, (1, 30)):
                break
            if (np.diff(gain[0]) > 0).any():
                failures.append(f"monotone: {method}() grows with distance at a UAV height of "
                                f"{height_m:g} m")
                break
    return failures


def _sampling(instance: ChannelModel, geometry: LinkGeometry) -> list[str]:
    """sample_los: booleans of the links' shape, the same draws from the same generator
    state, and no use of numpy's global generator."""
    failures: list[str] = []
    before = np.random.get_state()[1].copy()  # type: ignore[index]
    draws = [_call(failures, "sample_los", lambda: instance.sample_los(
        geometry, np.random.default_rng(7))) for _ in range(2)]
    if np.random.get_state()[1].tolist() != before.tolist():  # type: ignore[index]
        failures.append("generator: sample_los() drew from numpy's global generator; draw only "
                        "from the rng passed in")
    first, second = draws
    if first is None or second is None:
        return failures
    if not isinstance(first, np.ndarray) or first.dtype != bool or first.shape != SHAPE:
        failures.append(f"sample_los: returned {type(first).__name__} "
                        f"{getattr(first, 'dtype', '')} {getattr(first, 'shape', '')}, not a "
                        f"bool array of shape {SHAPE}")
    elif not np.array_equal(first, second):
        failures.append("reproducible: sample_los() gave other draws from the same generator "
                        "state")
    return failures
