"""Nested dicts of numpy arrays and scalars <-> HDF5 groups: arrays become datasets, strings
and numbers become attributes. Nothing is pickled. Every dataset carries a checksum
(``store.checksums``)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import h5py
import numpy as np

from adaptsky.arrays import Tree
from adaptsky.store.checksums import CHECKED_ARRAY, seal


def _write_array(group: h5py.Group, key: str, value: np.ndarray, compress: bool) -> None:
    """Overwrite in place where the stored dataset can take ``value`` (so a file rewritten at
    every checkpoint does not grow), else create it, resizable along its first axis."""
    existing = group.get(key)
    if isinstance(existing, h5py.Dataset) and existing.dtype == value.dtype and (
            existing.shape == value.shape or (
                value.ndim >= 1 and existing.maxshape[0] is None
                and existing.shape[1:] == value.shape[1:])):
        if existing.shape != value.shape:
            existing.resize(value.shape[0], axis=0)
        if value.size:
            existing[...] = value
        seal(existing, value)
        return
    if existing is not None:
        del group[key]
    if value.ndim == 0:  # HDF5 cannot chunk (nor filter) it: its CRC-32 alone
        seal(group.create_dataset(key, data=value), value)
        return
    options = {"compression": "gzip", "shuffle": True} if compress else {}
    seal(group.create_dataset(key, data=value, maxshape=(None, *value.shape[1:]),
                              **CHECKED_ARRAY, **options), value)


def write_tree(group: h5py.Group, tree: Tree, compress: bool = False,
               units: Mapping[str, str] | None = None) -> None:
    """Write ``tree`` below ``group``, replacing what is there under the same names; with
    ``units`` every dataset gets the attribute ``units``: ``units[name]``, else "1"."""
    for key, value in tree.items():
        if isinstance(value, dict):
            if key in group.attrs:
                del group.attrs[key]
            write_tree(group.require_group(key), value, compress, units)
        elif isinstance(value, np.ndarray):
            _write_array(group, key, value, compress)
            if units is not None:
                group[key].attrs["units"] = units.get(key, "1")
        elif isinstance(value, str | int | float | bool | np.integer | np.floating | np.bool_):
            if key in group:
                del group[key]
            group.attrs[key] = value
        else:
            raise TypeError(f"cannot store {type(value).__name__} at {group.name}/{key}")


def _plain(value: Any) -> Any:
    if isinstance(value, bytes):
        return value.decode()
    if isinstance(value, np.generic):
        return value.item()
    return value


def read_tree(group: h5py.Group) -> Tree:
    """Inverse of :func:`write_tree`."""
    tree: Tree = {key: _plain(value) for key, value in group.attrs.items()}
    for key, item in group.items():
        tree[key] = read_tree(item) if isinstance(item, h5py.Group) else item[()]
    return tree
