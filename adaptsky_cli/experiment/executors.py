"""Where runs execute: local processes (the default) or an existing Dask cluster.

Both speak ``concurrent.futures``: ``submit(spec) -> future`` and ``request_stop()``. A run
writes only its own file, so results come back through the files, never through memory, and
a retried run resumes from its last checkpoint.
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import uuid
from concurrent.futures import Future, ProcessPoolExecutor
from typing import Any, Protocol

from adaptsky_cli.errors import AdaptskyError
from adaptsky_cli.experiment.plan import RunSpec
from adaptsky_cli.experiment.runs import RunReport, execute_run


class Executor(Protocol):
    description: str
    capacity: int  # runs at once

    def submit(self, spec: RunSpec) -> Any: ...

    def request_stop(self) -> None: ...

    def close(self) -> None: ...


_stop_event: Any = None
_parent_pid = 0


def _init_local_worker(stop_event: Any, parent_pid: int) -> None:
    global _stop_event, _parent_pid
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent decides when to stop
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})  # blocked while starting
    _stop_event, _parent_pid = stop_event, parent_pid


def _orphaned() -> bool:
    return os.getppid() != _parent_pid


def _local_run(spec: RunSpec) -> RunReport:
    # a worker whose parent died stops without a checkpoint: a restarted reproduce must not
    # meet a second writer on the same file
    return execute_run(spec, _stop_event.is_set, _orphaned)


class LocalExecutor:
    """A pool of ``workers`` processes (spawned, one torch thread each)."""

    def __init__(self, workers: int) -> None:
        context = multiprocessing.get_context("spawn")
        self.stop_event = context.Event()
        self.pool = ProcessPoolExecutor(workers, mp_context=context,
                                        initializer=_init_local_worker,
                                        initargs=(self.stop_event, os.getpid()))
        self.capacity = workers
        self.description = f"{workers} local process{'es' if workers > 1 else ''}"

    def submit(self, spec: RunSpec) -> Future[RunReport]:
        return self.pool.submit(_local_run, spec)

    def request_stop(self) -> None:
        self.stop_event.set()

    def close(self) -> None:
        self.pool.shutdown(wait=True, cancel_futures=True)


def _dask_run(spec: RunSpec, stop_name: str) -> RunReport:
    from distributed import Event

    event = Event(stop_name)
    return execute_run(spec, event.is_set)


class DaskExecutor:
    """Runs as tasks of an existing Dask cluster: one run = one task, retried on another
    worker (from its last checkpoint) when its worker dies. The output folder must be on
    storage every worker shares."""

    def __init__(self, address: str) -> None:
        try:
            from distributed import Client, Event
        except ImportError:
            raise AdaptskyError("--scheduler needs Dask: pip install distributed") from None
        try:
            self.client = Client(address, timeout="20s")
        except (OSError, TimeoutError, ValueError) as error:
            raise AdaptskyError(f"--scheduler {address}: cannot connect "
                                f"({str(error).splitlines()[0]})") from None
        self.stop_name = f"adaptsky-stop-{uuid.uuid4().hex}"
        self.stop = Event(self.stop_name, client=self.client)
        workers = self.client.scheduler_info().get("workers", {})
        self.capacity = max(1, sum(int(w.get("nthreads", 1)) for w in workers.values()))
        self.description = f"Dask at {address} ({len(workers)} workers now)"

    def submit(self, spec: RunSpec) -> Any:
        return self.client.submit(_dask_run, spec, self.stop_name, pure=False,
                                  key=f"adaptsky-run-{spec.name}-{uuid.uuid4().hex[:8]}")

    def request_stop(self) -> None:
        self.stop.set()

    def close(self) -> None:
        self.client.close()


def make_executor(workers: int, scheduler: str | None) -> Executor:
    return DaskExecutor(scheduler) if scheduler else LocalExecutor(workers)
