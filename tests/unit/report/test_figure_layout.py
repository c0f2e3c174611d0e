"""Figures fit for a paper, every kind that ``plot`` and ``reproduce`` draw: one legend, below the
axes, whose box overlaps no axes and no plotted line (measured in display coordinates after
drawing), the note above the axes, whole numbers on episode and UAV axes, and the quantities in
mathtext with their units."""

from __future__ import annotations

import numpy as np
import pytest
from matplotlib.figure import Figure
from matplotlib.transforms import Bbox

from adaptsky.report.figures import (
    Level,
    Panel,
    Series,
    curve_panels,
    layout_gains,
    learning_curves,
    min_se_sweep,
    uav_count,
)
from tests.helpers.report import two_series


def short_series(episodes: int = 7) -> list[Series]:
    """Curves of a short run: 1 .. ``episodes``, where matplotlib's own ticks fall on halves."""
    x = np.arange(1, episodes + 1)
    rising = 30e9 + 1e9 * x
    return [Series("a", x, rising, rising - 2e9, rising + 2e9, runs=2),
            Series("b", x, rising - 5e9, rising - 6e9, rising - 4e9, runs=2)]


def uav_series() -> tuple[list[Series], list[Series]]:
    x = np.array([1.0, 2.0, 3.0, 4.0])
    rates = [Series("BDQ, last policy", x, 1e9 * x, 0.9e9 * x, 1.1e9 * x, 6),
             Series("SoA per UAV", x, 0.5e9 * x, 0.5e9 * x, 0.5e9 * x, 1)]
    fairness = [Series(s.label, x, 0.5 + 0.1 * x / 4, 0.45 + 0.1 * x / 4,
                       0.55 + 0.1 * x / 4, s.runs) for s in rates]
    return rates, fairness


FIGURES = {
    "learning curves": lambda: learning_curves(
        two_series(), [Level("SoA", 31.8e9), Level("oracle", 49.1e9, ":")], title="E3",
        note="$J_e$ at the last episode: 0.61\ntrailing mean over 10 episodes"),
    "two panels": lambda: curve_panels(
        [Panel("$R_e^{tot}$ (Gbit/s)", short_series(), scale=1e9),
         Panel("Jain's fairness $J_e$", [Series(s.label, s.x, s.mean / 1e11, s.low / 1e11,
                                                 s.high / 1e11, s.runs)
                                          for s in short_series()])],
        title="two panels", note="trailing mean over 1 episode"),
    "min-se sweep": lambda: min_se_sweep(
        [Series(s.label, np.array([0.5, 1.0, 2.0, 3.0, 4.0]), s.mean[:5], s.low[:5],
                s.high[:5], s.runs) for s in two_series()],
        {"dueling DQN": 3.0}, title="E2"),
    "layout gains": lambda: layout_gains(
        {"vs SoA": np.random.default_rng(0).normal(20, 15, 100),
         "oracle vs SoA (the reachable bound)": np.random.default_rng(1).normal(60, 10, 100)},
        title="E3", paper={"vs SoA": "paper: beats on 91%"}),
    "uav count": lambda: uav_count(*uav_series(), title="E4"),
}


def drawn(make) -> Figure:
    figure = make()
    figure.canvas.draw()
    return figure


def overlaps(a: Bbox, b: Bbox) -> bool:
    """Whether two boxes share an area (touching edges do not count)."""
    return a.x0 < b.x1 and b.x0 < a.x1 and a.y0 < b.y1 and b.y0 < a.y1


@pytest.mark.parametrize("name", FIGURES)
def test_the_legend_covers_no_curve(name):
    figure = drawn(FIGURES[name])
    renderer = figure.canvas.get_renderer()
    assert len(figure.legends) == 1 and all(a.get_legend() is None for a in figure.axes)
    legend = figure.legends[0].get_window_extent(renderer)
    assert figure.bbox.contains(legend.x0, legend.y0) and figure.bbox.contains(legend.x1,
                                                                               legend.y1)
    for axes in figure.axes:
        assert not overlaps(legend, axes.bbox), name
        for line in axes.get_lines():
            if len(line.get_xdata()):
                assert not overlaps(legend, line.get_window_extent(renderer)), line
        for band in axes.collections:
            assert not overlaps(legend, band.get_window_extent(renderer))
    assert legend.y1 < min(axes.bbox.y0 for axes in figure.axes)  # below every axes


@pytest.mark.parametrize("name", ["learning curves", "two panels"])
def test_the_note_is_above_the_plotted_area(name):
    figure = drawn(FIGURES[name])
    first = figure.axes[0]
    note = first.title.get_window_extent(figure.canvas.get_renderer())
    assert first.title.get_text() and note.y0 >= first.bbox.y1


@pytest.mark.parametrize("name", ["learning curves", "two panels", "uav count"])
def test_episode_and_uav_ticks_are_whole_numbers(name):
    figure = drawn(FIGURES[name])
    for axes in figure.axes:
        low, high = axes.get_xlim()
        ticks = [t for t in axes.get_xticks() if low <= t <= high]
        assert ticks and all(float(t).is_integer() for t in ticks), (name, ticks)
        labels = [label.get_text().replace("\N{MINUS SIGN}", "-")
                  for label in axes.get_xticklabels() if label.get_text()]
        assert all(float(text).is_integer() for text in labels), labels


def test_short_runs_get_no_half_episodes():
    # seven episodes: matplotlib's default ticks are 1.0, 1.5, ..., 7.0
    axes = drawn(lambda: learning_curves(short_series(), [], title="short")).axes[0]
    assert [int(t) for t in axes.get_xticks() if 1 <= t <= 7] == list(range(1, 8))


def test_labels_are_mathtext_with_units():
    figure = drawn(FIGURES["learning curves"])
    axes = figure.axes[0]
    assert axes.get_ylabel() == r"$R_e^{\mathrm{tot}}$ (Gbit/s)" and axes.get_xlabel() == "episode"
    labels = [t.get_text() for t in figure.legends[0].get_texts()]
    assert labels == ["dueling DQN (n = 3)", "DQN (n = 1)", "SoA: 31.80 Gbit/s",
                      "oracle: 49.10 Gbit/s"]
    panels = drawn(FIGURES["two panels"]).axes
    assert [a.get_ylabel() for a in panels] == ["$R_e^{tot}$ (Gbit/s)", "Jain's fairness $J_e$"]
    assert [a.get_xlabel() for a in panels] == ["", "episode"]  # one shared episode axis
