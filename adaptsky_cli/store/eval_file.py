"""Eval files: HDF5 holding an evaluation's results and trajectories (docs/file-format.md)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from adaptsky_cli import __version__
from adaptsky_cli.errors import AdaptskyError
from adaptsky_cli.evaluate.api import Method
from adaptsky_cli.store.atomic import rewrite, string_dataset, utc_timestamp
from adaptsky_cli.store.tree import read_tree, write_tree

FORMAT_VERSION = 1
KIND = "adaptsky-eval"


def write_eval(path: Path, results: dict[str, Any], methods: list[Method]) -> None:
    """Write a new eval file at ``path`` in one atomic step (replacing any file there)."""
    with rewrite(path, fresh=True) as file:
        file.attrs.update(format_version=FORMAT_VERSION, kind=KIND, adaptsky_version=__version__,
                          created_utc=utc_timestamp(),
                          scenario_name=results["scenario"], steps=results["steps"],
                          layouts=results["layouts"])
        string_dataset(file, "results_json", json.dumps(results))
        file.create_dataset("layouts_m", data=np.array(results["layouts_m"]))
        for method in methods:
            group = file.create_group(f"methods/{method.name}")
            write_tree(group, {key: np.asarray(value) for key, value in method.metrics.items()})
            trace = method.trace
            write_tree(group.create_group("trajectory"), {
                "sum_rate_bps": trace.sum_rate_bps, "rate_bps": trace.rate_bps,
                "uav_m": trace.uav_m, "alpha": trace.alpha}, compress=True)
        for name, comparison in results.get("comparison", {}).items():
            file.require_group("comparison").create_group(name).attrs.update(comparison)


def read_eval_metrics(path: Path) -> tuple[dict[str, Any] | None, dict[str, dict[str, np.ndarray]]]:
    """An eval file's ``record`` (what it evaluated, if written by ``reproduce``) and the
    per-layout metrics of each method."""
    try:
        with h5py.File(path, "r") as file:
            if file.attrs.get("kind") != KIND:
                raise AdaptskyError(f"{path}: not an adaptsky eval file")
            results = json.loads(file["results_json"][()].decode())
            methods = {}
            for name, group in file["methods"].items():
                tree = read_tree(group)
                tree.pop("trajectory", None)
                methods[name] = {key: np.asarray(value) for key, value in tree.items()}
    except (OSError, KeyError, ValueError) as error:
        raise AdaptskyError(f"{path}: damaged eval file ({str(error).splitlines()[0]})") from None
    return results.get("record"), methods
