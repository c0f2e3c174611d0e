"""The one shape of nested data adaptsky stores and sends: a :data:`Tree`, a dict of numpy arrays,
scalars, strings and nested trees (checkpoints, trajectories; ``store.tree`` writes it to HDF5)."""

from typing import Any

Tree = dict[str, Any]
