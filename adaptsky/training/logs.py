"""Scalar logs of a training beside its run file (``train --log tensorboard|csv``,
docs/training.md, "Logs"): every episode's learning-curve values, the learner's statistics
and the greedy evaluations, per seed, in ``<run>.logs/``:

- ``csv``: ``scalars.csv``, one row per value: ``seed,episode,wall_time,name,value``;
- ``tensorboard``: TensorBoard event files, one folder per seed (``seed<S>/``), the episode as
  the step; ``tensorboard --logdir <run>.logs`` shows them.

A resumed run continues its logs: what a seed logged after its last checkpoint (and trains
again) is dropped, from the CSV when it is opened and from TensorBoard's view by a purge at
the checkpoint's next episode (``SummaryWriter(purge_step=...)``), so each episode appears
once. The logs are written by the process that writes the run file.
"""

from __future__ import annotations

import csv
import math
import time
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any, Protocol

from adaptsky.errors import AdaptskyError
from adaptsky.store.atomic import write_text_atomic

LOG_KINDS = ("tensorboard", "csv")
CSV_NAME = "scalars.csv"
CSV_COLUMNS = ("seed", "episode", "wall_time", "name", "value")
TENSORBOARD_HINT = ("train --log tensorboard needs the tensorboard package: "
                    "pip install 'adaptsky[tensorboard]' (or pip install tensorboard)")


def logs_folder(run_path: Path) -> Path:
    """Where the logs of the run file ``run_path`` go: ``<run>.logs`` beside it."""
    return run_path.with_name(run_path.name.removesuffix(".h5") + ".logs")


def kinds_found(run_path: Path) -> tuple[str, ...]:
    """The kinds of log a run already has (what ``--resume`` continues by default)."""
    folder = logs_folder(run_path)
    found = []
    if any(folder.glob("seed*/events.out.tfevents.*")):
        found.append("tensorboard")
    if (folder / CSV_NAME).exists():
        found.append("csv")
    return tuple(found)


def check_kinds(kinds: Iterable[str]) -> tuple[str, ...]:
    """The kinds asked for, each once, in LOG_KINDS's order; one line for an unknown kind or
    a missing TensorBoard."""
    asked = set(kinds)
    unknown = sorted(asked - set(LOG_KINDS))
    if unknown:
        raise AdaptskyError(f"--log: unknown kind '{unknown[0]}'; allowed: "
                            f"{', '.join(LOG_KINDS)}")
    if "tensorboard" in asked:
        try:
            import tensorboard  # noqa: F401
        except ImportError:
            raise AdaptskyError(TENSORBOARD_HINT) from None
    return tuple(kind for kind in LOG_KINDS if kind in asked)


def scalars_of(metrics: Mapping[str, Any], stats: Mapping[str, float],
               evaluation: Mapping[str, Any] | None) -> dict[str, float]:
    """An episode's loggable values by tag: ``train/<metric>`` (the learning curve's
    scalars), ``learner/<stat>`` (losses, entropy, learning rate, ...) and ``greedy/<value>``
    (the greedy evaluation, when one ran); vectors and non-finite values (an epsilon or a loss
    a learner does not have) are left out."""
    tagged = {**{f"train/{k}": v for k, v in metrics.items()},
              **{f"learner/{k}": v for k, v in stats.items()},
              **{f"greedy/{k}": v for k, v in (evaluation or {}).items() if k != "episode"}}
    out: dict[str, float] = {}
    for tag, value in tagged.items():
        try:
            number = float(value)
        except (TypeError, ValueError):
            continue  # a vector (per user): not a scalar
        if math.isfinite(number):
            out[tag] = number
    return out


class ScalarLog(Protocol):
    def write(self, seed: int, episode: int, scalars: Mapping[str, float]) -> None: ...

    def close(self) -> None: ...


class CsvLog:
    """``scalars.csv``: rows appended as episodes end, flushed every episode."""

    def __init__(self, folder: Path, done: Mapping[int, int]) -> None:
        path = folder / CSV_NAME
        kept: list[list[str]] = []
        if path.exists():  # resumed: keep what each seed logged up to its checkpoint (and
            # every row of a seed that does not train now)
            with path.open(newline="") as f:
                rows = list(csv.reader(f))
            kept = [row for row in rows[1:] if len(row) == len(CSV_COLUMNS)
                    and int(row[1]) <= done.get(int(row[0]), math.inf)]
        lines = [",".join(CSV_COLUMNS)] + [",".join(row) for row in kept]
        write_text_atomic(path, "\n".join(lines) + "\n")
        self._file = path.open("a", newline="")
        self._writer = csv.writer(self._file)

    def write(self, seed: int, episode: int, scalars: Mapping[str, float]) -> None:
        now = f"{time.time():.3f}"
        for name, value in scalars.items():
            self._writer.writerow([seed, episode, now, name, repr(value)])
        self._file.flush()

    def close(self) -> None:
        self._file.close()


class TensorBoardLog:
    """One ``SummaryWriter`` per seed (``seed<S>/``), the episode as the step."""

    def __init__(self, folder: Path, done: Mapping[int, int]) -> None:
        from torch.utils.tensorboard import SummaryWriter

        self._writers = {seed: SummaryWriter(log_dir=str(folder / f"seed{seed}"),
                                             purge_step=episodes + 1)
                         for seed, episodes in done.items()}

    def write(self, seed: int, episode: int, scalars: Mapping[str, float]) -> None:
        writer = self._writers[seed]
        for name, value in scalars.items():
            writer.add_scalar(name, value, episode)
        writer.flush()

    def close(self) -> None:
        for writer in self._writers.values():
            writer.close()


class TrainingLogs:
    """The logs of one training: every kind asked for, fed each seed's episodes."""

    def __init__(self, run_path: Path, kinds: Iterable[str], done: Mapping[int, int]) -> None:
        self.kinds = check_kinds(kinds)
        self.folder = logs_folder(run_path)
        self._logs: list[ScalarLog] = []
        if not self.kinds:
            return
        self.folder.mkdir(parents=True, exist_ok=True)
        makers = {"csv": CsvLog, "tensorboard": TensorBoardLog}
        self._logs = [makers[kind](self.folder, done) for kind in self.kinds]

    def episode(self, seed: int, episode: int, scalars: Mapping[str, float]) -> None:
        for log in self._logs:
            log.write(seed, episode, scalars)

    def close(self) -> None:
        for log in self._logs:
            log.close()

    def __enter__(self) -> TrainingLogs:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
