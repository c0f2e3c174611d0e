"""One trial of a tuning: the scenario with the trial's sampled values trained into the run
file ``trial-NNNN.h5`` (every seed of the scenario, one stack in this process), its greedy
evaluations reported to Optuna as they come, the pruner asked after each, and its objective
read back from the run file.

The intermediate value at an evaluation episode is the mean over the seeds of the greedy
evaluations' score (docs/training.md: percent of the oracle, or of best response for several
UAVs, on the training layout; without a reference the sum rate); the objective is the mean
over the seeds of the last evaluation's score (``objective = "last"``) or of each seed's best
(``"best"``). A trial that lost its process is continued from its run file's last checkpoint:
evaluations it reported before are not reported again.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from adaptsky.errors import AdaptskyError
from adaptsky.progress import Silent
from adaptsky.store.run_file import RunFileError, RunReader
from adaptsky.training import api

if TYPE_CHECKING:
    import optuna


def trial_path(folder: Path, number: int) -> Path:
    return folder / f"trial-{number:04d}.h5"


@dataclass
class TrialRun:
    """What a trial trains: the scenario file with ``overrides`` (the command's ``--set``
    first, then the sampled values), and ``episodes``/``steps`` where the command gives
    them; ``eval_every`` where tune set ``train.eval_every`` itself (``--episodes`` fewer than
    the scenario's period: the trial is evaluated at its end), not written to best.toml."""

    scenario_path: Path
    overrides: list[str]
    episodes: int | None
    steps: int | None
    eval_every: int | None = None

    def training_overrides(self) -> list[str]:
        """``overrides``, then the evaluation period tune set, if it set one."""
        period = [] if self.eval_every is None else [f"train.eval_every={self.eval_every}"]
        return [*self.overrides, *period]


@dataclass
class TrialOutcome:
    state: str  # complete, pruned, failed, or stopped (interrupted: continued later)
    value: float = math.nan
    pruned_at: int | None = None
    error: str = ""  # why it failed (non-finite values, say)


@dataclass
class _Scores:
    """Each seed's evaluation scores by episode, until every seed has one for an episode."""

    seeds: int
    by_episode: dict[int, list[float]] = field(default_factory=dict)

    def add(self, episode: int, score: float) -> float | None:
        """The mean score at ``episode`` once all seeds have theirs there, else None."""
        scores = self.by_episode.setdefault(episode, [])
        scores.append(score)
        if len(scores) < self.seeds:
            return None
        del self.by_episode[episode]
        return float(np.mean(scores))


def objective_of(path: Path, objective: str) -> float:
    """The trial's value from its run file: the mean over seeds of the last evaluation's score
    (``"last"``) or of the best (``"best"``); NaN where a seed has no evaluation."""
    with RunReader(path, needs="curves") as run:
        values = []
        for seed in run.seeds:
            scores = np.asarray(run.evaluations(seed).get("score", []), dtype=float)
            if scores.size == 0:
                return math.nan
            values.append(scores[-1] if objective == "last" else np.nanmax(scores))
    return float(np.mean(values))


def run_trial(trial: optuna.trial.Trial, run: TrialRun, path: Path, objective: str,
              seeds: int, on_episode: Callable[[int, int], None] = lambda e, t: None,
              stop: Callable[[], bool] = lambda: False) -> TrialOutcome:
    """Train (or continue) the trial's run file at ``path``, reporting and pruning as the
    module says. ``on_episode(episode, episodes)`` hears the slowest seed's progress;
    ``stop()`` True ends the training at the next episode with a checkpoint (the trial stays
    running in the study, to be continued)."""
    reported = set(trial.storage.get_trial(trial._trial_id).intermediate_values)
    scores = _Scores(seeds)
    pruned: list[int] = []
    reached: dict[int, int] = {}

    def watch(seed: int, episode: int, metrics: dict[str, Any]) -> bool:
        reached[seed] = episode
        if len(reached) == seeds:
            on_episode(min(reached.values()), total)
        greedy = metrics.get("greedy")
        if greedy is not None:
            mean = scores.add(episode, float(greedy["score"]))
            if mean is not None and episode not in reported and math.isfinite(mean):
                trial.report(mean, episode)
                reported.add(episode)
                if trial.should_prune():
                    pruned.append(episode)
                    return True
        return stop()

    total = 0
    if path.exists():
        try:
            with RunReader(path, needs="curves") as reader:
                total = int(reader.config["train"]["episodes"])
        except RunFileError:
            path.unlink()  # a trial's file that never got its first write: start it again
    if path.exists():
        _, outcome = api.resume(run_path=path, progress=Silent(), watch=watch)
    else:
        scenario, _ = api.load_with_overrides(run.scenario_path, run.overrides)
        total = run.episodes or scenario.train.episodes
        _, outcome = api.train(scenario_path=run.scenario_path, out=path,
                               set_values=run.training_overrides(), episodes=run.episodes,
                               steps=run.steps, workers=1, progress=Silent(), watch=watch)
    if pruned:
        return TrialOutcome("pruned", pruned_at=pruned[0])
    if outcome.interrupted:
        return TrialOutcome("stopped")
    value = objective_of(path, objective)
    if not math.isfinite(value):
        raise AdaptskyError(f"{path}: the trial has no greedy evaluation to score it by "
                            "(train.eval_every)")
    return TrialOutcome("complete", value)
