"""The order of the default run's work (tests/README.md, "Two workers"): pytest-xdist's
``--dist loadfile`` runs each test file on one worker (a module fixture is built once), and
this plugin hands the files out longest first, by the seconds each took in a measured run
(``tests/durations.json``), so that no long file starts last while the other worker idles.
Files that share a session fixture which trains (:data:`TOGETHER`) go to one worker as one
unit, so that it trains once. xdist's own order is by the number of tests in a file, which
sends a file of three long tests (a Dask cluster's) to the end.

With ``ADAPTSKY_TEST_TIMES=FILE`` set, each test's seconds (setup, call and teardown, on the
wall clock) are appended to FILE, one JSON line a test; ``python -m tests.helpers.schedule
FILE`` sums them by file into ``tests/durations.json``. A file the table lacks goes first
(a new file is likely one being worked on: its failures show early)."""

from __future__ import annotations

import json
import os
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

TABLE = Path(__file__).resolve().parents[1] / "durations.json"
TIMES_ENV = "ADAPTSKY_TEST_TIMES"
# files whose tests share a session fixture that trains (tests/e2e/conftest.py:
# ``uninterrupted``, two runs of 60 episodes): one unit, on one worker
TOGETHER = {"tests/e2e/test_dask.py": "uninterrupted",
            "tests/e2e/test_reproduce.py": "uninterrupted"}


def unit_of(nodeid: str) -> str:
    """The unit of work a test belongs to: its file, or the group of :data:`TOGETHER`."""
    path = nodeid.split("::", 1)[0]
    return TOGETHER.get(path, path)


def seconds_by_unit(table: dict[str, float]) -> dict[str, float]:
    """The table's seconds by file, summed by unit."""
    units: dict[str, float] = {}
    for path, seconds in table.items():
        units[unit_of(path)] = units.get(unit_of(path), 0.0) + seconds
    return units


def longest_first(units: list[str], seconds: dict[str, float]) -> list[str]:
    """``units`` in the order to hand out: those the table lacks first (as collected), then
    the others longest first (ties as collected)."""
    unknown = [unit for unit in units if unit not in seconds]
    known = sorted((unit for unit in units if unit in seconds), key=lambda u: -seconds[u])
    return unknown + known


def _make_scheduler_class() -> type | None:
    try:
        from xdist.scheduler import LoadFileScheduling
    except ImportError:       # pytest-xdist absent: -n is unknown and none of this runs
        return None

    class LongestFilesFirst(LoadFileScheduling):
        """xdist's file scheduling, its units (files, :data:`TOGETHER`) longest first."""

        def __init__(self, config: pytest.Config, log: object = None) -> None:
            super().__init__(config, log)
            table = json.loads(TABLE.read_text()) if TABLE.is_file() else {}
            self.seconds = seconds_by_unit(table)
            self.ordered = False

        def _split_scope(self, nodeid: str) -> str:
            return unit_of(nodeid)

        def _assign_work_unit(self, node: object) -> None:
            if not self.ordered:     # the queue is complete at the first assignment
                order = longest_first(list(self.workqueue), self.seconds)
                for unit in order:
                    self.workqueue.move_to_end(unit)
                self.ordered = True
            super()._assign_work_unit(node)

    return LongestFilesFirst


SCHEDULER = _make_scheduler_class()


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_make_scheduler(config: pytest.Config, log: object) -> object | None:
    """The scheduler of ``--dist loadfile`` (the default run's); other modes as xdist has
    them."""
    if SCHEDULER is None or config.getoption("dist") != "loadfile":
        return None
    return SCHEDULER(config, log)


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item: pytest.Item) -> Iterator[None]:
    """With ``ADAPTSKY_TEST_TIMES`` set: one JSON line per test, its seconds."""
    target = os.environ.get(TIMES_ENV)
    start = time.monotonic()
    yield
    if target:
        line = json.dumps({"test": item.nodeid, "seconds": time.monotonic() - start})
        with open(target, "a") as times:
            times.write(line + "\n")


def summed(times: Path) -> dict[str, float]:
    """The seconds of a times file summed by test file, longest first, rounded to 0.1 s."""
    by_file: dict[str, float] = {}
    for line in times.read_text().splitlines():
        record = json.loads(line)
        path = record["test"].split("::", 1)[0]
        by_file[path] = by_file.get(path, 0.0) + record["seconds"]
    return {path: round(seconds, 1) for path, seconds in
            sorted(by_file.items(), key=lambda item: -item[1])}


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: python -m tests.helpers.schedule TIMES_FILE  (writes "
                 "tests/durations.json)")
    TABLE.write_text(json.dumps(summed(Path(sys.argv[1])), indent=1) + "\n")
    print(f"wrote {TABLE}")
