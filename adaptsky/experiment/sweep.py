"""Running the missing and unfinished runs of a plan on an executor, with progress.

Progress counts runs done / running / left and estimates the time left from the episodes
written to the run files since the start (the files are the only shared state, also on Dask).
"""

from __future__ import annotations

import signal
import time
from concurrent.futures import Future
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn

from adaptsky.errors import AdaptskyError
from adaptsky.progress import stamp
from adaptsky.store.run_file import RunFileError, RunReader
from adaptsky.training.runner import STOP_SIGNALS
from adaptsky.units import format_duration

if TYPE_CHECKING:  # the executors and runs import torch; the sweep itself needs none of it
    from adaptsky.experiment.executors import Executor
    from adaptsky.experiment.plan import RunSpec
    from adaptsky.experiment.runs import RunReport, RunState

POLL_S = 2.0
LOG_EVERY_S = 60.0


class SweepError(AdaptskyError):
    """Some runs failed; the others are kept."""


def _episodes_in_file(spec: RunSpec) -> int | None:
    try:
        with RunReader(spec.path, needs="curves") as run:
            return run.seed_attrs(spec.seed)["episodes_done"]
    except (RunFileError, KeyError):
        return None  # not written yet, or being replaced right now


@dataclass
class SweepOutcome:
    reports: list[RunReport] = field(default_factory=list)
    interrupted: bool = False
    seconds: float = 0.0


class _Display:
    """A Rich bar on a terminal; plain log lines elsewhere (or none with ``quiet``)."""

    def __init__(self, console: Console, quiet: bool, total_episodes: int, done: int) -> None:
        self.console, self.quiet = console, quiet
        self.live = console.is_terminal and not quiet
        self.progress = Progress(TextColumn("{task.description}"), BarColumn(),
                                 MofNCompleteColumn(), TextColumn("episodes  {task.fields[eta]}"),
                                 console=console, disable=not self.live)
        self.task = self.progress.add_task("", total=total_episodes, completed=done, eta="")
        self.last_log = time.monotonic()

    def __enter__(self) -> _Display:
        self.progress.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.progress.stop()

    def log(self, text: str) -> None:
        if not self.quiet:
            self.progress.console.print(text if self.live else stamp(text), markup=False,
                                        highlight=False, soft_wrap=not self.live)

    def update(self, status: str, episodes: int, eta: str) -> None:
        self.progress.update(self.task, description=status, completed=episodes, eta=eta)
        if not self.live and time.monotonic() - self.last_log >= LOG_EVERY_S:
            self.last_log = time.monotonic()
            self.log(f"{status}; {eta}")


def run_sweep(todo: list[tuple[RunSpec, RunState]], executor: Executor, console: Console,
              quiet: bool, total_runs: int) -> SweepOutcome:
    """Train every run in ``todo`` (resuming partial ones) on ``executor``. Ctrl-C
    checkpoints the running runs and stops."""
    start = time.monotonic()
    skipped = total_runs - len(todo)
    done_episodes = {spec.path: state.episodes_done for spec, state in todo}
    start_episodes = sum(done_episodes.values())
    total_episodes = sum(spec.episodes for spec, _ in todo)
    futures: dict[str, tuple[RunSpec, Any]] = {}
    outcome, failures = SweepOutcome(), []
    interrupted = False

    def on_interrupt(signum: int, frame: Any) -> None:
        nonlocal interrupted
        if interrupted:
            raise KeyboardInterrupt
        interrupted = True
        executor.request_stop()
        for _, future in futures.values():
            if isinstance(future, Future):
                future.cancel()  # local runs not started yet stay as they are
        display.log("interrupted: checkpointing the running runs at the end of their current "
                    "episode (Ctrl-C again to quit now)")

    display = _Display(console, quiet, total_episodes, start_episodes)
    # Local workers start with SIGINT blocked (they inherit the mask) and ignore it before
    # unblocking it, so a Ctrl-C while they start cannot kill them; it waits for this
    # process's handler, which asks every run to checkpoint and stop.
    signal.pthread_sigmask(signal.SIG_BLOCK, STOP_SIGNALS)
    try:
        specs = [spec for spec, _ in todo]
        for spec, future in zip(specs, executor.submit_all(specs), strict=True):
            futures[spec.path] = (spec, future)
    finally:
        previous = {signum: signal.signal(signum, on_interrupt) for signum in STOP_SIGNALS}
        signal.pthread_sigmask(signal.SIG_UNBLOCK, STOP_SIGNALS)
    try:
        with display:
            display.log(f"{total_runs} runs: {skipped} done before, {len(todo)} to run on "
                        f"{executor.description}")
            while futures:
                for key, (spec, future) in list(futures.items()):
                    name = spec.name
                    if not future.done():
                        episodes = _episodes_in_file(spec)
                        if episodes is not None:
                            done_episodes[key] = episodes
                        continue
                    del futures[key]
                    if future.cancelled():
                        continue
                    try:
                        report = future.result()
                    except Exception as error:  # one line per failed run, the others go on
                        message = str(error).splitlines()[0] if str(error) else type(error).__name__
                        failures.append(f"{name}: {message}")
                        display.log(f"run {name} failed: {message}")
                        continue
                    done_episodes[key] = report.episodes_done
                    outcome.reports.append(report)
                    resumed = (f", resumed from episode {report.started_at_episode}"
                               if report.started_at_episode else "")
                    display.log(f"run {name}: {report.episodes_done}/{spec.episodes} episodes "
                                f"in {format_duration(report.seconds)}{resumed}")
                episodes = sum(done_episodes.values())
                finished = total_runs - len(futures)
                running = min(len(futures), executor.capacity)
                elapsed = time.monotonic() - start
                rate = (episodes - start_episodes) / elapsed if elapsed > 0 else 0.0
                eta = (f"about {format_duration((total_episodes - episodes) / rate)} left"
                       if rate > 0 else "estimating time left")
                display.update(f"runs {finished} done · {running} running · "
                               f"{len(futures) - running} left", episodes, eta)
                if futures:
                    time.sleep(POLL_S)
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
        executor.close()
    outcome.interrupted, outcome.seconds = interrupted, time.monotonic() - start
    if failures and not interrupted:
        raise SweepError(f"{len(failures)} of {len(todo)} runs failed; the others are saved. "
                         f"First: {failures[0]}")
    return outcome
