"""What one figure kind of a reproduced experiment measured, where it writes, and the readers of
run and eval files every analysis shares.

Each analysis gives the figure's series, the CSV rows of what is plotted, and the measured
quantities that claims name, each as a list of per-run values (mean and spread over runs in
the report) or a single value.
"""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from adaptsky.experiment.evaluation import Evaluations
from adaptsky.experiment.models import Group
from adaptsky.experiment.plan import Plan, RunSpec, sweep_label
from adaptsky.report.curves import LAST_EPISODES
from adaptsky.report.figure_files import save_figure
from adaptsky.store.atomic import write_text_atomic
from adaptsky.store.run_file import RunReader


@dataclass
class Analysis:
    """What one figure kind measured. Per row (a group's last or best policy: ``rows`` keeps
    their order) and quantity: a list of per-run values (or one value), the same quantity for
    the oracle (``bounds``: the most any policy can reach), and details replacing the per-run
    list; notes for the report, and the files written."""

    rows: list[str] = field(default_factory=list)
    quantities: dict[str, dict[str, list[float]]] = field(default_factory=dict)
    bounds: dict[str, dict[str, list[float]]] = field(default_factory=dict)
    details: dict[str, dict[str, str]] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    files: list[Path] = field(default_factory=list)

    def add(self, row: str, quantity: str, value: float, bound: float | None = None) -> None:
        """One run's ``value`` (and the oracle's ``bound`` for the same run) in ``row``."""
        if row not in self.rows:
            self.rows.append(row)
        self.quantities.setdefault(row, {}).setdefault(quantity, []).append(value)
        if bound is not None:
            self.bounds.setdefault(row, {}).setdefault(quantity, []).append(bound)


@dataclass(frozen=True)
class Outputs:
    """Where an analysis writes: ``folder/<name>.<figure_format>`` (png, pdf or svg) and the
    plotted numbers in ``folder/<name>.csv``."""

    folder: Path
    name: str
    figure_format: str = "png"

    @property
    def figure(self) -> Path:
        return self.folder / f"{self.name}.{self.figure_format}"

    @property
    def csv(self) -> Path:
        return self.folder / f"{self.name}.csv"

    def save(self, figure: Figure) -> list[Path]:
        """Write ``figure``; the figure and CSV paths, for ``Analysis.files``."""
        save_figure(figure, self.figure)
        return [self.figure, self.csv]


def row_label(title: str, policy: str, policies: list[str]) -> str:
    """'AdaptSky, last policy': the policy named where the experiment evaluates several."""
    return f"{title}, {policy} policy" if len(policies) > 1 else title


def done_runs(runs: list[RunSpec]) -> list[RunSpec]:
    """The runs of ``runs`` that have trained all their episodes."""
    from adaptsky.experiment.runs import run_state  # imports torch: only when reporting

    return [run for run in runs if run_state(run).status == "done"]


def run_curves(run: RunSpec) -> dict[str, np.ndarray]:
    """``run``'s per-episode metrics, read from its run file."""
    with RunReader(run.path, needs="curves") as reader:
        return reader.episodes(run.seed)


def last_mean(values: np.ndarray) -> float:
    """R_e^tot or J_e: the mean of the last 100 episodes' values (all, for shorter runs)."""
    return float(np.mean(values[-LAST_EPISODES:]))


def write_csv(path: Path, header: list[str], rows: list[list[Any]]) -> None:
    """``header`` and ``rows`` as a CSV file, written whole or not at all."""
    text = io.StringIO()
    writer = csv.writer(text, lineterminator="\n")
    writer.writerow(header)
    writer.writerows(rows)
    write_text_atomic(path, text.getvalue())


def steady_states(plan: Plan, measured: Evaluations, group: str) -> list[tuple[float, float]]:
    """(steady sum rate, fairness) of each evaluated run of ``group`` in ``measured`` (its
    last or best policies): the means over layouts of the greedy steady state and of Jain's
    index."""
    states = []
    for run in plan.group_runs(group):
        mine = measured.runs.get(run.name)
        if mine is not None:
            states.append((float(np.mean(mine["steady_sum_rate_bps"])),
                           float(np.mean(mine["fairness"]))))
    return states


def add_against(analysis: Analysis, row: str, steady: float, fairness: float,
                bound: float | None, soa: float | None, share_quantity: str) -> None:
    """One run's greedy steady state ``steady`` and Jain's index into ``analysis``'s ``row``,
    beside the ``bound`` (its share of it as ``share_quantity``) and SoA (its gain over it, the
    bound's as the reachable value)."""
    analysis.add(row, "sum_rate_bps", steady, bound)
    analysis.add(row, "fairness", fairness)
    if bound:
        analysis.add(row, share_quantity, 100 * steady / bound, 100.0)
    if soa:
        analysis.add(row, "gain_vs_soa_pct", 100 * (steady - soa) / soa,
                     100 * (bound - soa) / soa if bound else None)


def baseline_mean(evaluations: Evaluations, name: str, value: Any, metric: str) -> float | None:
    """The mean of baseline ``name``'s ``metric`` at sweep value ``value``; None if absent."""
    metrics = evaluations.baselines.get((name, value))
    return None if metrics is None else float(np.mean(metrics[metric]))


def sweep_point(group: Group, value: Any, short: bool = False) -> str:
    """'users.speed_m_per_step = 2' (``short``: 'speed_m_per_step = 2', as run files name
    it): a swept group's point, as labels name it."""
    assert group.sweep is not None, "only a swept group has points"
    key = group.sweep.key.rsplit(".", 1)[-1] if short else group.sweep.key
    return sweep_label(key, value)


def figure_title(plan: Plan) -> str:
    """The figure's own title, or the experiment's."""
    return plan.experiment.figure.title or plan.experiment.title
