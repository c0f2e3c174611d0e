"""Run files: HDF5 holding a training run's scenario, learning curves, trajectories and
checkpoints (layout in ``docs/file-format.md``).

Every change is made on a copy that replaces the file in one ``os.replace``: a run killed at
any moment leaves the file as it was at its last checkpoint, never half written.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from adaptsky_cli import __version__
from adaptsky_cli.errors import AdaptskyError
from adaptsky_cli.store.atomic import rewrite, string_dataset, utc_timestamp
from adaptsky_cli.store.tree import Tree, read_tree, write_tree

FORMAT_VERSION = 1
KIND = "adaptsky-run"

EPISODE_METRICS = ("sum_rate_bps", "fairness", "reward", "mean_height_m", "epsilon", "loss")
PER_USER_METRICS = ("mean_rate_bps", "mean_alpha")
TRAJECTORY_FIELDS = ("uav_m", "alpha", "gain", "los", "rate_bps", "reward", "action")


class RunFileError(AdaptskyError):
    """A run file that is missing, not HDF5, damaged, too new, or lacks what is asked of it."""


def create_run(path: Path, scenario_text: str, config: dict[str, Any],
               plugins: dict[str, dict[str, str]], seeds: list[int], episodes: int,
               num_users: int, overrides: list[str] | None = None) -> None:
    """Write a new run file with empty learning curves for every seed; ``overrides`` are the
    ``--set`` items applied to the scenario text (already part of ``config``)."""
    with rewrite(path) as file:
        file.attrs.update(format_version=FORMAT_VERSION, kind=KIND,
                          adaptsky_version=__version__,
                          created_utc=utc_timestamp(),
                          scenario_name=config["name"])
        string_dataset(file, "scenario", scenario_text)
        string_dataset(file, "config", json.dumps(config, indent=1))
        string_dataset(file, "overrides", json.dumps(overrides or []))
        for name, info in plugins.items():
            file.create_group(f"plugins/{name}").attrs.update(info)
        for seed in seeds:
            group = file.create_group(f"seeds/{seed}")
            group.attrs.update(seed=seed, episodes_done=0, episodes_planned=episodes)
            empty: Tree = {name: np.zeros(0) for name in EPISODE_METRICS}
            empty |= {name: np.zeros((0, num_users)) for name in PER_USER_METRICS}
            write_tree(group.create_group("episodes"), empty, compress=True)


def set_planned_episodes(path: Path, config: dict[str, Any]) -> None:
    """Record a new episode target (``config["train"]["episodes"]``) for every seed."""
    with rewrite(path) as file:
        del file["config"]
        string_dataset(file, "config", json.dumps(config, indent=1))
        for group in file["seeds"].values():
            group.attrs["episodes_planned"] = config["train"]["episodes"]


def append_checkpoint(path: Path, seed: int, rows: dict[str, np.ndarray],
                      trajectories: dict[int, Tree], last_trajectory: tuple[int, Tree],
                      checkpoint: Tree) -> None:
    """Append learning-curve ``rows`` (k, ...) of one seed, its trajectories, and replace its
    checkpoint; ``checkpoint["episode"]`` becomes the seed's ``episodes_done``."""
    with rewrite(path) as file:
        group = file[f"seeds/{seed}"]
        done = int(group.attrs["episodes_done"])
        for name, values in rows.items():
            dataset = group[f"episodes/{name}"]
            dataset.resize(done + len(values), axis=0)
            dataset[done:] = values
        for episode, trajectory in trajectories.items():
            write_tree(group.require_group(f"trajectories/{episode}"),
                       {**trajectory, "episode": episode}, compress=True)
        episode, trajectory = last_trajectory
        write_tree(group.require_group("trajectory"), {**trajectory, "episode": episode},
                   compress=True)
        write_tree(group.require_group("checkpoint"), checkpoint)
        group.attrs["episodes_done"] = int(checkpoint["episode"])


class RunReader:
    """Read access to a run file, checked on opening; use as a context manager."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        if not self.path.is_file():
            raise RunFileError(f"{self.path}: no such run file")
        if not h5py.is_hdf5(self.path):
            raise RunFileError(f"{self.path}: not an HDF5 file")
        try:
            self.file = h5py.File(self.path, "r")
        except OSError as error:
            raise RunFileError(f"{self.path}: damaged or truncated HDF5 file "
                               f"({str(error).splitlines()[0]})") from None
        try:
            self._guard("its header", self._check)
        except BaseException:
            self.file.close()
            raise

    def _check(self) -> None:
        attrs = self.file.attrs
        if attrs.get("kind") != KIND:
            raise RunFileError(f"{self.path}: not an adaptsky run file")
        version = int(attrs.get("format_version", -1))
        if version > FORMAT_VERSION:
            raise RunFileError(f"{self.path}: format version {version} is newer than this "
                               f"adaptsky ({__version__}) reads ({FORMAT_VERSION}); upgrade")
        for name in ("scenario", "config", "seeds"):
            if name not in self.file:
                raise RunFileError(f"{self.path}: damaged run file: /{name} is missing")

    def __enter__(self) -> RunReader:
        return self

    def __exit__(self, *exc: object) -> None:
        self.file.close()

    def _guard(self, what: str, read: Any) -> Any:
        try:
            return read()
        except (OSError, KeyError, ValueError, TypeError, AttributeError) as error:
            raise RunFileError(f"{self.path}: damaged run file: cannot read {what} "
                               f"({str(error).splitlines()[0]})") from None

    @property
    def scenario_text(self) -> str:
        return self._guard("/scenario", lambda: self.file["scenario"][()].decode())

    @property
    def config(self) -> dict[str, Any]:
        return self._guard("/config", lambda: json.loads(self.file["config"][()].decode()))

    @property
    def overrides(self) -> list[str]:
        """The ``--set`` items of the run (files written before they existed: none)."""
        return self._guard("/overrides", lambda: json.loads(self.file["overrides"][()].decode())
                           if "overrides" in self.file else [])

    @property
    def attrs(self) -> dict[str, Any]:
        """The root attributes (format and adaptsky versions, creation time, ...)."""
        return self._guard("its attributes", lambda: {
            key: value.item() if isinstance(value, np.generic) else value
            for key, value in self.file.attrs.items()})

    @property
    def plugins(self) -> dict[str, dict[str, str]]:
        return self._guard("/plugins", lambda: read_tree(self.file["plugins"])
                           if "plugins" in self.file else {})

    @property
    def seeds(self) -> list[int]:
        return self._guard("/seeds", lambda: sorted(int(seed) for seed in self.file["seeds"]))

    def seed_attrs(self, seed: int) -> dict[str, int]:
        return self._guard(f"seed {seed}", lambda: {
            key: int(value) for key, value in self.file[f"seeds/{seed}"].attrs.items()})

    def has_checkpoint(self, seed: int) -> bool:
        def read() -> bool:
            group = self.file.get(f"seeds/{seed}/checkpoint")
            return group is not None and "episode" in group.attrs
        return self._guard(f"seed {seed}", read)

    def episodes(self, seed: int) -> dict[str, np.ndarray]:
        """Learning curves of ``seed`` up to its last checkpoint."""
        def read() -> dict[str, np.ndarray]:
            done = int(self.file[f"seeds/{seed}"].attrs["episodes_done"])
            group = self.file[f"seeds/{seed}/episodes"]
            return {name: group[name][:done] for name in group}
        return self._guard(f"seed {seed}'s episodes", read)

    def trajectory(self, seed: int) -> Tree:
        return self._guard(f"seed {seed}'s trajectory",
                           lambda: read_tree(self.file[f"seeds/{seed}/trajectory"]))

    def checkpoint(self, seed: int) -> Tree:
        self.require_checkpoint(seed)
        return self._guard(f"seed {seed}'s checkpoint",
                           lambda: read_tree(self.file[f"seeds/{seed}/checkpoint"]))

    def require_checkpoint(self, seed: int) -> None:
        if not self.has_checkpoint(seed):
            raise RunFileError(f"{self.path}: seed {seed} has no checkpoint (the run stopped "
                               "before its first one)")
