"""The search cache (docs/training.md, "The search cache"): best response (for one UAV the
oracle) and the best OMA configuration of a scenario's layouts, searched once per machine
rather than once per process (best response for four UAVs takes about a quarter of an hour a
layout, and every stack of a sweep or the suite, and every evaluation of a baseline, would
search it again).

One ``.npz`` file per search in ``searches/`` of the cache folder: ``ADAPTSKY_CACHE_DIR``,
else ``$XDG_CACHE_HOME/adaptsky``, else ``~/.cache/adaptsky``; ``ADAPTSKY_CACHE_DIR=off``
turns the cache off. A file is named by the SHA-256 of everything the search depends on: the
method, the scenario's physics, the layouts' bytes, the source of the packages that search
(``sim``, ``channels``, ``rollouts``, ``scenario``) and the channel plugin's package, version
and target; so a changed model, layout or plugin finds no file and searches again. Files are
read with ``allow_pickle=False`` (opening one never executes code) and used only with the
expected shapes and dtypes; the process time per layout is the one measured when the search
ran. They are written whole or not at all (atomic rename), and a cache that cannot be written
is skipped: the search then runs as before.
"""

from __future__ import annotations

import functools
import hashlib
import io
import json
import os
import zipfile
from collections.abc import Callable
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from adaptsky.channels.registry import plugin
from adaptsky.errors import AdaptskyError
from adaptsky.rollouts.several_uavs import SearchResult
from adaptsky.scenario import Scenario
from adaptsky.store.atomic import write_bytes_atomic

FloatArray = NDArray[np.float64]
CACHE_ENV = "ADAPTSKY_CACHE_DIR"
# the packages whose source a search depends on
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


def search_key(physics_json: str, channel_model: str, layouts_m: FloatArray,
               method: str = "best-response") -> str:
    """The file name (without ``.npz``) of the search ``method`` (``"best-response"``, for one
    UAV the oracle, or ``"oma"``) on ``layouts_m`` under the physics ``physics_json`` (the
    scenario without name, description, agent and train)."""
    info = plugin(channel_model)
    digest = hashlib.sha256()
    for part in (method, physics_json, info.package, info.version, info.target,
                 _source_digest(), str(layouts_m.shape), str(layouts_m.dtype)):
        digest.update(part.encode())
        digest.update(b"\0")
    digest.update(np.ascontiguousarray(layouts_m).tobytes())
    return digest.hexdigest()


def search_path(key: str) -> Path | None:
    """Where the search ``key`` lives (None when the cache is off)."""
    folder = cache_folder()
    return None if folder is None else folder / "searches" / f"{key}.npz"


# each array of a SearchResult: its dtype and number of dimensions (the first is the layouts)
_FIELDS = {"objective_bps": (np.float64, 1), "uav_m": (np.float64, 3),
           "alpha_first": (np.float64, 3), "rate_bps": (np.float64, 2),
           "rounds": (np.int64, 1), "converged": (np.bool_, 1)}


def read_search(key: str, layouts: int, uavs: int, users: int) -> SearchResult | None:
    """The cached search ``key`` of ``layouts`` layouts, ``uavs`` UAVs and ``users`` users, or
    None: none cached, the cache off, or a file that does not hold such a search (then searched
    again and rewritten)."""
    path = search_path(key)
    if path is None or not path.is_file():
        return None
    try:
        with np.load(path, allow_pickle=False) as stored:
            arrays = {name: stored[name] for name in (*_FIELDS, "seconds_per_layout")}
    except (OSError, ValueError, KeyError, zipfile.BadZipFile):
        return None
    expected = {"uav_m": (layouts, uavs, 3), "rate_bps": (layouts, users)}
    for name, (dtype, ndim) in _FIELDS.items():
        value = arrays[name]
        if value.dtype != dtype or value.ndim != ndim or value.shape[0] != layouts or \
                value.shape != expected.get(name, value.shape) or \
                (name == "alpha_first" and value.shape[1] != uavs):
            return None
    seconds = arrays["seconds_per_layout"]
    if seconds.shape != () or seconds.dtype != np.float64:
        return None
    return SearchResult(**{name: arrays[name] for name in _FIELDS},
                        seconds_per_layout=float(seconds))


def write_search(key: str, found: SearchResult) -> Path | None:
    """Store the search ``found`` as ``key``; its path, or None when the cache is off or cannot
    be written (nothing half-written is left)."""
    path = search_path(key)
    if path is None:
        return None
    buffer = io.BytesIO()
    np.savez(buffer, **{name: np.asarray(getattr(found, name), dtype=dtype)
                        for name, (dtype, _) in _FIELDS.items()},
             seconds_per_layout=np.float64(found.seconds_per_layout))
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        write_bytes_atomic(path, buffer.getbuffer())
    except (OSError, AdaptskyError):
        return None
    return path


def physics_json(scenario: Scenario) -> str:
    """What a search depends on of ``scenario``: all but its name, description, agent and
    training, as sorted JSON."""
    return json.dumps(scenario.model_dump(
        mode="json", exclude={"name", "description", "agent", "train"}), sort_keys=True)


def _key_of(scenario: Scenario, users_m: FloatArray, method: str) -> str:
    return search_key(physics_json(scenario), scenario.channel.model, users_m, method)


def cached_search(scenario: Scenario, users_m: FloatArray,
                  method: str = "best-response") -> SearchResult | None:
    """The search ``method`` on ``users_m`` (L, N, 2) if the cache has it, else None."""
    return read_search(_key_of(scenario, users_m, method), len(users_m), scenario.uav.count,
                       users_m.shape[1])


def search_once(scenario: Scenario, users_m: FloatArray, run: Callable[[], SearchResult],
                method: str = "best-response") -> SearchResult:
    """The cached search ``method`` on ``users_m``, else ``run()``'s, cached for later."""
    key = _key_of(scenario, users_m, method)
    found = read_search(key, len(users_m), scenario.uav.count, users_m.shape[1])
    if found is None:
        found = run()
        write_search(key, found)
    return found
