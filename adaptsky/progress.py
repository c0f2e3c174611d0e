"""Progress of long work through a small protocol: the library reports lines and counted
stages to a :class:`Reporter`; a front end shows them (the command line: a Rich display on a
terminal). Here: the rules every front end shares, plain timestamped lines (:class:`LogLines`,
for a pipe, nohup, a batch job, CI), :class:`Silent`, and the time left of counted work
(:class:`Pace`)."""

from __future__ import annotations

import math
import sys
import threading
import time
from collections import deque
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Literal, Protocol, TextIO

from adaptsky.units import format_duration, plural

LOG_EVERY_S = 30.0


class Tick(Protocol):
    """Reports how many units of a stage are done: a whole number, or a fraction where the
    work knows how far it is within a unit, with ``detail``, where in the unit it is ('round
    2, UAV 3/3: 40%')."""

    def __call__(self, done: float, detail: str = "", /) -> None: ...


Layout = Literal["work", "seeds", "runs", "trials"]
"""How a live display draws its stages: bars of work units (gone when done), one row per
training seed, one bar of a sweep's runs, one bar of a tuning's trials (with the running
trial's episodes)."""


def stamp(text: str) -> str:
    """``text`` after the local date and time, as log lines carry it."""
    return f"{time.strftime('%Y-%m-%d %H:%M:%S')} {text}"


def _per_unit(seconds: float) -> str:
    return f"{seconds:.2f} s" if seconds >= 0.1 else f"{1000 * seconds:.1f} ms"


def _left(seconds: float) -> str:
    return "under 1 s left" if seconds < 1 else f"about {format_duration(seconds)} left"


def _clock(seconds: float) -> str:
    """'0:01:12', as a clock of hours, minutes and seconds."""
    minutes, secs = divmod(round(seconds), 60)
    return f"{minutes // 60}:{minutes % 60:02d}:{secs:02d}"


def pace(seconds: float, done: float, total: int, unit: str) -> str:
    """'0.91 s/layout, about 1 min 12 s left' (empty before the first unit)."""
    if done <= 0:
        return ""
    per_unit = seconds / done
    left = "" if done >= total else f", {_left(per_unit * (total - done))}"
    return f"{_per_unit(per_unit)}/{unit}{left}"


PACE_WINDOW = 20
"""How many of the latest updates a :class:`Pace` measures over."""

PACE_MIN_UNITS = 2
"""How many units a :class:`Pace` times (after the first) before it estimates."""

ESTIMATING = "estimating time left"


class Pace:
    """The time per unit and the time left of work of ``total`` units, ``done`` of them
    already, measured over its latest :data:`PACE_WINDOW` updates from the end of its first
    unit on: the first (processes starting, imports, first allocations) is by far the slowest
    and says little of the others. Until :data:`PACE_MIN_UNITS` are timed it is estimating."""

    def __init__(self, total: int, done: int = 0, window: int = PACE_WINDOW) -> None:
        self.total, self.done = total, done
        self.samples: deque[tuple[float, int]] = deque(maxlen=window + 1)

    def update(self, done: int, now: float | None = None) -> None:
        """``done`` units are done (by ``now``, default the monotonic clock)."""
        if done > self.done:
            self.done = done
            self.samples.append((time.monotonic() if now is None else now, done))

    def per_unit_s(self) -> float | None:
        """Seconds per unit over the window; None while estimating."""
        if len(self.samples) < 2:
            return None
        (first_s, first), (last_s, last) = self.samples[0], self.samples[-1]
        return (last_s - first_s) / (last - first) if last - first >= PACE_MIN_UNITS else None

    def left(self, short: bool = False) -> str:
        """'about 1 min 12 s left', 'under 1 s left', :data:`ESTIMATING`; empty once done.
        ``short`` (a live row of 80 columns): '0:01:12', 'estimating'."""
        if self.done >= self.total:
            return ""
        per_unit = self.per_unit_s()
        if per_unit is None:
            return "estimating" if short else ESTIMATING
        seconds = per_unit * (self.total - self.done)
        return _clock(seconds) if short else _left(seconds)

    def text(self, unit: str) -> str:
        """'0.91 s/episode, about 1 min 12 s left' (the time per unit, once measured, and
        :meth:`left`)."""
        per_unit = self.per_unit_s()
        each = "" if per_unit is None else f"{_per_unit(per_unit)}/{unit}"
        return ", ".join(part for part in (each, self.left()) if part)


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

    def advance(self, key: object, done: float, **fields: object) -> None:
        """``done`` units of stage ``key`` are done (a fraction within a unit: a
        :class:`WorkProgress` stage's ``fields`` hold its ``detail``, where the work is within
        the next unit, empty where it says nothing); its text changes to ``fields``."""

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
        stream = self.stream or sys.stderr
        stream.write(text + "\n")  # one write: a stage's heartbeat may print from a thread
        stream.flush()


class WorkProgress:
    """Stages of work with a known number of units (layouts, steps) each: a live bar per
    stage (with the latest ``detail`` of its tick), or a log line at its start and end and one
    every ``log_every_s``: at a tick, and from a thread where no tick comes (a unit, or the
    part of one the work reports, takes longer)."""

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
        """A stage of ``total`` units; the yielded function takes the units done so far (and
        where the work is within the next, :class:`Tick`)."""
        start = time.monotonic()
        key = object()
        self.reporter.start(key, total, name=name, unit=unit)
        self.log(f"{name}: {plural(total, unit)} ...")
        state = _StageState(start)

        def line(now: float) -> str:
            done, detail = state.done, state.detail
            speed = pace(now - start, done, total, unit)
            if detail and done < total:
                return (f"{name}: {unit} {min(total, math.floor(done) + 1)}/{total}, {detail}"
                        + (f"; {speed}" if speed else ""))
            return f"{name}: {_count(done)}/{total} {unit}s" + (f", {speed}" if speed else "")

        def tick(done: float, detail: str = "", /) -> None:
            self.reporter.advance(key, done, detail=detail)
            with state.lock:
                state.done, state.detail = done, detail
                now = time.monotonic()
                if now - state.last_log >= self.log_every_s and done < total:
                    state.last_log = now
                    self.log(line(now))

        # a little early (1 s in 30), so that a line late by a busy machine still comes within
        # log_every_s of the one before, as the lines' whole seconds show it
        every = self.log_every_s - min(1.0, self.log_every_s / 30)

        def heartbeat() -> None:
            while not state.ended.wait(max(0.0, state.last_log + every - time.monotonic())):
                with state.lock:
                    now = time.monotonic()
                    if now - state.last_log >= every:
                        state.last_log = now
                        self.log(line(now))

        reporter = self.reporter
        beating = None
        if not reporter.live and not reporter.quiet and self.log_every_s > 0:
            beating = threading.Thread(target=heartbeat, name=f"progress: {name}", daemon=True)
            beating.start()
        try:
            yield tick
        finally:
            state.ended.set()
            if beating is not None:
                beating.join()
            self.reporter.finish(key)
        seconds = time.monotonic() - start
        self.log(f"{name}: done in " + (f"{seconds:.1f} s" if seconds < 60
                                        else format_duration(seconds)))


class _StageState:
    """What a stage's ticks and its heartbeat share: the units done, the latest detail, when
    it last logged, whether it ended."""

    def __init__(self, start: float) -> None:
        self.done: float = 0
        self.detail = ""
        self.last_log = start
        self.lock = threading.Lock()
        self.ended = threading.Event()


def _count(done: float) -> str:
    """'2' for whole units, '1.37' within one."""
    return str(int(done)) if float(done).is_integer() else f"{done:.2f}"
