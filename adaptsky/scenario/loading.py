"""Reading scenario files: TOML -> validated :class:`Scenario` with the plugin's params resolved.

Every problem becomes one ``file: field.path: message`` line in a :class:`ScenarioError`.
"""

from __future__ import annotations

import difflib
import os
import stat
import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import Any, get_args

from pydantic import BaseModel, ValidationError

from adaptsky.channels.contract import (
    ChannelModel,
    ChannelParams,
    carrier_parameter_hz,
    contract_version_of,
    declares_reciprocal_gains,
    default_carrier_hz,
    quantity_text,
    supported_range,
    supported_text,
)
from adaptsky.channels.registry import get_model_class
from adaptsky.errors import PluginError, ScenarioError
from adaptsky.scenario.agents import AGENT_MODELS, UNKNOWN_ALGORITHM
from adaptsky.scenario.models import Radio, Scenario
from adaptsky.scenario.overrides import apply_overrides


def _models_in(annotation: Any) -> list[type[BaseModel]]:
    """The Pydantic models an annotation names (through Optional, lists, Annotated, unions)."""
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return [annotation]
    return [model for arg in get_args(annotation) for model in _models_in(arg)]


def _keys_at(model: type[BaseModel] | None, where: tuple[str | int, ...]) -> list[str]:
    """The keys a table at ``where`` (an error's location below ``model``) may hold; [] where
    the location names no single model."""
    models = [model] if model is not None else []
    for part in where:
        if isinstance(part, str) and part in AGENT_MODELS and AGENT_MODELS[part] in models:
            models = [AGENT_MODELS[part]]  # the [agent] union's tag
            continue
        if isinstance(part, int) or len(models) != 1:
            models = models if isinstance(part, int) else []
            continue
        fields = models[0].model_fields
        if part in fields:
            models = _models_in(fields[part].annotation)
        else:
            return []
    return list(models[0].model_fields) if len(models) == 1 else []


def _unknown_key(model: type[BaseModel] | None, where: tuple[str | int, ...]) -> str:
    """"unknown key", with the closest allowed key where one is close (a typo)."""
    close = difflib.get_close_matches(str(where[-1]), _keys_at(model, where[:-1]), n=1)
    return f"unknown key; did you mean '{close[0]}'?" if close else "unknown key"


def validation_error_lines(source: str, error: ValidationError,
                           prefix: tuple[str | int, ...] = (),
                           model: type[BaseModel] | None = None) -> list[str]:
    """One ``source: field.path: message`` line per error; an unknown key of ``model`` (the
    validated model, None: no suggestions) names the closest allowed key."""
    lines = []
    for item in error.errors(include_url=False):
        where, message = item["loc"], item["msg"].removeprefix("Value error, ")
        if item["type"] == "extra_forbidden":
            message = _unknown_key(model, where)
        if where[:1] == ("agent",) and where[1:2] and where[1] in AGENT_MODELS:
            where = where[:1] + where[2:]  # the union's tag: agent.dqn.lr is agent.lr
        if item["type"] == UNKNOWN_ALGORITHM:
            where = (*where, "algorithm")
            message = (f"unknown algorithm {item['input'].get('algorithm')!r}; choose from "
                       f"{', '.join(AGENT_MODELS)}")
        elif item["type"] not in ("missing", "extra_forbidden") and "input" in item and (
                not isinstance(item["input"], dict)):
            shown = repr(item["input"])
            message = f"{message} (got {shown if len(shown) <= 60 else shown[:57] + '...'})"
        loc = ".".join(str(part) for part in (*prefix, *where))
        lines.append(f"{source}: {loc}: {message}" if loc else f"{source}: {message}")
    return lines


def parse_scenario(data: dict[str, Any], source: str = "<scenario>") -> Scenario:
    """Validate a scenario mapping; resolve ``channel.params`` with the named plugin's model,
    the ``[radio]`` keys it leaves out with the model's paper table (``default_radio``) and
    ``radio.carrier_hz`` with them (docs/scenario-format.md, ``[radio]``)."""
    try:
        scenario = Scenario.model_validate(data)
    except ValidationError as error:
        raise ScenarioError(validation_error_lines(source, error, model=Scenario)) from None
    try:
        model_class = get_model_class(scenario.channel.model)
    except PluginError as error:
        raise ScenarioError([f"{source}: channel.model: {error}"]) from None
    if scenario.users.height_m > 0 and contract_version_of(model_class) < 2:
        raise ScenarioError([
            f"{source}: users.height_m: channel model '{scenario.channel.model}' follows "
            f"plugin contract {contract_version_of(model_class)}, where users are on the "
            "ground; a user height needs a contract-2 model (docs/plugins.md, contract "
            "versions), or users.height_m = 0"])
    if scenario.channel.los == "geometric" and contract_version_of(model_class) < 3:
        raise ScenarioError([
            f"{source}: channel.los: 'geometric' needs a channel model of plugin contract 3, "
            f"which takes the buildings' LoS states; '{scenario.channel.model}' follows "
            f"contract {contract_version_of(model_class)} (docs/plugins.md, contract versions)"])
    radio, table_carrier_hz = _default_radio(scenario, model_class, source)
    scenario = scenario.model_copy(update={"radio": radio})
    _refuse_unsupported(scenario, model_class, scenario.radio.carrier_hz, source)
    params, carrier_hz = _channel_params(scenario, model_class, source, table_carrier_hz)
    if scenario.radio.carrier_hz is None:  # the carrier the model's defaults give
        _refuse_unsupported(scenario, model_class, carrier_hz, source)
    _refuse_two_fadings(scenario, model_class, params, source)
    _refuse_no_reciprocity(scenario, model_class, source)
    channel = scenario.channel.model_copy(update={"params": params.model_dump()})
    radio = scenario.radio.model_copy(update={"carrier_hz": carrier_hz})
    return scenario.model_copy(update={"channel": channel, "radio": radio})


def _default_radio(scenario: Scenario, model_class: type[ChannelModel], source: str
                   ) -> tuple[Radio, float | None]:
    """``[radio]`` with every key the scenario does not give taken from the channel model's
    paper table (its ``default_radio``; a model without one: the Radio defaults, the paper's
    mmWave Table I), and the table's carrier (resolved with the model's parameters, by
    :func:`_channel_params`)."""
    table = getattr(model_class, "default_radio", None)
    if table is None:
        return scenario.radio, None
    where = f"{source}: channel model '{scenario.channel.model}': default_radio"
    if not isinstance(table, Mapping):
        raise ScenarioError([f"{where}: {type(table).__name__} is not a table of [radio] keys; "
                             "fix the plugin (docs/plugins.md)"])
    try:
        paper = Radio.model_validate(dict(table))
    except ValidationError as error:
        lines = validation_error_lines(where, error, model=Radio)
        raise ScenarioError([f"{line}; fix the plugin (docs/plugins.md)"
                             for line in lines]) from None
    given = scenario.radio.model_fields_set
    taken = {key: getattr(paper, key) for key in table if key not in given}
    carrier_hz = taken.pop("carrier_hz", None)
    return scenario.radio.model_copy(update=taken), carrier_hz


def _refuse_unsupported(scenario: Scenario, model_class: type[ChannelModel],
                        carrier_hz: float | None, source: str) -> None:
    """One line for each shared setting outside what the channel model supports
    (docs/plugins.md, ``Supports``; a ``carrier_hz`` parameter's range limits the carrier)."""
    values = {"carrier_hz": ("radio.carrier_hz", carrier_hz),
              "bandwidth_hz": ("radio.bandwidth_hz", scenario.radio.bandwidth_hz),
              "user_height_m": ("users.height_m", scenario.users.height_m)}
    lines = []
    for setting, (key, value) in values.items():
        allowed = supported_range(model_class, setting)
        if value is None or allowed is None or allowed[0] <= value <= allowed[1]:
            continue
        unset = " (the default: radio.carrier_hz is not set)" if (
            setting == "carrier_hz" and scenario.radio.carrier_hz is None) else ""
        lines.append(f"{source}: {key}: {quantity_text(setting, value)}{unset}, but channel "
                     f"model '{scenario.channel.model}' supports "
                     f"{supported_text(setting, allowed)}; give {key} a value it supports, or "
                     "choose another model (adaptsky plugins list)")
    if lines:
        raise ScenarioError(lines)


def _refuse_no_reciprocity(scenario: Scenario, model_class: type[ChannelModel],
                           source: str) -> None:
    """Refuse the uplink (docs/model.md §17) with a channel model that does not state its
    gains hold both ways (``Supports(reciprocal=True)``, docs/plugins.md)."""
    if scenario.uplink and not declares_reciprocal_gains(model_class):
        raise ScenarioError([
            f"{source}: radio.direction: 'uplink', but channel model "
            f"'{scenario.channel.model}' does not state that its gains hold from the users to "
            "the UAV (Supports(reciprocal=True), docs/plugins.md); use 'downlink', or a model "
            "that states it (adaptsky plugins list)"])


def _refuse_two_fadings(scenario: Scenario, model_class: type[ChannelModel],
                       params: ChannelParams, source: str) -> None:
    """Refuse built-in fading (docs/model.md §11) on a channel model that draws its own with
    these parameters (plugin contract 2's ``fading_enabled()``): one link would fade twice."""
    built_in = scenario.channel.fading.model
    if built_in == "none" or contract_version_of(model_class) < 2:
        return
    if model_class(params).fading_enabled():
        raise ScenarioError([
            f"{source}: channel.fading.model: '{built_in}', but channel model "
            f"'{scenario.channel.model}' draws its own fading with these channel.params; "
            "every link would fade twice: set channel.fading.model = 'none', or turn the "
            "model's fading off in channel.params (adaptsky plugins show "
            f"{scenario.channel.model})"])


def _channel_params(scenario: Scenario, model_class: type[ChannelModel], source: str,
                    table_hz: float | None = None) -> tuple[ChannelParams, float]:
    """The model's validated parameters and the run's carrier f_c.

    A model with a ``carrier_hz`` parameter shares it with ``[radio]``: given in one place,
    the other takes it; given in both, they must agree; given in neither, the carrier of the
    model's paper table ``table_hz`` where it has one, else the parameter's default. Otherwise
    f_c is ``radio.carrier_hz`` or, unset, ``table_hz``, the one carrier the model declares
    (``Supports``), else the paper's 28 GHz.
    """
    data, radio_hz = dict(scenario.channel.params), scenario.radio.carrier_hz
    shared = "carrier_hz" in model_class.Params.model_fields
    given_hz = data.get("carrier_hz")
    if shared and radio_hz is None and given_hz is None and table_hz is not None:
        data["carrier_hz"] = table_hz
    if shared and radio_hz is not None:
        if given_hz is not None and given_hz != radio_hz:
            raise ScenarioError([f"{source}: channel.params.carrier_hz: {given_hz!r} Hz "
                                 f"differs from radio.carrier_hz = {radio_hz!r} Hz; give the "
                                 "carrier once, in [radio]"])
        data["carrier_hz"] = radio_hz
    try:
        params = model_class.Params.model_validate(data)
    except ValidationError as error:
        lines = validation_error_lines(source, error, ("channel", "params"), model_class.Params)
        if shared and radio_hz is not None and given_hz is None:  # the carrier came from [radio]
            lines = [line.replace(": channel.params.carrier_hz: ", ": radio.carrier_hz: ")
                     + f" (the range of channel model '{scenario.channel.model}')"
                     if ": channel.params.carrier_hz: " in line else line for line in lines]
        raise ScenarioError(lines) from None
    value = carrier_parameter_hz(params)
    if value is not None:
        return params, value
    if radio_hz is not None:
        return params, radio_hz
    return params, default_carrier_hz(model_class) if table_hz is None else table_hz


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate the scenario file at ``path``."""
    return load_scenario_with_text(path)[0]


def load_scenario_with_text(path: str | Path) -> tuple[Scenario, str]:
    """The validated scenario and the file's text (kept verbatim in run files)."""
    text = read_scenario_text(path)
    return parse_scenario(parse_toml(text, str(path)), str(path)), text


def load_scenario_with_overrides(path: str | Path, set_values: list[str] | None = None
                                 ) -> tuple[Scenario, str]:
    """The scenario file at ``path`` with the ``--set section.key=value`` overrides
    ``set_values`` applied, validated as one file (as ``train --set`` reads it), and the
    source its lines name: the file, or ``FILE with --set``."""
    return parse_with_overrides(read_scenario_text(path), path, set_values)


def parse_with_overrides(text: str, path: str | Path, set_values: list[str] | None = None
                         ) -> tuple[Scenario, str]:
    """:func:`load_scenario_with_overrides` of the text ``text`` read from ``path``."""
    source = str(path)
    data = parse_toml(text, source)
    if set_values:
        data = apply_overrides(data, set_values, source)
        source = f"{path} with --set"
    return parse_scenario(data, source), source


MAX_FILE_BYTES = 1 << 20  # scenario and experiment files are a few kB
HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"  # the first bytes of every run and eval file


def _hdf5_line(path: str | Path, what: str) -> str:
    """The line for an HDF5 file (a run or eval file) given where TOML was expected."""
    hint = (f"; to continue the run: adaptsky train --resume {_shown(path)}"
            if what == "scenario file" else "")
    return (f"{_shown(path)}: cannot read {what}: it is an HDF5 file (an adaptsky run or eval "
            f"file), not TOML{hint}")


def read_scenario_text(path: str | Path, what: str = "scenario file") -> str:
    """The text of a scenario (or experiment) file; one line if it cannot be read. Only a
    regular file of at most 1 MiB is read (a FIFO would block, /dev/zero never end)."""
    try:
        handle = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
        try:
            info = os.fstat(handle)
            if not stat.S_ISREG(info.st_mode):
                kind = ("is a folder" if stat.S_ISDIR(info.st_mode) else
                        "is not a regular file (a pipe, device or socket)")
                raise ScenarioError([f"{_shown(path)}: cannot read {what}: {kind}"])
            data = os.read(handle, len(HDF5_SIGNATURE))
            if data == HDF5_SIGNATURE:
                raise ScenarioError([_hdf5_line(path, what)])
            if info.st_size > MAX_FILE_BYTES:
                raise ScenarioError([f"{_shown(path)}: cannot read {what}: {info.st_size} bytes "
                                     f"is too large (at most {MAX_FILE_BYTES})"])
            data += os.read(handle, MAX_FILE_BYTES + 1)
        finally:
            os.close(handle)
        return data.decode("utf-8")
    except ScenarioError:
        raise
    except Exception as error:  # OSError, UnicodeDecodeError, ValueError (a NUL in the path)...
        raise ScenarioError([f"{_shown(path)}: cannot read {what}: {_reason(error)}"]) from None


def parse_toml(text: str, source: str) -> dict[str, Any]:
    """The TOML document ``text``; one line naming ``source`` whatever the parser raises
    (a TOMLDecodeError, a RecursionError on arrays nested hundreds deep, ...)."""
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:
        raise ScenarioError([f"{source}: invalid TOML: {error}"]) from None
    except RecursionError:
        raise ScenarioError([f"{source}: invalid TOML: nested too deeply for the parser; "
                             "scenario and experiment files need a few levels"]) from None
    except Exception as error:  # whatever else the parser may raise
        raise ScenarioError([f"{source}: cannot parse TOML: {_reason(error)}"]) from None


def _shown(path: str | Path) -> str:
    """``path`` printable on one line (control characters escaped)."""
    text = str(path)
    return text if text.isprintable() else repr(text)[1:-1]


def _reason(error: BaseException) -> str:
    """An exception as a short one-line reason."""
    if isinstance(error, OSError) and error.strerror:
        return error.strerror
    text = " ".join(str(error).split()) or type(error).__name__
    return text if len(text) <= 200 else text[:197] + "..."
