"""``--set section.key=value`` overrides of a scenario, validated exactly like the file.

A value is read as a TOML value (``0.5``, ``true``, ``[0, 1]``, ``"text"``); anything that is
not valid TOML is taken as a plain string, so ``--set channel.los=sampled`` works unquoted.
"""

from __future__ import annotations

import copy
import tomllib
from typing import Any

from adaptsky.errors import ScenarioError


def parse_value(text: str) -> Any:
    """The TOML value written in ``text``, or ``text`` itself if it is not one."""
    try:
        return tomllib.loads(f"value = {text}")["value"]
    except (tomllib.TOMLDecodeError, RecursionError):  # not TOML, or nested too deeply
        return text


def split_override(item: str, source: str) -> tuple[list[str], Any]:
    """``"agent.lr=1e-4"`` -> (["agent", "lr"], 0.0001); one clear line if malformed."""
    key, sep, value = item.partition("=")
    path = [part.strip() for part in key.split(".")]
    if not sep or not all(path):
        raise ScenarioError([f"{source}: --set {item!r}: expected section.key=value, "
                             "e.g. agent.lr=1e-4 or reward.min_se=1.5"])
    return path, parse_value(value.strip())


def apply_overrides(data: dict[str, Any], items: list[str], source: str) -> dict[str, Any]:
    """A copy of the scenario mapping ``data`` with every override applied, in order.

    Keys are not checked here: the result is validated like a scenario file, so an unknown
    key or a wrong type is reported as ``source: section.key: message``.
    """
    result = copy.deepcopy(data)
    for item in items:
        path, value = split_override(item, source)
        table = result
        for depth, part in enumerate(path[:-1]):
            child = table.setdefault(part, {})
            if not isinstance(child, dict):
                where = ".".join(path[:depth + 1])
                raise ScenarioError([f"{source}: --set {item!r}: {where} is a value, "
                                     "not a table"])
            table = child
        table[path[-1]] = value
    return result
