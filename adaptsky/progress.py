"""Progress of long work through a small protocol: the library reports lines and counted
stages to a :class:`Reporter`; a front end shows them (the command line: a Rich display on a
terminal). Here: the rules every front end shares, plain timestamped lines (:class:`LogLines`,
for a pipe, nohup, a batch job, CI) and :class:`Silent`."""

from __future__ import annotations

import sys
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Literal, TextIO

from adaptsky.units import format_duration, plural

LOG_EVERY_S = 30.0

Tick = Callable[[int], None]
"""Reports how many units of a stage are done."""

Layout = Literal["work", "seeds", "runs"]
"""How a live display draws its stages: bars of work units (gone when done), one row per
training seed, one bar of a sweep's runs."""


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


class Reporter:
    """Where long work reports. A front end implements :meth:`print` and, if it draws stages
    as they go (``live``), :meth:`open` to :meth:`close`; the line methods below are the
    rules every front end shares. ``quiet``: only warnings and interrupts."""

    live = False  # stages are drawn as they go: log lines are left out, messages unstamped
    quiet = False

    def print(self, text: str) -> None:
        """A line as it is (a warning), always."""
        raise NotImplementedError

    def say(self, text: str) -> None:
        """A line as it is (a result), unless quiet."""
        if not self.quiet:
            self.print(text)

    def message(self, text: str) -> None:
        """A line about the work (an interrupt), always: timestamped where nothing is live."""
        self.print(text if self.live else stamp(text))

    def note(self, text: str) -> None:
        """:meth:`message`, unless quiet."""
        if not self.quiet:
            self.message(text)

    def log(self, text: str) -> None:
        """A timestamped progress line where nothing is live (a log), unless quiet."""
        if not self.live and not self.quiet:
            self.print(stamp(text))

    def open(self, layout: Layout) -> None:
        """A display of stages drawn as ``layout`` begins (one at a time)."""

    def close(self) -> None:
        """The display ends."""

    def start(self, key: object, total: int, done: int = 0, **fields: object) -> None:
        """A stage of ``total`` units, ``done`` of them already; ``fields`` name its text."""

    def advance(self, key: object, done: int, **fields: object) -> None:
        """``done`` units of stage ``key`` are done; its text changes to ``fields``."""

    def finish(self, key: object) -> None:
        """Stage ``key`` is over (a live display may drop it)."""


class Silent(Reporter):
    """Shows nothing."""

    quiet = True

    def print(self, text: str) -> None:
        pass


class LogLines(Reporter):
    """Plain lines on ``stream`` (standard error by default): timestamped progress."""

    def __init__(self, stream: TextIO | None = None, *, quiet: bool = False) -> None:
        self.stream, self.quiet = stream, quiet

    def print(self, text: str) -> None:
        print(text, file=self.stream or sys.stderr, flush=True)


class WorkProgress:
    """Stages of work with a known number of units (layouts, steps) each: a live bar per
    stage, or a log line at its start and end and one every ``log_every_s``."""

    def __init__(self, reporter: Reporter, *, log_every_s: float | None = None) -> None:
        self.reporter = reporter
        self.log_every_s = LOG_EVERY_S if log_every_s is None else log_every_s

    def __enter__(self) -> WorkProgress:
        self.reporter.open("work")
        return self

    def __exit__(self, *exc: object) -> None:
        self.reporter.close()

    def log(self, text: str) -> None:
        """A timestamped line (in a log only; a live display shows the bars)."""
        self.reporter.log(text)

    @contextmanager
    def stage(self, name: str, total: int, unit: str) -> Iterator[Tick]:
        """A stage of ``total`` units; the yielded function takes the units done so far."""
        start = last_log = time.monotonic()
        key = object()
        self.reporter.start(key, total, name=name, unit=unit)
        self.log(f"{name}: {plural(total, unit)} ...")

        def tick(done: int) -> None:
            nonlocal last_log
            self.reporter.advance(key, done)
            now = time.monotonic()
            if now - last_log >= self.log_every_s and done < total:
                last_log = now
                self.log(f"{name}: {done}/{total} {unit}s, {pace(now - start, done, total, unit)}")

        try:
            yield tick
        finally:
            self.reporter.finish(key)
        seconds = time.monotonic() - start
        self.log(f"{name}: done in " + (f"{seconds:.1f} s" if seconds < 60
                                        else format_duration(seconds)))
