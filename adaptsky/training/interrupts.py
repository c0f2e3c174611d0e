"""Ctrl-C and SIGTERM while work runs, one policy for ``train`` and ``reproduce``: the first
asks the work to checkpoint and stop, the second quits at once (never in the middle of a write
of this process: then when the write is done). Worker processes ignore both: their parent
decides."""

from __future__ import annotations

import signal
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any, TypeVar

# Ctrl-C, and the stop that `kill`, `timeout` and batch schedulers send: both checkpoint and end
STOP_SIGNALS = {signal.SIGINT, signal.SIGTERM}

T = TypeVar("T")


@contextmanager
def stop_signals_blocked() -> Iterator[None]:
    """Block the stop signals in this thread while the block runs (processes started meanwhile
    inherit the mask, so a Ctrl-C cannot interrupt their start-up); one that came meanwhile is
    then delivered to this process's handler."""
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, STOP_SIGNALS)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


def ignore_stop_signals() -> None:
    """In a worker process: the parent decides when to stop (through an event); the signals
    were blocked while it started."""
    for signum in STOP_SIGNALS:
        signal.signal(signum, signal.SIG_IGN)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, STOP_SIGNALS)


def in_finaliser(frame: Any) -> bool:
    """Whether the signal came while a weakref callback or a ``__del__`` ran: Python would
    print an exception raised there ("Exception ignored in ...") and drop it."""
    while frame is not None:
        code = frame.f_code
        if code.co_name == "__del__" or code.co_filename.endswith(("weakref.py", "_weakrefset.py")):
            return True
        frame = frame.f_back
    return False


class StopOnInterrupt:
    """First Ctrl-C (or SIGTERM): ``request_stop()`` (the work checkpoints and stops) and say
    ``notice``. Second, or the first once ``stopping()`` (a failure asked for a stop already):
    KeyboardInterrupt, held back while :meth:`shielded` work runs."""

    def __init__(self, request_stop: Callable[[], None], say: Callable[[str], None],
                 notice: str, stopping: Callable[[], bool] = lambda: False) -> None:
        self.request_stop, self.say, self.notice = request_stop, say, notice
        self.stopping = stopping
        self.interrupted = self.writing = self.quit_pending = False

    def __enter__(self) -> StopOnInterrupt:
        self.previous = {signum: signal.signal(signum, self._handle) for signum in STOP_SIGNALS}
        return self

    def _handle(self, signum: int, frame: Any) -> None:
        if self.interrupted or self.stopping():
            self.quit_pending = True  # kept: check() raises it later where it cannot now
            if self.writing or in_finaliser(frame):
                return
            raise KeyboardInterrupt
        self.interrupted = True
        self.request_stop()
        self.say(self.notice)

    def check(self) -> None:
        """Raise the second Ctrl-C's KeyboardInterrupt where the handler held it back (it came
        while a weakref callback or ``__del__`` ran) or Python dropped it. Loops that wait on
        work call this on every turn."""
        if self.quit_pending and not self.writing:
            raise KeyboardInterrupt

    def shielded(self, handle: Callable[[T], None]) -> Callable[[T], None]:
        """``handle`` with a second Ctrl-C held back while it runs (it writes a file: an
        interrupt inside HDF5's callbacks could leave a file it cannot close)."""
        def shielded_handle(message: T) -> None:
            self.writing = True
            try:
                handle(message)
            finally:
                self.writing = False
            if self.quit_pending:
                raise KeyboardInterrupt
        return shielded_handle

    def __exit__(self, *exc: object) -> None:
        for signum, previous in self.previous.items():
            signal.signal(signum, previous)
