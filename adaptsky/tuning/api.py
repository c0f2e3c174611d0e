"""``adaptsky tune`` as a library function (docs/tuning.md): a study of a scenario's
hyperparameters with Optuna, every trial a run file, the best trial written as a scenario.

``workers`` processes share the study: this one and ``workers - 1`` started beside it (each
trains one trial at a time, its seeds as one stack, on one thread). Running the same call
again continues the study; so does a ``tune`` on another machine given the same storage and
a shared folder.
"""

from __future__ import annotations

import contextlib
import math
import multiprocessing
import os
import re
import time
from dataclasses import dataclass, field
from multiprocessing.connection import wait as wait_processes
from pathlib import Path
from typing import Any

from adaptsky.errors import AdaptskyError
from adaptsky.progress import LOG_EVERY_S, LogLines, Pace, Reporter
from adaptsky.scenario.loading import parse_with_overrides, read_scenario_text
from adaptsky.scenario.toml_writer import dumps
from adaptsky.store.atomic import make_parent, write_text_atomic
from adaptsky.training.api import load_with_overrides
from adaptsky.tuning.space import check_against, load_space, shown
from adaptsky.tuning.study import (
    Counts,
    Tuning,
    counts_of,
    default_storage,
    open_study,
    work,
)
from adaptsky.tuning.trial import TrialOutcome, TrialRun

BEST_NAME = "best.toml"
POLL_S = 2.0
NAME = re.compile(r"[A-Za-z0-9_.-]+")


@dataclass
class TuneOutcome:
    folder: Path
    storage: str
    study: str
    counts: Counts
    trials: list[dict[str, Any]] = field(default_factory=list)  # best first
    best_path: Path | None = None
    interrupted: bool = False


def tune(*, scenario_path: str | os.PathLike[str], space_path: str | os.PathLike[str],
         trials: int, storage: str | None = None, study: str | None = None,
         out: str | os.PathLike[str] | None = None, workers: int = 1,
         episodes: int | None = None, steps: int | None = None,
         set_values: list[str] | None = None, quiet: bool = False,
         progress: Reporter | None = None) -> TuneOutcome:
    """Tune until the study has ``trials`` trials finished or pruned (the module docstring);
    the trials' run files, the study's SQLite file (without ``storage``) and ``best.toml`` go
    in ``out`` (default ``tune/<study>``; ``study`` defaults to the scenario file's name)."""
    progress = progress or LogLines(quiet=quiet)
    scenario_path, space_path = Path(scenario_path), Path(space_path)
    name = study or scenario_path.stem
    if not NAME.fullmatch(name):
        raise AdaptskyError(f"--study {name!r}: use letters, digits, '.', '_' and '-'")
    if trials < 1:
        raise AdaptskyError(f"--trials {trials}: expected at least 1")
    set_values = list(set_values or [])
    scenario, _ = load_with_overrides(scenario_path, set_values)
    space = load_space(space_path)
    check_against(space, space_path, scenario_path, set_values)
    t = scenario.train
    total_episodes = episodes or t.episodes
    if t.eval_every <= 0:
        raise AdaptskyError(
            f"{scenario_path}: train.eval_every = {t.eval_every}: tune scores trials by the "
            f"greedy evaluations during training; set it between 1 and the episodes "
            f"({total_episodes}), e.g. --set train.eval_every={max(1, total_episodes // 10)}")
    eval_every, adjusted = t.eval_every, None
    if eval_every > total_episodes:  # --episodes shortened the trials below the period
        eval_every = adjusted = total_episodes
        progress.message(
            f"tune: train.eval_every = {t.eval_every} is more than the {total_episodes} "
            f"episodes of a trial: set to {total_episodes} (one greedy evaluation, at each "
            f"trial's end; the pruner needs more: --set train.eval_every=N)")
    folder = Path(out) if out is not None else Path("tune") / name
    if folder.exists() and not folder.is_dir():
        raise AdaptskyError(f"{folder}: is a file; --out names the study's folder")
    make_parent(folder / "study.db")
    tuning = Tuning(folder, storage or default_storage(folder), name, space,
                    TrialRun(scenario_path, set_values, episodes, steps, adjusted), trials,
                    eval_every, len(t.seeds))
    the_study = open_study(tuning)
    view = _View(progress, tuning, the_study)
    others: list[multiprocessing.process.BaseProcess] = []
    context = multiprocessing.get_context("spawn")
    stop_event = context.Event()
    interrupted = False
    try:
        with view:
            # beside a live display the others stay silent; in a log each says its trials
            lines = not progress.live and not progress.quiet
            for index in range(1, workers):
                process = context.Process(target=_worker, args=(tuning, index, os.getpid(),
                                                               stop_event, lines), daemon=False)
                process.start()
                others.append(process)
            finished = work(tuning, the_study, view.event, stop_event.is_set)
            interrupted = not finished
            if interrupted:  # Ctrl-C stopped this process's trial: the others stop too
                stop_event.set()
            while any(p.is_alive() for p in others):
                view.event("wait", {})   # back as soon as one of them ends
                wait_processes([p.sentinel for p in others if p.is_alive()], POLL_S)
    except KeyboardInterrupt:
        interrupted = True
        stop_event.set()
        progress.message("interrupted: the running trials checkpoint at the end of their "
                         "episode; run the same command again to continue the study")
        for process in others:
            process.join()
    failed = [p.exitcode for p in others if p.exitcode]
    if failed and not interrupted:
        progress.print(f"warning: {len(failed)} of the {workers - 1} processes beside this one "
                       f"ended with exit code {failed[0]} (see above); run the same command "
                       "again to continue the study")
    outcome = TuneOutcome(folder, tuning.storage, name, counts_of(the_study),
                          interrupted=interrupted)
    outcome.trials = _table(the_study)
    outcome.best_path = write_best(tuning, the_study)
    return outcome


def _worker(tuning: Tuning, index: int, parent_pid: int, stop_event: Any,
            lines: bool = False) -> None:
    """A process beside ``tune``'s: trials until the study is done, the parent is gone or
    asks for a stop (Ctrl-C reaches every process: the training checkpoints and ends); with
    ``lines``, its trials' log lines on standard error, as the parent's."""
    import signal

    from adaptsky.training.host import pin_threads

    pin_threads()
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # between trials: the parent decides

    def stop() -> bool:
        return stop_event.is_set() or os.getppid() != parent_pid

    log = _TrialLog(LogLines(quiet=not lines), f"process {index}: ")
    with contextlib.suppress(KeyboardInterrupt):  # a second Ctrl-C: the parent reports
        work(tuning, open_study(tuning, worker=index), log.event, stop)


def _table(study: Any) -> list[dict[str, Any]]:
    """Every trial finished or pruned, the best first: number, state, value, params."""
    from optuna.trial import TrialState

    rows = []
    for t in study.get_trials(deepcopy=False, states=(TrialState.COMPLETE, TrialState.PRUNED)):
        last = max(t.intermediate_values) if t.intermediate_values else None
        rows.append({"number": t.number, "state": t.state.name.lower(),
                     "value": t.value if t.value is not None else math.nan,
                     "pruned_at": last if t.state == TrialState.PRUNED else None,
                     "params": dict(t.params)})
    rows.sort(key=lambda r: (r["state"] != "complete", -r["value"]
                             if math.isfinite(r["value"]) else math.inf))
    return rows


def write_best(tuning: Tuning, study: Any) -> Path | None:
    """``best.toml`` in the study's folder: the scenario with the best trial's values (and the
    command's ``--set``; not its --episodes or --steps); None before any trial finished."""
    counts = counts_of(study)
    if counts.best_number is None:
        return None
    trial = study.trials[counts.best_number]
    overrides = [*tuning.run.overrides, *tuning.space.overrides(trial.params)]
    text = read_scenario_text(tuning.run.scenario_path)
    scenario, _ = parse_with_overrides(text, tuning.run.scenario_path, overrides)
    header = [f"# The best trial of study '{tuning.name}' ({tuning.storage}): trial "
              f"{trial.number}, objective {trial.value:.6g}",
              f"# ({tuning.space.study.objective} greedy evaluation's score, mean over seeds), "
              f"of {counts.settled} trials finished or pruned.",
              f"# {tuning.run.scenario_path} with: {', '.join(overrides)}", ""]
    path = tuning.folder / BEST_NAME
    write_text_atomic(path, "\n".join(header) + dumps(scenario.model_dump(mode="json")))
    return path


class _TrialLog:
    """Log lines of the trials one process runs (nothing where the display is live): a line
    as a trial starts, at its first episode and at most one every ``log_every_s`` after
    (episodes done, time per episode, time left), and as it ends."""

    def __init__(self, progress: Reporter, prefix: str = "",
                 log_every_s: float | None = None) -> None:
        self.progress, self.prefix = progress, prefix
        self.log_every_s = LOG_EVERY_S if log_every_s is None else log_every_s
        self.pace: Pace | None = None
        self.last_log: float | None = None

    def event(self, kind: str, fields: dict[str, Any]) -> None:
        if kind == "start":
            params = ", ".join(f"{k}={shown(v)}" for k, v in fields["params"].items())
            verb = "continues" if fields["continued"] else "starts"
            self.progress.log(f"{self.prefix}trial {fields['number']} {verb}: {params}")
            self.pace, self.last_log = None, None
        elif kind == "episode":
            self._episode(fields["number"], fields["episode"], fields["episodes"])
        elif kind == "end":  # (the parent's view says it with the study's best)
            self.progress.log(self.prefix + _ended(fields["number"], fields["outcome"],
                                                   Counts()))

    def _episode(self, number: int, episode: int, episodes: int) -> None:
        if self.pace is None:
            self.pace = Pace(episodes, episode - 1)
        self.pace.update(episode)
        now = time.monotonic()
        if self.last_log is not None and now - self.last_log < self.log_every_s:
            return
        self.last_log = now
        speed = self.pace.text("episode")
        self.progress.log(f"{self.prefix}trial {number}: episode {episode}/{episodes}"
                          + (f", {speed}" if speed else ""))


class _View:
    """One bar of the study's trials (finished or pruned of ``trials``), its text the running
    trial's episodes here, the trials running anywhere and the best so far; in a log, the
    lines of the trials this process runs (:class:`_TrialLog`) and one as each ends."""

    def __init__(self, progress: Reporter, tuning: Tuning, study: Any) -> None:
        self.progress, self.tuning, self.study = progress, tuning, study
        self.counts = counts_of(study)
        self.pace = Pace(tuning.trials, self.counts.settled)
        self.here = ""
        self.polled = 0.0
        self.lines = _TrialLog(progress)

    def __enter__(self) -> _View:
        self.progress.open("trials")
        self.progress.start(self, self.tuning.trials, min(self.counts.settled,
                                                          self.tuning.trials),
                            status=self._status(), eta="")
        self.progress.note(f"study '{self.tuning.name}' in {self.tuning.storage}: "
                           f"{self.counts.settled} of {self.tuning.trials} trials finished "
                           f"or pruned before; trials in {self.tuning.folder}")
        return self

    def __exit__(self, *exc: object) -> None:
        self.progress.close()

    def _status(self) -> str:
        c = self.counts
        best = (f"best {c.best_value:.2f} (trial {c.best_number})"
                if c.best_number is not None else "no best yet")
        return (f"{self.here}{c.complete} done · {c.pruned} pruned · {c.running} running · "
                f"{best}")

    def _refresh(self, now: bool = False) -> None:
        """The bar's text now (the running trial's episode), the study's counts read from the
        storage at most every :data:`POLL_S` (unless ``now``)."""
        if now or time.monotonic() - self.polled >= POLL_S:
            self.polled = time.monotonic()
            self.counts = counts_of(self.study)
            self.pace.update(min(self.counts.settled, self.tuning.trials))
        self.progress.advance(self, min(self.counts.settled, self.tuning.trials),
                              status=self._status(), eta=self.pace.left(short=True))

    def event(self, kind: str, fields: dict[str, Any]) -> None:
        if kind != "end":
            self.lines.event(kind, fields)
        if kind == "start":
            self.here = f"trial {fields['number']} "
        elif kind == "episode":
            self.here = f"trial {fields['number']} ep {fields['episode']}/{fields['episodes']} · "
        elif kind == "end":
            self.here = ""
            self._refresh(now=True)
            self.progress.note(_ended(fields["number"], fields["outcome"], self.counts))
            return
        self._refresh()


def _ended(number: int, outcome: TrialOutcome, counts: Counts) -> str:
    best = (f"; best {counts.best_value:.2f} (trial {counts.best_number})"
            if counts.best_number is not None else "")
    if outcome.state == "complete":
        return f"trial {number}: {outcome.value:.2f}{best}"
    if outcome.state == "pruned":
        return f"trial {number}: pruned at episode {outcome.pruned_at}{best}"
    if outcome.state == "failed":
        return f"trial {number}: failed: {outcome.error}{best}"
    return f"trial {number}: stopped; its run file keeps its last checkpoint"

