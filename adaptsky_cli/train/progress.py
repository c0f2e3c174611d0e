"""Live display of training: one Rich progress row per seed."""

from __future__ import annotations

from collections import deque

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

from adaptsky_cli.report.units import format_rate

MOVING_WINDOW = 100


class TrainingProgress:
    """Episode, moving-average sum rate (last 100 episodes), fairness and epsilon per seed."""

    def __init__(self, console: Console, quiet: bool) -> None:
        self.quiet = quiet
        self.progress = Progress(
            TextColumn("seed {task.fields[seed]:>3}"), BarColumn(), MofNCompleteColumn(),
            TextColumn("R {task.fields[rate]}  J {task.fields[fairness]}  "
                       "eps {task.fields[epsilon]}"),
            TimeRemainingColumn(), console=console, disable=quiet, transient=False)
        self.tasks: dict[int, int] = {}
        self.rates: dict[int, deque[float]] = {}
        self.fairness: dict[int, deque[float]] = {}

    def __enter__(self) -> TrainingProgress:
        self.progress.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.progress.stop()

    def add_seed(self, seed: int, done: int, total: int) -> None:
        self.rates[seed] = deque(maxlen=MOVING_WINDOW)
        self.fairness[seed] = deque(maxlen=MOVING_WINDOW)
        self.tasks[seed] = self.progress.add_task("", total=total, completed=done, seed=seed,
                                                  rate="-", fairness="-", epsilon="-")

    def episode(self, seed: int, episode: int, metrics: dict[str, float]) -> None:
        self.rates[seed].append(metrics["sum_rate_bps"])
        self.fairness[seed].append(metrics["fairness"])
        rates, fairness = self.rates[seed], self.fairness[seed]
        self.progress.update(self.tasks[seed], completed=episode,
                             rate=format_rate(sum(rates) / len(rates)),
                             fairness=f"{sum(fairness) / len(fairness):.3f}",
                             epsilon=f"{metrics['epsilon']:.3f}")

    def message(self, text: str) -> None:
        self.progress.console.print(text, markup=False, highlight=False)
