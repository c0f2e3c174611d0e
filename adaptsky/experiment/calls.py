"""The calls of ``reproduce`` on one output folder, ``DIR/calls.json``: when each started,
how long it took, on what machine, and what it trained. A folder trained over several calls
(resumed after an interruption, or continued on another machine) reports the sum of their wall
times as the experiment's."""

from __future__ import annotations

import json
import os
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from adaptsky import __version__
from adaptsky.store.atomic import write_text_atomic
from adaptsky.store.run_file import environment

CALLS_FILE = "calls.json"


@dataclass(frozen=True)
class Calls:
    """The recorded calls of a folder (oldest first)."""

    rows: list[dict[str, Any]]

    @property
    def wall_s(self) -> float:
        return float(sum(row["wall_s"] for row in self.rows))


def read_calls(out: Path) -> Calls:
    """The folder's calls; none for a folder without the file or with a damaged one (the
    record is informative, never a reason to refuse the runs)."""
    try:
        rows = json.loads((out / CALLS_FILE).read_text())
    except (OSError, ValueError):
        return Calls([])
    valid = isinstance(rows, list) and all(
        isinstance(row, dict) and isinstance(row.get("wall_s"), int | float) for row in rows)
    return Calls(rows if valid else [])


def record_call(out: Path, *, started_utc: str, wall_s: float, trained: int,
                interrupted: bool, device: str) -> None:
    """Append this call to ``DIR/calls.json`` (rewritten atomically)."""
    rows = read_calls(out).rows
    rows.append({"started_utc": started_utc, "wall_s": round(wall_s, 3),
                 "runs_trained": trained, "interrupted": interrupted,
                 "command_line": list(sys.argv), "device": device,
                 "cpu_count": os.cpu_count(), "adaptsky_version": __version__,
                 **environment()})
    write_text_atomic(out / CALLS_FILE, json.dumps(rows, indent=1))
