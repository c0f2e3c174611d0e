"""Run files: HDF5 holding a training run's scenario, learning curves, trajectories and
checkpoints (layout in ``docs/file-format.md``, as data in ``store.layout``).

Every change is made on a copy that replaces the file in one ``os.replace``: a run killed at
any moment leaves the file as it was at its last checkpoint, never half written. Every file is
validated against the layout when it is opened, before anything is read or written.
"""

from __future__ import annotations

import json
import os
import platform
import stat
import sys
from dataclasses import dataclass
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from adaptsky import __version__
from adaptsky.arrays import Tree
from adaptsky.scenario import Scenario
from adaptsky.store.atomic import rewrite, string_dataset, utc_timestamp
from adaptsky.store.checksums import first_damage, seal
from adaptsky.store.layout import (
    EPISODES,
    FORMAT_VERSION,
    KIND,
    SEED_ATTRS,
    TRAJECTORY,
    UNITS,
    Needs,
    RunFileError,
    added_after,
    episode_fields,
    evaluation_fields,
    require_finite,
    validate_run,
)
from adaptsky.store.links import target
from adaptsky.store.lock import writer_of
from adaptsky.store.tree import read_tree, write_tree
from adaptsky.units import plural

__all__ = ["FORMAT_VERSION", "KIND", "RunFileError", "RunReader", "SeedCheckpoint",
           "append_checkpoint", "append_checkpoints", "create_run", "environment",
           "record_session", "set_planned_episodes"]

# episode columns that may be NaN: the loss before the first update, epsilon for a learner
# without one (PPO), the entropy for a learner without a stochastic policy (the Q-learners)
NAN_ALLOWED = ("loss", "epsilon", "entropy")
EPISODE_METRICS = tuple(field.name for field in episode_fields(FORMAT_VERSION)
                        if len(field.shape) == 1)
PER_USER_METRICS = tuple(field.name for field in EPISODES if len(field.shape) == 2)
TRAJECTORY_FIELDS = tuple(field.name for field in TRAJECTORY)


def environment() -> dict[str, str]:
    """Versions of Python, numpy, torch (read without importing it) and h5py; the platform."""
    try:
        torch_version = version("torch")
    except PackageNotFoundError:
        torch_version = "not installed"
    return {"python_version": platform.python_version(), "numpy_version": np.__version__,
            "torch_version": torch_version, "h5py_version": h5py.__version__,
            "platform": platform.platform()}


def create_run(path: Path, scenario_text: str, config: dict[str, Any],
               plugins: dict[str, dict[str, str]], seeds: list[int], episodes: int,
               num_users: int, overrides: list[str] | None = None,
               argv: list[str] | None = None, evaluation: Tree | None = None) -> None:
    """Write a new run file with empty learning curves for every seed; ``overrides`` are the
    ``--set`` items applied to the scenario text (already part of ``config``), ``argv`` the
    command line that made it (default ``sys.argv``), ``evaluation`` the layouts and oracle of
    the greedy evaluations during training (``EvaluationSet.arrays()``: ``/evaluation``)."""
    with rewrite(path, fresh=True) as file:
        file.attrs.update(format_version=FORMAT_VERSION, kind=KIND,
                          adaptsky_version=__version__,
                          created_utc=utc_timestamp(),
                          scenario_name=config["name"],
                          command_line=json.dumps(sys.argv if argv is None else argv),
                          **environment())
        string_dataset(file, "scenario", scenario_text)
        string_dataset(file, "config", json.dumps(config, indent=1))
        string_dataset(file, "overrides", json.dumps(overrides or []))
        for name, info in plugins.items():
            file.create_group(f"plugins/{name}").attrs.update(info)
        if evaluation is not None:
            write_tree(file.create_group("evaluation"), evaluation, units=UNITS)
        for seed in seeds:
            group = file.create_group(f"seeds/{seed}")
            group.attrs.update(seed=seed, episodes_done=0, episodes_planned=episodes)
            empty: Tree = {name: np.zeros(0) for name in EPISODE_METRICS}
            empty |= {name: np.zeros((0, num_users)) for name in PER_USER_METRICS}
            write_tree(group.create_group("episodes"), empty, compress=True, units=UNITS)
            write_tree(group.create_group("evaluations"), {
                field.name: np.zeros(0, dtype=np.int64 if field.dtype == "int" else np.float64)
                for field in evaluation_fields(FORMAT_VERSION)}, compress=True, units=UNITS)


def set_planned_episodes(path: Path, config: dict[str, Any]) -> None:
    """Record a new episode target (``config["train"]["episodes"]``) for every seed."""
    with rewrite(path) as file:
        del file["config"]
        string_dataset(file, "config", json.dumps(config, indent=1))
        for group in file["seeds"].values():
            group.attrs["episodes_planned"] = config["train"]["episodes"]


@dataclass(frozen=True)
class SeedCheckpoint:
    """One seed's checkpoint as a run file stores it: the learning-curve ``rows`` and greedy
    ``evaluations`` since the last one (one array per column; {} for none), the trajectories
    kept meanwhile, the last episode's trajectory and everything needed to continue.
    ``key`` is the seed (a training stack may key it otherwise until it reaches the file)."""

    key: Any
    rows: dict[str, np.ndarray]
    trajectories: dict[int, Tree]
    last_trajectory: tuple[int, Tree]
    checkpoint: Tree
    evaluations: dict[str, np.ndarray]

    @property
    def episode(self) -> int:
        return int(self.checkpoint["episode"])


def append_checkpoint(path: Path, seed: int, rows: dict[str, np.ndarray],
                      trajectories: dict[int, Tree], last_trajectory: tuple[int, Tree],
                      checkpoint: Tree, evaluations: dict[str, np.ndarray] | None = None
                      ) -> None:
    """Append learning-curve ``rows`` (k, ...) of one seed, its trajectories and evaluation
    rows, and replace its checkpoint; ``checkpoint["episode"]`` becomes the seed's
    ``episodes_done``."""
    append_checkpoints(path, [SeedCheckpoint(seed, rows, trajectories, last_trajectory,
                                             checkpoint, evaluations or {})])


def append_checkpoints(path: Path, items: list[SeedCheckpoint]) -> None:
    """:func:`append_checkpoint` for several seeds in one rewrite of the file (the seeds of a
    stack checkpoint together: one copy of the file per round, not one per seed)."""
    with rewrite(path) as file:
        for item in items:
            _write_checkpoint(file[f"seeds/{item.key}"], item.rows, item.trajectories,
                              item.last_trajectory, item.checkpoint, item.evaluations)


def _append_rows(table: h5py.Group, start: int, rows: dict[str, np.ndarray]) -> None:
    for name, values in rows.items():
        dataset = table[name]
        dataset.resize(start + len(values), axis=0)
        dataset[start:] = values
        seal(dataset, dataset[()])  # (the in-memory image's rows: no disk read)


def _in_format(file: h5py.File, tree: dict[str, Any]) -> dict[str, Any]:
    """``tree`` without what formats after the file's add (the energy from format 3, the
    service metrics and the users' positions from format 4): a run continued by ``train
    --resume`` keeps its format."""
    added = added_after(int(file.attrs["format_version"]))
    return {name: value for name, value in tree.items() if name not in added}


def _write_checkpoint(group: h5py.Group, rows: dict[str, np.ndarray],
                      trajectories: dict[int, Tree], last_trajectory: tuple[int, Tree],
                      checkpoint: Tree, evaluations: dict[str, np.ndarray]) -> None:
    done = int(group.attrs["episodes_done"])
    rows = _in_format(group.file, rows)
    trajectories = {episode: _in_format(group.file, trajectory)
                    for episode, trajectory in trajectories.items()}
    last_trajectory = (last_trajectory[0], _in_format(group.file, last_trajectory[1]))
    _append_rows(group["episodes"], done, rows)
    if evaluations:
        table = group["evaluations"]
        _append_rows(table, len(table["episode"]), {  # the columns the file has (format 4
            field.name: evaluations.get(field.name,    # files made before tracking lack it)
                                        np.full(len(evaluations["episode"]), np.nan))
            for field in evaluation_fields(FORMAT_VERSION) if field.name in table})
    for episode, trajectory in trajectories.items():
        write_tree(group.require_group(f"trajectories/{episode}"),
                   {**trajectory, "episode": episode}, compress=True, units=UNITS)
    episode, trajectory = last_trajectory
    write_tree(group.require_group("trajectory"), {**trajectory, "episode": episode},
               compress=True, units=UNITS)
    write_tree(group.require_group("checkpoint"), checkpoint, units=UNITS)
    group.attrs["episodes_done"] = int(checkpoint["episode"])


def record_session(path: Path, kind: str, argv: list[str], started_utc: str, wall_s: float,
                   episodes_before: dict[int, int]) -> None:
    """Append one row to the run's ``/sessions`` (a JSON list): what ran (``kind``: train or
    resume; the command line), when and for how long, where (versions, platform), and every
    seed's episodes done before and after."""
    with rewrite(path) as file:
        sessions = json.loads(file["sessions"][()].decode()) if "sessions" in file else []
        after = {seed: int(group.attrs["episodes_done"]) for seed, group in file["seeds"].items()}
        sessions.append({"kind": kind, "command_line": list(argv), "started_utc": started_utc,
                         "wall_s": round(wall_s, 3), "adaptsky_version": __version__,
                         **environment(),
                         "episodes_before": {str(k): v for k, v in episodes_before.items()},
                         "episodes_after": after})
        if "sessions" in file:
            del file["sessions"]
        string_dataset(file, "sessions", json.dumps(sessions))


def _dead_link(path: Path) -> str:
    """What is wrong with ``path``, a symbolic link that leads to no file."""
    try:
        os.stat(path)
    except FileNotFoundError:
        return f"a symbolic link to {os.readlink(path)}, which does not exist"
    except OSError:
        pass
    return "a symbolic link that points to itself or to nothing"


def _status(path: Path, real: Path) -> os.stat_result:
    """``real``'s own status (``real``: the file ``path`` names), or one line for the reader."""
    try:
        info = os.lstat(real)
    except FileNotFoundError:
        raise RunFileError(f"{path}: no such run file") from None
    except OSError as error:
        raise RunFileError(f"{path}: cannot read run file ({error.strerror})") from None
    if stat.S_ISLNK(info.st_mode):  # a link that target() could not follow to a file
        raise RunFileError(f"{path}: is {_dead_link(real)}; give a run file's path")
    return info


def open_run_file(path: Path) -> h5py.File:
    """``path`` opened read-only: a regular, readable HDF5 file, or a symbolic link to one
    (followed, ``store.links``; links inside the file are the validator's to refuse)."""
    real = target(path)
    info = _status(path, real)
    if stat.S_ISDIR(info.st_mode):
        raise RunFileError(f"{path}: is a directory, not a run file")
    if not stat.S_ISREG(info.st_mode):
        raise RunFileError(f"{path}: is not a regular file, not a run file")
    try:
        os.close(os.open(real, os.O_RDONLY | os.O_NOFOLLOW))
        hdf5 = h5py.is_hdf5(real)
    except OSError as error:
        raise RunFileError(f"{path}: cannot read run file ({error.strerror or error}); check "
                           "its permissions") from None
    if not hdf5:
        raise RunFileError(f"{path}: not an HDF5 file")
    try:
        return h5py.File(real, "r")
    except OSError as error:
        raise RunFileError(f"{path}: damaged or truncated HDF5 file "
                           f"({str(error).splitlines()[0]})") from None


class RunReader:
    """Read access to a run file, validated on opening against the documented layout
    (``store.layout``: names, dtypes, declared shapes, attributes; no array is read), then
    every dataset it may read is read once and its checksum verified (``store.checksums``);
    every array read is checked to be finite. Use as a context manager. ``needs="curves"``
    leaves checkpoints and trajectories unchecked and unreadable, for readers of learning
    curves."""

    def __init__(self, path: str | Path, needs: Needs = "all") -> None:
        self.path = Path(path)
        self.needs = needs
        self.file = open_run_file(self.path)
        try:
            self.scenario: Scenario = self._guard(
                "its layout", lambda: validate_run(self.file, self.path, needs))
            self._verify_checksums()
        except BaseException:
            self.file.close()
            raise

    def __enter__(self) -> RunReader:
        return self

    def __exit__(self, *exc: object) -> None:
        self.file.close()

    def _verify_checksums(self) -> None:
        """Read every dataset this reader may read once, its checksum verified (with
        ``needs="curves"``, none of the checkpoints and trajectories)."""
        def skip(name: str) -> bool:
            parts = name.split("/")
            return self.needs != "all" and len(parts) == 4 and parts[1] == "seeds" and (
                parts[3] in ("checkpoint", "trajectory", "trajectories"))
        found = self._guard("its datasets", lambda: first_damage(self.file, skip))
        if found is not None:
            raise RunFileError(f"{self.path}: damaged run file: {found[0]}: {found[1]}")

    def _guard(self, what: str, read: Any) -> Any:
        try:
            return read()
        except (OSError, KeyError, ValueError, TypeError, AttributeError,
                RuntimeError) as error:
            raise RunFileError(f"{self.path}: damaged run file: cannot read {what} "
                               f"({str(error).splitlines()[0]})") from None

    def _text(self, name: str) -> str:
        return self._guard(f"/{name}", lambda: self.file[name][()].decode())

    @property
    def scenario_text(self) -> str:
        return self._text("scenario")

    @property
    def config(self) -> dict[str, Any]:
        return json.loads(self._text("config"))  # valid JSON: checked on opening

    @property
    def overrides(self) -> list[str]:
        """The ``--set`` items of the run (files written before they existed: none)."""
        return json.loads(self._text("overrides")) if "overrides" in self.file else []

    @property
    def sessions(self) -> list[dict[str, Any]]:
        """One row per ``train`` or ``--resume`` (files written before they existed: none)."""
        return json.loads(self._text("sessions")) if "sessions" in self.file else []

    @property
    def attrs(self) -> dict[str, Any]:
        """The root attributes (format and adaptsky versions, creation time, provenance)."""
        return self._guard("its attributes", lambda: {
            key: value.item() if isinstance(value, np.generic) else value
            for key, value in self.file.attrs.items()})

    @property
    def plugins(self) -> dict[str, dict[str, str]]:
        return self._guard("/plugins", lambda: read_tree(self.file["plugins"])
                           if "plugins" in self.file else {})

    @property
    def seeds(self) -> list[int]:
        """The seeds of /config train.seeds, sorted (each has its group: checked on opening)."""
        return sorted(self.scenario.train.seeds)

    def seed_attrs(self, seed: int) -> dict[str, int]:
        """The seed's documented attributes (seed, episodes_done, episodes_planned); others
        a later version may add are left alone."""
        return self._guard(f"seed {seed}", lambda: {
            key: int(value) for key, value in self.file[f"seeds/{seed}"].attrs.items()
            if key in SEED_ATTRS})

    def has_checkpoint(self, seed: int) -> bool:
        return self._guard(f"seed {seed}", lambda: f"seeds/{seed}/checkpoint" in self.file)

    def episodes(self, seed: int) -> dict[str, np.ndarray]:
        """Learning curves of ``seed`` up to its last checkpoint (only ``loss``, and where a
        learner has none ``epsilon`` and ``entropy``, may be NaN)."""
        def read() -> dict[str, np.ndarray]:
            done = int(self.file[f"seeds/{seed}"].attrs["episodes_done"])
            group = self.file[f"seeds/{seed}/episodes"]
            return {field.name: group[field.name][:done]
                    for field in episode_fields(FORMAT_VERSION) if field.name in group}
        curves = self._guard(f"seed {seed}'s episodes", read)
        for name, values in curves.items():
            require_finite(self.path, f"/seeds/{seed}/episodes/{name}", values,
                           allow_nan=name in NAN_ALLOWED)
        return curves

    def evaluations(self, seed: int) -> dict[str, np.ndarray]:
        """The greedy evaluations of ``seed`` during training, one row each (docs/training.md;
        columns a run does not measure are NaN, as are those its format lacks; files without
        evaluations: no rows)."""
        fields = evaluation_fields(FORMAT_VERSION)

        def read() -> dict[str, np.ndarray]:
            group = self.file[f"seeds/{seed}"].get("evaluations")
            if group is None:
                return {field.name: np.zeros(0) for field in fields}
            rows = len(group["episode"])
            return {field.name: group[field.name][:] if field.name in group
                    else np.full(rows, np.nan) for field in fields}
        table = self._guard(f"seed {seed}'s evaluations", read)
        for name, values in table.items():
            require_finite(self.path, f"/seeds/{seed}/evaluations/{name}", values,
                           allow_nan=True)
        return table

    def evaluation_oracle(self) -> list[np.ndarray] | None:
        """The stored oracle of the evaluation layouts, one array per group (training layout,
        held-out layouts; those the run has), or None (older files: computed again)."""
        def read() -> list[np.ndarray] | None:
            group = self.file.get("evaluation")
            if group is None:
                return None
            return [group[f"{name}_oracle_bps"][:] for name in ("training", "heldout")
                    if f"{name}_oracle_bps" in group]
        return self._guard("/evaluation", read)

    def best(self, seed: int) -> Tree | None:
        """``seed``'s best policy in the greedy evaluations (episode, score, policy weights),
        or None where it has none."""
        self.require_checkpoint(seed)
        if not self._guard(f"seed {seed}", lambda: f"seeds/{seed}/checkpoint/best" in self.file):
            return None
        return self._read_finite(f"seeds/{seed}/checkpoint/best", f"seed {seed}'s best policy")

    def trajectory(self, seed: int) -> Tree:
        return self._read_finite(f"seeds/{seed}/trajectory", f"seed {seed}'s trajectory")

    def checkpoint(self, seed: int) -> Tree:
        self.require_checkpoint(seed)
        return self._read_finite(f"seeds/{seed}/checkpoint", f"seed {seed}'s checkpoint")

    def require_checkpoint(self, seed: int) -> None:
        if self.has_checkpoint(seed):
            return
        writer = writer_of(self.path)
        if writer is not None:
            episodes = plural(self.scenario.train.checkpoint_every, "episode")
            raise RunFileError(f"{self.path}: seed {seed} has no checkpoint yet: {writer} is "
                               f"training it and writes the first after {episodes}; try "
                               "again then")
        raise RunFileError(f"{self.path}: seed {seed} has no checkpoint (the run stopped "
                           "before its first one); continue it with adaptsky train "
                           f"--resume {self.path}")

    def _read_finite(self, name: str, what: str) -> Tree:
        if self.needs != "all":
            raise ValueError(f"RunReader(needs={self.needs!r}) does not read {what}")
        tree = self._guard(what, lambda: read_tree(self.file[name]))
        self._check_finite(tree, f"/{name}")
        return tree

    def _check_finite(self, tree: Tree, where: str) -> None:
        for key, value in tree.items():
            if isinstance(value, dict):
                self._check_finite(value, f"{where}/{key}")
            elif isinstance(value, np.ndarray):
                require_finite(self.path, f"{where}/{key}", value)
