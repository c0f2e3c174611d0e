"""Training several seeds, in parallel processes, into one run file.

Each seed trains in its own process (torch pinned to one thread) and sends its results to
this process, the only writer of the run file. A seed sends a checkpoint every
``checkpoint_every`` episodes, at its end, and when asked to stop (Ctrl-C).
"""

from __future__ import annotations

import multiprocessing
import os
import queue
import signal
import threading
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from adaptsky_cli.errors import AdaptskyError
from adaptsky_cli.scenario.models import Scenario
from adaptsky_cli.store import run_file
from adaptsky_cli.store.tree import Tree
from adaptsky_cli.train.progress import TrainingProgress
from adaptsky_cli.train.seed_run import SeedRun

Emit = Callable[[tuple[Any, ...]], None]


class TrainingError(AdaptskyError):
    """A seed failed while training."""


@dataclass
class SeedTask:
    """What one worker trains: a seed up to ``episodes``, from a checkpoint if given."""

    scenario: Scenario
    seed: int
    episodes: int
    checkpoint_every: int
    trajectory_every: int
    checkpoint: Tree | None = None
    parent_pid: int = field(default_factory=os.getpid)  # a worker's parent: the writer

    @property
    def episodes_done(self) -> int:
        return int(self.checkpoint["episode"]) if self.checkpoint is not None else 0


def pin_threads() -> None:
    """One BLAS and torch thread per process: on this network size one is as fast as two."""
    for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ[var] = "1"
    import torch

    torch.set_num_threads(1)


def train_seed(task: SeedTask, emit: Emit, stop: Callable[[], bool],
               orphaned: Callable[[], bool] = lambda: False) -> None:
    """Run one seed to ``task.episodes``, emitting progress and checkpoint messages.

    ``stop()`` asks for a checkpoint and an early end; ``orphaned()`` (the parent died) for an
    end without one.
    """
    run = SeedRun(task.scenario, task.seed)
    if task.checkpoint is not None:
        run.restore(task.checkpoint)
    rows: list[dict[str, Any]] = []
    trajectories: dict[int, Tree] = {}
    while run.episodes_done < task.episodes:
        result = run.run_episode()
        rows.append(result.metrics)
        if task.trajectory_every and result.episode % task.trajectory_every == 0:
            trajectories[result.episode] = result.trajectory
        if orphaned():
            return  # nobody is left to write the run file: it keeps its last checkpoint
        emit(("progress", task.seed, result.episode,
              {k: result.metrics[k] for k in ("sum_rate_bps", "fairness", "epsilon")}))
        stopping = stop()
        if (result.episode % task.checkpoint_every == 0 or result.episode == task.episodes
                or stopping):
            stacked = {name: np.array([row[name] for row in rows]) for name in rows[0]}
            emit(("checkpoint", task.seed, stacked, trajectories,
                  (result.episode, result.trajectory), run.checkpoint()))
            rows, trajectories = [], {}
        if stopping:
            break
    emit(("done", task.seed))


def _worker(task: SeedTask, messages: Any, stop_event: Any) -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent decides when to stop
    pin_threads()
    def orphaned() -> bool:
        if os.getppid() == task.parent_pid:
            return False
        messages.cancel_join_thread()  # unsent messages have no reader: do not wait on them
        return True

    try:
        train_seed(task, messages.put, stop_event.is_set, orphaned)
    except Exception as error:  # reported by the parent as one line
        last = traceback.format_exception_only(type(error), error)[-1].strip()
        messages.put(("error", task.seed, last))


class _StopOnInterrupt:
    """First Ctrl-C: finish the current episodes, checkpoint, stop. Second: stop at once."""

    def __init__(self, event: Any, view: TrainingProgress) -> None:
        self.event, self.view = event, view

    def __enter__(self) -> _StopOnInterrupt:
        self.previous = signal.signal(signal.SIGINT, self._handle)
        return self

    def _handle(self, signum: int, frame: Any) -> None:
        if self.event.is_set():
            raise KeyboardInterrupt
        self.event.set()
        self.view.message("interrupted: checkpointing at the end of the current episode "
                          "(Ctrl-C again to quit now)")

    def __exit__(self, *exc: object) -> None:
        signal.signal(signal.SIGINT, self.previous)


class RunFileWriter:
    """Handles a seed's messages: checkpoints go into the run file at ``path`` (this process is
    its only writer), progress to ``on_episode``, errors into ``errors``."""

    def __init__(self, path: Path, done: dict[int, int], errors: list[str],
                 on_episode: Callable[[int, int, dict[str, float]], None] | None = None) -> None:
        self.path, self.done, self.errors, self.on_episode = path, done, errors, on_episode

    def __call__(self, message: tuple[Any, ...]) -> None:
        kind, seed = message[0], message[1]
        if kind == "progress" and self.on_episode is not None:
            self.on_episode(seed, message[2], message[3])
        elif kind == "checkpoint":
            _, _, rows, trajectories, last, checkpoint = message
            run_file.append_checkpoint(self.path, seed, rows, trajectories, last, checkpoint)
            self.done[seed] = int(checkpoint["episode"])
        elif kind == "error":
            self.errors.append(f"seed {seed} failed: {message[2]}")


@dataclass
class RunOutcome:
    episodes_done: dict[int, int]
    interrupted: bool


def run_tasks(path: Path, tasks: list[SeedTask], workers: int,
              view: TrainingProgress) -> RunOutcome:
    """Train every task, writing each checkpoint to the run file at ``path``."""
    done: dict[int, int] = {task.seed: task.episodes_done for task in tasks}
    errors: list[str] = []
    handle = RunFileWriter(path, done, errors, view.episode)

    workers = max(1, min(workers, len(tasks), os.cpu_count() or 1))
    if workers == 1:
        stop = threading.Event()
        pin_threads()
        with _StopOnInterrupt(stop, view):
            for task in tasks:
                if stop.is_set():
                    break
                train_seed(task, handle, stop.is_set)
        return RunOutcome(done, stop.is_set())

    context = multiprocessing.get_context("spawn")
    messages, stop_event = context.Queue(), context.Event()
    pending = list(tasks)
    running: dict[int, Any] = {}
    finished: set[int] = set()
    with _StopOnInterrupt(stop_event, view):
        while pending or running:
            while pending and len(running) < workers and not stop_event.is_set():
                task = pending.pop(0)
                process = context.Process(target=_worker, args=(task, messages, stop_event),
                                          daemon=True)
                process.start()
                running[task.seed] = process
            if stop_event.is_set():
                pending.clear()
            try:
                message = messages.get(timeout=0.5)
            except queue.Empty:
                for seed, process in list(running.items()):
                    if not process.is_alive() and seed not in finished:
                        errors.append(f"seed {seed} failed: its process ended with exit code "
                                      f"{process.exitcode}")
                        running.pop(seed)
                continue
            handle(message)
            if message[0] in ("done", "error"):
                finished.add(message[1])
                process = running.pop(message[1], None)
                if process is not None:
                    process.join()
                if message[0] == "error":
                    stop_event.set()
    if errors:
        raise TrainingError("; ".join(errors))
    return RunOutcome(done, stop_event.is_set())
