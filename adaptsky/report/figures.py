"""The paper's figures as PNG files: learning curves (Fig. 2), the minimum-spectral-efficiency
sweep (Fig. 3), per-layout gains (Fig. 4), and ours: sum rate and fairness against the
number of UAVs (E4).

Drawn on a bare :class:`~matplotlib.figure.Figure` with the Agg canvas: no pyplot, no global
state, no display needed. Each file is written whole or not at all.
"""

from __future__ import annotations

import io
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from adaptsky.report.curves import gain_stats
from adaptsky.store.atomic import write_bytes_atomic

SIZE_IN = (7.0, 4.5)
DPI = 150
BAND_ALPHA = 0.2


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
    """A horizontal reference line (the SoA level, the oracle ceiling) in the base unit."""

    label: str
    value: float
    style: str = "--"


def _new_axes() -> tuple[Figure, Axes]:
    figure = Figure(figsize=SIZE_IN, layout="constrained")
    FigureCanvasAgg(figure)
    axes = figure.add_subplot()
    axes.grid(True, alpha=0.3)
    return figure, axes


def _save(figure: Figure, path: Path, dpi: int) -> None:
    png = io.BytesIO()
    figure.savefig(png, format="png", dpi=dpi)
    write_bytes_atomic(path, png.getvalue())


def _unit(label: str) -> str:
    """The unit in an axis label's last parentheses: 'R_e^tot (Gbit/s)' -> 'Gbit/s'."""
    head, _, tail = label.rpartition("(")
    return tail.rstrip(")").strip() if head else ""


def _draw_series(axes: Axes, series: list[Series], scale: float, marker: str | None) -> None:
    for i, line in enumerate(series):
        color = f"C{i}"
        axes.plot(line.x, line.mean / scale, color=color, marker=marker, markersize=4,
                  label=line.legend)
        axes.fill_between(line.x, line.low / scale, line.high / scale, color=color,
                          alpha=BAND_ALPHA, linewidth=0)


def _lower_right(axes: Axes, text: str) -> None:
    axes.text(0.98, 0.03, text, transform=axes.transAxes, ha="right", va="bottom", fontsize=8,
              bbox={"boxstyle": "round", "facecolor": "white", "alpha": 0.85,
                    "edgecolor": "0.7"})


def learning_curves(path: Path, series: list[Series], levels: list[Level], *, title: str,
                    ylabel: str = "R_e^tot (Gbit/s)", scale: float = 1e9,
                    note: str | None = None, dpi: int = DPI) -> None:
    """Fig. 2: value / ``scale`` against episode, a line and band per series, a horizontal line
    per level (its value in the legend, in ``ylabel``'s unit), ``note`` in the lower right."""
    figure, axes = _new_axes()
    _draw_series(axes, series, scale, marker=None)
    unit = _unit(ylabel)
    for j, level in enumerate(levels):
        value = level.value / scale
        axes.axhline(value, color=f"C{len(series) + j}", linestyle=level.style,
                     label=f"{level.label}: {value:.2f} {unit}".rstrip())
    if note:
        _lower_right(axes, note)
    axes.set(title=title, xlabel="episode", ylabel=ylabel)
    axes.legend(fontsize=8)
    _save(figure, path, dpi)


def min_se_sweep(path: Path, series: list[Series], served: dict[str, float | None], *,
                 title: str, ylabel: str = "R_e^tot (Gbit/s)", scale: float = 1e9,
                 dpi: int = DPI) -> None:
    """Fig. 3: value / ``scale`` against the required minimum spectral efficiency (bit/s/Hz);
    ``served[label]`` is the highest threshold that series' method serves for every user
    (None: none), drawn as a dotted vertical line in the series' colour."""
    unknown = sorted(set(served) - {line.label for line in series})
    if unknown:
        raise ValueError(f"served names no series: {', '.join(unknown)}")
    figure, axes = _new_axes()
    _draw_series(axes, series, scale, marker="o")
    for i, line in enumerate(series):
        threshold = served.get(line.label)
        if threshold is None:
            continue
        axes.axvline(threshold, color=f"C{i}", linestyle=":", linewidth=1.2)
        axes.text(threshold, 0.03 + 0.06 * i, f" serves <= {float(threshold)}",
                  color=f"C{i}", transform=axes.get_xaxis_transform(), ha="left",
                  va="bottom", fontsize=8)
    axes.set(title=title, xlabel="required minimum spectral efficiency (bit/s/Hz)",
             ylabel=ylabel)
    axes.legend(fontsize=8)
    _save(figure, path, dpi)


def layout_gains(path: Path, gains_pct: dict[str, np.ndarray], *, title: str,
                 paper: dict[str, str] | None = None, dpi: int = DPI) -> None:
    """Fig. 4: per label (``"vs SoA"``, ...), the empirical CDF over layouts of the policy's
    sum-rate gain in % ((policy - other) / other * 100), a line at 0%, and a box with the share
    of layouts gained on, the median and max gain (and ``paper[label]`` beside them)."""
    figure, axes = _new_axes()
    lines = []
    for i, (label, gains) in enumerate(gains_pct.items()):
        gains = np.sort(np.asarray(gains, dtype=np.float64))
        stats = gain_stats(gains)
        shares = np.arange(1, len(gains) + 1) / len(gains)
        axes.step(gains, shares, where="post", color=f"C{i}", label=label)
        lines.append(f"{label}: beats on {stats['share_positive']:.0%} of {len(gains)}, "
                     f"median {stats['median_pct']:+.2f}%, max {stats['max_pct']:+.2f}%")
        if paper and label in paper:
            lines.append(f"    {paper[label]}")
    axes.axvline(0.0, color="black", linewidth=0.8)
    _lower_right(axes, "\n".join(lines))
    axes.set(title=title, xlabel="sum-rate gain of the policy over the method (%)",
             ylabel="share of layouts", ylim=(0.0, 1.02))
    axes.legend(fontsize=8, loc="upper left")
    _save(figure, path, dpi)


def uav_count(path: Path, rates: list[Series], fairness: list[Series], *, title: str,
              ylabel: str = "sum rate (Gbit/s)", scale: float = 1e9, dpi: int = DPI) -> None:
    """E4: sum rate / ``scale`` (left) and Jain's fairness (right) against the number of
    UAVs, a line with a band per method; integer ticks; the legend below the panels."""
    figure = Figure(figsize=(9.0, 4.5), layout="constrained")
    FigureCanvasAgg(figure)
    left, right = figure.subplots(1, 2)
    for axes, lines, label, divisor in ((left, rates, ylabel, scale),
                                        (right, fairness, "Jain's fairness", 1.0)):
        axes.grid(True, alpha=0.3)
        _draw_series(axes, lines, divisor, marker="o")
        axes.set(xlabel="UAVs", ylabel=label)
        counts = sorted({float(x) for line in lines for x in line.x})
        axes.set_xticks(counts, [f"{c:g}" for c in counts])
    right.set_ylim(0.0, 1.02)
    figure.suptitle(title)
    handles, labels = left.get_legend_handles_labels()
    figure.legend(handles, labels, loc="outside lower center", ncol=3, fontsize=8)
    _save(figure, path, dpi)
