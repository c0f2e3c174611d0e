"""The study: Optuna's storage (SQLite in the study's folder by default, any SQLAlchemy URL),
its TPE sampler and pruner, and the loop every ``tune`` process runs on it.

A study ends with ``trials`` trials finished or pruned. Each process, until then: continues a
trial that lost its process (its claim is free: :mod:`adaptsky.tuning.claims`), else asks
Optuna for a new one while fewer than ``trials`` are finished, pruned or running, else waits
for the running ones. A process that asks at the same moment as another and gets a trial past
the count marks it failed before it trains (``user_attrs["surplus"]``): no trial is trained
twice and none is lost, whether processes end, crash or are killed.
"""

from __future__ import annotations

import json
import math
import os
import socket
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from adaptsky.errors import AdaptskyError, NonFiniteError
from adaptsky.training.runner import TrainingError
from adaptsky.tuning.claims import Claim, is_held
from adaptsky.tuning.space import Space
from adaptsky.tuning.trial import TrialOutcome, TrialRun, run_trial, trial_path

if TYPE_CHECKING:
    import optuna

WAIT_S = 2.0
# a running trial without a claim file this long after it started lost its process before
# it took the claim (or belongs to a machine that does not share the folder)
UNCLAIMED_S = 120.0
# opening a new database that another process is creating at the same moment
SCHEMA_TRIES = 5
SCHEMA_WAIT_S = 0.5


class StudyError(AdaptskyError):
    """The study cannot be opened, or was made for another search."""


def default_storage(folder: Path) -> str:
    return f"sqlite:///{(folder / 'study.db').resolve()}"


@dataclass(frozen=True)
class Tuning:
    """What a study searches and how; a study remembers it (``user_attrs["tuning"]``) and
    refuses to go on with another."""

    folder: Path
    storage: str
    name: str
    space: Space
    run: TrialRun
    trials: int
    eval_every: int
    seeds: int

    def identity(self) -> str:
        """What must be the same for a study to be continued (not the count of trials)."""
        return json.dumps({"space": json.loads(self.space.to_json()),
                           "scenario": str(self.run.scenario_path.resolve()),
                           "set": self.run.overrides, "episodes": self.run.episodes,
                           "steps": self.run.steps}, sort_keys=True)


def open_storage(url: str) -> Any:
    """Optuna's storage at ``url``. Two processes opening a new database at the same moment
    both create its tables; the one that loses gets "table ... already exists" and tries again
    (the tables are there by then)."""
    import optuna

    kwargs = {"connect_args": {"timeout": 120}} if url.startswith("sqlite") else {}
    for attempt in range(SCHEMA_TRIES):
        try:
            return optuna.storages.RDBStorage(url, engine_kwargs=kwargs)
        except Exception as error:  # SQLAlchemy's many kinds: a bad URL, a missing driver, ...
            if "already exists" in str(error) and attempt + 1 < SCHEMA_TRIES:
                time.sleep(SCHEMA_WAIT_S)
                continue
            reason = str(error).splitlines()[0] if str(error) else type(error).__name__
            raise StudyError(
                f"--storage {url}: cannot open the study's storage: {reason}") from None
    raise AssertionError("unreachable")


def open_study(tuning: Tuning, worker: int = 0) -> optuna.study.Study:
    """The study (made where it is new), with a TPE sampler seeded from the space's seed,
    the trials the study holds and ``worker`` (so processes and sessions draw differently)
    and the space's pruner."""
    import optuna

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    storage = open_storage(tuning.storage)
    settings = tuning.space.study
    pruner: optuna.pruners.BasePruner = optuna.pruners.NopPruner()
    if settings.pruner == "median":
        pruner = optuna.pruners.MedianPruner(
            n_startup_trials=settings.startup_trials,
            # Optuna prunes from the step n_warmup_steps on: after warmup_evaluations
            n_warmup_steps=settings.warmup_evaluations * tuning.eval_every + 1)
    study = optuna.create_study(storage=storage, study_name=tuning.name, direction="maximize",
                                pruner=pruner, load_if_exists=True)
    made_for = study.user_attrs.get("tuning")
    if made_for is None:
        study.set_user_attr("tuning", tuning.identity())
    elif made_for != tuning.identity():
        raise StudyError(f"study '{tuning.name}' in {tuning.storage} was made for another "
                         f"search (scenario, --set, --episodes, --steps or space differ); "
                         "give another --study, or the same settings")
    held = len(study.get_trials(deepcopy=False))
    seed = int(np.random.SeedSequence([settings.seed, held, worker]).generate_state(1)[0])
    study.sampler = optuna.samplers.TPESampler(
        seed=seed, n_startup_trials=settings.startup_trials, constant_liar=True)
    return study


@dataclass
class Counts:
    complete: int = 0
    pruned: int = 0
    running: int = 0
    best_value: float = math.nan
    best_number: int | None = None

    @property
    def settled(self) -> int:
        return self.complete + self.pruned


def counts_of(study: optuna.study.Study) -> Counts:
    from optuna.trial import TrialState

    counts = Counts()
    for t in study.get_trials(deepcopy=False):
        if t.state == TrialState.COMPLETE:
            counts.complete += 1
            if t.value is not None and not (counts.best_value >= t.value):
                counts.best_value, counts.best_number = t.value, t.number
        elif t.state == TrialState.PRUNED:
            counts.pruned += 1
        elif t.state == TrialState.RUNNING:
            counts.running += 1
    return counts


def _orphan(study: optuna.study.Study, folder: Path) -> tuple[Any, Claim] | None:
    """A running trial whose process is gone, now claimed by this one."""
    from optuna.trial import TrialState

    now = time.time()
    for t in study.get_trials(deepcopy=False, states=(TrialState.RUNNING,)):
        held = is_held(folder, t.number)
        if held or (held is None and t.datetime_start is not None
                    and now - t.datetime_start.timestamp() < UNCLAIMED_S):
            continue
        claim = Claim(folder, t.number)
        if not claim.take():
            continue
        # its process may have ended it (and let go of its claim) since the list was read
        if any(r.number == t.number
               for r in study.get_trials(deepcopy=False, states=(TrialState.RUNNING,))):
            return t, claim
        claim.release()
    return None


def _surplus(study: optuna.study.Study, number: int, trials: int) -> bool:
    """True where ``trials`` trials that count come before trial ``number`` (two processes
    asked at once)."""
    from optuna.trial import TrialState

    counted = (TrialState.COMPLETE, TrialState.PRUNED, TrialState.RUNNING, TrialState.WAITING)
    before = [t for t in study.get_trials(deepcopy=False, states=counted) if t.number < number]
    return len(before) >= trials


Event = Callable[[str, dict[str, Any]], None]


def work(tuning: Tuning, study: optuna.study.Study, event: Event,
         stop: Callable[[], bool] = lambda: False) -> bool:
    """Run trials on ``study`` until it has ``tuning.trials`` finished or pruned; False if
    ``stop()`` ended it first. ``event(kind, fields)`` hears: "start" (number, params,
    continued), "episode" (number, episode, episodes), "end" (number, outcome), "wait"."""
    import optuna
    from optuna.trial import TrialState

    distributions = tuning.space.distributions()
    while not stop():
        counts = counts_of(study)
        if counts.settled >= tuning.trials:
            return True
        found = _orphan(study, tuning.folder)
        if found is not None:
            frozen, claim = found
            trial = optuna.trial.Trial(study, frozen._trial_id)
            params, continued = tuning.space.suggest(trial), True
        elif counts.settled + counts.running < tuning.trials:
            trial = study.ask(distributions)
            claim = Claim(tuning.folder, trial.number)
            claim.take()  # new: nobody else knows its number yet
            if _surplus(study, trial.number, tuning.trials):
                trial.set_user_attr("surplus", True)
                study.tell(trial, state=TrialState.FAIL)
                claim.release()
                continue
            trial.set_user_attr("host", f"{socket.gethostname()}:{os.getpid()}")
            params, continued = trial.params, False
        else:
            event("wait", {})
            time.sleep(WAIT_S)
            continue
        with claim:
            try:
                outcome = _run(tuning, trial, params, continued, event, stop)
            except (TrainingError, NonFiniteError) as error:  # these values cannot train
                outcome = TrialOutcome("failed", error=str(error).splitlines()[0])
                trial.set_user_attr("error", outcome.error)
                study.tell(trial, state=TrialState.FAIL)
            if outcome.state == "complete":
                study.tell(trial, outcome.value)
            elif outcome.state == "pruned":
                study.tell(trial, state=TrialState.PRUNED)
            event("end", {"number": trial.number, "outcome": outcome})
            if outcome.state == "stopped":
                return False
    return False


def _run(tuning: Tuning, trial: optuna.trial.Trial, params: dict[str, Any], continued: bool,
         event: Event, stop: Callable[[], bool]) -> TrialOutcome:
    number = trial.number
    overrides = [*tuning.run.overrides, *tuning.space.overrides(params)]
    trial.set_user_attr("run_file", trial_path(tuning.folder, number).name)
    event("start", {"number": number, "params": params, "continued": continued})
    run = TrialRun(tuning.run.scenario_path, overrides, tuning.run.episodes, tuning.run.steps,
                   tuning.run.eval_every)
    return run_trial(trial, run, trial_path(tuning.folder, number), tuning.space.study.objective,
                     tuning.seeds,
                     on_episode=lambda e, total: event("episode", {"number": number,
                                                                   "episode": e,
                                                                   "episodes": total}),
                     stop=stop)
