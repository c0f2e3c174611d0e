"""An evaluation's per-layout numbers as a CSV to take away (``eval --csv``, ``inspect EVAL.h5
--csv``): one row per method and layout, the metrics in their base units (bit/s, bit/s/Hz,
shares 0..1, %), the steady state as a percentage of the reference where one was compared,
and every user's steady-state rate in a column of its own."""

from __future__ import annotations

import csv
import io
import math
import os
from pathlib import Path
from typing import Any

import numpy as np

from adaptsky.errors import AdaptskyError
from adaptsky.report.eval_table import REFERENCES
from adaptsky.report.user_rates import eval_user_rates
from adaptsky.rollouts.metrics import percent_of
from adaptsky.store.atomic import write_text_atomic

LAYOUT_METRICS = ("mean_sum_rate_bps", "steady_sum_rate_bps", "fairness", "min_user_se",
                  "satisfied_share", "steady_satisfied_share", "outage_share",
                  "mean_least_rate_bps", "p5_rate_bps")
"""The per-layout metrics of docs/evaluation.md with one number per layout, in this order."""
USER_COLUMN = "steady_rate_bps_user_{}"
"""The column of user i's steady-state rate (users numbered from 0, in the layout's order)."""


def check_csv_path(path: Path, option: str = "--csv") -> None:
    """Refuse, before any work, a CSV path that does not end in .csv (never a CSV written over a
    run, eval or scenario file), names a folder, or lies in a folder that is missing or cannot
    be written. An existing CSV file is replaced (atomically)."""
    if path.suffix.lower() != ".csv":
        given = f"'{path.suffix}'" if path.suffix else "no suffix"
        raise AdaptskyError(f"{option} {path}: a CSV file must end in .csv (it has {given})")
    if path.is_dir():
        raise AdaptskyError(f"{option} {path}: is a folder; give a file name ending in .csv")
    folder = path.parent
    if not folder.is_dir():
        raise AdaptskyError(f"{option} {path}: the folder {folder} does not exist; create it "
                            f"or choose another {option}")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise AdaptskyError(f"{option} {path}: cannot write in {folder} (permission denied "
                            f"or read-only); choose another {option}")


def reference_of(results: dict[str, Any]) -> str | None:
    """The compared method the steady states are a percentage of: the oracle, else best
    response (as the policy's share in the table), or None."""
    return next((name for name in REFERENCES if name in results["methods"]), None)


def pct_column(reference: str) -> str:
    """'steady_pct_of_oracle', 'steady_pct_of_best_response'."""
    return f"steady_pct_of_{reference.replace('-', '_')}"


def eval_csv_rows(results: dict[str, Any]) -> tuple[list[str], list[list[Any]]]:
    """The header and rows of :func:`write_eval_csv` (empty cells: no number, such as a
    percentage of a reference rate of 0)."""
    methods = results["methods"]
    users = eval_user_rates(results)
    reference = reference_of(results)
    # the metrics every method has (an eval file made before the service metrics lacks them)
    metrics = [key for key in LAYOUT_METRICS
               if all(key in entry["layouts"] for entry in methods.values())]
    header = ["method", "layout", *metrics]
    if reference is not None:
        header.append(pct_column(reference))
        ceiling = np.asarray(methods[reference]["layouts"]["mean_sum_rate_bps"])
    count = next(iter(users.values())).shape[1]
    header += [USER_COLUMN.format(user) for user in range(count)]
    rows = []
    for name, entry in methods.items():
        layouts = entry["layouts"]
        pct = (percent_of(np.asarray(layouts["steady_sum_rate_bps"]), ceiling)
               if reference is not None else None)
        for layout in range(int(results["layouts"])):
            row: list[Any] = [name, layout, *(float(layouts[key][layout])
                                              for key in metrics)]
            if pct is not None:
                row.append(float(pct[layout]))
            row += users[name][layout].tolist()
            rows.append(["" if isinstance(v, float) and not math.isfinite(v) else v
                         for v in row])
    return header, rows


def write_eval_csv(path: Path, results: dict[str, Any]) -> Path:
    """Every method's per-layout numbers to ``path`` (checked by :func:`check_csv_path`),
    written whole or not at all. Returns ``path``."""
    check_csv_path(path)
    header, rows = eval_csv_rows(results)
    text = io.StringIO()
    writer = csv.writer(text, lineterminator="\n")
    writer.writerow(header)
    writer.writerows(rows)
    write_text_atomic(path, text.getvalue())
    return path
