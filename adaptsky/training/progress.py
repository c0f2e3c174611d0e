"""Progress of training: one live row per seed where the reporter draws stages (a terminal);
elsewhere (a pipe, nohup, a batch job, CI) one timestamped log line per seed at its first and
last episode and at most one every ``log_every_s`` in between. Both give the time left from
the seed's latest episodes, its first left out (:class:`adaptsky.progress.Pace`)."""

from __future__ import annotations

import math
import time
from collections import deque

from adaptsky import progress as work_progress
from adaptsky.progress import Pace, Reporter
from adaptsky.units import format_rate

MOVING_WINDOW = 100
# the episode metrics that progress shows (those a run's format lacks are left out)
PROGRESS_METRICS = ("sum_rate_bps", "fairness", "epsilon", "entropy", "outage_share",
                    "mean_least_rate_bps")


class _SeedLog:
    """When a seed last logged, and its pace."""

    def __init__(self, done: int, total: int) -> None:
        self.pace = Pace(total, done)
        self.last_log: float | None = None


class TrainingProgress:
    """Episode, moving averages over the last 100 episodes (sum rate, fairness, outage and,
    in log lines, the least user rate: docs/model.md §14) and epsilon per seed, and the last
    greedy evaluation, a percentage of ``reference`` ('oracle', or 'best response' for
    several UAVs)."""

    def __init__(self, reporter: Reporter, log_every_s: float | None = None,
                 reference: str = "oracle") -> None:
        self.reporter, self.reference = reporter, reference
        self.log_every_s = work_progress.LOG_EVERY_S if log_every_s is None else log_every_s
        self.totals: dict[int, int] = {}
        self.logs: dict[int, _SeedLog] = {}
        self.rates: dict[int, deque[float]] = {}
        self.fairness: dict[int, deque[float]] = {}
        self.outage: dict[int, deque[float]] = {}
        self.least: dict[int, deque[float]] = {}
        self.greedy: dict[int, dict[str, float]] = {}  # each seed's last greedy evaluation

    def __enter__(self) -> TrainingProgress:
        self.reporter.open("seeds")
        return self

    def __exit__(self, *exc: object) -> None:
        self.reporter.close()

    def add_seed(self, seed: int, done: int, total: int) -> None:
        self.rates[seed] = deque(maxlen=MOVING_WINDOW)
        self.fairness[seed] = deque(maxlen=MOVING_WINDOW)
        self.outage[seed] = deque(maxlen=MOVING_WINDOW)
        self.least[seed] = deque(maxlen=MOVING_WINDOW)
        self.totals[seed], self.logs[seed] = total, _SeedLog(done, total)
        self.reporter.start(seed, total, done, seed=seed, rate="-", fairness="-", outage="-",
                            epsilon="eps -",
                            greedy="-", left=self.logs[seed].pace.left(short=True))

    def episode(self, seed: int, episode: int, metrics: dict[str, float]) -> None:
        """Seed ``seed`` has done ``episode`` episodes, the last with ``metrics``."""
        pace = self.logs[seed].pace
        pace.update(episode)
        self.rates[seed].append(metrics["sum_rate_bps"])
        self.fairness[seed].append(metrics["fairness"])
        rates, fairness = self.rates[seed], self.fairness[seed]
        rate = format_rate(sum(rates) / len(rates))
        mean_fairness = sum(fairness) / len(fairness)
        self.outage[seed].append(metrics.get("outage_share", math.nan))
        self.least[seed].append(metrics.get("mean_least_rate_bps", math.nan))
        outage = _mean(self.outage[seed])
        if "greedy" in metrics:
            self.greedy[seed] = metrics["greedy"]  # type: ignore[assignment]
        greedy = (greedy_text(self.greedy[seed], short=True, reference=self.reference)
                  if seed in self.greedy else "-")
        self.reporter.advance(seed, episode, rate=rate, fairness=f"{mean_fairness:.3f}",
                              outage=f"{100 * outage:.0f}%" if math.isfinite(outage) else "-",
                              epsilon=_exploration(metrics, short=True), greedy=greedy,
                              left=pace.left(short=True))
        if not self.reporter.live and not self.reporter.quiet:
            self._log(seed, episode, rate, mean_fairness, _exploration(metrics))

    def _service(self, seed: int) -> str:
        """', outage 25.3%, least 10.96 Mbit/s': the seed's moving averages ('' before
        format 4's metrics)."""
        outage, least = _mean(self.outage[seed]), _mean(self.least[seed])
        if not math.isfinite(outage):
            return ""
        return f", outage {100 * outage:.1f}%, least {format_rate(least)}"

    def _log(self, seed: int, episode: int, rate: str, fairness: float, exploration: str
             ) -> None:
        log, total, now = self.logs[seed], self.totals[seed], time.monotonic()
        due = (log.last_log is None or episode >= total
               or now - log.last_log >= self.log_every_s)
        if not due:
            return
        log.last_log = now
        speed = log.pace.text("episode")
        averaged = len(self.rates[seed])
        greedy = (f"; greedy {greedy_text(self.greedy[seed], reference=self.reference)}"
                  if seed in self.greedy else "")
        self.reporter.log(f"seed {seed}: episode {episode}/{total}, mean of the last "
                          f"{averaged}: sum rate {rate}, J {fairness:.3f}{self._service(seed)}; "
                          f"{exploration}"
                          f"{greedy}" + (f", {speed}" if speed else ""))

    def message(self, text: str) -> None:
        """A line above the live rows; timestamped where there are none (a log)."""
        self.reporter.message(text)


def _exploration(metrics: dict[str, float], short: bool = False) -> str:
    """How the seed explores: its epsilon ('eps 0.100'), or for a learner without one its
    policy's entropy ('entropy 1.23' in a line, 'H 1.23' in the row)."""
    epsilon = metrics.get("epsilon", math.nan)
    if math.isfinite(epsilon):
        return f"eps {epsilon:.3f}"
    entropy = metrics.get("entropy", math.nan)
    value = f"{entropy:.2f}" if math.isfinite(entropy) else "-"
    return f"H {value}" if short else f"entropy {value}"


def _mean(values: deque[float]) -> float:
    """The mean of ``values``; NaN when empty or any is NaN."""
    return sum(values) / len(values) if values else math.nan


SHORT_REFERENCE = {"oracle": "oracle", "best response": "BR"}
"""A reference's name in a live row (80 columns)."""


def greedy_text(row: dict[str, float], short: bool = False, reference: str = "oracle") -> str:
    """The last greedy evaluation in a few characters: percent of the reference (the oracle,
    or for several UAVs best response) on the training layout, else on the held-out layouts
    (mean), else the training layout's sum rate, with the gain over the tracking baseline
    where users move: '97.4% of best response (held-out)', '2.74 Gbit/s, +0.6% over
    tracking'; ``short`` (the live row, 80 columns): '97.4% BR', '2.74 Gbit/s +0.6% tr'."""
    name = next((name for name in ("pct_oracle", "heldout_pct_oracle", "sum_rate_bps")
                 if math.isfinite(row[name])), "heldout_sum_rate_bps")
    value = format_rate(row[name]) if name.endswith("bps") else f"{row[name]:.1f}%"
    of = name.endswith("oracle")
    held_out = name.startswith("heldout")
    tracking = row.get("heldout_tracking_bps" if held_out else "tracking_bps", math.nan)
    gain = (100.0 * (row[name] / tracking - 1.0)
            if name.endswith("bps") and math.isfinite(tracking) and tracking > 0 else None)
    if short:
        text = f"{value} {SHORT_REFERENCE.get(reference, reference)}" if of else value
        return text + ("" if gain is None else f" {gain:+.1f}% tr")
    return (value + (f" of {reference}" if of else "")
            + ("" if gain is None else f", {gain:+.1f}% over tracking")
            + (" (held-out)" if held_out else ""))
