"""Atomic rewriting of HDF5 files: changes go to a copy that replaces the file in one rename."""

from __future__ import annotations

import os
import shutil
from collections.abc import Iterator
from contextlib import contextmanager
from datetime import UTC, datetime
from pathlib import Path

import h5py


@contextmanager
def rewrite(path: Path, fresh: bool = False) -> Iterator[h5py.File]:
    """Open a copy of ``path`` (or a new file, always with ``fresh``) for writing; on success
    it replaces ``path``."""
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    try:
        if path.exists() and not fresh:
            shutil.copyfile(path, tmp)
        with h5py.File(tmp, "a") as file:
            yield file
        with open(tmp, "rb+") as handle:
            os.fsync(handle.fileno())
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def remove_stale_copies(path: Path) -> None:
    """Delete copies left by a process killed while writing (they are never the real file)."""
    for stale in path.parent.glob(f".{path.name}.tmp-*"):
        stale.unlink(missing_ok=True)


def string_dataset(group: h5py.Group, name: str, text: str) -> None:
    group.create_dataset(name, data=text, dtype=h5py.string_dtype())


def utc_timestamp() -> str:
    """Now, as stored in ``created_utc`` attributes: 2026-11-22T03:04:15Z."""
    return datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ")


def fresh_path(directory: Path, prefix: str) -> Path:
    """<directory>/<prefix>-<local time>.h5, with a -2, -3, ... suffix rather than an
    existing file's name."""
    stem = f"{prefix}-{datetime.now().strftime('%Y%m%d-%H%M%S')}"
    path, n = directory / f"{stem}.h5", 1
    while path.exists():
        n += 1
        path = directory / f"{stem}-{n}.h5"
    return path


def write_bytes_atomic(path: Path, data: bytes) -> None:
    """Write ``data`` to a copy that replaces ``path`` in one rename: never half written."""
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    try:
        tmp.write_bytes(data)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def write_text_atomic(path: Path, text: str) -> None:
    write_bytes_atomic(path, text.encode("utf-8"))
