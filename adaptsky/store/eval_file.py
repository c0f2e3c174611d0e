"""Eval files: HDF5 holding an evaluation's results and trajectories, what was evaluated and
with what software (docs/evaluation.md#eval-files)."""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import h5py
import numpy as np

from adaptsky import __version__
from adaptsky.errors import AdaptskyError
from adaptsky.store.atomic import rewrite, string_dataset, utc_timestamp
from adaptsky.store.checksums import CHECKED_ARRAY, first_damage, seal
from adaptsky.store.run_file import environment, open_run_file
from adaptsky.store.tree import read_tree, write_tree

if TYPE_CHECKING:
    from adaptsky.rollouts.metrics import Method

FORMAT_VERSION = 1
KIND = "adaptsky-eval"
TEXT = "text"
"""The ``units`` attribute of datasets that hold text (JSON, TOML)."""
UNITS = {"mean_sum_rate_bps": "bit/s", "steady_sum_rate_bps": "bit/s", "sum_rate_bps": "bit/s",
         "rate_bps": "bit/s", "min_user_se": "bit/s/Hz", "fairness": "1",
         "satisfied_share": "1", "steady_satisfied_share": "1", "alpha": "1",
         "steady_user_rate_bps": "bit/s",
         "final_uav_m": "m", "uav_m": "m", "users_m": "m", "layouts_m": "m",
         "objective_bps": "bit/s",
         "rounds": "1", "converged": "1",
         "outage_share": "1", "mean_least_rate_bps": "bit/s", "p5_rate_bps": "bit/s"}
"""The ``units`` attribute of every numeric dataset, by name ("1": dimensionless)."""


OUTSIDE = "outside"
"""The ``policy`` of the record of a policy from outside adaptsky (``evaluate_policy``): no
run file, no checkpoint, no training curve; the root attributes ``policy`` and
``policy_label`` say so."""


def outside_record(results: dict[str, Any]) -> dict[str, Any] | None:
    """The record of the evaluated policy where it came from outside adaptsky, else None."""
    record = results.get("policy")
    return record if isinstance(record, dict) and record.get("policy") == OUTSIDE else None


def check_new_eval_file(path: Path, option: str = "out") -> None:
    """Refuse, before any work, an eval file path that exists, names a folder, or lies in a
    folder that is missing or cannot be written."""
    if path.is_dir():
        raise AdaptskyError(f"{option} {path}: is a folder; give an eval file name, e.g. "
                            f"{path / 'eval.h5'}")
    if path.exists():
        raise AdaptskyError(f"{option} {path}: exists; choose another {option}")
    if not path.parent.is_dir():
        raise AdaptskyError(f"{option} {path}: the folder {path.parent} does not exist; create "
                            f"it or choose another {option}")
    if not os.access(path.parent, os.W_OK | os.X_OK):
        raise AdaptskyError(f"{option} {path}: cannot write in {path.parent} (permission "
                            f"denied or read-only); choose another {option}")


SEARCH = "search"
"""The group of best response's and OMA's search, per layout: objective_bps, rounds,
converged, and the attribute seconds_per_layout (seconds_per_step for the per-step searches,
where the users move)."""
SEARCH_SECONDS = ("seconds_per_layout", "seconds_per_step")


def group_name(label: str) -> str:
    """An HDF5 name for a method label: '/' (a run file's folder) becomes '%2F'."""
    return label.replace("%", "%25").replace("/", "%2F")


def _with_units(group: h5py.Group) -> None:
    """Set ``units`` on every dataset below ``group``."""
    def visit(name: str, item: Any) -> None:
        if isinstance(item, h5py.Dataset):
            item.attrs["units"] = UNITS.get(name.rsplit("/", 1)[-1], TEXT)
    group.visititems(visit)


def write_eval(path: Path, results: dict[str, Any], methods: list[Method],
               provenance: dict[str, Any] | None = None) -> None:
    """Write a new eval file at ``path`` in one atomic step (replacing any file there).

    ``provenance``: more root attributes (the command line, the wall time); the versions of
    Python, numpy, torch, h5py and the platform are added here, and the evaluation scenario
    (``results["scenario_toml"]``) goes to ``/scenario``."""
    labels = [method.name for method in methods]
    if len(set(map(group_name, labels))) != len(labels):
        raise AdaptskyError(f"{path}: two methods share a label ({', '.join(labels)}); "
                            "every method needs its own")
    with rewrite(path, fresh=True) as file:
        file.attrs.update(format_version=FORMAT_VERSION, kind=KIND, adaptsky_version=__version__,
                          created_utc=utc_timestamp(),
                          scenario_name=results["scenario"], steps=results["steps"],
                          layouts=results["layouts"], **environment())
        for key in ("checkpoint", "seed", "checkpoint_episode", "scenario_file"):
            if results.get(key) is not None:
                file.attrs[key] = results[key]
        outside = outside_record(results)
        if outside is not None:  # no run file: what the caller named the policy
            file.attrs.update(policy=OUTSIDE, policy_label=outside["label"])
        file.attrs.update(provenance or {})
        string_dataset(file, "results_json", json.dumps(results))
        if results.get("scenario_toml") is not None:
            string_dataset(file, "scenario", results["scenario_toml"])
        layouts_m = np.array(results["layouts_m"])
        seal(file.create_dataset("layouts_m", data=layouts_m, **CHECKED_ARRAY), layouts_m)
        for method in methods:
            group = file.create_group(f"methods/{group_name(method.name)}")
            group.attrs["label"] = method.name
            write_tree(group, {key: np.asarray(value) for key, value in method.metrics.items()})
            trace = method.trace
            trajectory = {"sum_rate_bps": trace.sum_rate_bps, "rate_bps": trace.rate_bps,
                          "uav_m": trace.uav_m, "alpha": trace.alpha,
                          "energy_j": trace.energy_j}
            if trace.users_m is not None:   # users that walk: where they were at each step
                trajectory["users_m"] = trace.users_m
            write_tree(group.create_group("trajectory"), trajectory, compress=True)
            if "rounds" in method.details:  # best response and OMA
                search = group.create_group(SEARCH)
                write_tree(search, {key: np.asarray(method.details[key]) for key in
                                    ("objective_bps", "rounds", "converged")})
                for key in SEARCH_SECONDS:   # per layout, or per step (users that move)
                    if key in method.details:
                        search.attrs[key] = float(method.details[key])
        for name, comparison in results.get("comparison", {}).items():
            group = file.require_group("comparison").create_group(group_name(name))
            group.attrs.update(comparison, label=name)
        _with_units(file)


def damaged_eval_file(path: Path, error: BaseException) -> AdaptskyError:
    """The one line for an eval file that cannot be read as one: the damaged dataset and its
    checksum where one does not match (``store.checksums``), else the error's first line."""
    if isinstance(error, OSError):
        try:
            with h5py.File(path, "r") as file:
                found = first_damage(file)
        except OSError:
            found = None
        if found is not None:
            return AdaptskyError(f"{path}: damaged eval file: {found[0]}: {found[1]}")
    return AdaptskyError(f"{path}: damaged eval file "
                         f"({(str(error).splitlines() or ['unreadable'])[0]})")


def verify_eval_file(file: h5py.File, path: Path) -> None:
    """Read every dataset of an open eval file once, its checksum verified
    (``store.checksums``): one line naming the first damaged one."""
    found = first_damage(file)
    if found is not None:
        raise AdaptskyError(f"{path}: damaged eval file: {found[0]}: {found[1]}")


def read_eval_metrics(path: Path) -> tuple[dict[str, Any] | None, dict[str, dict[str, np.ndarray]]]:
    """An eval file's ``record`` (what it evaluated, if written by ``reproduce``) and the
    per-layout metrics of each method, by label (a search's datasets as ``search_<name>``)."""
    try:
        with h5py.File(path, "r") as file:
            if file.attrs.get("kind") != KIND:
                raise AdaptskyError(f"{path}: not an adaptsky eval file")
            verify_eval_file(file, path)
            results = json.loads(file["results_json"][()].decode())
            check_searches(file)
            methods = {}
            for name, group in file["methods"].items():
                tree = read_tree(group)
                tree.pop("trajectory", None)
                search = tree.pop(SEARCH, None) or {}
                label = str(tree.pop("label", name))
                methods[label] = {key: np.asarray(value) for key, value in tree.items()}
                # a search's rounds, convergence and time, as search_<name>
                methods[label] |= {f"{SEARCH}_{key}": np.asarray(value)
                                   for key, value in search.items()}
    except (OSError, KeyError, ValueError) as error:
        raise damaged_eval_file(path, error) from None
    return results.get("record"), methods


def check_searches(file: h5py.File) -> None:
    """Raise ValueError where a method's ``search`` group is not what :func:`write_eval`
    writes: objective_bps (float, >= 0), rounds (integer, >= 1) and converged (bool), one per
    layout, and seconds_per_layout (or seconds_per_step) >= 0."""
    kinds = {"objective_bps": "f", "rounds": "iu", "converged": "b"}
    for name, group in file.get("methods", {}).items():
        search = group.get(SEARCH)
        if search is None:
            continue
        layouts = file["layouts_m"].shape[0]
        for key, kind in kinds.items():
            data = search.get(key)
            if not isinstance(data, h5py.Dataset) or data.shape != (layouts,) or \
                    data.dtype.kind not in kind:
                raise ValueError(f"methods/{name}/{SEARCH}/{key} is not one "
                                 f"{'number' if kind != 'b' else 'bool'} per layout")
        if not (np.all(search["objective_bps"][()] >= 0) and np.all(search["rounds"][()] >= 1)):
            raise ValueError(f"methods/{name}/{SEARCH}: a negative objective or no round")
        times = [search.attrs[key] for key in SEARCH_SECONDS if key in search.attrs]
        if not times or not all(isinstance(seconds, float | np.floating) and seconds >= 0
                                for seconds in times):
            raise ValueError(f"methods/{name}/{SEARCH}: no seconds_per_layout or "
                             "seconds_per_step")


@dataclass(frozen=True)
class EvalContents:
    """What an eval file holds to draw an episode: the evaluation scenario as TOML, the
    layouts (L, N, 2), m, the methods' labels in the order they were evaluated (the policy
    first), and the results (``results_json``, with the policy's record)."""

    scenario_toml: str
    layouts_m: np.ndarray
    labels: list[str]
    results: dict[str, Any]


def read_eval_contents(path: Path) -> EvalContents:
    """:class:`EvalContents` of the eval file at ``path`` (no trajectory is read)."""
    try:
        with open_run_file(path) as file:
            if file.attrs.get("kind") not in (KIND, KIND.encode()):
                raise AdaptskyError(f"{path}: not an adaptsky eval file")
            results = json.loads(file["results_json"][()].decode())
            toml = file["scenario"][()].decode()
            layouts_m = np.asarray(file["layouts_m"][()], dtype=np.float64)
            stored = {str(group.attrs.get("label", name)) for name, group in
                      file["methods"].items()}
    except (OSError, KeyError, ValueError, TypeError, UnicodeDecodeError) as error:
        raise damaged_eval_file(path, error) from None
    labels = [label for label in results.get("methods", {}) if label in stored]
    if layouts_m.ndim != 3 or layouts_m.shape[2] != 2 or not labels:
        raise AdaptskyError(f"{path}: damaged eval file (layouts_m of shape "
                            f"{layouts_m.shape} or no method)")
    return EvalContents(toml, layouts_m, labels, results)


def read_eval_trajectory(path: Path, label: str, layout: int, steps: int | None = None
                         ) -> dict[str, np.ndarray]:
    """Method ``label``'s trajectory on layout ``layout``, its first ``steps`` rows (None:
    all): ``uav_m`` (T, 3), or (T, U, 3) for several UAVs, ``alpha`` and ``rate_bps``
    (T, N), each step's energy ``energy_j`` (T,) or (T, U) where the file holds it (eval
    files made before the energy do not), and every user's position ``users_m`` (T, N, 2)
    where the users walk. Only those rows of that layout are read."""
    names = ("uav_m", "alpha", "rate_bps")
    try:
        with open_run_file(path) as file:
            group = file[f"methods/{group_name(label)}/trajectory"]
            datasets = [group[name] for name in names]
            rows = datasets[0].shape[0] if steps is None else min(steps, datasets[0].shape[0])
            if not rows or any(data.shape[:2] != datasets[0].shape[:2] or data.ndim < 3
                               for data in datasets):
                raise ValueError(f"methods/{group_name(label)}/trajectory: shapes "
                                 f"{[data.shape for data in datasets]}")
            found = {name: np.asarray(data[:rows, layout], dtype=np.float64)
                     for name, data in zip(names, datasets, strict=True)}
            for name in ("energy_j", "users_m"):   # (files before the energy hold none;
                data = group.get(name)                # users_m only where users walk)
                if data is None:
                    continue
                if data.shape[:2] != datasets[0].shape[:2]:
                    raise ValueError(f"methods/{group_name(label)}/trajectory/{name}: "
                                     f"shape {data.shape}")
                found[name] = np.asarray(data[:rows, layout], dtype=np.float64)
            return found
    except (OSError, KeyError, ValueError, TypeError, IndexError) as error:
        raise damaged_eval_file(path, error) from None
