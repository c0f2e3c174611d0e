"""E4's analysis: the greedy steady state against the number of UAVs, beside SoA per UAV, best
response and OMA."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from adaptsky.experiment.analysis import (
    Analysis,
    Outputs,
    add_against,
    figure_title,
    row_label,
    steady_states,
    write_csv,
)
from adaptsky.experiment.evaluation import Evaluations, Metrics
from adaptsky.experiment.plan import Plan
from adaptsky.report import figures
from adaptsky.report.curves import band
from adaptsky.units import plural, rate_unit

UAV_COUNT_METHODS = (("soa", "SoA per UAV"), ("best-response", "best response"),
                     ("oma", "OMA (best found)"))


def _search_summary(metrics: Metrics) -> str:
    """'3 rounds, converged, 61.2 s per layout' of a search's eval metrics."""
    rounds, converged = metrics.get("search_rounds"), metrics.get("search_converged")
    seconds = metrics.get("search_seconds_per_layout")
    if rounds is None or converged is None:
        return "(no search record)"
    state = "converged" if bool(np.all(converged)) else (
        f"converged on {int(np.sum(converged))} of {len(converged)} layouts")
    text = f"{plural(int(np.max(rounds)), 'round')}, {state}"
    return text + (f", {float(seconds):.3g} s per layout (process time)" if seconds is not None
                   else "")


@dataclass
class _Lines:
    """The figure's lines: per method label and metric, a (mean, low, high, runs) point at
    each number of UAVs (``xs``), and the CSV row of each point; ``bands``: the figure's
    spread over runs."""

    bands: str
    points: dict[str, dict[str, list[tuple[float, float, float, int]]]] = field(
        default_factory=dict)
    xs: dict[str, list[float]] = field(default_factory=dict)
    csv_rows: list[list[Any]] = field(default_factory=list)

    def add(self, label: str, count: int, metric: str, values: list[float]) -> None:
        """``values`` (one per run) of ``metric`` for ``label`` at ``count`` UAVs."""
        mean, low, high = band(np.array([[v] for v in values]), self.bands)
        self.points.setdefault(label, {}).setdefault(metric, []).append(
            (float(mean[0]), float(low[0]), float(high[0]), len(values)))
        if metric == "sum_rate_bps":
            self.xs.setdefault(label, []).append(float(count))
        self.csv_rows.append([count, label, metric, float(mean[0]), float(low[0]),
                              float(high[0]), len(values)])

    def series(self, metric: str) -> list[figures.Series]:
        """A line per label of ``metric`` against the number of UAVs."""
        return [figures.Series(label, np.array(self.xs[label]),
                               *(np.array([p[i] for p in values[metric]]) for i in range(3)),
                               min(p[3] for p in values[metric]))
                for label, values in self.points.items()]


def uav_count(plan: Plan, evaluations: Evaluations, out: Outputs) -> Analysis:
    """E4: the greedy steady state of each group's policies (last, best; one group per number
    of UAVs U, on its own training layout) against SoA per UAV, best response and OMA, sum
    rate and fairness against U; the policy's share of best response, its gain over SoA,
    and NOMA's gain over OMA (best response over the best OMA configuration)."""
    experiment, analysis = plan.experiment, Analysis()
    spec = experiment.evaluation
    points: list[tuple[int, str]] = []
    for group in (spec.policy, *spec.also):
        runs = plan.group_runs(group)
        if runs:
            points.append((int(runs[0].config["uav"]["count"]), group))
    points.sort()
    lines = _Lines(experiment.figure.band)
    for count, group in points:
        base = {name: evaluations.baselines.get((name, group)) for name, _ in UAV_COUNT_METHODS}
        reference = base["best-response"]
        best_bps = float(np.mean(reference["mean_sum_rate_bps"])) if reference else None
        soa_bps = float(np.mean(base["soa"]["mean_sum_rate_bps"])) if base["soa"] else None
        for policy in spec.policies:
            rates, fairness = _measure_policy(plan, evaluations.of(policy), analysis, group,
                                              policy, best_bps, soa_bps)
            if rates:
                label = f"{experiment.group(spec.policy).title.split(',')[0]}, {policy} policy"
                lines.add(label, count, "sum_rate_bps", rates)
                lines.add(label, count, "fairness", fairness)
        for name, label in UAV_COUNT_METHODS:
            metrics = base[name]
            if metrics is None:
                continue
            lines.add(label, count, "sum_rate_bps", [float(np.mean(metrics["mean_sum_rate_bps"]))])
            lines.add(label, count, "fairness", [float(np.mean(metrics["fairness"]))])
        oma = base["oma"]
        if best_bps and oma is not None:
            oma_bps = float(np.mean(oma["mean_sum_rate_bps"]))
            row = f"best response, {plural(count, 'UAV')}"
            analysis.add(row, "noma_over_oma_pct", 100 * (best_bps - oma_bps) / oma_bps)
            analysis.add(row, "sum_rate_bps", best_bps)
        searches = [f"{label} {_search_summary(base[name])}"
                    for name, label in UAV_COUNT_METHODS[1:] if base[name] is not None]
        if searches:
            analysis.notes.append(f"{plural(count, 'UAV')}: " + "; ".join(searches))
    if not lines.points:
        analysis.notes.append("nothing has been evaluated: nothing to draw")
        return analysis
    series = {metric: lines.series(metric) for metric in ("sum_rate_bps", "fairness")}
    scale, unit = rate_unit([float(np.max(line.high)) for line in series["sum_rate_bps"]])
    figure = figures.uav_count(series["sum_rate_bps"], series["fairness"],
                               title=figure_title(plan), ylabel=f"sum rate ({unit})",
                               scale=scale)
    write_csv(out.csv, ["uavs", "method", "metric", "mean", "low", "high", "runs"],
              lines.csv_rows)
    analysis.notes.append(
        f"each group is one number of UAVs on its own training layout; a policy's value is the "
        f"mean of the last {min(100, spec.steps)} of {spec.steps} greedy steps (mean ± "
        "population standard "
        "deviation over its runs), the baselines hold their configuration; best response is "
        "our reference (each UAV in turn takes its best lattice point and power split with the "
        "others fixed, docs/model.md §9), not an optimum; its column 'reachable' is best "
        "response's own value")
    analysis.files += out.save(figure)
    return analysis


def _measure_policy(plan: Plan, measured: Evaluations, analysis: Analysis, group: str,
                    policy: str, best_bps: float | None, soa_bps: float | None
                    ) -> tuple[list[float], list[float]]:
    """Each run of ``group`` as ``measured`` (its last or best policy) into ``analysis``:
    steady sum rate and fairness, against best response and SoA; the runs' sum rates and
    fairness."""
    spec = plan.experiment.evaluation
    row = row_label(plan.experiment.group(group).title, policy, spec.policies)
    rates, fairness = [], []
    for steady, jain in steady_states(plan, measured, group):
        rates.append(steady)
        fairness.append(jain)
        add_against(analysis, row, steady, jain, best_bps, soa_bps, "pct_of_best_response")
    return rates, fairness
