"""TOML text of resolved scenarios, as a person writes it: short arrays and pairs such as
``[x, y]`` on one line, longer arrays one element (or a line's worth of numbers) per line, and
floats in their shortest exact form, ``2e9`` rather than ``2000000000.0``.

Strings and keys that need quoting are written by tomli-w (escaped as TOML requires, so every
string, control characters included, reads back as it was); every float reads back as the same
float (its digits are Python's shortest round-trip ``repr``).
"""

from __future__ import annotations

import math
import re
from typing import Any

import tomli_w

WIDTH = 100  # the longest line an array is kept on, in characters
INDENT = "    "
_BARE_KEY = re.compile(r"[A-Za-z0-9_-]+")
_SCIENTIFIC_FROM = 1e6  # integral floats this large may be written as 2e9


def _without_none(value: Any) -> Any:
    """``value`` with every None entry of its tables left out (TOML has no null)."""
    if isinstance(value, dict):
        return {key: _without_none(item) for key, item in value.items() if item is not None}
    if isinstance(value, list | tuple):
        return [_without_none(item) for item in value]
    return value


def dumps(data: dict[str, Any]) -> str:
    """TOML text of ``data``; None values are left out."""
    return "\n".join(_tables(_without_none(data), ()))


def toml_value(value: Any) -> str:
    """One TOML value as text, e.g. for a ``--set key=value`` override."""
    return tomli_w.dumps({"v": _without_none(value)}).removeprefix("v = ").rstrip("\n")


def _tables(table: dict[str, Any], path: tuple[str, ...]) -> list[str]:
    """The blocks of ``table`` at ``path``: its own keys under its header, then its sub-tables
    (a header is left out for a table that holds only sub-tables, as TOML allows)."""
    values = {key: value for key, value in table.items() if not isinstance(value, dict)}
    children = {key: value for key, value in table.items() if isinstance(value, dict)}
    lines = [f"{_key(key)} = {_value(value, len(_key(key)) + 3)}"
             for key, value in values.items()]
    blocks = []
    if path and (values or not children):
        lines.insert(0, f"[{'.'.join(_key(part) for part in path)}]")
    if lines:
        blocks.append("\n".join(lines) + "\n")
    for key, child in children.items():
        blocks += _tables(child, (*path, key))
    return blocks


def _key(key: str) -> str:
    return key if _BARE_KEY.fullmatch(key) else toml_value(key)


def _value(value: Any, column: int) -> str:
    """``value`` as TOML text, starting at ``column`` of its line."""
    if isinstance(value, float):
        return float_text(value)
    if isinstance(value, list):
        return _array(value, column)
    return toml_value(value)


def _array(items: list[Any], column: int) -> str:
    """One line where it fits in WIDTH; else one element per line (a pair ``[x, y]`` each),
    or for plain numbers and strings as many as fit on each line."""
    texts = [_value(item, len(INDENT)) for item in items]
    one_line = f"[{', '.join(texts)}]"
    if column + len(one_line) <= WIDTH and "\n" not in one_line:
        return one_line
    rows = texts if any(isinstance(item, list | dict) for item in items) else _packed(texts)
    return "[\n" + "".join(f"{INDENT}{row},\n" for row in rows) + "]"


def _packed(texts: list[str]) -> list[str]:
    """``texts`` joined by ", " into rows that fit in WIDTH after the indent."""
    rows = [texts[0]]
    for text in texts[1:]:
        if len(INDENT) + len(rows[-1]) + len(text) + 3 > WIDTH:
            rows.append(text)
        else:
            rows[-1] += f", {text}"
    return rows


def float_text(value: float) -> str:
    """A float as a person writes it and TOML reads back exactly: ``2e9``, ``3.5e9``,
    ``1e-5``, ``-84.0``, ``0.001`` (the digits of ``repr``, the shorter of its plain and
    scientific forms for integral values from 1e6)."""
    if not math.isfinite(value):
        return toml_value(value)
    text = repr(value)
    mantissa, _, exponent = text.partition("e")
    if exponent:  # 1e-05 -> 1e-5, 1.5e+20 -> 1.5e20
        return f"{mantissa}e{int(exponent)}"
    if abs(value) < _SCIENTIFIC_FROM or not value.is_integer():
        return text
    sign, digits = ("-", text[1:-2]) if value < 0 else ("", text[:-2])  # without ".0"
    head = digits.rstrip("0")
    scientific = f"{sign}{head[0]}{'.' + head[1:] if len(head) > 1 else ''}e{len(digits) - 1}"
    return scientific if len(scientific) < len(text) else text
