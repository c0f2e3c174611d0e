"""TOML text of resolved scenarios, written by tomli-w (keys quoted and strings escaped as
TOML requires, so every string, control characters included, reads back as it was)."""

from __future__ import annotations

from typing import Any

import tomli_w


def _without_none(value: Any) -> Any:
    """``value`` with every None entry of its tables left out (TOML has no null)."""
    if isinstance(value, dict):
        return {key: _without_none(item) for key, item in value.items() if item is not None}
    if isinstance(value, list | tuple):
        return [_without_none(item) for item in value]
    return value


def dumps(data: dict[str, Any]) -> str:
    """TOML text of ``data``; None values are left out."""
    return tomli_w.dumps(_without_none(data))


def toml_value(value: Any) -> str:
    """One TOML value as text, e.g. for a ``--set key=value`` override."""
    return tomli_w.dumps({"v": _without_none(value)}).removeprefix("v = ").rstrip("\n")
