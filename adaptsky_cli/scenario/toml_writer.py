"""A small TOML writer for resolved scenarios (tables of scalars, lists and nested tables)."""

from __future__ import annotations

import json
import math
from typing import Any


def _value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_value(item) for item in value) + "]"
    raise TypeError(f"cannot write {type(value).__name__} as a TOML value")


def dumps(data: dict[str, Any], _table: str = "") -> str:
    """TOML text of ``data``; None values are left out (TOML has no null)."""
    lines: list[str] = []
    tables: list[tuple[str, dict[str, Any]]] = []
    for key, value in data.items():
        if value is None:
            continue
        if isinstance(value, dict):
            tables.append((f"{_table}.{key}" if _table else key, value))
        else:
            lines.append(f"{key} = {_value(value)}")
    parts = []
    if _table:
        parts.append(f"[{_table}]")
    parts.extend(lines)
    text = "\n".join(parts)
    for name, table in tables:
        text += ("\n\n" if text else "") + dumps(table, name)
    return text
