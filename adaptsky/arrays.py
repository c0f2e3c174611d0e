"""The one shape of nested data adaptsky stores and sends: a :data:`Tree`, a dict of numpy arrays,
scalars, strings and nested trees (checkpoints, trajectories; ``store.tree`` writes it to HDF5),
and :class:`Field`, one declared dataset of a stored tree (the run-file layout and each
algorithm's checkpoint declare theirs with it)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

Tree = dict[str, Any]
Dtype = Literal["float", "int", "bool"]
Shape = tuple[int | str, ...]


@dataclass(frozen=True)
class Field:
    """One dataset of a layout: its name, dtype kind, shape (sizes, or symbols such as ``N``
    that the stored scenario gives) and units (the ``units`` attribute written on it)."""

    name: str
    dtype: Dtype
    shape: Shape
    units: str = "1"
