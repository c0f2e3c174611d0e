"""Where runs execute: local processes of stacked runs (on the CPU or a GPU), or a Dask
cluster (one run per task).

All speak ``concurrent.futures``: ``submit_all(specs) -> [future per run]`` and
``request_stop()``. A run writes only its own file, so results come back through the files,
never through memory, and a retried run resumes from its last checkpoint.
"""

from __future__ import annotations

import multiprocessing
import os
import uuid
from concurrent.futures import Future, ProcessPoolExecutor
from pathlib import Path
from typing import Any, Protocol

import torch

from adaptsky.algos.device_step import describe
from adaptsky.errors import AdaptskyError
from adaptsky.experiment.plan import RunSpec
from adaptsky.experiment.runs import RunReport, execute_run, execute_runs
from adaptsky.scenario import parse_scenario
from adaptsky.training.runner import ignore_stop_signals
from adaptsky.training.stack_run import stack_key


class Executor(Protocol):
    description: str
    capacity: int  # runs at once

    def submit_all(self, specs: list[RunSpec]) -> list[Any]: ...

    def request_stop(self) -> None: ...

    def close(self) -> None: ...


_stop_event: Any = None
_parent_pid = 0


def _init_local_worker(stop_event: Any, parent_pid: int) -> None:
    global _stop_event, _parent_pid
    ignore_stop_signals()
    _stop_event, _parent_pid = stop_event, parent_pid


def _orphaned() -> bool:
    return os.getppid() != _parent_pid


def _stack_run(specs: list[RunSpec], device: str) -> list[RunReport]:
    return execute_runs(specs, _stop_event.is_set, _orphaned, torch.device(device))


class RunFuture(Future[RunReport]):
    """One run's future inside a stack's: cancelling it cancels the stack, and fails (the run
    goes on to its checkpoint) once the stack is running."""

    def __init__(self) -> None:
        super().__init__()
        self.stack: Future[list[RunReport]] | None = None

    def cancel(self) -> bool:
        if self.stack is not None and not self.stack.cancel():
            return False
        return super().cancel()


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
    seed-steps per second on one core as one seed does); on a GPU every group is one stack."""

    def __init__(self, workers: int, device: torch.device) -> None:
        context = multiprocessing.get_context("spawn")
        self.stop_event = context.Event()
        self.pool = ProcessPoolExecutor(workers, mp_context=context,
                                        initializer=_init_local_worker,
                                        initargs=(self.stop_event, os.getpid()))
        self.workers = self.capacity = workers
        self.device = device
        self.stacks: list[Future[list[RunReport]]] = []
        self.description = (f"{describe(device)}, {workers} process"
                            f"{'es' if workers > 1 else ''} of stacked runs")

    def submit_all(self, specs: list[RunSpec]) -> list[RunFuture]:
        futures = {spec.path: RunFuture() for spec in specs}
        max_size = None if self.device.type != "cpu" else -(-len(specs) // self.workers)
        groups = stacks(specs, max_size)
        self.capacity = sum(sorted(map(len, groups), reverse=True)[:self.workers])
        for group in groups:
            stacked = self.pool.submit(_stack_run, group, str(self.device))
            self.stacks.append(stacked)
            for spec in group:
                futures[spec.path].stack = stacked
            stacked.add_done_callback(lambda done, group=group: _settle(done, group, futures))
        return [futures[spec.path] for spec in specs]

    def request_stop(self) -> None:
        """Running stacks checkpoint and stop; stacks not started yet stay as they are."""
        self.stop_event.set()
        for stacked in self.stacks:
            stacked.cancel()

    def close(self) -> None:
        self.pool.shutdown(wait=True, cancel_futures=True)


def _settle(done: Future[list[RunReport]], group: list[RunSpec],
            futures: dict[Path, RunFuture]) -> None:
    """Hand a finished stack's outcome to the futures of its runs."""
    for index, spec in enumerate(group):
        future = futures[spec.path]
        if future.done():  # cancelled by the sweep
            continue
        if done.cancelled():
            future.cancel()
        elif done.exception() is not None:
            future.set_exception(done.exception())
        else:
            future.set_result(done.result()[index])


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

    def submit_all(self, specs: list[RunSpec]) -> list[Any]:
        return [self.client.submit(_dask_run, spec, self.stop_name, pure=False,
                                   key=f"adaptsky-run-{spec.name}-{uuid.uuid4().hex[:8]}")
                for spec in specs]

    def request_stop(self) -> None:
        self.stop.set()

    def close(self) -> None:
        self.client.close()


def make_executor(workers: int, scheduler: str | None,
                  device: torch.device | None = None) -> Executor:
    if scheduler:
        if device is not None and device.type != "cpu":
            raise AdaptskyError("--scheduler runs on the Dask workers' CPUs; leave out "
                                "--device or --scheduler")
        return DaskExecutor(scheduler)
    return LocalExecutor(workers, device or torch.device("cpu"))
