"""E5's figure (ours, docs/model.md §10): the front of sum rate against energy efficiency, a
point per reward weight w_e with error bars over the runs in both directions, the hovering
baselines as reference points, and the most energy efficiency any policy can reach."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from adaptsky.report.figures import DPI, _new_axes, _save


@dataclass(frozen=True)
class FrontPoint:
    """One reward weight's runs: energy efficiency (bit/J) and sum rate (bit/s), each a mean
    with a low and high end of its band."""

    label: str
    ee_bpj: tuple[float, float, float]
    rate_bps: tuple[float, float, float]
    runs: int


def draw_energy_front(path: Path, points: list[FrontPoint], references: dict[str, tuple[float,
                 float]], bound_bpj: float | None, *, title: str, ee_scale: float = 1e6,
                 rate_scale: float = 1e9, dpi: int = DPI) -> None:
    """Sum rate / ``rate_scale`` (Gbit/s) against energy efficiency / ``ee_scale`` (Mbit/J):
    the ``points`` joined in order, each labelled; ``references`` (name -> (EE, rate)) as
    single markers; a dashed vertical line at ``bound_bpj``."""
    figure, axes = _new_axes()
    ee = np.array([p.ee_bpj for p in points]) / ee_scale
    rate = np.array([p.rate_bps for p in points]) / rate_scale
    runs = min((p.runs for p in points), default=0)
    if len(points):
        axes.errorbar(ee[:, 0], rate[:, 0],
                      xerr=[ee[:, 0] - ee[:, 1], ee[:, 2] - ee[:, 0]],
                      yerr=[rate[:, 0] - rate[:, 1], rate[:, 2] - rate[:, 0]],
                      marker="o", color="C0", capsize=3, label=f"policy (n = {runs})")
        for point, x, y in zip(points, ee[:, 0], rate[:, 0], strict=True):
            axes.annotate(point.label, (x, y), textcoords="offset points", xytext=(5, 5),
                          fontsize=8)
    for i, (name, (x, y)) in enumerate(references.items()):
        axes.plot([x / ee_scale], [y / rate_scale], marker="s^Dv"[i % 4], linestyle="none",
                  color=f"C{i + 1}", label=name)
    if bound_bpj is not None:
        axes.axvline(bound_bpj / ee_scale, color="black", linestyle="--", linewidth=1.0,
                     label="most any policy can reach")
    axes.set(title=title, xlabel="energy efficiency (Mbit/J)",
             ylabel=r"$R^{tot}$, greedy steady state (Gbit/s)")
    handles, labels = axes.get_legend_handles_labels()
    figure.legend(handles, labels, loc="outside lower center", ncol=4, fontsize=8)
    _save(figure, path, dpi)
