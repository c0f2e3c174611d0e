"""The channel-model contract as checks (docs/plugins.md), like Gymnasium's ``check_env``.

:func:`structural_problems` is what the class declares (nothing is called) and
:func:`call_problems` one call of each method on a few links: the registry runs both at
discovery, so a malformed class, or one whose gains have the wrong shape, is listed ``broken``
with the reason.
:func:`check_channel_model` adds the behaviour on a fixed set of links: shapes, dtypes,
finite and positive gains, LoS probabilities in [0, 1], gains that fall with distance,
``expected_gain`` between the LoS and NLoS gains, LoS draws and (contract 2) fading draws that
come from the generator passed in and nothing else, and, for a model that declares
``Supports(monotone_gains=True)``, that promise on lines of links. A contract-2 model is
checked with users on the ground and with user antennas above it. Each failure is one line,
``rule: what was found``; a plugin's own tests assert ``check_channel_model(MyModel) == []``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from pydantic import ValidationError

from adaptsky.channels.contract import (
    CONTRACT_VERSION,
    SHARED_SETTINGS,
    SUPPORTED_CONTRACT_VERSIONS,
    ChannelModel,
    ChannelParams,
    LinkGeometry,
    Supports,
    carrier_parameter_hz,
    contract_version_of,
    declares_monotone_gains,
    default_carrier_hz,
    implements_fading,
    supported_range,
    supported_text,
)

ARRAY_METHODS = ("los_probability", "gain_los", "gain_nlos", "expected_gain")
SHAPE = (6, 5)  # links the behaviour checks use: 6 UAVs (environments) x 5 users
USER_HEIGHT_M = 1.5  # user antennas of the contract-2 checks (3GPP's usual h_UT), m
CONTRACT_2_HOOKS = ("fading_enabled", "sample_fading")


def structural_problems(model: Any) -> list[str]:
    """What ``model`` (a class) declares against the contract, one line per problem."""
    if not (isinstance(model, type) and issubclass(model, ChannelModel)):
        return [f"class: {getattr(model, '__name__', model)!r} is not a ChannelModel subclass"]
    problems = [f"method: {name}() is not implemented (abstract in ChannelModel)"
                for name in sorted(getattr(model, "__abstractmethods__", ()))]
    problems += _contract_problems(model)
    params = model.Params
    if not (isinstance(params, type) and issubclass(params, ChannelParams)):
        return [*problems, "params: Params is not a ChannelParams subclass"]
    try:
        problems += _supports_problems(model, params())
    except ValidationError:
        problems.append("params: a Params field has no default (every parameter needs one)")
    for key, field in params.model_fields.items():
        if not field.description:
            problems.append(f"params: {key} has no description (say what it is and its unit)")
    if not isinstance(model.description, str) or not model.description.strip():
        problems.append("description: the class has no description (one line for plugins list)")
    return problems


def call_problems(model: type[ChannelModel]) -> list[str]:
    """One call of each array method of a structurally sound class, with its default
    parameters, on 2 x 3 links: what raises or returns no finite float64 array of the links'
    shape (the part of the behaviour discovery checks; microseconds for a vectorised model)."""
    failures: list[str] = []
    instance = _call(failures, "__init__", model)
    if instance is None:
        return failures
    uav_m = np.array([[0.0, 0.0, 50.0], [20.0, -10.0, 120.0]])
    users_m = np.array([[[10.0, 0.0], [-30.0, 40.0], [0.0, 0.0]]] * 2)
    geometry = LinkGeometry.between(uav_m, users_m, carrier_hz=_carrier_hz(instance, None))
    for method in ARRAY_METHODS:
        if method == "expected_gain" and failures:
            break  # it combines the other three: their failure is said once, there
        value = _call(failures, method, lambda m=method: getattr(instance, m)(geometry))
        if value is not None:
            _array(failures, method, value, geometry.shape)
    if not failures and contract_version_of(model) >= 3:
        failures += _los_mask_problems(instance, geometry)
    return failures


def _los_mask_problems(instance: ChannelModel, geometry: LinkGeometry) -> list[str]:
    """Contract 3: the LoS and NLoS gains of links that carry the buildings' LoS states
    (``geometry.los``, docs/plugins.md §2) are float64 arrays of the links' shape."""
    failures: list[str] = []
    mask = np.zeros(geometry.shape, dtype=bool)
    mask[:, ::2] = True
    with_mask = geometry.with_los(mask)
    for method in ("gain_los", "gain_nlos"):
        value = _call(failures, method,
                      lambda m=method: getattr(instance, m)(with_mask))
        if value is not None:
            _array(failures, method, value, geometry.shape)
    return failures


def _contract_problems(model: type[ChannelModel]) -> list[str]:
    """The declared contract version, and hooks that need a later one."""
    declared = model.contract_version
    versions = [str(v) for v in SUPPORTED_CONTRACT_VERSIONS]
    supported = f"{', '.join(versions[:-1])} and {versions[-1]}"
    if declared is not None and (type(declared) is not int
                                 or declared not in SUPPORTED_CONTRACT_VERSIONS):
        if type(declared) is int and declared > CONTRACT_VERSION:
            return [f"contract: written for plugin contract {declared}; this adaptsky supports "
                    f"contracts {supported}: upgrade adaptsky"]
        return [f"contract: contract_version must be one of {supported} (got {declared!r})"]
    problems = []
    if contract_version_of(model) < 2:
        problems += [f"contract: {hook}() is a contract-2 hook; declare contract_version = 2 "
                     "in the class to use it" for hook in CONTRACT_2_HOOKS
                     if getattr(model, hook) is not getattr(ChannelModel, hook)]
    elif (model.fading_enabled is not ChannelModel.fading_enabled
          and not implements_fading(model)):
        problems.append("fading: fading_enabled() is overridden but sample_fading() is not "
                        "implemented")
    return problems


def _supports_problems(model: type[ChannelModel], defaults: ChannelParams) -> list[str]:
    """The ``supports`` declaration: a :class:`Supports` of ranges (low, high), low <= high,
    of a contract-2 class, holding the default of a ``carrier_hz`` parameter."""
    declared = model.supports
    if declared is None:
        return []
    if not isinstance(declared, Supports):
        return [f"supports: must be a Supports(...) declaration, not {type(declared).__name__}"]
    if contract_version_of(model) < 2:
        return ["contract: supports is a contract-2 declaration; declare contract_version = 2 "
                "in the class to use it"]
    if not isinstance(declared.monotone_gains, bool):
        return [f"supports: monotone_gains = {declared.monotone_gains!r} is not True or False"]
    problems = [f"supports: {setting} = {value!r} is not a range (low, high) of finite numbers "
                f"with {'0 <=' if setting.endswith('_m') else '0 <'} low <= high"
                for setting in SHARED_SETTINGS
                if (value := getattr(declared, setting)) is not None
                and not _is_range(value, positive=not setting.endswith("_m"))]
    carrier = carrier_parameter_hz(defaults)
    allowed = supported_range(model, "carrier_hz")
    if not problems and carrier is not None and allowed and not (
            allowed[0] <= carrier <= allowed[1]):
        problems.append(f"supports: the carrier_hz parameter's default, {carrier:g} Hz, is "
                        f"outside the model's {supported_text('carrier_hz', allowed)}")
    return problems


def _is_range(value: object, positive: bool) -> bool:
    """Whether ``value`` is (low, high): two finite real numbers, 0 <(=) low <= high."""
    if not (isinstance(value, tuple | list) and len(value) == 2 and all(
            isinstance(v, int | float) and not isinstance(v, bool) for v in value)):
        return False
    low, high = value
    return bool(np.isfinite([low, high]).all() and (low > 0 if positive else low >= 0)
                and low <= high)


def _carrier_hz(instance: ChannelModel, carrier_hz: float | None) -> float:
    """The carrier of the checks: as given, else the model's ``carrier_hz`` parameter, else
    the one carrier it declares it supports, else the paper's 28 GHz."""
    if carrier_hz is not None:
        return carrier_hz
    value = carrier_parameter_hz(instance.params)
    return default_carrier_hz(type(instance)) if value is None else value


def _links(user_height_m: float, carrier_hz: float, seed: int = 0) -> LinkGeometry:
    """Random links: UAVs at 10-200 m over a 100 m square, users anywhere in it."""
    rng = np.random.default_rng(seed)
    uav_m = np.column_stack([rng.uniform(-50, 50, SHAPE[0]), rng.uniform(-50, 50, SHAPE[0]),
                             rng.uniform(10, 200, SHAPE[0])])
    return LinkGeometry.between(uav_m, rng.uniform(-50, 50, size=(SHAPE[0], SHAPE[1], 2)),
                                user_height_m=user_height_m, carrier_hz=carrier_hz)


def _line(height_m: float, user_height_m: float, carrier_hz: float) -> LinkGeometry:
    """One UAV at ``height_m`` and users on a line 0 to 140 m away."""
    horizontal_m = np.linspace(0.0, 140.0, 30)
    users_m = np.column_stack([horizontal_m, np.zeros_like(horizontal_m)])[None]
    return LinkGeometry.between(np.array([[0.0, 0.0, height_m]]), users_m,
                                user_height_m=user_height_m, carrier_hz=carrier_hz)


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


def check_channel_model(model: Any, params: ChannelParams | None = None, *,
                        carrier_hz: float | None = None,
                        user_height_m: float = USER_HEIGHT_M) -> list[str]:
    """Every contract rule for the class ``model`` (with ``params``, default its defaults):
    one line per failure, an empty list when it passes.

    The links carry ``carrier_hz`` (default: the model's ``carrier_hz`` parameter, else
    28 GHz); a model with a ``carrier_hz`` parameter gets it there too, as in a run. A
    contract-2 model is checked with users on the ground and, again, with user antennas
    ``user_height_m`` above it.
    """
    failures = structural_problems(model) or _declared_carrier_problems(model, carrier_hz)
    if failures:
        return failures
    params, failures = _with_carrier(model, params, carrier_hz)
    if failures:
        return failures
    instance = _call(failures, "__init__", lambda: model(params))
    if instance is None:
        return failures
    carrier = _carrier_hz(instance, carrier_hz)
    for height in _user_heights(model, user_height_m):
        found = _behaviour(instance, height, carrier)
        # the same rule broken with and without user heights is said once
        failures += [line + (f" (users {height:g} m above the ground)" if height else "")
                     for line in found if not (height and line in failures)]
    return failures


def checked_conditions(model: type[ChannelModel], params: ChannelParams | None = None,
                       carrier_hz: float | None = None,
                       user_height_m: float = USER_HEIGHT_M) -> str:
    """What :func:`check_channel_model` checked a model that passed under, in words."""
    instance = model(_with_carrier(model, params, carrier_hz)[0])
    heights = " and ".join("on the ground" if h == 0 else f"{h:g} m up"
                           for h in _user_heights(model, user_height_m))
    given = ", ".join(f"{key}={value!r}" for key, value in
                      (params.model_dump(exclude_defaults=True).items() if params else ())
                      if key != "carrier_hz")
    fading = ("fading hook checked" if implements_fading(model) and contract_version_of(model) >= 2
              else "no fading hook")
    supports = "; ".join(supported_text(setting, value_range) for setting in SHARED_SETTINGS
                         if model.supports is not None
                         and (value_range := getattr(model.supports, setting)) is not None)
    geometric = (", gains of links with LoS states (geometric LoS) checked"
                 if contract_version_of(model) >= 3 else "")
    return (f"f_c {_carrier_hz(instance, carrier_hz) / 1e9:g} GHz, users {heights}, "
            f"{fading}{geometric}, parameters: {given or 'defaults'}"
            + (f", supports {supports}" if supports else ""))


def _user_heights(model: type[ChannelModel], user_height_m: float) -> tuple[float, ...]:
    """Users on the ground and ``user_height_m`` up (contract 2), each moved into the user
    heights the model declares it supports."""
    if contract_version_of(model) < 2:
        return (0.0,)
    low, high = supported_range(model, "user_height_m") or (0.0, np.inf)
    return tuple(dict.fromkeys(float(np.clip(h, low, high)) for h in (0.0, user_height_m)))


def _declared_carrier_problems(model: type[ChannelModel], carrier_hz: float | None
                               ) -> list[str]:
    """A carrier to check at outside the carriers the model declares (``supports``)."""
    declared = model.supports.carrier_hz if model.supports is not None else None
    if carrier_hz is None or declared is None or declared[0] <= carrier_hz <= declared[1]:
        return []
    return [f"carrier: carrier_hz = {carrier_hz:g} Hz is outside what the model supports "
            f"({supported_text('carrier_hz', tuple(declared))})"]


def ignored_carrier_note(model: type[ChannelModel], params: ChannelParams | None = None
                         ) -> str:
    """For a contract-2 model that declares no carriers and has no ``carrier_hz`` parameter
    but gives the same numbers at 2 and 28 GHz, a note: it ignores the scenario's carrier and
    should declare the one its constants hold; "" otherwise (contract 1: as before)."""
    if (contract_version_of(model) < 2 or supported_range(model, "carrier_hz") is not None):
        return ""
    instance = model(params)
    numbers = [[getattr(instance, method)(_links(0.0, carrier_hz))
                for method in ARRAY_METHODS] for carrier_hz in (2e9, 28e9)]
    if any(not np.array_equal(a, b) for a, b in zip(*numbers, strict=True)):
        return ""
    return ("its gains are the same at 2 and 28 GHz: it ignores radio.carrier_hz, which a "
            "scenario may then set to anything; declare the carrier its constants hold, "
            "supports = Supports(carrier_hz=(F, F)) (docs/plugins.md, shared settings)")


def _with_carrier(model: type[ChannelModel], params: ChannelParams | None,
                  carrier_hz: float | None) -> tuple[ChannelParams | None, list[str]]:
    """``params`` with ``carrier_hz`` where the model has a ``carrier_hz`` parameter (a run
    keeps the two equal), or the line saying why that cannot be."""
    if carrier_hz is None or "carrier_hz" not in model.Params.model_fields:
        return params, []
    given = params.model_dump() if params is not None else {}
    chosen = params.model_fields_set if params is not None else set()
    if "carrier_hz" in chosen and given["carrier_hz"] != carrier_hz:
        return params, [f"carrier: carrier_hz = {carrier_hz:g} Hz differs from the "
                        f"parameters' carrier_hz = {given['carrier_hz']:g} Hz; in a run they "
                        "are one value"]
    try:
        return model.Params.model_validate({**given, "carrier_hz": carrier_hz}), []
    except ValidationError as error:
        message = error.errors(include_url=False)[0]["msg"]
        return params, [f"carrier: carrier_hz = {carrier_hz:g} Hz is outside the model's "
                        f"carrier_hz range: {message}"]


def _behaviour(instance: ChannelModel, user_height_m: float, carrier_hz: float) -> list[str]:
    """The rules on links whose users stand ``user_height_m`` above the ground."""
    failures: list[str] = []
    geometry = _links(user_height_m, carrier_hz)
    values: dict[str, np.ndarray] = {}
    for method in ARRAY_METHODS:
        if method == "expected_gain" and len(values) < 3:
            break  # it combines the other three: their failure is said once, there
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
    # gains already found broken on these links are not followed along a line as well
    failures += _monotone(instance, user_height_m, carrier_hz,
                          [m for m in ("gain_los", "gain_nlos") if m in values])
    if declares_monotone_gains(instance) and not failures:
        failures += _monotone_gains(instance, geometry, user_height_m, carrier_hz)
    failures += _sampling(instance, geometry)
    if contract_version_of(instance) >= 2:
        failures += _fading(instance, geometry)
    return failures


def _monotone(instance: ChannelModel, user_height_m: float, carrier_hz: float,
              methods: list[str]) -> list[str]:
    """Gains must not grow as a user moves away at a fixed UAV height."""
    failures: list[str] = []
    for method in methods:
        for height_m in (10.0, 60.0, 150.0):
            line = _line(height_m, user_height_m, carrier_hz)
            gain = _call(failures, method, lambda m=method, g=line: getattr(instance, m)(g))
            if gain is None or not _array(failures, method, gain, (1, 30)):
                break
            if (np.diff(gain[0]) > 0).any():
                failures.append(f"monotone: {method}() grows with distance at a UAV height of "
                                f"{height_m:g} m")
                break
    return failures


def _monotone_gains(instance: ChannelModel, geometry: LinkGeometry, user_height_m: float,
                    carrier_hz: float) -> list[str]:
    """The promise of ``Supports(monotone_gains=True)``: neither gain grows with the UAV's
    height at a fixed ground distance, the NLoS gain is at most the LoS gain (on the random
    links and on lines of links), and (contract 3) the buildings' LoS states change
    neither."""
    failures: list[str] = []
    lines = [(f"at a ground distance of {d:g} m", _column(d, user_height_m, carrier_hz))
             for d in (0.0, 50.0, 140.0)]
    for method in ("gain_los", "gain_nlos"):
        for where, links in lines:
            gain = _call(failures, method, lambda m=method, g=links: getattr(instance, m)(g))
            if gain is None or not _array(failures, method, gain, links.shape):
                return failures
            if (np.diff(gain[:, 0]) > 0).any():
                failures.append(f"monotone_gains: {method}() grows with the UAV height {where}"
                                " (declared Supports(monotone_gains=True))")
                break
    every = [geometry, *(_line(h, user_height_m, carrier_hz) for h in (10.0, 60.0, 150.0)),
             *(links for _, links in lines)]
    if any((instance.gain_nlos(links) > instance.gain_los(links)).any() for links in every):
        failures.append("monotone_gains: gain_nlos() exceeds gain_los() on some links "
                        "(declared Supports(monotone_gains=True))")
    if contract_version_of(instance) >= 3:
        mask = np.random.default_rng(5).random(geometry.shape) < 0.5
        with_mask = geometry.with_los(mask)
        if any(not np.array_equal(getattr(instance, m)(geometry), getattr(instance, m)(with_mask))
               for m in ("gain_los", "gain_nlos")):
            failures.append("monotone_gains: the gains change with the links' LoS states "
                            "(geometry.los; declared Supports(monotone_gains=True))")
    return failures


def _column(horizontal_m: float, user_height_m: float, carrier_hz: float) -> LinkGeometry:
    """UAVs at heights 10 to 200 m, each with one user ``horizontal_m`` away (links (30, 1))."""
    heights_m = np.linspace(10.0, 200.0, 30)
    uav_m = np.column_stack([np.zeros_like(heights_m), np.zeros_like(heights_m), heights_m])
    users_m = np.broadcast_to([[[horizontal_m, 0.0]]], (len(heights_m), 1, 2))
    return LinkGeometry.between(uav_m, np.array(users_m), user_height_m=user_height_m,
                                carrier_hz=carrier_hz)


def _global_state() -> tuple[Any, ...]:
    """numpy's global generator state, whole: its key changes only every 624 words drawn, its
    position and cached Gaussian at every draw."""
    name, key, position, has_gauss, cached = np.random.get_state()
    return name, key.tobytes(), position, has_gauss, cached


def _sampling(instance: ChannelModel, geometry: LinkGeometry) -> list[str]:
    """sample_los: booleans of the links' shape, the same draws from the same generator
    state, and no use of numpy's global generator."""
    failures: list[str] = []
    before = _global_state()
    draws = [_call(failures, "sample_los", lambda: instance.sample_los(
        geometry, np.random.default_rng(7))) for _ in range(2)]
    if _global_state() != before:
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


def _fading(instance: ChannelModel, geometry: LinkGeometry) -> list[str]:
    """Contract 2: fading_enabled() is a bool; where the class implements sample_fading()
    (whether or not these parameters enable it, so that a hook off by default is checked
    too), it returns finite factors > 0 of the links' shape, the same from the same
    generator state, drawn from that generator only."""
    failures: list[str] = []
    enabled = _call(failures, "fading_enabled", instance.fading_enabled)
    if failures:
        return failures
    if not isinstance(enabled, bool | np.bool_):
        return [f"fading: fading_enabled() returned {type(enabled).__name__}, not a bool"]
    if not implements_fading(type(instance)):
        return failures
    los = np.random.default_rng(3).random(SHAPE) < 0.5
    before = _global_state()
    draws = [_call(failures, "sample_fading", lambda: instance.sample_fading(
        geometry, los, np.random.default_rng(11))) for _ in range(2)]
    if _global_state() != before:
        failures.append("generator: sample_fading() drew from numpy's global generator; draw "
                        "only from the rng passed in")
    first, second = draws
    if first is None or second is None or not _array(failures, "sample_fading", first, SHAPE):
        return failures
    if not (first > 0).all():
        failures.append(f"positive: sample_fading() returned factors <= 0 (min "
                        f"{first.min():.3g}); a fading factor multiplies a power gain")
    elif not (isinstance(second, np.ndarray) and np.array_equal(first, second)):
        failures.append("reproducible: sample_fading() gave other draws from the same "
                        "generator state")
    return failures
