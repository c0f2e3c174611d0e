"""Eval files: HDF5 holding an evaluation's results and trajectories (docs/file-format.md)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from adaptsky_cli import __version__
from adaptsky_cli.evaluate.api import Method
from adaptsky_cli.store.atomic import rewrite, string_dataset, utc_timestamp
from adaptsky_cli.store.tree import write_tree

FORMAT_VERSION = 1
KIND = "adaptsky-eval"


def write_eval(path: Path, results: dict[str, Any], methods: list[Method]) -> None:
    """Write a new eval file at ``path`` in one atomic step."""
    with rewrite(path) as file:
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
