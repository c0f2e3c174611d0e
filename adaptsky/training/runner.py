"""Training several seeds into one run file: processes on a CPU, one stack on a GPU.

On a CPU the seeds are dealt to worker processes (torch pinned to one thread), each training
its share as one stack (:mod:`adaptsky.training.stack_run`), and send their results to this
process, the only writer of the run file. On a GPU one stack in this process trains them all.
Every seed sends a checkpoint every ``checkpoint_every`` episodes, at its end, and when asked
to stop (Ctrl-C).
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import threading
import time
import traceback
from collections.abc import Callable
from contextlib import contextmanager
from dataclasses import dataclass, field
from multiprocessing.connection import Connection, wait
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from adaptsky.arrays import Tree
from adaptsky.errors import AdaptskyError
from adaptsky.scenario.models import Scenario
from adaptsky.store import run_file
from adaptsky.store.run_file import SeedCheckpoint
from adaptsky.training.evaluation import EvaluationSet
from adaptsky.training.messages import Checkpoints, Done, Failed, Message, Progress
from adaptsky.training.progress import TrainingProgress

if TYPE_CHECKING:  # torch is imported where training starts: commands start without it
    import torch

Emit = Callable[[Message], None]


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
    label: object = None  # names the task in messages when seeds alone do not (see key)
    evaluation: EvaluationSet | None = None  # greedy evaluations during training (or none)

    @property
    def key(self) -> object:
        """The task's name in messages: its label, else its seed."""
        return self.seed if self.label is None else self.label

    @property
    def episodes_done(self) -> int:
        return int(self.checkpoint["episode"]) if self.checkpoint is not None else 0


def pin_threads() -> None:
    """One BLAS and torch thread per process: on this network size one is as fast as two.
    (threadpoolctl: environment variables set after numpy is imported have no effect.)"""
    import torch
    from threadpoolctl import threadpool_limits

    threadpool_limits(limits=1)
    torch.set_num_threads(1)


# Ctrl-C, and the stop that `kill`, `timeout` and batch schedulers send: both checkpoint and end
STOP_SIGNALS = {signal.SIGINT, signal.SIGTERM}


@contextmanager
def stop_signals_blocked() -> Any:
    """Block the stop signals in this thread while the block runs (processes started meanwhile
    inherit the mask, so a Ctrl-C cannot interrupt their start-up); one that came meanwhile is
    then delivered to this process's handler."""
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, STOP_SIGNALS)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


def train_stack(tasks: list[SeedTask], emit: Emit, stop: Callable[[], bool],
                orphaned: Callable[[], bool] = lambda: False,
                device: str | torch.device = "cpu") -> None:
    """Run every task to its ``episodes`` as stacks of members at the same episode, emitting
    a :class:`Progress` per member and episode, one :class:`Checkpoints` per episode where
    members checkpoint (written in one rewrite), and a :class:`Done` per task (their ``key``
    is ``task.key``).

    Tasks resumed from different episodes: the ones furthest behind train first and join the
    others when they catch up. ``stop()`` asks for a checkpoint of every member and an early
    end; ``orphaned()`` (the parent died) for an end without one.
    """
    from adaptsky.training.stack_run import Member, StackRun

    states = {task.key: task.checkpoint for task in tasks}
    done = {task.key: task.episodes_done for task in tasks}
    rows: dict[object, list[dict[str, Any]]] = {task.key: [] for task in tasks}
    evaluations: dict[object, list[dict[str, float]]] = {task.key: [] for task in tasks}
    trajectories: dict[object, dict[int, Tree]] = {task.key: {} for task in tasks}
    while True:
        left = [task for task in tasks if done[task.key] < task.episodes]
        if not left:
            break
        episode = min(done[task.key] for task in left)
        group = [task for task in left if done[task.key] == episode]
        merge_at = min((done[task.key] for task in left if done[task.key] > episode),
                       default=None)
        run = StackRun([Member(task.scenario, task.seed, task.evaluation) for task in group],
                       device)
        for index, task in enumerate(group):
            if states[task.key] is not None:
                run.restore(index, states[task.key])
        while True:
            results = run.run_episode()
            if orphaned():
                return  # nobody is left to write the run file: it keeps its last checkpoint
            stopping = stop()
            checkpoints = []
            for index, (task, result) in enumerate(zip(group, results, strict=True)):
                rows[task.key].append(result.metrics)
                if task.trajectory_every and result.episode % task.trajectory_every == 0:
                    trajectories[task.key][result.episode] = result.trajectory
                shown = {k: result.metrics[k] for k in ("sum_rate_bps", "fairness", "epsilon")}
                if result.evaluation is not None:
                    evaluations[task.key].append(result.evaluation)
                    shown["greedy"] = result.evaluation
                emit(Progress(task.key, result.episode, shown))
                if (result.episode % task.checkpoint_every == 0
                        or result.episode == task.episodes or stopping):
                    checkpoints.append(SeedCheckpoint(
                        task.key, _columns(rows[task.key]), trajectories[task.key],
                        (result.episode, result.trajectory), run.checkpoint(index),
                        _columns(evaluations[task.key])))
                    rows[task.key], trajectories[task.key] = [], {}
                    evaluations[task.key] = []
            if checkpoints:  # one message: the writer stores them in one rewrite
                emit(Checkpoints(checkpoints))
            if stopping:
                break
            if (run.episodes_done == merge_at
                    or any(run.episodes_done == task.episodes for task in group)):
                break
        if stopping:
            break  # every member has just sent its checkpoint
        for index, task in enumerate(group):  # regroup: someone finished or others wait here
            done[task.key] = run.episodes_done
            if run.episodes_done < task.episodes:
                states[task.key] = run.checkpoint(index)
    for task in tasks:
        emit(Done(task.key))


def _columns(rows: list[dict[str, Any]]) -> dict[str, np.ndarray]:
    """Rows of equal keys as one array per key ({} for no rows)."""
    return {name: np.array([row[name] for row in rows]) for name in rows[0]} if rows else {}


def ignore_stop_signals() -> None:
    """In a worker process: the parent decides when to stop (through an event); the signals
    were blocked while it started."""
    for signum in STOP_SIGNALS:
        signal.signal(signum, signal.SIG_IGN)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, STOP_SIGNALS)


def _worker(group: list[SeedTask], connection: Connection, stop_event: Any,
            quit_event: Any) -> None:
    """A worker process: train ``group`` as one stack, sending every message through
    ``connection`` (a pipe of its own; a send waits until the parent reads it). It ends
    without a word when the parent is gone or says to quit (``quit_event``)."""
    ignore_stop_signals()
    pin_threads()
    parent_pid = group[0].parent_pid

    def orphaned() -> bool:
        return os.getppid() != parent_pid or quit_event.is_set()

    try:
        try:
            train_stack(group, connection.send, stop_event.is_set, orphaned)
        except Exception as error:  # reported by the parent as one line
            last = (str(error) if isinstance(error, AdaptskyError)
                    else traceback.format_exception_only(type(error), error)[-1].strip())
            for task in group:
                connection.send(Failed(task.key, last))
    except OSError:  # the parent closed its end (it quit or died): nobody reads any more
        pass
    finally:
        connection.close()


class _StopOnInterrupt:
    """First Ctrl-C (or SIGTERM): finish the current episodes, checkpoint, stop. Second: stop
    at once, but never in the middle of writing the run file (:meth:`shielded`): then it
    takes effect when the write is done."""

    def __init__(self, event: Any, view: TrainingProgress) -> None:
        self.event, self.view = event, view
        self.writing = self.quit_pending = False

    def __enter__(self) -> _StopOnInterrupt:
        self.previous = {signum: signal.signal(signum, self._handle) for signum in STOP_SIGNALS}
        return self

    def _handle(self, signum: int, frame: Any) -> None:
        if self.event.is_set():
            if self.writing:
                self.quit_pending = True
                return
            raise KeyboardInterrupt
        self.event.set()
        self.view.message("interrupted: checkpointing at the end of the current episode "
                          "(Ctrl-C again to quit now)")

    def shielded(self, handle: Emit) -> Emit:
        """``handle`` with a second Ctrl-C held back while it runs (it writes the run file:
        an interrupt inside HDF5's callbacks could leave a file it cannot close)."""
        def shielded_handle(message: Message) -> None:
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


class RunFileWriter:
    """Handles a seed's messages: checkpoints go into the run file at ``path`` (this process is
    its only writer), progress to ``on_episode``, errors into ``errors``; ``reached`` holds
    each seed's last episode trained (stored or not)."""

    def __init__(self, path: Path, done: dict[int, int], errors: list[str],
                 on_episode: Callable[[int, int, dict[str, float]], None] | None = None) -> None:
        self.path, self.done, self.errors, self.on_episode = path, done, errors, on_episode
        self.reached: dict[object, int] = dict(done)

    def __call__(self, message: Message) -> None:
        if isinstance(message, Progress):
            self.reached[message.key] = message.episode
            if self.on_episode is not None:
                self.on_episode(message.key, message.episode, message.metrics)
        elif isinstance(message, Checkpoints):  # keyed by seed
            run_file.append_checkpoints(self.path, message.items)
            for item in message.items:
                self.done[item.key] = item.episode
        elif isinstance(message, Failed):
            self.errors.append(f"seed {message.key} failed: {message.error}")

    def lost(self) -> str:
        """What an end without waiting for checkpoints keeps and loses, in one line."""
        kept = ", ".join(f"seed {seed} at episode {done}" if done else
                         f"seed {seed} without a checkpoint" for seed, done in self.done.items())
        behind = [seed for seed, done in self.done.items() if self.reached.get(seed, 0) > done]
        lost = (f"; what seed{'s' if len(behind) > 1 else ''} "
                f"{', '.join(map(str, behind))} trained after that is lost" if behind else "")
        return f"quit: {self.path} keeps {kept}{lost}"


@dataclass
class RunOutcome:
    episodes_done: dict[int, int]
    interrupted: bool
    complete: bool = False  # every seed had already reached its target: nothing was trained


def partition(tasks: list[SeedTask], workers: int) -> list[list[SeedTask]]:
    """Tasks dealt round-robin into at most ``workers`` groups, one process (a stack) each."""
    count = max(1, min(workers, len(tasks)))
    return [tasks[start::count] for start in range(count)]


# how long workers told to quit (a second Ctrl-C, an error here) may take to end by themselves
# (they look at the end of every episode) before they are killed; nothing they hold would be
# stored
QUIT_GRACE_S = 1.0
# how long workers that sent everything may take to exit before they are killed
EXIT_GRACE_S = 10.0


def run_tasks(path: Path, tasks: list[SeedTask], workers: int, view: TrainingProgress,
              device: torch.device | None = None) -> RunOutcome:
    """Train every task, writing each checkpoint to the run file at ``path``.

    On a CPU the tasks are shared among ``workers`` processes (at most the cores), each
    training its share as one stack; on another device one stack in this process holds them
    all. A second Ctrl-C ends at once (after a write in progress), saying in one line what
    the run file keeps.
    """
    import torch

    done: dict[int, int] = {task.seed: task.episodes_done for task in tasks}
    errors: list[str] = []
    handle = RunFileWriter(path, done, errors, view.episode)
    device = device or torch.device("cpu")
    workers = max(1, min(workers, len(tasks), os.cpu_count() or 1))
    local = device.type != "cpu" or workers == 1
    stop = threading.Event() if local else multiprocessing.get_context("spawn").Event()
    try:
        with _StopOnInterrupt(stop, view) as interrupts:
            if local:
                pin_threads()
                train_stack(tasks, interrupts.shielded(handle), stop.is_set, device=device)
            else:
                _run_workers(tasks, workers, interrupts.shielded(handle), errors, stop)
    except KeyboardInterrupt:
        view.message(handle.lost())
        raise
    if errors:
        raise TrainingError("; ".join(errors))
    return RunOutcome(done, stop.is_set())


@dataclass
class _Worker:
    """A worker process, the read end of its pipe (None once it ended) and its tasks' keys."""

    process: Any
    connection: Connection | None
    keys: set[object]


def _run_workers(tasks: list[SeedTask], workers: int, handle: Emit, errors: list[str],
                 stop_event: Any) -> None:
    """Train ``tasks`` in ``workers`` processes, handing their messages to ``handle``; every
    process has ended (or been killed) when this returns or raises."""
    context = multiprocessing.get_context("spawn")
    quit_event = context.Event()
    started: list[_Worker] = []
    try:
        with stop_signals_blocked():  # children ignore them before they import anything
            for group in partition(tasks, workers):
                reader, writer = context.Pipe(duplex=False)
                process = context.Process(target=_worker, daemon=True,
                                          args=(group, writer, stop_event, quit_event))
                started.append(_Worker(process, reader, {task.key for task in group}))
                process.start()
                writer.close()  # the child's end: EOF here once the child has ended
        _collect(started, {task.key for task in tasks}, handle, errors, stop_event)
    except BaseException:
        quit_event.set()  # nobody will write what they send: end now
        _end(started, QUIT_GRACE_S)
        raise
    _end(started, EXIT_GRACE_S)


def _collect(started: list[_Worker], left: set[object], handle: Emit, errors: list[str],
             stop_event: Any) -> None:
    """Hand the workers' messages to ``handle`` until every task is done or failed."""
    while left:
        open_ends = {worker.connection: worker for worker in started
                     if worker.connection is not None}
        if not open_ends:
            break
        for connection in wait(list(open_ends), timeout=1.0):
            worker = open_ends[connection]  # type: ignore[index]
            try:
                message = connection.recv()  # type: ignore[union-attr]
            except (EOFError, OSError):  # it ended: whatever it had not finished failed
                worker.connection = None
                connection.close()  # type: ignore[union-attr]
                if worker.keys & left:
                    worker.process.join(EXIT_GRACE_S)
                    errors.append(f"seeds {sorted(worker.keys & left)} failed: their process "
                                  f"ended with exit code {worker.process.exitcode}")
                    left -= worker.keys
                    stop_event.set()
                continue
            handle(message)
            if isinstance(message, Done | Failed):
                left.discard(message.key)
                if isinstance(message, Failed):
                    stop_event.set()


def _end(started: list[_Worker], grace_s: float) -> None:
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
