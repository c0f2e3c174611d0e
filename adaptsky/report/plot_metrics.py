"""What ``adaptsky plot --metric`` can draw: name -> how to read it from one seed of a run file,
its axis label with the unit shown, and whether it is a per-episode learning curve (smoothed
by the trailing mean of R_e^tot) or a series of points drawn as stored. Every series of one
number per episode that a run file stores (``/seeds/<S>/episodes/``, store.layout) is a
metric, and the greedy evaluations' score; the per-user series (one number per episode and
user) are not drawn. A new metric is one entry of :data:`METRICS` (and its name in ``plot
--help``, which a test checks).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from difflib import get_close_matches

import numpy as np

from adaptsky.errors import AdaptskyError
from adaptsky.report.evaluations import score_kind
from adaptsky.report.figures import FAIRNESS_LABEL, RATE_LABEL
from adaptsky.scenario import Scenario
from adaptsky.store.run_file import RunReader
from adaptsky.units import rate_unit

DEFAULT_METRIC = "sum-rate"


@dataclass(frozen=True)
class SeedCurve:
    """One seed's ``values`` (V,) at ``episodes`` (V,), the 1-based episodes they belong to,
    increasing."""

    episodes: np.ndarray
    values: np.ndarray


Scaling = Callable[[list[float]], tuple[float, str]]
"""Values in the base unit -> (the divisor shown, the unit shown): rates by their size
(``units.rate_unit``: 4.2e10 bit/s -> 1e9, 'Gbit/s')."""


@dataclass(frozen=True)
class Axis:
    """The quantity in mathtext (without its unit), the unit of the stored values ('' for a
    dimensionless number) and how they are scaled for display (default: as they are)."""

    quantity: str
    unit: str
    scaling: Scaling | None = None

    def shown(self, values: list[float]) -> tuple[float, str]:
        """The divisor and unit the values are shown in."""
        return self.scaling(values) if self.scaling else (1.0, self.unit)

    def label(self, unit: str) -> str:
        """'$R_e^{tot}$ (Gbit/s)'; the quantity alone for a dimensionless one."""
        return f"{self.quantity} ({unit})" if unit else self.quantity

    @property
    def name(self) -> str:
        """What the axis measures, in words for a message: 'greedy score, % of oracle'."""
        return f"{self.quantity}, {self.unit}" if self.unit else self.quantity


@dataclass(frozen=True)
class PlotMetric:
    """One ``--metric``: ``read`` gives a seed's curve (no points: the seed is left out),
    ``axis`` the axis of a run's scenario (runs whose axes differ cannot share a panel);
    ``smoothed``: a value per episode, smoothed over the window of R_e^tot; ``column``: the
    metric's part of its CSV columns (empty: the sum rate's columns as they always were);
    ``empty``: why no seed may have any point, for the one line that says so."""

    name: str
    read: Callable[[RunReader, int], SeedCurve]
    axis: Callable[[Scenario], Axis]
    smoothed: bool
    column: str
    empty: str


def _per_episode(name: str) -> Callable[[RunReader, int], SeedCurve]:
    """The seed's learning curve ``/seeds/<S>/episodes/<name>``, episodes 1 .. done (none
    where the file's format lacks it: the energy before format 3; none where no value is a
    number: the loss before the first update is NaN)."""
    def read(run: RunReader, seed: int) -> SeedCurve:
        values = run.episodes(seed).get(name, np.zeros(0))
        if not np.isfinite(values).any():
            values = np.zeros(0)
        return SeedCurve(np.arange(1, len(values) + 1), values)
    return read


def _per_joule(values: list[float]) -> tuple[float, str]:
    """Bit per joule shown in Mbit/J (the UAVs of the shipped scenarios carry tens to
    hundreds of Mbit per joule)."""
    return 1e6, "Mbit/J"


def _joules(values: list[float]) -> tuple[float, str]:
    """Energy in J, kJ or MJ, by the largest value shown."""
    largest = max((abs(v) for v in values if np.isfinite(v)), default=0.0)
    return next(((scale, unit) for scale, unit in ((1e6, "MJ"), (1e3, "kJ"))
                 if largest >= scale), (1.0, "J"))


def _greedy_score(run: RunReader, seed: int) -> SeedCurve:
    table = run.evaluations(seed)
    return SeedCurve(table["episode"].astype(np.int64), table["score"])


def _greedy_axis(scenario: Scenario) -> Axis:
    """The score of docs/training.md: percent of the oracle (best response for several UAVs)
    on the training layout, or the mean over held-out layouts with fresh placement; a steady
    sum rate where there is no oracle."""
    held_out = ", held-out layouts" if scenario.users.placement == "fresh" else ""
    if score_kind(scenario) == "pct":
        reference = "oracle" if scenario.uav.count == 1 else "best response"
        return Axis(f"greedy score{held_out}", f"% of {reference}")
    return Axis(rf"greedy steady $R^{{\mathrm{{tot}}}}${held_out}", "bit/s", rate_unit)


_NO_EPISODE = "no seed has finished an episode yet"
_NO_ENERGY = ("no seed has an episode with its energy (run files made before the energy, "
              "format 2 or older, hold none)")
_NO_SERVICE = ("no seed has an episode with its service metrics (run files made before them, "
               "format 3 or older, hold none)")

METRICS: dict[str, PlotMetric] = {metric.name: metric for metric in (
    # R_e^tot, the mean sum rate of each episode (the paper's Fig. 2)
    PlotMetric("sum-rate", _per_episode("sum_rate_bps"),
               lambda _: Axis(RATE_LABEL, "bit/s", rate_unit), smoothed=True, column="",
               empty=_NO_EPISODE),
    # J_e, the mean Jain's fairness index of each episode
    PlotMetric("fairness", _per_episode("fairness"), lambda _: Axis(FAIRNESS_LABEL, ""),
               smoothed=True, column="fairness", empty=_NO_EPISODE),
    # the score of the greedy evaluations during training (docs/training.md)
    PlotMetric("greedy", _greedy_score, _greedy_axis, smoothed=False, column="greedy",
               empty="no seed has a greedy evaluation during training (train.eval_every is "
               "0, the runs are shorter than it, or they were made before evaluations "
               "existed)"),
    # each episode's bits over its propulsion and transmit energy (docs/model.md §10)
    PlotMetric("energy-efficiency", _per_episode("energy_efficiency_bpj"),
               lambda _: Axis("energy efficiency", "bit/J", _per_joule), smoothed=True,
               column="energy_efficiency", empty=_NO_ENERGY),
    # the other per-episode series of /seeds/<S>/episodes/ (docs/file-format.md)
    PlotMetric("reward", _per_episode("reward"),
               lambda _: Axis("return (sum of the episode's rewards)", ""), smoothed=True,
               column="reward", empty=_NO_EPISODE),
    PlotMetric("height", _per_episode("mean_height_m"),
               lambda _: Axis("mean UAV height", "m"), smoothed=True, column="height",
               empty=_NO_EPISODE),
    PlotMetric("epsilon", _per_episode("epsilon"),
               lambda _: Axis(r"exploration rate $\epsilon$", ""), smoothed=True,
               column="epsilon", empty=_NO_EPISODE),
    PlotMetric("loss", _per_episode("loss"), lambda _: Axis("mean TD loss", ""),
               smoothed=True, column="loss",
               empty="no seed has a loss yet (NaN until the first update, once the replay "
               "memory holds a batch, agent.batch_size steps)"),
    PlotMetric("energy", _per_episode("energy_j"),
               lambda _: Axis("energy per episode", "J", _joules), smoothed=True,
               column="energy", empty=_NO_ENERGY),
    # the service metrics of each episode (docs/model.md §14)
    PlotMetric("outage", _per_episode("outage_share"),
               lambda _: Axis("share of user-steps in outage", ""), smoothed=True,
               column="outage", empty=_NO_SERVICE),
    PlotMetric("least-rate", _per_episode("mean_least_rate_bps"),
               lambda _: Axis("mean least user rate", "bit/s", rate_unit), smoothed=True,
               column="least_rate", empty=_NO_SERVICE),
    PlotMetric("p5-rate", _per_episode("p5_rate_bps"),
               lambda _: Axis("5th percentile of the user rates", "bit/s", rate_unit),
               smoothed=True, column="p5_rate", empty=_NO_SERVICE),
)}
STORED_AS = {"sum_rate_bps": "sum-rate", "energy_efficiency_bpj": "energy-efficiency",
             "mean_height_m": "height", "energy_j": "energy", "score": "greedy",
             "outage_share": "outage", "mean_least_rate_bps": "least-rate",
             "p5_rate_bps": "p5-rate"}
"""The run file's names of the series whose metric is named otherwise (for "did you mean")."""


def parse_metrics(text: str) -> list[PlotMetric]:
    """``--metric``: one name or several, comma-separated (one panel each, in that order),
    each once; an unknown or repeated name is one line listing the allowed ones."""
    names = [name.strip() for name in text.split(",")]
    allowed = ", ".join(METRICS)
    for name in names:
        if name not in METRICS:
            close = STORED_AS.get(name) or next(iter(get_close_matches(
                name, list(METRICS), n=1, cutoff=0.75)), None)
            guess = f"did you mean '{close}'? " if close else ""
            raise AdaptskyError(f"--metric: unknown metric '{name}'; {guess}choose from "
                                f"{allowed}, or several comma-separated (e.g. "
                                "sum-rate,fairness)")
    repeated = sorted({name for name in names if names.count(name) > 1})
    if repeated:
        raise AdaptskyError(f"--metric: {', '.join(repeated)} given more than once; name "
                            f"each metric once (from {allowed})")
    return [METRICS[name] for name in names]
