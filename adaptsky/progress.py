"""Progress of long work: a Rich bar on a terminal; elsewhere (a pipe, nohup, a batch job, CI)
timestamped log lines, one at the start and end of each stage and one every ``log_every_s``."""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager

from rich.console import Console
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    TextColumn,
    TimeElapsedColumn,
    TimeRemainingColumn,
)

from adaptsky.units import format_duration, plural

LOG_EVERY_S = 30.0

Tick = Callable[[int], None]
"""Reports how many units of a stage are done."""


def stamp(text: str) -> str:
    """``text`` after the local date and time, as log lines carry it."""
    return f"{time.strftime('%Y-%m-%d %H:%M:%S')} {text}"


def pace(seconds: float, done: int, total: int, unit: str) -> str:
    """'0.91 s/layout, about 1 min 12 s left' (empty before the first unit)."""
    if done <= 0:
        return ""
    per_unit, left_s = seconds / done, seconds / done * (total - done)
    left = "" if done >= total else (", under 1 s left" if left_s < 1 else
                                     f", about {format_duration(left_s)} left")
    each = f"{per_unit:.2f} s" if per_unit >= 0.1 else f"{1000 * per_unit:.1f} ms"
    return f"{each}/{unit}{left}"


class WorkProgress:
    """Stages of work with a known number of units (layouts, steps) each."""

    def __init__(self, console: Console, *, quiet: bool = False,
                 log_every_s: float | None = None) -> None:
        self.console, self.quiet = console, quiet
        self.log_every_s = LOG_EVERY_S if log_every_s is None else log_every_s
        self.live = console.is_terminal and not quiet
        self.progress = Progress(TextColumn("{task.description}"), BarColumn(),
                                 MofNCompleteColumn(), TextColumn("{task.fields[unit]}s"),
                                 TimeElapsedColumn(), TimeRemainingColumn(), console=console,
                                 disable=not self.live, transient=True)

    def __enter__(self) -> WorkProgress:
        self.progress.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.progress.stop()

    def log(self, text: str) -> None:
        """A timestamped line (plain mode only; a terminal shows the bars)."""
        if not self.quiet and not self.live:
            self.console.print(stamp(text), markup=False, highlight=False, soft_wrap=True)

    @contextmanager
    def stage(self, name: str, total: int, unit: str) -> Iterator[Tick]:
        """A stage of ``total`` units; the yielded function takes the units done so far."""
        start = last_log = time.monotonic()
        task = self.progress.add_task(name, total=total, unit=unit)
        self.log(f"{name}: {plural(total, unit)} ...")

        def tick(done: int) -> None:
            nonlocal last_log
            self.progress.update(task, completed=done)
            now = time.monotonic()
            if now - last_log >= self.log_every_s and done < total:
                last_log = now
                self.log(f"{name}: {done}/{total} {unit}s, {pace(now - start, done, total, unit)}")

        try:
            yield tick
        finally:
            self.progress.remove_task(task)
        seconds = time.monotonic() - start
        self.log(f"{name}: done in " + (f"{seconds:.1f} s" if seconds < 60
                                        else format_duration(seconds)))


class SilentProgress(WorkProgress):
    """Shows nothing (library calls without a console)."""

    def __init__(self) -> None:
        super().__init__(Console(quiet=True), quiet=True)
