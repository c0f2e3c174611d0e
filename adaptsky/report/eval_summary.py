"""Eval files among run files: which paths are eval files (``plot`` skips them, ``inspect``
summarises them) and what ``inspect EVAL.h5`` shows of one (docs/evaluation.md#eval-files)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import h5py

from adaptsky.errors import AdaptskyError
from adaptsky.report.user_rates import USER_RATES
from adaptsky.rollouts.metrics import STEADY_STEPS, steady_user_rates
from adaptsky.store.eval_file import (
    KIND,
    check_searches,
    damaged_eval_file,
    outside_record,
    verify_eval_file,
)
from adaptsky.store.run_file import open_run_file

HEADER = ("adaptsky_version", "format_version", "created_utc", "command_line")
"""The eval file's root attributes ``inspect`` shows."""


def is_eval_file(path: Path) -> bool:
    """Whether ``path`` is a readable HDF5 file of kind ``adaptsky-eval`` with its results
    (anything else, or a file that cannot be read, is left to the run-file reader to name)."""
    try:
        with open_run_file(path) as file:
            return file.attrs.get("kind") in (KIND, KIND.encode()) and "results_json" in file
    except (AdaptskyError, OSError):
        return False


def split_eval_files(paths: list[Path]) -> tuple[list[Path], list[Path]]:
    """``paths`` as (the others, the eval files), each in the order given."""
    evals = [path for path in paths if is_eval_file(path)]
    return [path for path in paths if path not in evals], evals


def read_eval_file(path: Path) -> tuple[dict[str, Any], dict[str, Any]]:
    """An eval file's header attributes and its results (what ``eval --json`` printed)."""
    try:
        with open_run_file(path) as file:
            if file.attrs.get("kind") not in (KIND, KIND.encode()):
                raise AdaptskyError(f"{path}: not an adaptsky eval file")
            header = {key: _plain(file.attrs[key]) for key in HEADER if key in file.attrs}
            verify_eval_file(file, path)
            results = json.loads(file["results_json"][()].decode())
            check_searches(file)
            if isinstance(results, dict) and isinstance(results.get("methods"), dict):
                _add_user_rates(file, results["methods"])
    except (OSError, KeyError, ValueError, UnicodeDecodeError) as error:
        raise damaged_eval_file(path, error) from None
    if not isinstance(results, dict) or "methods" not in results:
        raise AdaptskyError(f"{path}: damaged eval file (results_json holds no methods)")
    return header, results


def _add_user_rates(file: h5py.File, methods: dict[str, Any]) -> None:
    """Each user's steady-state rate per layout, for eval files written before eval stored it
    (``steady_user_rate_bps``): from the rates of the last 100 steps of each method's
    trajectory, as eval computes it."""
    for group in file["methods"].values():
        label = _plain(group.attrs.get("label", ""))
        layouts = methods.get(label, {}).get("layouts")
        if isinstance(layouts, dict) and USER_RATES not in layouts:
            rates = group["trajectory/rate_bps"]
            tail = rates[max(0, rates.shape[0] - STEADY_STEPS):]
            layouts[USER_RATES] = steady_user_rates(tail).tolist()


def _plain(value: Any) -> Any:
    """An HDF5 attribute as a JSON-able value."""
    if isinstance(value, bytes):
        return value.decode()
    return value.item() if hasattr(value, "item") else value


def eval_header_line(path: Path, header: dict[str, Any], results: dict[str, Any]) -> str:
    """The first line of ``inspect EVAL.h5``: what the file is and what it evaluated."""
    outside = outside_record(results)
    if outside is not None:
        what = f"the outside policy '{outside['label']}'"
    elif results.get("checkpoint"):
        what = f"seed {results['seed']} of {results['checkpoint']}"
    else:
        what = "baselines"
    made = f", created {header['created_utc']}" if "created_utc" in header else ""
    return (f"{path}: eval file of {what}, adaptsky {header.get('adaptsky_version', '?')}"
            f"{made}")


def outside_policy_line(results: dict[str, Any]) -> str | None:
    """Which policy was evaluated, where it came from outside adaptsky (``evaluate_policy``):
    its label and action space; it has no run file and no training curve. None otherwise."""
    outside = outside_record(results)
    if outside is None:
        return None
    space = outside.get("action_space")
    actions = f", {space} actions" if space else ""
    return (f"policy: the outside policy '{outside['label']}'{actions} (evaluate_policy; no "
            "run file, no training curve)")
