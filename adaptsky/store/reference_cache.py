"""The cache of the greedy evaluations' references (docs/training.md, "The reference cache"):
the oracle or best response of a scenario's evaluation layouts, searched once per machine
rather than once per process (best response for four UAVs takes about a quarter of an hour a
layout, and every run of a sweep or the suite would search it again).

One ``.npy`` file per reference in ``references/`` of the cache folder: ``ADAPTSKY_CACHE_DIR``,
else ``$XDG_CACHE_HOME/adaptsky``, else ``~/.cache/adaptsky``; ``ADAPTSKY_CACHE_DIR=off``
turns the cache off. A file is named by the SHA-256 of everything the search depends on: the
scenario's physics, the layouts' bytes, the source of the packages that search (``sim``,
``channels``, ``rollouts``, ``scenario``) and the channel plugin's package, version and
target; so a changed model, layout or plugin finds no file and searches again. Files are
read with ``allow_pickle=False`` (opening one never executes code) and used only with the
expected shape and dtype; they are written whole or not at all (atomic rename), and a cache
that cannot be written is skipped: the reference is then searched as before.
"""

from __future__ import annotations

import functools
import hashlib
import io
import os
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from adaptsky.channels.registry import plugin
from adaptsky.errors import AdaptskyError
from adaptsky.store.atomic import write_bytes_atomic

FloatArray = NDArray[np.float64]
CACHE_ENV = "ADAPTSKY_CACHE_DIR"
# the packages whose source a reference depends on
_SEARCH_PACKAGES = ("sim", "channels", "rollouts", "scenario")


def cache_folder() -> Path | None:
    """The cache's folder, or None when ``ADAPTSKY_CACHE_DIR=off``."""
    chosen = os.environ.get(CACHE_ENV, "")
    if chosen.lower() == "off":
        return None
    if chosen:
        return Path(chosen).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "adaptsky"


@functools.cache
def _source_digest() -> str:
    """SHA-256 of the search's source files, by path relative to the package."""
    package = Path(__file__).resolve().parents[1]
    digest = hashlib.sha256()
    for name in _SEARCH_PACKAGES:
        for path in sorted((package / name).rglob("*.py")):
            digest.update(path.relative_to(package).as_posix().encode())
            digest.update(path.read_bytes())
    return digest.hexdigest()


def reference_key(physics_json: str, channel_model: str, layouts_m: FloatArray) -> str:
    """The file name (without ``.npy``) of the reference of ``layouts_m`` under the physics
    ``physics_json`` (the scenario without name, description, agent and train)."""
    info = plugin(channel_model)
    digest = hashlib.sha256()
    for part in (physics_json, info.package, info.version, info.target, _source_digest(),
                 str(layouts_m.shape), str(layouts_m.dtype)):
        digest.update(part.encode())
        digest.update(b"\0")
    digest.update(np.ascontiguousarray(layouts_m).tobytes())
    return digest.hexdigest()


def reference_path(key: str) -> Path | None:
    """Where the reference ``key`` lives (None when the cache is off)."""
    folder = cache_folder()
    return None if folder is None else folder / "references" / f"{key}.npy"


def read_reference(key: str, count: int) -> FloatArray | None:
    """The cached reference (count,) of ``key``, or None: none cached, the cache off, or a
    file that is not one float64 vector of ``count`` (then searched again and rewritten)."""
    path = reference_path(key)
    if path is None or not path.is_file():
        return None
    try:
        values = np.load(path, allow_pickle=False)
    except (OSError, ValueError):
        return None
    if not isinstance(values, np.ndarray) or values.dtype != np.float64 or \
            values.shape != (count,):
        return None
    return values


def write_reference(key: str, values: FloatArray) -> Path | None:
    """Store ``values`` as the reference ``key``; its path, or None when the cache is off or
    cannot be written (nothing half-written is left)."""
    path = reference_path(key)
    if path is None:
        return None
    buffer = io.BytesIO()
    np.save(buffer, np.asarray(values, dtype=np.float64), allow_pickle=False)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        write_bytes_atomic(path, buffer.getbuffer())
    except (OSError, AdaptskyError):
        return None
    return path
