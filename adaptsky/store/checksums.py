"""Checksums of stored data, verified on reading: HDF5's Fletcher32 filter on every dataset
HDF5 can chunk (arrays of one or more axes: HDF5 checks a chunk whenever it reads it), and on
every dataset a CRC-32 of its whole value in the attribute ``crc32`` (what Fletcher32 cannot
see: a chunk zeroed whole with its checksum, numbers of shape (), texts). Files written before
checksums have neither and read as before."""

from __future__ import annotations

import math
import zlib
from collections.abc import Callable
from typing import Any

import h5py
import numpy as np

CRC_ATTR = "crc32"
# the creation options of an array dataset of one axis or more (chunked, so it can grow)
CHECKED_ARRAY: dict[str, Any] = {"chunks": True, "fletcher32": True}
MISMATCH = "checksum mismatch (its stored bytes changed after they were written)"
# a dataset larger than this is read in parts when verified, not whole
_WHOLE_BYTES = 1 << 26
# one declared larger than this (more than any array adaptsky writes: never read whole) is
# verified by its stored chunks' Fletcher32 alone
_CRC_BYTES = 1 << 32


def _little_endian(value: Any) -> Any:
    array = np.asarray(value)
    return np.ascontiguousarray(array.astype(array.dtype.newbyteorder("<"), copy=False))


def crc32_of(value: Any, running: int = 0) -> int:
    """CRC-32 of a text (its UTF-8 bytes), bytes, or an array's little-endian bytes in C
    order (``running``: of what came before)."""
    if isinstance(value, str):
        value = value.encode("utf-8")
    elif not isinstance(value, bytes):
        value = _little_endian(value).reshape(-1).view(np.uint8)  # (no copy)
    return zlib.crc32(value, running)


def seal(dataset: h5py.Dataset, value: Any) -> None:
    """Store the CRC-32 of ``value`` (all that ``dataset`` holds) on it."""
    dataset.attrs[CRC_ATTR] = np.int64(crc32_of(value))


def _has_fletcher32(dataset: h5py.h5d.DatasetID) -> bool:
    plist = dataset.get_create_plist()
    return any(plist.get_filter(i)[0] == h5py.h5z.FILTER_FLETCHER32
               for i in range(plist.get_nfilters()))


def _stored_crc(dataset: h5py.h5d.DatasetID) -> int | None:
    key = CRC_ATTR.encode()
    if not h5py.h5a.exists(dataset, key):
        return None
    stored = np.zeros((), dtype=np.int64)
    try:
        h5py.h5a.open(dataset, key).read(stored)
    except (OSError, TypeError, ValueError):
        return -1  # not a number: never a CRC-32, so a mismatch
    return int(stored)


def _crc_of_stored(dataset: h5py.h5d.DatasetID) -> int | None:
    """The CRC-32 of what ``dataset`` holds, read once (in blocks of rows when large); None
    for one declared too large to read whole, whose stored chunks are read instead."""
    if dataset.shape is None:  # an empty dataspace: nothing stored
        return crc32_of(b"")
    if dataset.shape == () or h5py.check_string_dtype(dataset.dtype) is not None:
        return crc32_of(h5py.Dataset(dataset)[()])
    shape = tuple(int(n) for n in dataset.shape)
    size = math.prod(shape) * dataset.dtype.itemsize
    if size <= _WHOLE_BYTES:
        value = np.empty(shape, dtype=dataset.dtype)
        if value.size:
            dataset.read(h5py.h5s.ALL, h5py.h5s.ALL, value)
        return crc32_of(value)
    whole = h5py.Dataset(dataset)
    if size <= _CRC_BYTES:
        rows, running = max(1, _WHOLE_BYTES * shape[0] // size), 0
        for start in range(0, shape[0], rows):
            running = crc32_of(whole[start:start + rows], running)
        return running
    for index in range(dataset.get_num_chunks() if whole.chunks else 0):
        offset = dataset.get_chunk_info(index).chunk_offset
        whole[tuple(slice(start, min(start + extent, length))
                    for start, extent, length in zip(offset, whole.chunks, shape, strict=True))]
    return None


def damage(dataset: h5py.h5d.DatasetID) -> str | None:
    """What is wrong with ``dataset``'s stored bytes, read once against its checksums (None:
    they match, or it has none, as in files written before checksums: it is not read)."""
    stored = _stored_crc(dataset)
    if stored is None and not _has_fletcher32(dataset):
        return None
    try:
        found = _crc_of_stored(dataset)
    except (OSError, TypeError, ValueError) as error:
        # where Fletcher32 fails, HDF5 says "... (filter returned failure during read)"
        reason = (str(error).splitlines() or ["unknown error"])[0]
        return MISMATCH if "filter returned failure" in reason else f"cannot be read ({reason})"
    if stored is not None and found is not None and found != stored:
        return MISMATCH
    return None


def first_damage(group: h5py.Group, skip: Callable[[str], bool] = lambda name: False
                 ) -> tuple[str, str] | None:
    """The first damaged dataset below ``group`` (in name order) and what is wrong, or None;
    groups whose name ``skip`` accepts are left out. (HDF5's low-level API: a fraction of
    the cost of h5py's objects.)"""
    return _first_damage(group.id, "" if group.name == "/" else group.name, skip)


def _first_damage(group: h5py.h5g.GroupID, name: str, skip: Callable[[str], bool]
                  ) -> tuple[str, str] | None:
    for key in sorted(group):
        if group.links.get_info(key).type != h5py.h5l.TYPE_HARD:
            continue  # links are the validator's to refuse
        where, item = f"{name}/{key.decode('utf-8', 'replace')}", h5py.h5o.open(group, key)
        if isinstance(item, h5py.h5g.GroupID):
            found = None if skip(where) else _first_damage(item, where, skip)
        elif isinstance(item, h5py.h5d.DatasetID):
            problem = damage(item)
            found = None if problem is None else (where, problem)
        else:
            found = None
        if found is not None:
            return found
    return None
