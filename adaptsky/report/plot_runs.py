"""Curves of run files, as ``adaptsky plot`` draws them: per metric of ``plot_metrics`` (R_e^tot
by default, a trailing mean of the episode sum rates) a panel with a line and band over every
seed of each scenario, as a PNG, PDF or SVG, and the plotted numbers as a CSV beside it."""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass, field
from pathlib import Path
from typing import cast

import numpy as np
from matplotlib.figure import Figure

from adaptsky.errors import AdaptskyError
from adaptsky.report.curves import BAND_KINDS, BandKind, curve_window, trailing_mean
from adaptsky.report.curves import band as band_over_runs
from adaptsky.report.figure_files import format_of, save_figure
from adaptsky.report.figures import Panel, Series, curve_panels
from adaptsky.report.plot_metrics import (
    DEFAULT_METRIC,
    Axis,
    PlotMetric,
    SeedCurve,
    parse_metrics,
)
from adaptsky.store.atomic import write_text_atomic
from adaptsky.store.run_file import RunReader
from adaptsky.units import plural

BAND_NOTES = {"std": "mean ± 1 std over runs", "bootstrap": "95% bootstrap CI of the mean"}
CSV_COLUMNS = ("mean", "low", "high", "runs")


def default_figure_path(run_path: Path) -> Path:
    """``<run stem>-curves.png`` beside the run file."""
    return run_path.with_name(f"{run_path.stem}-curves.png")


@dataclass
class Group:
    """The seeds of one scenario name over every file: per metric, their curves (seeds without
    a point left out), and the axis each file's scenario gives the metric, by file (files
    with a point of it)."""

    curves: dict[str, list[SeedCurve]] = field(default_factory=dict)
    axes: dict[str, dict[Path, Axis]] = field(default_factory=dict)


def read_groups(run_paths: list[Path], metrics: list[PlotMetric]) -> dict[str, Group]:
    """Scenario name -> its :class:`Group`, over every file (each read once, however often
    given), in order of appearance."""
    groups: dict[str, Group] = {}
    seen: set[Path] = set()
    for path in run_paths:
        if path.resolve() in seen:
            continue
        seen.add(path.resolve())
        with RunReader(path, needs="curves") as run:
            group = groups.setdefault(run.config["name"], Group())
            for metric in metrics:
                curves = [c for c in (metric.read(run, seed) for seed in run.seeds)
                          if len(c.values)]
                group.curves.setdefault(metric.name, []).extend(curves)
                if curves:
                    group.axes.setdefault(metric.name, {})[path] = metric.axis(run.scenario)
    return groups


def curve_series(label: str, curves: list[np.ndarray], window: int, kind: BandKind) -> Series:
    """One series: every curve cut to the shortest, smoothed over ``window`` episodes, and
    banded over curves; x is the episode (1-based) that ends each window."""
    episodes = min(len(c) for c in curves)
    smoothed = _trailing_mean_with_gaps(np.stack([c[:episodes] for c in curves]), window)
    mean, low, high = band_over_runs(smoothed, kind)
    return Series(label=label, x=np.arange(window, episodes + 1), mean=mean, low=low,
                  high=high, runs=len(curves))


def _trailing_mean_with_gaps(values: np.ndarray, window: int) -> np.ndarray:
    """:func:`trailing_mean`, NaN for a window with a NaN in it (the loss before the first
    update) and not for every window after it, as a plain running sum would have it."""
    gaps = np.isnan(values)
    means = trailing_mean(np.where(gaps, 0.0, values), window)
    return np.where(trailing_mean(gaps, window) > 0, np.nan, means)


def point_series(label: str, curves: list[SeedCurve], kind: BandKind) -> Series:
    """One series of points drawn as stored (no smoothing), banded over the curves at the
    episodes every curve has."""
    common = curves[0].episodes
    for curve in curves[1:]:
        common = np.intersect1d(common, curve.episodes)
    if not len(common):
        raise AdaptskyError(f"'{label}': its seeds have no episode in common to draw a band "
                            "at; plot runs evaluated at the same episodes (train.eval_every) "
                            "together")
    values = np.stack([c.values[np.searchsorted(c.episodes, common)] for c in curves])
    mean, low, high = band_over_runs(values, kind)
    return Series(label=label, x=common, mean=mean, low=low, high=high, runs=len(curves))


def write_curves_csv(path: Path, series: list[Series], names: list[str] | None = None,
                     x_name: str = "episode") -> None:
    """``x_name`` (``episode``, or ``tau`` for a profile) then ``<name>_mean, _low, _high,
    _runs`` per series (``names``: default the series' labels; rates in bit/s); empty cells
    where a series has no point (or a NaN one: the loss before the first update)."""
    names = names or [s.label for s in series]
    xs = np.unique(np.concatenate([s.x for s in series]))
    rows_at = [{x: k for k, x in enumerate(s.x.tolist())} for s in series]
    text = io.StringIO()
    writer = csv.writer(text, lineterminator="\n")
    writer.writerow([x_name, *(f"{name}_{c}" for name in names for c in CSV_COLUMNS)])
    for x in xs.tolist():
        row: list[object] = [x]
        for s, at in zip(series, rows_at, strict=True):
            k = at.get(x)
            row += (["", "", "", ""] if k is None or np.isnan(s.mean[k]) else
                    [float(s.mean[k]), float(s.low[k]), float(s.high[k]), s.runs])
        writer.writerow(row)
    write_text_atomic(path, text.getvalue())


def axis_of(metric: PlotMetric, groups: dict[str, Group]) -> Axis:
    """The one axis every file gives ``metric``, or one line naming two files that differ."""
    by_axis: dict[Axis, Path] = {}
    for group in groups.values():
        for path, axis in group.axes.get(metric.name, {}).items():
            by_axis.setdefault(axis, path)
    if len(by_axis) > 1:
        (one, a), (two, b) = list(by_axis.items())[:2]
        raise AdaptskyError(f"--metric {metric.name}: {a} and {b} measure it differently "
                            f"({one.name}; {two.name}); plot them apart")
    return next(iter(by_axis))


def _note(metrics: list[PlotMetric], window: int | None, band: str) -> str:
    """How the curves were made: 'trailing mean over 100 episodes; band: ...'."""
    parts = []
    if window is not None:
        parts.append(f"trailing mean over {plural(window, 'episode')}")
    points = [m.name for m in metrics if not m.smoothed]
    if points:
        what = f"{', '.join(points)}: each point as stored, unsmoothed"
        parts.append(f"({what})" if window is not None else what)
    return f"{' '.join(parts)}; band: {BAND_NOTES[band]}"


@dataclass(frozen=True)
class RunsFigure:
    """What ``plot`` draws: the figure, its series (every panel's, in order) and their names
    in the CSV."""

    figure: Figure
    series: list[Series]
    names: list[str]


def _panel(metric: PlotMetric, groups: dict[str, Group], window: int | None,
           kind: BandKind) -> Panel:
    """One metric's panel: a series per scenario with points, in the metric's axis."""
    series = [curve_series(name, [c.values for c in g.curves[metric.name]], window or 1, kind)
              if metric.smoothed else point_series(name, g.curves[metric.name], kind)
              for name, g in groups.items() if g.curves[metric.name]]
    axis = axis_of(metric, groups)
    # the largest value drawn (the loss is NaN before the first update: no point there)
    scale, unit = axis.shown([float(np.abs(s.mean[np.isfinite(s.mean)]).max(initial=0.0))
                              for s in series])
    return Panel(axis.label(unit), series, scale=scale, marker=None if metric.smoothed else "o")


def runs_figure(*, run_paths: list[Path], band: str = "std", title: str | None = None,
                metric: str = DEFAULT_METRIC) -> RunsFigure:
    """Draw ``metric`` (one of ``plot_metrics.METRICS``, or several comma-separated: a panel
    each, sharing the episode axis) of every seed of ``run_paths``: one series per scenario
    name (one in all when the files share it); learning curves smoothed over one window
    (:func:`curve_window` of the shortest)."""
    if band not in BAND_KINDS:
        raise AdaptskyError(f"--band: unknown band '{band}'; choose from "
                            f"{', '.join(BAND_KINDS)}")
    metrics = parse_metrics(metric)
    groups = read_groups(run_paths, metrics)
    for each in metrics:
        if not any(group.curves[each.name] for group in groups.values()):
            raise AdaptskyError(f"{', '.join(map(str, run_paths))}: {each.empty}; nothing to "
                                f"plot for --metric {each.name}")
    smoothed = [c for m in metrics if m.smoothed for g in groups.values()
                for c in g.curves[m.name]]
    window = curve_window(min(len(c.values) for c in smoothed)) if smoothed else None
    panels = [_panel(each, groups, window, cast(BandKind, band)) for each in metrics]
    names = [f"{s.label}_{each.column}" if each.column else s.label
             for each, panel in zip(metrics, panels, strict=True) for s in panel.series]
    drawn = [name for name, g in groups.items() if any(g.curves[m.name] for m in metrics)]
    title = title.replace("$", r"\$") if title else None  # literal text, not TeX math
    figure = curve_panels(panels, title=title or f"Learning curves: {', '.join(drawn)}",
                          note=_note(metrics, window, band))
    return RunsFigure(figure, [s for panel in panels for s in panel.series], names)


def plot_runs(*, run_paths: list[Path], out: Path, band: str = "std",
              title: str | None = None, metric: str = DEFAULT_METRIC) -> Path:
    """:func:`runs_figure` to ``out`` (PNG, PDF or SVG by its suffix) and the plotted numbers
    to ``out`` with ``.csv``. Returns ``out``."""
    format_of(out)  # never a figure written over a .toml or .h5
    drawn = runs_figure(run_paths=run_paths, band=band, title=title, metric=metric)
    out.parent.mkdir(parents=True, exist_ok=True)
    save_figure(drawn.figure, out)
    write_curves_csv(out.with_suffix(".csv"), drawn.series, drawn.names)
    return out
