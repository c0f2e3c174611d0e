"""Work in local worker processes, one host for ``train`` and ``reproduce``.

Jobs run in spawned processes, at most ``workers`` at once (the others wait in a queue), each
sending typed messages (:mod:`adaptsky.training.messages`) through a pipe of its own to this
process, which hands them to one handler. A stop asks the running jobs to checkpoint and end
(queued ones never start); a quit ends them at once: told to, then killed after a grace.
"""

from __future__ import annotations

import multiprocessing
import os
import time
import traceback
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from multiprocessing.connection import Connection, wait
from typing import Any

from adaptsky.errors import AdaptskyError
from adaptsky.training.interrupts import ignore_stop_signals, stop_signals_blocked
from adaptsky.training.messages import Done, Failed, HostMessage, Message, WorkerLost

Handle = Callable[[HostMessage], None]

# how long workers told to quit (a second Ctrl-C, an error here) may take to end by themselves
# (they look at the end of every episode) before they are killed; nothing they hold would be
# stored
QUIT_GRACE_S = 1.0
# how long workers that sent everything may take to exit before they are killed
EXIT_GRACE_S = 10.0


@dataclass(frozen=True)
class Job:
    """One worker process's work: ``target(*args, emit, stop, orphaned)`` (picklable), which
    emits a :class:`Done` or :class:`Failed` for each of ``keys``. ``stop()`` asks for a
    checkpoint and an early end; ``orphaned()`` (the parent is gone or quits) for an end
    without one."""

    target: Callable[..., None]
    args: tuple[Any, ...]
    keys: tuple[object, ...]


def pin_threads() -> None:
    """One BLAS and torch thread per process: on this network size one is as fast as two.
    (threadpoolctl: environment variables set after numpy is imported have no effect.)"""
    import torch
    from threadpoolctl import threadpool_limits

    threadpool_limits(limits=1)
    torch.set_num_threads(1)


def one_line(error: BaseException) -> str:
    """An error as the user reads it: an AdaptskyError's text, else its type and text."""
    if isinstance(error, AdaptskyError):
        return str(error)
    return traceback.format_exception_only(type(error), error)[-1].strip()


def _worker(job: Job, connection: Connection, stop_event: Any, quit_event: Any,
            parent_pid: int) -> None:
    """A worker process: run ``job``, sending every message through ``connection`` (a pipe
    of its own; a send waits until the parent reads it). It ends without a word when the
    parent is gone or says to quit."""
    ignore_stop_signals()
    pin_threads()

    def orphaned() -> bool:
        return os.getppid() != parent_pid or quit_event.is_set()

    try:
        try:
            job.target(*job.args, connection.send, stop_event.is_set, orphaned)
        except Exception as error:  # reported by the parent as one line
            for key in job.keys:
                connection.send(Failed(key, one_line(error)))
    except OSError:  # the parent closed its end (it quit or died): nobody reads any more
        pass
    finally:
        connection.close()


@dataclass
class _Worker:
    """A worker process, the read end of its pipe (None once it ended) and its job's keys
    not yet done or failed."""

    process: Any
    connection: Connection | None
    left: set[object]


class ProcessHost:
    """Runs jobs in at most ``workers`` processes at once. :meth:`pump` hands their messages
    to a handler; :meth:`close` ends every process. ``on_drop`` hears of each queued job that
    a stop leaves unstarted."""

    def __init__(self, workers: int, on_drop: Callable[[Job], None] = lambda job: None) -> None:
        self.context = multiprocessing.get_context("spawn")
        self.stop_event, self.quit_event = self.context.Event(), self.context.Event()
        self.workers, self.on_drop = workers, on_drop
        self.queue: deque[Job] = deque()
        self.started: list[_Worker] = []

    def submit(self, jobs: list[Job]) -> None:
        """Queue ``jobs``; those that fit start now."""
        self.queue.extend(jobs)
        self._launch()

    def request_stop(self) -> None:
        """Running jobs checkpoint and end; queued jobs never start."""
        self.stop_event.set()

    @property
    def active(self) -> bool:
        """Whether a job is queued or has keys not yet done or failed."""
        return bool(self.queue) or any(worker.left for worker in self.started)

    def pump(self, handle: Handle, timeout_s: float) -> bool:
        """Hand the messages that arrive within about ``timeout_s`` to ``handle``, starting
        queued jobs as others end; whether work is left (:attr:`active`)."""
        self._launch()
        open_ends = {worker.connection: worker for worker in self.started
                     if worker.connection is not None}
        if not open_ends:
            return self.active
        for connection in wait(list(open_ends), timeout=timeout_s):
            worker = open_ends[connection]  # type: ignore[index]
            try:
                message: Message = connection.recv()  # type: ignore[union-attr]
            except (EOFError, OSError):  # it ended: whatever it had not finished is lost
                worker.connection = None
                connection.close()  # type: ignore[union-attr]
                if worker.left:
                    worker.process.join(EXIT_GRACE_S)
                    lost, worker.left = tuple(worker.left), set()
                    handle(WorkerLost(lost, worker.process.exitcode))
                continue
            handle(message)
            if isinstance(message, Done | Failed):
                worker.left.discard(message.key)
        self._launch()
        return self.active

    def _launch(self) -> None:
        if self.stop_event.is_set():
            while self.queue:
                self.on_drop(self.queue.popleft())
        busy = sum(1 for worker in self.started if worker.left)
        if not self.queue or busy >= self.workers:
            return
        with stop_signals_blocked():  # children ignore them before they import anything
            while self.queue and busy < self.workers:
                job = self.queue.popleft()
                reader, writer = self.context.Pipe(duplex=False)
                process = self.context.Process(
                    target=_worker, daemon=True,
                    args=(job, writer, self.stop_event, self.quit_event, os.getpid()))
                self.started.append(_Worker(process, reader, set(job.keys)))
                process.start()
                writer.close()  # the child's end: EOF here once the child has ended
                busy += 1

    def close(self, grace_s: float, *, quit_now: bool = False) -> None:
        """End every process (``quit_now``: tell the running jobs to end at once, without a
        checkpoint); queued jobs are dropped without a word."""
        if quit_now:
            self.quit_event.set()
        self.queue.clear()
        end(self.started, grace_s)


def end(started: list[_Worker], grace_s: float) -> None:
    """Close every pipe (a worker blocked sending then fails at once and ends), wait at most
    ``grace_s`` for the workers to end, then kill (SIGKILL) those still running: they ignore
    SIGINT and SIGTERM."""
    for worker in started:
        if worker.connection is not None:
            worker.connection.close()
            worker.connection = None
    deadline = time.monotonic() + grace_s
    try:
        for worker in started:
            if worker.process.pid is not None:
                worker.process.join(max(0.0, deadline - time.monotonic()))
    finally:
        for worker in started:
            if worker.process.pid is not None and worker.process.is_alive():
                worker.process.kill()
                worker.process.join(EXIT_GRACE_S)
