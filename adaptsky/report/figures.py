"""The paper's figures: learning curves (Fig. 2, one panel or several sharing the episode
axis), the minimum-spectral-efficiency sweep (Fig. 3), per-layout gains (Fig. 4), and ours:
sum rate and fairness against the number of UAVs (E4).

Each function draws a bare :class:`~matplotlib.figure.Figure` on the Agg canvas (no pyplot,
no global state, no display needed) and returns it; ``figure_files.save_figure`` writes it as
PNG, PDF or SVG. Figures fit for a paper: quantities in mathtext with their units, integer
ticks on episode and UAV axes, and the legend below the axes, where it covers no curve.
"""

from __future__ import annotations

import textwrap
from dataclasses import dataclass, field

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from adaptsky.report.curves import gain_stats

SIZE_IN = (7.0, 4.5)
PANEL_HEIGHT_IN = 3.0
"""Height of each panel of a figure of several stacked panels (plus 1.5 in for the title
and the legend)."""
BAND_ALPHA = 0.2
FONT_SMALL = 8
RATE_LABEL = r"$R_e^{\mathrm{tot}}$"
"""The paper's R_e^tot, the mean sum rate of an episode (sec. V-C), in mathtext."""
FAIRNESS_LABEL = r"Jain's fairness $J_e$"
EPISODE_LABEL = "episode"


@dataclass(frozen=True, eq=False)
class Series:
    """A line with a shaded band: ``mean``, ``low`` and ``high`` at the points ``x``, all the
    same shape (X,), in the figure's base unit (bit/s for rates); ``runs`` goes in the legend."""

    label: str
    x: np.ndarray
    mean: np.ndarray
    low: np.ndarray
    high: np.ndarray
    runs: int

    def __post_init__(self) -> None:
        shapes = {np.shape(a) for a in (self.x, self.mean, self.low, self.high)}
        if len(shapes) != 1 or len(next(iter(shapes))) != 1:
            raise ValueError(f"series '{self.label}': x, mean, low and high must share one "
                             f"1-D shape, not {sorted(shapes)}")

    @property
    def legend(self) -> str:
        return f"{self.label} (n = {self.runs})"


@dataclass(frozen=True)
class Level:
    """A horizontal reference line (the SoA level, the oracle ceiling) in the base unit;
    ``color`` (e.g. a swept value's curve's ``"C1"``), or the next colour after the curves'."""

    label: str
    value: float
    style: str = "--"
    color: str | None = None


@dataclass(frozen=True)
class Panel:
    """One axes of a learning-curve figure: series and levels in their base unit, shown
    divided by ``scale``; ``ylabel`` names the quantity and the unit shown; ``marker`` marks
    each point (sparse points, such as evaluations every 10 episodes)."""

    ylabel: str
    series: list[Series]
    levels: list[Level] = field(default_factory=list)
    scale: float = 1.0
    marker: str | None = None


def new_figure(size_in: tuple[float, float] = SIZE_IN) -> Figure:
    """An empty figure of ``size_in`` (width, height) inches, constrained layout, drawn with
    Agg (no display needed)."""
    figure = Figure(figsize=size_in, layout="constrained")
    FigureCanvasAgg(figure)
    return figure


def _unit(label: str) -> str:
    """The unit in an axis label's last parentheses: 'R_e^tot (Gbit/s)' -> 'Gbit/s'."""
    head, _, tail = label.rpartition("(")
    return tail.rstrip(")").strip() if head else ""


def _draw_series(axes: Axes, series: list[Series], scale: float, marker: str | None,
                 colors: dict[str, str] | None = None) -> None:
    """A line and band per series, value / ``scale``; colour by label (default: C0, C1, ...
    in order)."""
    axes.grid(True, alpha=0.3)
    for i, line in enumerate(series):
        color = colors[line.label] if colors else f"C{i}"
        axes.plot(line.x, line.mean / scale, color=color, marker=marker, markersize=4,
                  label=line.legend)
        axes.fill_between(line.x, line.low / scale, line.high / scale, color=color,
                          alpha=BAND_ALPHA, linewidth=0)


def _integer_ticks(axes: Axes) -> None:
    """Ticks on whole numbers only (episodes, UAVs): never 'episode 2.5'."""
    axes.xaxis.set_major_locator(MaxNLocator(integer=True))


def legend_below(figure: Figure, axes: list[Axes], columns: int = 3) -> None:
    """One legend for every axes of ``figure`` (each label once, in order), below them: the
    constrained layout gives it room of its own, so it never covers a curve."""
    entries: dict[str, object] = {}
    for each in axes:
        for handle, label in zip(*each.get_legend_handles_labels(), strict=True):
            entries.setdefault(label, handle)
    if entries:
        figure.legend(list(entries.values()), list(entries), loc="outside lower center",
                      ncol=min(columns, len(entries)), fontsize=FONT_SMALL)


def _titles(figure: Figure, axes: Axes, title: str, note: str | None) -> None:
    """The title above everything and the note (how the curves were made) under it, above the
    first axes: never inside the plotted area."""
    figure.suptitle(title)
    if note:
        axes.set_title(note, fontsize=FONT_SMALL)


def curve_panels(panels: list[Panel], *, title: str, note: str | None = None,
                 xlabel: str = EPISODE_LABEL, legend_columns: int = 3) -> Figure:
    """Learning curves in stacked panels sharing the episode axis: per panel a line and band
    per series (value / the panel's ``scale``; one colour per series label in every panel), a
    horizontal line per level (its value in the legend, in the panel's unit); the legend in
    ``legend_columns`` columns (fewer for long labels)."""
    if not panels:
        raise ValueError("no panel to draw")
    height = SIZE_IN[1] if len(panels) == 1 else 1.5 + PANEL_HEIGHT_IN * len(panels)
    figure = new_figure((SIZE_IN[0], height))
    grid = figure.subplots(len(panels), 1, sharex=True, squeeze=False)[:, 0]
    labels = dict.fromkeys(line.label for panel in panels for line in panel.series)
    colors = {label: f"C{i}" for i, label in enumerate(labels)}
    for axes, panel in zip(grid, panels, strict=True):
        _draw_series(axes, panel.series, panel.scale, marker=panel.marker, colors=colors)
        unit = _unit(panel.ylabel)
        for j, level in enumerate(panel.levels):
            value = level.value / panel.scale
            axes.axhline(value, color=level.color or f"C{len(colors) + j}",
                         linestyle=level.style,
                         label=f"{level.label}: {value:.2f} {unit}".rstrip())
        axes.set_ylabel(panel.ylabel)
        _integer_ticks(axes)
    grid[-1].set_xlabel(xlabel)
    _titles(figure, grid[0], title, note)
    legend_below(figure, list(grid), columns=legend_columns)
    return figure


def learning_curves(series: list[Series], levels: list[Level], *, title: str,
                    ylabel: str = f"{RATE_LABEL} (Gbit/s)", scale: float = 1e9,
                    note: str | None = None, legend_columns: int = 3) -> Figure:
    """Fig. 2: value / ``scale`` against episode, a line and band per series, a horizontal line
    per level (its value in the legend, in ``ylabel``'s unit), ``note`` under the title."""
    return curve_panels([Panel(ylabel, series, levels, scale)], title=title, note=note,
                        legend_columns=legend_columns)


def min_se_sweep(series: list[Series], served: dict[str, float | None], *, title: str,
                 ylabel: str = f"{RATE_LABEL} (Gbit/s)", scale: float = 1e9) -> Figure:
    """Fig. 3: value / ``scale`` against the required minimum spectral efficiency (bit/s/Hz);
    ``served[label]`` is the highest threshold that series' method serves for every user
    (None: none), drawn as a dotted vertical line in the series' colour."""
    unknown = sorted(set(served) - {line.label for line in series})
    if unknown:
        raise ValueError(f"served names no series: {', '.join(unknown)}")
    figure = new_figure()
    axes = figure.add_subplot()
    _draw_series(axes, series, scale, marker="o")
    for i, line in enumerate(series):
        threshold = served.get(line.label)
        if threshold is None:
            continue
        axes.axvline(threshold, color=f"C{i}", linestyle=":", linewidth=1.2)
        axes.text(threshold, 0.03 + 0.06 * i, rf" serves $\leq$ {float(threshold)}",
                  color=f"C{i}", transform=axes.get_xaxis_transform(), ha="left",
                  va="bottom", fontsize=FONT_SMALL)
    axes.set(xlabel="required minimum spectral efficiency (bit/s/Hz)", ylabel=ylabel)
    figure.suptitle(title)
    legend_below(figure, [axes])
    return figure


def layout_gains(gains_pct: dict[str, np.ndarray], *, title: str,
                 paper: dict[str, str] | None = None) -> Figure:
    """Fig. 4: per label (``"vs SoA"``, ...), the empirical CDF over layouts of the policy's
    sum-rate gain in % ((policy - other) / other * 100), a line at 0%, and in the legend the
    share of layouts gained on, the median and max gain (and ``paper[label]`` below them)."""
    figure = new_figure()
    axes = figure.add_subplot()
    axes.grid(True, alpha=0.3)
    for i, (label, gains) in enumerate(gains_pct.items()):
        gains = np.sort(np.asarray(gains, dtype=np.float64))
        stats = gain_stats(gains)
        shares = np.arange(1, len(gains) + 1) / len(gains)
        text = (f"{label}: beats on {stats['share_positive']:.0%} of {len(gains)}, "
                f"median {stats['median_pct']:+.2f}%, max {stats['max_pct']:+.2f}%")
        if paper and label in paper:
            text += f"\n    {paper[label]}"
        axes.step(gains, shares, where="post", color=f"C{i}", label=text)
    axes.axvline(0.0, color="black", linewidth=0.8)
    axes.set(xlabel="sum-rate gain of the policy over the method (%)",
             ylabel="share of layouts (empirical CDF)", ylim=(0.0, 1.02))
    figure.suptitle(title)
    legend_below(figure, [axes], columns=1)
    return figure


def uav_count(rates: list[Series], fairness: list[Series], *, title: str,
              ylabel: str = "sum rate (Gbit/s)", scale: float = 1e9) -> Figure:
    """E4: sum rate / ``scale`` (left) and Jain's fairness (right) against the number of
    UAVs, a line with a band per method; integer ticks; the legend below the panels."""
    figure = new_figure((9.0, 4.5))
    left, right = figure.subplots(1, 2)
    for axes, lines, label, divisor in ((left, rates, ylabel, scale),
                                        (right, fairness, "Jain's fairness", 1.0)):
        _draw_series(axes, lines, divisor, marker="o")
        axes.set(xlabel="UAVs", ylabel=label)
        counts = sorted({float(x) for line in lines for x in line.x})
        axes.set_xticks(counts, [f"{c:g}" for c in counts])
    right.set_ylim(0.0, 1.02)
    figure.suptitle(title)
    legend_below(figure, [left])
    return figure


@dataclass(frozen=True)
class Bars:
    """One method's bars over a panel's conditions: ``mean``, ``low`` and ``high`` (C,) in the
    figure's base unit (NaN where the method has no value there); ``runs`` in the legend
    (1 for a baseline)."""

    label: str
    mean: np.ndarray
    low: np.ndarray
    high: np.ndarray
    runs: int


def conditions(panels: list[tuple[str, list[str], list[Bars]]], *, title: str,
               ylabel: str = "sum rate (Gbit/s)", scale: float = 1e9) -> Figure:
    """Ours (E6): per panel ``(name, conditions, bars)`` grouped bars, one group per condition
    and one bar per method (value / ``scale``, the runs' spread as an error bar); panels side
    by side, wide as their number of conditions; one colour per method label in every
    panel; the legend below."""
    if not panels:
        raise ValueError("no panel to draw")
    widths = [max(2, len(names)) for _, names, _ in panels]
    figure = new_figure((min(14.0, 2.0 + 1.1 * sum(widths)), 4.8))
    grid = figure.subplots(1, len(panels), squeeze=False, width_ratios=widths)[0]
    labels = dict.fromkeys(bar.label for _, _, bars in panels for bar in bars)
    colors = {label: f"C{i}" for i, label in enumerate(labels)}
    for axes, (name, names, bars), share in zip(grid, panels, widths, strict=True):
        axes.grid(True, axis="y", alpha=0.3)
        width = 0.8 / max(1, len(bars))
        x = np.arange(len(names))
        for i, bar in enumerate(bars):
            mean, low, high = (np.asarray(a, dtype=np.float64) / scale
                               for a in (bar.mean, bar.low, bar.high))
            spread = bar.runs > 1
            legend = f"{bar.label} (n = {bar.runs})" if spread else bar.label
            axes.bar(x - 0.4 + width * (i + 0.5), mean, width, color=colors[bar.label],
                     label=legend, yerr=np.vstack([mean - low, high - mean]) if spread
                     else None, capsize=2)
        axes.set_xticks(x, names, rotation=20, ha="right", fontsize=FONT_SMALL)
        # wrapped to the panel's width (about ten characters an inch at this size)
        panel_in = (figure.get_figwidth() - 1.0) * share / sum(widths)
        axes.set_title(textwrap.fill(name, max(12, int(10 * panel_in)),
                                     break_long_words=False), fontsize=FONT_SMALL + 1)
    grid[0].set_ylabel(ylabel)
    figure.suptitle(title)
    legend_below(figure, list(grid), columns=4)
    return figure
