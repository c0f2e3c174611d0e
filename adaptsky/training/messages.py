"""What a training stack tells the writer of its run files, and a worker process the process
that started it (:mod:`adaptsky.training.host`), as typed messages (they cross process
boundaries pickled, so they hold only arrays, numbers, strings and dataclasses of them).

``key`` names a task: its seed in ``train``, its run file in ``reproduce``."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from adaptsky.store.run_file import SeedCheckpoint


@dataclass(frozen=True)
class Progress:
    """A task has done ``episode`` episodes; ``metrics`` of the last one (and its greedy
    evaluation under ``greedy``, when one ran)."""

    key: Any
    episode: int
    metrics: dict[str, Any]


@dataclass(frozen=True)
class Checkpoints:
    """The checkpoints of the members of a stack that checkpoint together (one write; each
    keyed by the task until the writer gives the file its seed)."""

    items: list[SeedCheckpoint]


@dataclass(frozen=True)
class Done:
    """A task reached its episodes (or stopped when asked); ``result``: what it reports, if
    anything."""

    key: Any
    result: Any = None


@dataclass(frozen=True)
class Failed:
    """A task failed; ``error`` is one line."""

    key: Any
    error: str


@dataclass(frozen=True)
class WorkerLost:
    """Said by the host, never sent: a worker process ended (exit code ``exitcode``) before
    its tasks ``keys`` were done or failed."""

    keys: tuple[Any, ...]
    exitcode: int | None


Message = Progress | Checkpoints | Done | Failed
HostMessage = Message | WorkerLost
