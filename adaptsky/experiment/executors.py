"""Where runs execute: local processes of stacked runs (on the CPU or a GPU, through
:class:`adaptsky.training.host.ProcessHost`), or a Dask cluster (one run per task).

All speak futures: ``submit_all(specs) -> [future per run]``, ``wait_any(futures, timeout_s)``
(back as soon as one is done, or after ``timeout_s``), ``request_stop()`` (running runs
checkpoint and end, runs not started stay as they are) and ``close(now)``. A run writes only
its own file, so results come back through the files, never through memory, and a retried run
resumes from its last checkpoint.
"""

from __future__ import annotations

import contextlib
import threading
import uuid
from collections.abc import Callable
from concurrent.futures import FIRST_COMPLETED, Future
from concurrent.futures import wait as wait_futures
from pathlib import Path
from typing import Any, Protocol

import torch

from adaptsky.algos.device_step import describe
from adaptsky.errors import AdaptskyError
from adaptsky.experiment.plan import RunSpec
from adaptsky.experiment.runs import RunReport, execute_run, execute_runs
from adaptsky.scenario import parse_scenario
from adaptsky.training.host import EXIT_GRACE_S, QUIT_GRACE_S, Job, ProcessHost
from adaptsky.training.messages import Done, Failed, HostMessage, Message, WorkerLost
from adaptsky.training.stack_run import stack_key

# how often the local executor's thread looks at a stop or quit between messages
PUMP_S = 0.2


class Executor(Protocol):
    description: str
    capacity: int  # runs at once

    def submit_all(self, specs: list[RunSpec]) -> list[Any]: ...

    def wait_any(self, futures: list[Any], timeout_s: float) -> None: ...

    def request_stop(self) -> None: ...

    def close(self, now: bool = False) -> None: ...


def _stack_job(specs: list[RunSpec], device: str, emit: Callable[[Message], None],
               stop: Callable[[], bool], orphaned: Callable[[], bool]) -> None:
    """A local worker's job: train ``specs`` as one stack, then report each run."""
    reports = execute_runs(specs, stop, orphaned, torch.device(device))
    for spec, report in zip(specs, reports, strict=True):
        emit(Done(spec.path, report))


def stacks(specs: list[RunSpec], max_size: int | None = None) -> list[list[RunSpec]]:
    """Runs grouped into stacks of at most ``max_size``: runs whose scenarios may share one
    (same network, same environment but for reward weights and seeds), in plan order."""
    groups: dict[str, list[RunSpec]] = {}
    for spec in specs:
        key = stack_key(parse_scenario(spec.config, spec.name))
        groups.setdefault(key, []).append(spec)
    size = max_size or len(specs) or 1
    return [group[start:start + size] for group in groups.values()
            for start in range(0, len(group), size)]


class LocalExecutor:
    """Stacks of runs, each in one process on ``device``: one trainer updates all the runs of
    a stack together. ``workers`` stacks run at once. On a CPU the runs are cut into about
    ``workers`` stacks (one per core: a stack of four trains about 1.45 times as many
    seed-steps per second on one core as one seed does); on a GPU every group is one stack.
    A thread of this process hands the workers' messages to the runs' futures."""

    def __init__(self, workers: int, device: torch.device) -> None:
        self.host = ProcessHost(workers, on_drop=self._drop)
        self.workers = self.capacity = workers
        self.device = device
        self.futures: dict[Path, Future[RunReport]] = {}
        self.quit = threading.Event()
        self.lock = threading.Lock()  # the host is used by this thread and by the pump's
        self.thread = threading.Thread(target=self._pump, name="adaptsky-runs", daemon=True)
        self.description = (f"{describe(device)}, {workers} process"
                            f"{'es' if workers > 1 else ''} of stacked runs")

    def submit_all(self, specs: list[RunSpec]) -> list[Future[RunReport]]:
        futures = {spec.path: Future[RunReport]() for spec in specs}
        self.futures.update(futures)
        max_size = None if self.device.type != "cpu" else -(-len(specs) // self.workers)
        groups = stacks(specs, max_size)
        self.capacity = sum(sorted(map(len, groups), reverse=True)[:self.workers])
        with self.lock:
            self.host.submit([Job(_stack_job, (group, str(self.device)),
                                  tuple(spec.path for spec in group)) for group in groups])
        if not self.thread.is_alive():
            self.thread.start()
        return [futures[spec.path] for spec in specs]

    def wait_any(self, futures: list[Future[RunReport]], timeout_s: float) -> None:
        """Until one of ``futures`` is done, at most ``timeout_s``."""
        wait_futures(futures, timeout=timeout_s, return_when=FIRST_COMPLETED)

    def _pump(self) -> None:
        try:
            while not self.quit.is_set():
                with self.lock:
                    if not self.host.pump(self._settle, PUMP_S):
                        return
        except BaseException as error:  # a bug here: every run waiting on it fails
            for key in self.futures:
                self._resolve(key, error)

    def _settle(self, message: HostMessage) -> None:
        """A worker's word to the futures of its runs."""
        if isinstance(message, Done):
            self._resolve(message.key, message.result)
        elif isinstance(message, Failed):
            self._resolve(message.key, AdaptskyError(message.error))
        elif isinstance(message, WorkerLost):
            for key in message.keys:
                self._resolve(key, AdaptskyError(f"its process ended with exit code "
                                                 f"{message.exitcode}"))

    def _resolve(self, key: object, outcome: object) -> None:
        future = self.futures[key]  # type: ignore[index]
        if future.done():  # cancelled
            return
        if isinstance(outcome, BaseException):
            future.set_exception(outcome)
        else:
            future.set_result(outcome)  # type: ignore[arg-type]

    def _drop(self, job: Job) -> None:
        for key in job.keys:
            self.futures[key].cancel()

    def request_stop(self) -> None:
        """Running stacks checkpoint and stop; stacks not started yet stay as they are."""
        self.host.request_stop()

    def close(self, now: bool = False) -> None:
        """End every worker: when they are done, or ``now`` (a second Ctrl-C: within about
        a second, without a checkpoint)."""
        if now:
            self.quit.set()
        if self.thread.is_alive():
            self.thread.join()
        self.host.close(QUIT_GRACE_S if now else EXIT_GRACE_S, quit_now=now)
        for future in self.futures.values():
            future.cancel()


CONNECT_TIMEOUT_S = 20.0
"""How long ``--scheduler ADDRESS`` tries to reach the scheduler before one line says so."""


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
            self.client = Client(address, timeout=CONNECT_TIMEOUT_S)
        except (OSError, TimeoutError, ValueError) as error:
            raise AdaptskyError(f"--scheduler {address}: cannot connect "
                                f"({str(error).splitlines()[0]})") from None
        self.stop_name = f"adaptsky-stop-{uuid.uuid4().hex}"
        self.stop = Event(self.stop_name, client=self.client)
        workers = self.client.scheduler_info().get("workers", {})
        self.capacity = max(1, sum(int(w.get("nthreads", 1)) for w in workers.values()))
        self.description = f"Dask at {address} ({len(workers)} workers now)"

    def submit_all(self, specs: list[RunSpec]) -> list[Any]:
        return [self.client.submit(_dask_run, spec, self.stop_name, pure=False,
                                   key=f"adaptsky-run-{spec.name}-{uuid.uuid4().hex[:8]}")
                for spec in specs]

    def wait_any(self, futures: list[Any], timeout_s: float) -> None:
        """Until one of ``futures`` is done, at most ``timeout_s``."""
        from distributed import wait

        with contextlib.suppress(TimeoutError):   # none done within timeout_s
            wait(futures, timeout=timeout_s, return_when="FIRST_COMPLETED")

    def request_stop(self) -> None:
        self.stop.set()

    def close(self, now: bool = False) -> None:
        self.client.close()


def make_executor(workers: int, scheduler: str | None,
                  device: torch.device | None = None) -> Executor:
    if scheduler:
        if device is not None and device.type != "cpu":
            raise AdaptskyError("--scheduler runs on the Dask workers' CPUs; leave out "
                                "--device or --scheduler")
        return DaskExecutor(scheduler)
    return LocalExecutor(workers, device or torch.device("cpu"))
