"""E5's figure (ours, docs/model.md §10): the front of sum rate against energy efficiency, a
point per reward weight w_e with error bars over the runs in both directions, the hovering
baselines as reference points, and the most energy efficiency any policy can reach."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from matplotlib.figure import Figure

from adaptsky.report.figures import FONT_SMALL, legend_below, new_figure


@dataclass(frozen=True)
class FrontPoint:
    """One reward weight's runs: energy efficiency (bit/J) and sum rate (bit/s), each a mean
    with a low and high end of its band."""

    label: str
    ee_bpj: tuple[float, float, float]
    rate_bps: tuple[float, float, float]
    runs: int


def draw_energy_front(points: list[FrontPoint], references: dict[str, tuple[float, float]],
                      bound_bpj: float | None, *, title: str, ee_scale: float = 1e6,
                      rate_scale: float = 1e9) -> Figure:
    """Sum rate / ``rate_scale`` (Gbit/s) against energy efficiency / ``ee_scale`` (Mbit/J):
    the ``points`` joined in order, each labelled; ``references`` (name -> (EE, rate)) as
    single markers; a dashed vertical line at ``bound_bpj``."""
    figure = new_figure()
    axes = figure.add_subplot()
    axes.grid(True, alpha=0.3)
    ee = np.array([p.ee_bpj for p in points]).reshape(-1, 3) / ee_scale
    rate = np.array([p.rate_bps for p in points]).reshape(-1, 3) / rate_scale
    runs = min((p.runs for p in points), default=0)
    if len(points):
        axes.errorbar(ee[:, 0], rate[:, 0],
                      xerr=[ee[:, 0] - ee[:, 1], ee[:, 2] - ee[:, 0]],
                      yerr=[rate[:, 0] - rate[:, 1], rate[:, 2] - rate[:, 0]],
                      marker="o", color="C0", capsize=3, label=f"policy (n = {runs})")
        for point, x, y in zip(points, ee[:, 0], rate[:, 0], strict=True):
            axes.annotate(point.label, (x, y), textcoords="offset points", xytext=(5, 5),
                          fontsize=FONT_SMALL)
    for i, (name, (x, y)) in enumerate(references.items()):
        axes.plot([x / ee_scale], [y / rate_scale], marker="s^Dv"[i % 4], linestyle="none",
                  color=f"C{i + 1}", label=name)
    if bound_bpj is not None:
        axes.axvline(bound_bpj / ee_scale, color="black", linestyle="--", linewidth=1.0,
                     label="most any policy can reach")
    axes.set(xlabel="energy efficiency (Mbit/J)",
             ylabel=r"$R^{\mathrm{tot}}$, greedy steady state (Gbit/s)")
    figure.suptitle(title)
    legend_below(figure, [axes], columns=4)
    return figure
