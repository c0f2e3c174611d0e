"""One run of an experiment, wherever it executes: start it, resume it from its file, or
find it done. The run file is the only state, so a retry (after Ctrl-C, kill -9 or a Dask
worker that died) is a resume from its last checkpoint.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from contextlib import ExitStack
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Literal

from adaptsky.errors import AdaptskyError
from adaptsky.experiment.plan import RunSpec, scenario_text
from adaptsky.scenario import Scenario, parse_scenario
from adaptsky.scenario.variants import with_values
from adaptsky.store import run_file
from adaptsky.store.atomic import make_parent
from adaptsky.store.lock import run_lock
from adaptsky.store.run_file import RunFileError, RunReader
from adaptsky.training.api import create_run_file
from adaptsky.training.evaluation import EVALUATION_KEYS, evaluation_set
from adaptsky.training.host import pin_threads
from adaptsky.training.messages import Checkpoints, Message
from adaptsky.training.runner import RunFileWriter, SeedTask, train_stack

if TYPE_CHECKING:
    import torch

Status = Literal["missing", "partial", "done"]


class RunConflictError(AdaptskyError):
    """A run file in the output folder was made with a different configuration."""


@dataclass(frozen=True)
class RunState:
    status: Status
    episodes_done: int


def _first_difference(a: object, b: object, prefix: str = "") -> str:
    if isinstance(a, dict) and isinstance(b, dict):
        for key in sorted(set(a) | set(b)):
            found = _first_difference(a.get(key), b.get(key), f"{prefix}{key}.")
            if found:
                return found
        return ""
    return "" if a == b else f"{prefix.rstrip('.')} is {a!r} there, {b!r} here"


def run_state(spec: RunSpec) -> RunState:
    """Where ``spec``'s run file stands. A file made before its first checkpoint counts as
    missing (it holds no work); one with another configuration is refused, except for a
    larger episode target, which is resumed."""
    if not spec.path.exists():
        return RunState("missing", 0)
    try:
        with RunReader(spec.path) as run:
            stored = run.scenario  # the stored config, validated on opening
            if spec.seed not in run.seeds or not run.has_checkpoint(spec.seed):
                return RunState("missing", 0)
            done = run.seed_attrs(spec.seed)["episodes_done"]
    except RunFileError as error:
        raise RunConflictError(f"{error}; remove it to train this run again") from None
    stored_json = stored.model_dump(mode="json")
    # neither the episode target nor the evaluation settings change what was trained
    ignored = dict.fromkeys(("episodes", *EVALUATION_KEYS), 0)
    mine = {**spec.config, "train": {**spec.config["train"], **ignored}}
    theirs = {**stored_json, "train": {**stored_json["train"], **ignored}}
    if mine != theirs:
        raise RunConflictError(
            f"{spec.path}: made with another configuration ({_first_difference(theirs, mine)});"
            " use another --out, or remove the file")
    if done > spec.episodes:
        raise RunConflictError(f"{spec.path}: has {done} episodes, more than the "
                               f"{spec.episodes} asked for; use another --out")
    return RunState("done" if done == spec.episodes else "partial", done)


@dataclass(frozen=True)
class RunReport:
    """What a run's execution did, for the log: it may have started from a checkpoint."""

    name: str
    started_at_episode: int
    episodes_done: int
    seconds: float
    host: str
    pid: int


def _prepare(spec: RunSpec) -> tuple[RunState, SeedTask | None]:
    """Create or open ``spec``'s run file; the task that finishes it (None when done). The
    caller holds its lock."""
    state = run_state(spec)
    scenario = parse_scenario(spec.config, spec.name)
    checkpoint, evaluation = None, None
    if state.status == "missing":
        spec.path.unlink(missing_ok=True)  # a stub from before the first checkpoint
        evaluation = create_run_file(spec.path, scenario, scenario_text(spec),
                                     list(spec.set_values))
    elif state.status == "partial":
        with RunReader(spec.path) as run:
            checkpoint = run.checkpoint(spec.seed)
            planned = run.seed_attrs(spec.seed)["episodes_planned"]
            # the file's own evaluation settings (a file older than evaluations has none)
            scenario = _with_evaluation_of(scenario, run.scenario)
            stored_oracle = run.evaluation_oracle()
        if planned != spec.episodes:
            run_file.set_planned_episodes(spec.path, spec.config)
        evaluation = evaluation_set(scenario, stored_oracle)
    if state.status == "done":
        return state, None
    t = scenario.train
    return state, SeedTask(scenario, spec.seed, t.episodes, t.checkpoint_every,
                           t.trajectory_every, checkpoint, label=spec.path,
                           evaluation=evaluation)


def _with_evaluation_of(scenario: Scenario, stored: Scenario) -> Scenario:
    """``scenario`` with the evaluation settings of ``stored`` (they change no training)."""
    return with_values(scenario, "train", {key: getattr(stored.train, key)
                                           for key in EVALUATION_KEYS}, f"{stored.name} as stored")


def execute_runs(specs: list[RunSpec], stop: Callable[[], bool] = lambda: False,
                 orphaned: Callable[[], bool] = lambda: False,
                 device: torch.device | None = None) -> list[RunReport]:
    """Train ``specs`` to their episode targets in this process (one thread) as one stack,
    each from its file's last checkpoint if it has one (members of a stack must share
    :func:`adaptsky.training.stack_run.stack_key`). ``stop()`` asks for a checkpoint and an
    early end. Each run file is locked while this runs: a second writer is refused."""
    with ExitStack() as locks:
        for spec in specs:
            make_parent(spec.path)
            locks.enter_context(run_lock(spec.path))
        return _execute_locked(specs, stop, orphaned, device)


def _execute_locked(specs: list[RunSpec], stop: Callable[[], bool],
                    orphaned: Callable[[], bool], device: torch.device | None
                    ) -> list[RunReport]:
    import torch

    start = time.perf_counter()
    pin_threads()
    prepared = [_prepare(spec) for spec in specs]
    tasks = [task for _, task in prepared if task is not None]
    errors: list[str] = []
    writers = {spec.path: RunFileWriter(spec.path, {spec.seed: state.episodes_done}, errors)
               for spec, (state, _) in zip(specs, prepared, strict=True)}
    seeds = {spec.path: spec.seed for spec in specs}

    def route(message: Message) -> None:  # a run's messages (keyed by file) to its own file
        if isinstance(message, Checkpoints):  # one seed per file
            for item in message.items:
                writers[item.key](Checkpoints([replace(item, key=seeds[item.key])]))
            return
        writers[message.key](replace(message, key=seeds[message.key]))

    if tasks:
        train_stack(tasks, route, stop, orphaned, device or torch.device("cpu"))
    if errors:
        raise AdaptskyError(f"{specs[0].name}: {errors[0]}")
    seconds = time.perf_counter() - start
    return [RunReport(spec.name, state.episodes_done, run_state(spec).episodes_done, seconds,
                      os.uname().nodename, os.getpid())
            for spec, (state, _) in zip(specs, prepared, strict=True)]


def execute_run(spec: RunSpec, stop: Callable[[], bool] = lambda: False,
                orphaned: Callable[[], bool] = lambda: False) -> RunReport:
    """Train one run on the CPU; see :func:`execute_runs`."""
    return execute_runs([spec], stop, orphaned)[0]
