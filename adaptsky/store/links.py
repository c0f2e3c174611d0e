"""Which file a run path names. A run file may be reached through symbolic links
(``latest.h5 -> run-20261122-030415.h5``): reads, locks and rewrites all go to the file at the
links' end, so a rewrite replaces that file and leaves the link as it was. While this process
holds a run file's lock (:func:`pinned`), the path names the file it locked, even if the link
is moved to another file meanwhile. Links inside an HDF5 file are another matter: the
validator refuses them (``store.layout``)."""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

_pinned: dict[Path, Path] = {}  # absolute path as given -> the file it named when pinned


def _key(path: Path) -> Path:
    return Path(os.path.abspath(path))


def target(path: Path) -> Path:
    """The file ``path`` names: the one pinned for it, else the end of its symbolic links;
    ``path`` itself where it is no link, or a link that leads nowhere (a loop, a missing
    file: the caller's own checks say so)."""
    pinned_file = _pinned.get(_key(path))
    if pinned_file is not None:
        return pinned_file
    if not os.path.islink(path):
        return path
    try:
        return Path(os.path.realpath(path, strict=True))
    except OSError:
        return path


@contextmanager
def pinned(path: Path) -> Iterator[Path]:
    """While the block runs, :func:`target` of ``path`` stays the file it names now (yielded),
    wherever a link on the way is moved."""
    key, real = _key(path), target(path)
    previous = _pinned.get(key)
    _pinned[key] = real
    try:
        yield real
    finally:
        if previous is None:
            del _pinned[key]
        else:
            _pinned[key] = previous
