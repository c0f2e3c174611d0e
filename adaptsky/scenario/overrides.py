"""``--set section.key=value`` overrides of a scenario, validated exactly like the file.

A value is read as a TOML value (``0.5``, ``true``, ``[0, 1]``, ``"text"``); anything that is
not valid TOML is taken as a plain string, so ``--set channel.los=sampled`` works unquoted.
"""

from __future__ import annotations

import copy
import tomllib
from typing import Any

from adaptsky.errors import ScenarioError
from adaptsky.scenario.switches import drop_unread


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
    key or a wrong type is reported as ``source: section.key: message``. An override that
    changes a model (``channel.fading.model``, ``agent.algorithm``, ...) drops the keys the
    new one does not read (``adaptsky.scenario.switches``; :func:`override_notes` says which).
    """
    return overridden(data, items, source)[0]


def override_notes(data: dict[str, Any], items: list[str], source: str) -> list[str]:
    """One line per model an override changes whose old keys were dropped (those the new
    model does not read), naming them; [] where nothing was dropped."""
    return overridden(data, items, source)[1]


def overridden(data: dict[str, Any], items: list[str], source: str
               ) -> tuple[dict[str, Any], list[str]]:
    """:func:`apply_overrides` of ``data`` and :func:`override_notes`, in one pass."""
    result = copy.deepcopy(data)
    paths: list[list[str]] = []
    for item in items:
        path, value = split_override(item, source)
        paths.append(path)
        table = result
        for depth, part in enumerate(path[:-1]):
            child = table.setdefault(part, {})
            if not isinstance(child, dict):
                where = ".".join(path[:depth + 1])
                raise ScenarioError([f"{source}: --set {item!r}: {where} is a value, "
                                     "not a table"])
            table = child
        table[path[-1]] = value
    return result, drop_unread(data, result, paths, source)
