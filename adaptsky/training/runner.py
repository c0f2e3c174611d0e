"""Training several seeds into one run file: processes on a CPU, one stack on a GPU.

On a CPU the seeds are dealt to worker processes (torch pinned to one thread), each training
its share as one stack (:mod:`adaptsky.training.stack_run`), and send their results to this
process, the only writer of the run file. On a GPU one stack in this process trains them all.
Every seed sends a checkpoint every ``checkpoint_every`` episodes, at its end, and when asked
to stop (Ctrl-C).
"""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from adaptsky.arrays import Tree
from adaptsky.errors import AdaptskyError
from adaptsky.scenario.models import Scenario
from adaptsky.store import run_file
from adaptsky.store.run_file import SeedCheckpoint
from adaptsky.training.evaluation import EvaluationSet
from adaptsky.training.host import (
    EXIT_GRACE_S,
    QUIT_GRACE_S,
    Handle,
    Job,
    ProcessHost,
    pin_threads,
)
from adaptsky.training.interrupts import StopOnInterrupt
from adaptsky.training.logs import TrainingLogs, scalars_of
from adaptsky.training.messages import (
    Checkpoints,
    Done,
    Failed,
    HostMessage,
    Message,
    Progress,
    WorkerLost,
)
from adaptsky.training.progress import PROGRESS_METRICS, TrainingProgress

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
    label: object = None  # names the task in messages when seeds alone do not (see key)
    evaluation: EvaluationSet | None = None  # greedy evaluations during training (or none)

    @property
    def key(self) -> object:
        """The task's name in messages: its label, else its seed."""
        return self.seed if self.label is None else self.label

    @property
    def episodes_done(self) -> int:
        return int(self.checkpoint["episode"]) if self.checkpoint is not None else 0


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
        env_steps = group[0].scenario.train.steps * run.envs  # per member and episode
        while True:
            started_s = time.perf_counter()
            results = run.run_episode()
            seconds = time.perf_counter() - started_s
            if orphaned():
                return  # nobody is left to write the run file: it keeps its last checkpoint
            stopping = stop()
            checkpoints = []
            for index, (task, result) in enumerate(zip(group, results, strict=True)):
                rows[task.key].append(result.metrics)
                if task.trajectory_every and result.episode % task.trajectory_every == 0:
                    trajectories[task.key][result.episode] = result.trajectory
                shown = {k: result.metrics[k] for k in PROGRESS_METRICS if k in result.metrics}
                if result.evaluation is not None:
                    evaluations[task.key].append(result.evaluation)
                    shown["greedy"] = result.evaluation
                # for the logs (train --log): every scalar, and this member's pace
                shown["scalars"] = scalars_of(result.metrics, result.stats,
                                              result.evaluation)
                shown["scalars"]["speed/env_steps_per_s"] = env_steps / max(seconds, 1e-9)
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


class RunFileWriter:
    """Handles a seed's messages: checkpoints go into the run file at ``path`` (this process is
    its only writer), progress to ``on_episode``, errors into ``errors``; ``reached`` holds
    each seed's last episode trained (stored or not)."""

    def __init__(self, path: Path, done: dict[int, int], errors: list[str],
                 on_episode: Callable[[int, int, dict[str, float]], None] | None = None) -> None:
        self.path, self.done, self.errors, self.on_episode = path, done, errors, on_episode
        self.reached: dict[object, int] = dict(done)

    def __call__(self, message: HostMessage) -> None:
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
        elif isinstance(message, WorkerLost):
            seeds = sorted(message.keys)
            self.errors.append(f"seeds {seeds} failed: their process ended with exit code "
                               f"{message.exitcode}")

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


INTERRUPT_NOTICE = ("interrupted: checkpointing at the end of the current episode "
                    "(Ctrl-C again to quit now)")


Watch = Callable[[int, int, dict[str, Any]], bool]
"""Hears every episode of every seed (seed, episode, what progress shows: the learning
curve's scalars and ``"greedy"``, the evaluation row, after an evaluation); True asks every
seed to checkpoint and end, as a Ctrl-C does (``adaptsky tune``'s pruner)."""


def run_tasks(path: Path, tasks: list[SeedTask], workers: int, view: TrainingProgress,
              device: torch.device | None = None, logs: TrainingLogs | None = None,
              watch: Watch | None = None) -> RunOutcome:
    """Train every task, writing each checkpoint to the run file at ``path``.

    On a CPU the tasks are shared among ``workers`` processes (at most the cores), each
    training its share as one stack; on another device one stack in this process holds them
    all. A second Ctrl-C ends at once (after a write in progress), saying in one line what
    the run file keeps.
    """
    import torch

    done: dict[int, int] = {task.seed: task.episodes_done for task in tasks}
    errors: list[str] = []
    device = device or torch.device("cpu")
    workers = max(1, min(workers, len(tasks), os.cpu_count() or 1))
    host = None if device.type != "cpu" or workers == 1 else ProcessHost(workers)
    stop = threading.Event() if host is None else host.stop_event

    def on_episode(seed: int, episode: int, metrics: dict[str, Any]) -> None:
        view.episode(seed, episode, metrics)
        if logs is not None:
            logs.episode(seed, episode, metrics["scalars"])
        if watch is not None and watch(seed, episode, metrics):
            stop.set()

    handle = RunFileWriter(path, done, errors, on_episode)
    try:
        with StopOnInterrupt(stop.set, view.message, INTERRUPT_NOTICE, stop.is_set) as interrupts:
            if host is None:
                pin_threads()
                train_stack(tasks, interrupts.shielded(handle), stop.is_set, device=device)
            else:
                _run_workers(host, partition(tasks, workers), interrupts.shielded(handle),
                             interrupts.check)
    except KeyboardInterrupt:
        view.message(handle.lost())
        raise
    if errors:
        raise TrainingError("; ".join(errors))
    return RunOutcome(done, stop.is_set())


def _run_workers(host: ProcessHost, groups: list[list[SeedTask]], write: Handle,
                 check: Callable[[], None] = lambda: None) -> None:
    """Train each group as one stack in a process of ``host``, handing their messages to
    ``write``; a failed seed stops the others (they checkpoint). Every process has ended (or
    been killed) when this returns or raises."""
    def handle(message: HostMessage) -> None:
        write(message)
        if isinstance(message, Failed | WorkerLost):
            host.request_stop()

    try:
        host.submit([Job(train_stack, (group,), tuple(task.key for task in group))
                     for group in groups])
        while host.pump(handle, timeout_s=1.0):
            check()  # a second Ctrl-C that Python dropped
    except BaseException:
        host.close(QUIT_GRACE_S, quit_now=True)  # nobody will write what they send: end now
        raise
    host.close(EXIT_GRACE_S)
