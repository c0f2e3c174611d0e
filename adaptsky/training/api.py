"""``train`` and ``resume`` as keyword-only library functions (the CLI only forwards)."""

from __future__ import annotations

import os
import sys
import time
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from adaptsky.arrays import Tree
from adaptsky.channels.registry import plugin
from adaptsky.errors import AdaptskyError
from adaptsky.progress import LogLines, Reporter
from adaptsky.scenario import Scenario
from adaptsky.scenario.loading import parse_with_overrides, read_scenario_text
from adaptsky.scenario.toml_writer import dumps
from adaptsky.scenario.variants import with_values
from adaptsky.store import run_file
from adaptsky.store.atomic import (
    FileGoneError,
    StorageError,
    fresh_path,
    make_parent,
    utc_timestamp,
)
from adaptsky.store.lock import run_lock
from adaptsky.store.run_file import RunReader
from adaptsky.training.evaluation import EvaluationSet, evaluation_set, reference_name
from adaptsky.training.logs import TrainingLogs, check_kinds, kinds_found
from adaptsky.training.progress import TrainingProgress
from adaptsky.training.resources import check_fits
from adaptsky.training.runner import RunOutcome, SeedTask, Watch, run_tasks

if TYPE_CHECKING:  # imported where training starts: commands start without torch
    import torch


class OutputExistsError(AdaptskyError):
    pass


class RunFileGoneError(AdaptskyError):
    """The run file was removed or replaced by another file while training: adaptsky stops
    and never writes it again (the same for any number of seeds)."""

    def __init__(self, path: Path) -> None:
        self.path = path
        if path.exists():
            text = ("was replaced by another file during training; training stopped without "
                    "writing over it (if that file is a copy of this run, continue it with "
                    f"adaptsky train --resume {path})")
        else:
            text = ("was removed during training; training stopped and wrote nothing in its "
                    "place (a copy of the run continues with adaptsky train --resume COPY)")
        super().__init__(f"{path}: the run file {text}")


def default_output(scenario: Scenario, directory: Path = Path("runs")) -> Path:
    """runs/<scenario name>-<time>.h5, never an existing file."""
    return fresh_path(directory, scenario.name)


def _with_train(scenario: Scenario, **overrides: object) -> Scenario:
    """The scenario with ``[train]`` overrides (those not None), validated again."""
    changes = {key: value for key, value in overrides.items() if value is not None}
    return with_values(scenario, "train", changes, "command line")


def _plugins_used(scenario: Scenario) -> dict[str, dict[str, str]]:
    info = plugin(scenario.channel.model)
    return {info.name: {"package": info.package, "version": info.version,
                        "target": info.target}}


def load_with_overrides(scenario_path: Path, set_values: list[str] | None = None
                        ) -> tuple[Scenario, str]:
    """The scenario file with ``--set`` overrides applied, validated as one file; its text."""
    text = read_scenario_text(scenario_path)
    return parse_with_overrides(text, scenario_path, set_values)[0], text


def scenario_text(scenario: Scenario | str | os.PathLike[str]) -> tuple[str, str]:
    """The TOML text of a scenario file, or of a ``Scenario`` in memory (its validated values,
    written by :func:`adaptsky.scenario.toml_writer.dumps`), and the name its messages give
    it: the file's path, or ``<scenario NAME>``."""
    if isinstance(scenario, Scenario):
        return dumps(scenario.model_dump(mode="json")), f"<scenario {scenario.name}>"
    return read_scenario_text(scenario), str(scenario)


def prepare_output(path: Path) -> None:
    """Make ``path``'s folder; refuse a folder or an existing file at ``path`` (call it again
    under the run's lock: another writer may have made it meanwhile)."""
    if path.is_dir():
        raise OutputExistsError(f"{path}: is a folder; give a run file name, e.g. "
                                f"--out {path / 'run.h5'}")
    if path.exists():
        raise OutputExistsError(f"{path}: exists; choose another --out, or continue it with "
                                f"--resume {path}")
    make_parent(path)


def create_run_file(path: Path, scenario: Scenario, text: str,
                    set_values: list[str] | None = None, progress: Reporter | None = None
                    ) -> EvaluationSet | None:
    """A new run file for every seed of ``scenario`` (refuses an existing ``path``), with the
    layouts and oracle of its greedy evaluations (returned; ``progress`` shows their search);
    the caller holds its lock (:func:`adaptsky.store.lock.run_lock`)."""
    prepare_output(path)
    evaluation = evaluation_set(scenario, progress=progress)
    t = scenario.train
    run_file.create_run(path, text, scenario.model_dump(mode="json"), _plugins_used(scenario),
                        t.seeds, t.episodes, scenario.num_users, set_values or [],
                        evaluation=evaluation.arrays() if evaluation is not None else None)
    return evaluation


def train(*, scenario: Scenario | str | os.PathLike[str] | None = None,
          scenario_path: str | os.PathLike[str] | None = None,
          out: str | os.PathLike[str] | None = None,
          seeds: list[int] | None = None, episodes: int | None = None,
          steps: int | None = None, workers: int | None = None,
          checkpoint_every: int | None = None, set_values: list[str] | None = None,
          device: str = "cpu", quiet: bool = False, progress: Reporter | None = None,
          logs: list[str] | tuple[str, ...] = (), watch: Watch | None = None
          ) -> tuple[Path, RunOutcome]:
    """Train every seed of the scenario into a new run file; returns its path.

    ``scenario``: a ``Scenario`` in memory or the path of a scenario file (``scenario_path``
    is the same as a path). The run file keeps the scenario's TOML text (a ``Scenario``'s is
    written from its values), so ``resume``, ``inspect`` and ``eval`` treat both alike, and
    both train the same numbers. ``set_values`` are ``section.key=value`` overrides, applied
    before the options below and recorded in the run file. ``device``: cpu, cuda or auto
    (cuda when available). ``progress`` hears of the training (default: timestamped lines on
    standard error, only warnings and interrupts with ``quiet``). ``logs``: the kinds of
    scalar log to write beside the run file (``"tensorboard"``, ``"csv"``;
    :mod:`adaptsky.training.logs`). ``watch`` hears every episode and may end the training
    early (:data:`adaptsky.training.runner.Watch`; the outcome is then ``interrupted``).
    """
    if (scenario is None) == (scenario_path is None):
        raise TypeError("train() takes one of scenario= and scenario_path=")
    log_kinds = check_kinds(logs)
    progress = progress or LogLines(quiet=quiet)
    started_utc, start_s = utc_timestamp(), time.monotonic()
    torch_device = training_device(device)
    text, source = scenario_text(scenario if scenario is not None else scenario_path)
    loaded = parse_with_overrides(text, source, set_values)[0]
    scenario = _with_train(loaded, seeds=seeds, episodes=episodes, steps=steps,
                           checkpoint_every=checkpoint_every)
    check_fits(scenario, source, workers=workers)
    path = Path(out) if out is not None else default_output(scenario)
    prepare_output(path)
    with run_lock(path):
        evaluation = create_run_file(path, scenario, text, set_values, progress)
        t = scenario.train
        tasks = [SeedTask(scenario, seed, t.episodes, t.checkpoint_every, t.trajectory_every,
                          evaluation=evaluation) for seed in t.seeds]
        outcome = _run(path, tasks, workers, torch_device, progress, log_kinds, watch)
        _record_session(path, "train", started_utc, start_s, dict.fromkeys(t.seeds, 0),
                        progress)
        return path, outcome


def read_progress(run_path: Path) -> tuple[Scenario, dict[int, Tree | None],
                                           list[np.ndarray] | None]:
    """A run file's scenario (validated on opening), each seed's last checkpoint (None for
    a seed stopped before its first: it starts from zero) and the stored oracle of its
    evaluations (None where the file has none)."""
    with RunReader(run_path) as run:
        scenario = run.scenario
        checkpoints: dict[int, Tree | None] = {}
        for seed in run.seeds:  # (the reader refuses a seed with episodes but no checkpoint)
            checkpoints[seed] = run.checkpoint(seed) if run.has_checkpoint(seed) else None
            run.episodes(seed)  # the curves it appends to must read back (no damaged index)
        return scenario, checkpoints, run.evaluation_oracle()


def resume(*, run_path: Path, episodes: int | None = None, workers: int | None = None,
           device: str = "cpu", quiet: bool = False, progress: Reporter | None = None,
           logs: list[str] | tuple[str, ...] | None = None, watch: Watch | None = None
           ) -> tuple[Path, RunOutcome]:
    """Continue every seed of a run file from its last checkpoint, a seed without one from
    zero (on any device: only the same device continues bit for bit); ``quiet`` and
    ``progress`` as for :func:`train`. ``logs``: the kinds of scalar log to continue (or
    start); None continues those the run has beside it. ``watch`` as for :func:`train`."""
    log_kinds = check_kinds(kinds_found(Path(run_path)) if logs is None else logs)
    progress = progress or LogLines(quiet=quiet)
    started_utc, start_s = utc_timestamp(), time.monotonic()
    torch_device = training_device(device)
    with RunReader(run_path, needs="curves"):
        pass  # a missing or damaged file: its own line, before a lock file is made beside it
    with run_lock(run_path):
        scenario, checkpoints, stored_oracle = read_progress(run_path)
        done = max(int(c["episode"]) if c is not None else 0 for c in checkpoints.values())
        if episodes is not None and episodes < done:
            raise AdaptskyError(f"--episodes {episodes} is fewer than the {done} episodes "
                                f"{run_path} has done")
        if episodes is not None:
            scenario = _with_train(scenario, episodes=episodes)
        check_fits(scenario, str(run_path), workers=workers)  # before anything is written
        if episodes is not None:
            run_file.set_planned_episodes(run_path, scenario.model_dump(mode="json"))
        t = scenario.train
        tasks = [SeedTask(scenario, seed, t.episodes, t.checkpoint_every, t.trajectory_every,
                          checkpoint) for seed, checkpoint in checkpoints.items()]
        tasks = [task for task in tasks if task.episodes_done < t.episodes]
        if not tasks:
            return run_path, RunOutcome({seed: t.episodes for seed in checkpoints}, False,
                                        complete=True)
        # computed only if it must run
        evaluation = evaluation_set(scenario, stored_oracle, progress)
        tasks = [replace(task, evaluation=evaluation) for task in tasks]
        before = {seed: int(c["episode"]) if c is not None else 0
                  for seed, c in checkpoints.items()}
        outcome = _run(run_path, tasks, workers, torch_device, progress, log_kinds, watch)
        _record_session(run_path, "resume", started_utc, start_s, before, progress)
        return run_path, outcome


def _record_session(path: Path, kind: str, started_utc: str, start_s: float,
                    episodes_before: dict[int, int], progress: Reporter) -> None:
    """Append this session to the run's history; the training it describes is stored
    already, so a failure to write it (a full disk) is a warning, not a failed run."""
    try:
        run_file.record_session(path, kind, sys.argv, started_utc, time.monotonic() - start_s,
                                episodes_before)
    except FileGoneError:
        raise RunFileGoneError(path) from None
    except StorageError as error:
        progress.print(f"warning: the session history was not recorded: {error}")


def training_device(name: str) -> torch.device:
    """The torch device for ``--device`` (cpu, cuda, cuda:N or auto), or one clear error."""
    from adaptsky.algos.device_step import resolve_device

    try:
        return resolve_device(name)
    except (ValueError, RuntimeError) as error:
        raise AdaptskyError(str(error)) from None


def _run(path: Path, tasks: list[SeedTask], workers: int | None, device: torch.device,
         progress: Reporter, logs: tuple[str, ...] = (), watch: Watch | None = None
         ) -> RunOutcome:
    try:
        with TrainingProgress(progress, reference=reference_name(tasks[0].scenario)) as view, \
                TrainingLogs(path, logs, {task.seed: task.episodes_done for task in tasks}
                             ) as written:
            for task in tasks:
                view.add_seed(task.seed, task.episodes_done, task.episodes)
            return run_tasks(path, tasks, workers or len(tasks), view, device, written, watch)
    except StorageError as error:
        if error.path != path or not path.exists():
            raise
        failure = error.with_advice(f"{error.advice}; {path} keeps its last checkpoints: "
                                    f"continue it with adaptsky train --resume {path}")
    except FileGoneError as error:
        if error.path != path:
            raise
        failure = RunFileGoneError(path)
    raise failure

