"""Keys that choose which keys of their table are read: a model, an algorithm, a placement.

A ``--set`` that changes one (``--set channel.fading.model=none`` on a Rician scenario) drops
the keys of the old choice that the new one does not read (``k0_db``, ``k90_db``,
``correlation``), which validation would otherwise refuse, and says which in one note; a key
typed in the same command is never dropped, so validation still refuses it
(docs/scenario-format.md, "Overrides").
"""

from __future__ import annotations

from collections.abc import Callable, Collection
from dataclasses import dataclass
from typing import Any

from adaptsky.scenario.agents import AGENT_MODELS, DEFAULT_ALGORITHM
from adaptsky.scenario.models import MOBILITY_KEYS

FADING_KEYS: dict[str, tuple[str, ...]] = {
    "none": (),
    "rayleigh": ("correlation",),
    "rician": ("k0_db", "k90_db", "correlation"),
}
"""The keys of ``[channel.fading]`` each fading model reads besides ``model`` (models.Fading)."""
BUILDINGS_KEYS: dict[str, tuple[str, ...]] = {
    "none": (),
    "generated": ("city", "built_up_ratio", "buildings_per_km2", "height_scale_m"),
    "listed": ("building",),
}
"""The keys of ``[world]`` each ``buildings`` reads besides ``buildings`` and ``seed``."""
PLACEMENT_KEYS: dict[str, tuple[str, ...]] = {
    "listed": ("positions_m",),
    "uniform": (),
    "fresh": (),
    "hotspots": ("hotspots", "spread_m"),
}
"""The keys of ``[users]`` each placement reads among those only some read (models.Users)."""
ASSOCIATION_KEYS: dict[str, tuple[str, ...]] = {"kmeans": (), "listed": ("uav",)}
"""The keys of ``[users]`` each association reads among those only some read."""


@dataclass(frozen=True)
class Switch:
    """``key`` chooses which keys of ``table`` are read; ``default`` where it is absent (one
    whose keys, where the file gives them, are those the absent key implies: ``listed``
    placement with ``positions_m``)."""

    key: tuple[str, ...]
    table: tuple[str, ...]
    default: str
    reads: Callable[[str], Collection[str] | None]
    """The keys of ``table`` a choice reads among those the switch decides; None for a value
    that is no choice (validation says so and nothing is dropped)."""


def _from(keys: dict[str, tuple[str, ...]]) -> Callable[[str], Collection[str] | None]:
    return keys.get


def _agent_keys(algorithm: str) -> Collection[str] | None:
    model = AGENT_MODELS.get(algorithm)
    return None if model is None else tuple(model.model_fields)


def _channel_params(model: str) -> Collection[str] | None:
    """The parameters of channel model ``model``; None where it does not load (the scenario's
    validation reports that)."""
    from adaptsky.channels.registry import get_model_class
    try:
        return tuple(get_model_class(model).Params.model_fields)
    except Exception:  # an unknown or broken plugin: validation names it
        return None


SWITCHES: tuple[Switch, ...] = (
    Switch(("channel", "fading", "model"), ("channel", "fading"), "none", _from(FADING_KEYS)),
    Switch(("users", "mobility", "model"), ("users", "mobility"), "static",
           _from(MOBILITY_KEYS)),
    Switch(("agent", "algorithm"), ("agent",), DEFAULT_ALGORITHM, _agent_keys),
    Switch(("world", "buildings"), ("world",), "none", _from(BUILDINGS_KEYS)),
    Switch(("users", "placement"), ("users",), "listed", _from(PLACEMENT_KEYS)),
    Switch(("users", "association"), ("users",), "listed", _from(ASSOCIATION_KEYS)),
    Switch(("channel", "model"), ("channel", "params"), "mmwave-nyc", _channel_params),
)
"""Every key that chooses the keys of a table (a test checks each against the models)."""


def _at(data: dict[str, Any], path: tuple[str, ...]) -> Any:
    """The value at ``path`` in nested tables; None where a part is missing or no table."""
    value: Any = data
    for part in path:
        if not isinstance(value, dict):
            return None
        value = value.get(part)
    return value


def _typed(paths: list[list[str]], table: tuple[str, ...]) -> set[str] | None:
    """The keys of ``table`` the overrides ``paths`` set; None where one sets the table, or a
    table above it, whole (then every key in it was typed)."""
    keys: set[str] = set()
    for path in paths:
        if tuple(path[:len(table)]) == table[:len(path)] and len(path) <= len(table):
            return None
        if tuple(path[:len(table)]) == table:
            keys.add(path[len(table)])
    return keys


def drop_unread(before: dict[str, Any], after: dict[str, Any], paths: list[list[str]],
                source: str) -> list[str]:
    """Drop from ``after`` (``before`` with the overrides ``paths`` applied) the keys that a
    switch's old choice read and its new one does not, unless an override typed them; one
    note per switch that dropped keys."""
    notes = []
    for switch in SWITCHES:
        old, new = (_at(data, switch.key) for data in (before, after))
        old, new = (switch.default if value is None else value for value in (old, new))
        table, typed = _at(after, switch.table), _typed(paths, switch.table)
        if old == new or not isinstance(table, dict) or typed is None or not all(
                isinstance(value, str) for value in (old, new)):
            continue
        old_reads, new_reads = switch.reads(old), switch.reads(new)
        if old_reads is None or new_reads is None:
            continue
        dropped = [key for key in table if key in old_reads and key not in new_reads
                   and key not in typed]
        for key in dropped:
            del table[key]
        if dropped:
            keys = [".".join((*switch.table, key)) for key in dropped]
            listed = " and ".join([", ".join(keys[:-1]), keys[-1]] if len(keys) > 1 else keys)
            notes.append(f"{source}: dropped {listed}: {'.'.join(switch.key)} = '{new}' does "
                         f"not read {'them' if len(keys) > 1 else 'it'} ('{old}' did)")
    return notes
