"""Performance profiles of run files (``adaptsky plot --profile last|best``; docs/evaluation.md,
"Statistics over runs"): for each scenario name among the files, the share of its seeds whose
greedy evaluation score (the last evaluation's, or each seed's best) is above a threshold tau,
for every tau across the scores, with a pointwise 95% stratified bootstrap band; the figure
and its CSV (``tau`` then ``<name>_mean, _low, _high, _runs``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from adaptsky.errors import AdaptskyError
from adaptsky.report.figure_files import format_of, save_figure
from adaptsky.report.figures import Series
from adaptsky.report.plot_metrics import METRICS, Axis
from adaptsky.report.plot_runs import axis_of, read_groups, write_curves_csv
from adaptsky.report.statistics import performance_profile

PROFILE_POLICIES = ("last", "best")
THRESHOLDS = 201


def final_scores(run_paths: list[Path], policy: str) -> tuple[dict[str, np.ndarray], Axis]:
    """Each scenario name's seeds' scores (the last greedy evaluation's, or the best), and the
    axis they share."""
    if policy not in PROFILE_POLICIES:
        raise AdaptskyError(f"--profile: unknown policy '{policy}'; choose from "
                            f"{', '.join(PROFILE_POLICIES)}")
    metric = METRICS["greedy"]
    groups = read_groups(run_paths, [metric])
    scores = {name: np.array([c.values[-1] if policy == "last" else np.nanmax(c.values)
                              for c in group.curves[metric.name]])
              for name, group in groups.items() if group.curves[metric.name]}
    if not scores:
        raise AdaptskyError(f"{', '.join(map(str, run_paths))}: {metric.empty}; no score to "
                            "profile")
    return scores, axis_of(metric, groups)


def profile_series(scores: dict[str, np.ndarray], taus: np.ndarray) -> list[Series]:
    series = []
    for name, values in scores.items():
        mean, low, high = performance_profile(values, taus)
        series.append(Series(label=name, x=taus, mean=mean, low=low, high=high,
                             runs=len(values)))
    return series


def plot_profiles(*, run_paths: list[Path], out: Path, policy: str = "last",
                  title: str | None = None) -> Path:
    """The profile figure to ``out`` (PNG, PDF or SVG by its suffix) and its CSV beside it."""
    format_of(out)
    scores, axis = final_scores(run_paths, policy)
    everything = np.concatenate(list(scores.values()))
    low, high = float(np.nanmin(everything)), float(np.nanmax(everything))
    span = max(high - low, abs(high) * 1e-6, 1e-12)
    taus = np.linspace(low - 0.02 * span, high + 0.02 * span, THRESHOLDS)
    series = profile_series(scores, taus)
    divisor, unit = axis.shown([low, high])
    figure = Figure(figsize=(6.4, 4.0), layout="constrained")
    ax = figure.add_subplot()
    for s in series:
        line, = ax.plot(s.x / divisor, s.mean, drawstyle="steps-post",
                        label=f"{s.label} (n = {s.runs})")
        ax.fill_between(s.x / divisor, s.low, s.high, step="post", alpha=0.2,
                        color=line.get_color(), linewidth=0)
    ax.set_xlabel(f"threshold tau: {axis.quantity}, each seed's {policy} evaluation"
                  + (f" ({unit})" if unit else ""))
    ax.set_ylabel("share of runs with a score above tau")
    ax.set_ylim(-0.02, 1.02)
    ax.grid(alpha=0.3)
    ax.legend(loc="lower left")
    title = title.replace("$", r"\$") if title else None
    ax.set_title(title or "Performance profiles (95% stratified bootstrap bands)",
                 fontsize="medium")
    out.parent.mkdir(parents=True, exist_ok=True)
    save_figure(figure, out)
    write_curves_csv(out.with_suffix(".csv"), series, x_name="tau")
    return out
