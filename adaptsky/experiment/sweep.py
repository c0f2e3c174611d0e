"""Running the missing and unfinished runs of a plan on an executor, with progress.

Progress counts runs done / running / left and estimates the time left from the episodes
written to the run files lately (the files are the only shared state, also on Dask), those of
the first checkpoints left out (:class:`adaptsky.progress.Pace`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from adaptsky.errors import AdaptskyError
from adaptsky.progress import Pace, Reporter
from adaptsky.store.run_file import RunFileError, RunReader
from adaptsky.training.interrupts import StopOnInterrupt
from adaptsky.units import format_duration

if TYPE_CHECKING:  # the executors and runs import torch; the sweep itself needs none of it
    from adaptsky.experiment.executors import Executor
    from adaptsky.experiment.plan import RunSpec
    from adaptsky.experiment.runs import RunReport, RunState

POLL_S = 2.0   # the progress is read from the files at least this often; a run's end at once
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
    """One bar of the sweep's episodes where the reporter draws live; else a log line every
    ``LOG_EVERY_S``."""

    def __init__(self, reporter: Reporter, total_episodes: int, done: int) -> None:
        self.reporter, self.total, self.done = reporter, total_episodes, done
        self.last_log = time.monotonic()

    def __enter__(self) -> _Display:
        self.reporter.open("runs")
        self.reporter.start(self, self.total, self.done, status="", eta="")
        return self

    def __exit__(self, *exc: object) -> None:
        self.reporter.close()

    def update(self, status: str, episodes: int, eta: str) -> None:
        self.reporter.advance(self, episodes, status=status, eta=eta)
        if time.monotonic() - self.last_log >= LOG_EVERY_S:
            self.last_log = time.monotonic()
            self.reporter.log(f"{status}; {eta}" if eta else status)


INTERRUPT_NOTICE = ("interrupted: checkpointing the running runs at the end of their current "
                    "episode (Ctrl-C again to quit now)")


def run_sweep(todo: list[tuple[RunSpec, RunState]], executor: Executor, progress: Reporter,
              total_runs: int) -> SweepOutcome:
    """Train every run in ``todo`` (resuming partial ones) on ``executor``. The first Ctrl-C
    checkpoints the running runs and stops; the second quits at once."""
    start = time.monotonic()
    skipped = total_runs - len(todo)
    done_episodes = {spec.path: state.episodes_done for spec, state in todo}
    start_episodes = sum(done_episodes.values())
    total_episodes = sum(spec.episodes for spec, _ in todo)
    pace = Pace(total_episodes, start_episodes)  # from the episodes written, the first left out
    futures: dict[Any, tuple[RunSpec, Any]] = {}
    outcome, failures = SweepOutcome(), []
    interrupts = StopOnInterrupt(executor.request_stop, progress.note, INTERRUPT_NOTICE)
    try:
        with interrupts, _Display(progress, total_episodes, start_episodes) as display:
            specs = [spec for spec, _ in todo]
            for spec, future in zip(specs, executor.submit_all(specs), strict=True):
                futures[spec.path] = (spec, future)
            progress.note(f"{total_runs} runs: {skipped} done before, {len(todo)} to run on "
                          f"{executor.description}")
            while futures:
                interrupts.check()
                for key, (spec, future) in list(futures.items()):
                    if not future.done():
                        episodes = _episodes_in_file(spec)
                        if episodes is not None:
                            done_episodes[key] = episodes
                        continue
                    del futures[key]
                    report = _settled(spec, future, failures, progress)
                    if report is not None:
                        done_episodes[key] = report.episodes_done
                        outcome.reports.append(report)
                episodes = sum(done_episodes.values())
                finished = total_runs - len(futures)
                running = min(len(futures), executor.capacity)
                pace.update(episodes)
                display.update(f"runs {finished} done · {running} running · "
                               f"{len(futures) - running} left", episodes, pace.left())
                if futures:
                    executor.wait_any([future for _, future in futures.values()], POLL_S)
    except BaseException:
        executor.close(now=True)
        if interrupts.interrupted:  # a second Ctrl-C: what the files keep, then exit 130
            progress.message(_kept([spec for spec, _ in futures.values()]))
        raise
    executor.close()
    outcome.interrupted, outcome.seconds = interrupts.interrupted, time.monotonic() - start
    if failures and not interrupts.interrupted:
        raise SweepError(f"{len(failures)} of {len(todo)} runs failed; the others are saved. "
                         f"First: {failures[0]}")
    return outcome


def _settled(spec: RunSpec, future: Any, failures: list[str], progress: Reporter
             ) -> RunReport | None:
    """A finished run's report, logged; None for a run cancelled or failed (logged and added
    to ``failures``)."""
    if future.cancelled():
        return None
    try:
        report = future.result()
    except Exception as error:  # one line per failed run, the others go on
        message = str(error).splitlines()[0] if str(error) else type(error).__name__
        failures.append(f"{spec.name}: {message}")
        progress.note(f"run {spec.name} failed: {message}")
        return None
    resumed = (f", resumed from episode {report.started_at_episode}"
               if report.started_at_episode else "")
    progress.note(f"run {spec.name}: {report.episodes_done}/{spec.episodes} episodes in "
                  f"{format_duration(report.seconds)}{resumed}")
    return report


def _kept(unfinished: list[RunSpec]) -> str:
    """What quitting at once keeps of the runs not finished, in one line."""
    kept = ", ".join(f"{spec.name} at episode {episodes}" if episodes else
                     f"{spec.name} without a checkpoint"
                     for spec in unfinished for episodes in [_episodes_in_file(spec)])
    return (f"quit: the run files keep {kept}; what the running runs trained after that is "
            "lost" if kept else "quit")
