"""Reading scenario files: TOML -> validated :class:`Scenario` with the plugin's params resolved.

Every problem becomes one ``file: field.path: message`` line in a :class:`ScenarioError`.
"""

from __future__ import annotations

import os
import stat
import tomllib
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from adaptsky.channels.contract import (
    DEFAULT_CARRIER_HZ,
    ChannelModel,
    ChannelParams,
    carrier_parameter_hz,
    contract_version_of,
)
from adaptsky.channels.registry import get_model_class
from adaptsky.errors import PluginError, ScenarioError
from adaptsky.scenario.agents import AGENT_MODELS, UNKNOWN_ALGORITHM
from adaptsky.scenario.models import Scenario


def _error_lines(source: str, error: ValidationError,
                 prefix: tuple[str | int, ...] = ()) -> list[str]:
    lines = []
    for item in error.errors(include_url=False):
        where = item["loc"]
        if where[:1] == ("agent",) and where[1:2] and where[1] in AGENT_MODELS:
            where = where[:1] + where[2:]  # the union's tag: agent.dqn.lr is agent.lr
        loc = ".".join(str(part) for part in (*prefix, *where))
        message = item["msg"].removeprefix("Value error, ")
        if item["type"] == "extra_forbidden":
            message = "unknown key"
        elif item["type"] == UNKNOWN_ALGORITHM:
            loc = ".".join(str(part) for part in (*prefix, *where, "algorithm"))
            message = (f"unknown algorithm {item['input'].get('algorithm')!r}; choose from "
                       f"{', '.join(AGENT_MODELS)}")
        elif "input" in item and item["type"] not in ("missing",) and not isinstance(
                item["input"], dict):
            shown = repr(item["input"])
            message = f"{message} (got {shown if len(shown) <= 60 else shown[:57] + '...'})"
        lines.append(f"{source}: {loc}: {message}" if loc else f"{source}: {message}")
    return lines


def parse_scenario(data: dict[str, Any], source: str = "<scenario>") -> Scenario:
    """Validate a scenario mapping; resolve ``channel.params`` with the named plugin's model
    and ``radio.carrier_hz`` with them (docs/scenario-format.md, ``[radio]``)."""
    try:
        scenario = Scenario.model_validate(data)
    except ValidationError as error:
        raise ScenarioError(_error_lines(source, error)) from None
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
    params, carrier_hz = _channel_params(scenario, model_class, source)
    channel = scenario.channel.model_copy(update={"params": params.model_dump()})
    radio = scenario.radio.model_copy(update={"carrier_hz": carrier_hz})
    return scenario.model_copy(update={"channel": channel, "radio": radio})


def _channel_params(scenario: Scenario, model_class: type[ChannelModel], source: str
                    ) -> tuple[ChannelParams, float]:
    """The model's validated parameters and the run's carrier f_c.

    A model with a ``carrier_hz`` parameter shares it with ``[radio]``: given in one place,
    the other takes it; given in both, they must agree. Otherwise f_c is ``radio.carrier_hz``
    or, unset, the paper's 28 GHz.
    """
    data, radio_hz = dict(scenario.channel.params), scenario.radio.carrier_hz
    shared = "carrier_hz" in model_class.Params.model_fields
    given_hz = data.get("carrier_hz")
    if shared and radio_hz is not None:
        if given_hz is not None and given_hz != radio_hz:
            raise ScenarioError([f"{source}: channel.params.carrier_hz: {given_hz!r} Hz "
                                 f"differs from radio.carrier_hz = {radio_hz!r} Hz; give the "
                                 "carrier once, in [radio]"])
        data["carrier_hz"] = radio_hz
    try:
        params = model_class.Params.model_validate(data)
    except ValidationError as error:
        lines = _error_lines(source, error, ("channel", "params"))
        if shared and radio_hz is not None and given_hz is None:  # the carrier came from [radio]
            lines = [line.replace(": channel.params.carrier_hz: ", ": radio.carrier_hz: ")
                     + f" (the range of channel model '{scenario.channel.model}')"
                     if ": channel.params.carrier_hz: " in line else line for line in lines]
        raise ScenarioError(lines) from None
    value = carrier_parameter_hz(params)
    if value is not None:
        return params, value
    return params, DEFAULT_CARRIER_HZ if radio_hz is None else radio_hz


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate the scenario file at ``path``."""
    return load_scenario_with_text(path)[0]


def load_scenario_with_text(path: str | Path) -> tuple[Scenario, str]:
    """The validated scenario and the file's text (kept verbatim in run files)."""
    text = read_scenario_text(path)
    return parse_scenario(parse_toml(text, str(path)), str(path)), text


MAX_FILE_BYTES = 1 << 20  # scenario and experiment files are a few kB


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
            if info.st_size > MAX_FILE_BYTES:
                raise ScenarioError([f"{_shown(path)}: cannot read {what}: {info.st_size} bytes "
                                     f"is too large (at most {MAX_FILE_BYTES})"])
            data = os.read(handle, MAX_FILE_BYTES + 1)
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
