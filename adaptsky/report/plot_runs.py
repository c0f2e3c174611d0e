"""Learning curves of run files: R_e^tot (a trailing mean of the episode sum rates) with a band
over every seed, as a PNG, and the plotted numbers as a CSV beside it."""

from __future__ import annotations

import csv
import io
from pathlib import Path
from typing import cast

import numpy as np

from adaptsky.errors import AdaptskyError
from adaptsky.report.curves import BAND_KINDS, BandKind, curve_window, trailing_mean
from adaptsky.report.curves import band as band_over_runs
from adaptsky.report.figures import Series, learning_curves
from adaptsky.store.atomic import write_text_atomic
from adaptsky.store.run_file import RunReader
from adaptsky.units import rate_unit

BAND_NOTES = {"std": "mean ± 1 std over runs", "bootstrap": "95% bootstrap CI of the mean"}
CSV_COLUMNS = ("mean", "low", "high", "runs")


FIGURE_SUFFIXES = (".png",)  # figures.py writes PNG


def default_figure_path(run_path: Path) -> Path:
    """``<run stem>-curves.png`` beside the run file."""
    return run_path.with_name(f"{run_path.stem}-curves.png")


def read_sum_rates(run_paths: list[Path]) -> dict[str, list[np.ndarray]]:
    """Scenario name -> the episode sum rates (E,) in bit/s of every seed, over all files (each
    file read once), leaving out seeds without an episode yet; in order of appearance."""
    groups: dict[str, list[np.ndarray]] = {}
    seen: set[Path] = set()
    for path in run_paths:
        if path.resolve() in seen:
            continue
        seen.add(path.resolve())
        with RunReader(path, needs="curves") as run:
            name = run.config["name"]
            rates = [run.episodes(seed)["sum_rate_bps"] for seed in run.seeds]
        groups.setdefault(name, []).extend(r for r in rates if len(r))
    return {name: curves for name, curves in groups.items() if curves}


def curve_series(label: str, curves: list[np.ndarray], window: int, kind: BandKind) -> Series:
    """One series: every curve cut to the shortest, smoothed over ``window`` episodes, and
    banded over curves; x is the episode (1-based) that ends each window."""
    episodes = min(len(c) for c in curves)
    smoothed = trailing_mean(np.stack([c[:episodes] for c in curves]), window)
    mean, low, high = band_over_runs(smoothed, kind)
    return Series(label=label, x=np.arange(window, episodes + 1), mean=mean, low=low,
                  high=high, runs=len(curves))


def write_curves_csv(path: Path, series: list[Series]) -> None:
    """``episode`` then ``<label>_mean, _low, _high, _runs`` per series (rates in bit/s); empty
    cells past a series' last episode."""
    episodes = np.unique(np.concatenate([s.x for s in series]))
    rows_at = [{int(e): k for k, e in enumerate(s.x)} for s in series]
    text = io.StringIO()
    writer = csv.writer(text, lineterminator="\n")
    writer.writerow(["episode", *(f"{s.label}_{c}" for s in series for c in CSV_COLUMNS)])
    for episode in episodes.tolist():
        row: list[object] = [episode]
        for s, at in zip(series, rows_at, strict=True):
            k = at.get(episode)
            row += (["", "", "", ""] if k is None else
                    [float(s.mean[k]), float(s.low[k]), float(s.high[k]), s.runs])
        writer.writerow(row)
    write_text_atomic(path, text.getvalue())


def plot_runs(*, run_paths: list[Path], out: Path, band: str = "std",
              title: str | None = None) -> Path:
    """Draw the R_e^tot learning curves of every seed of ``run_paths`` to ``out`` (PNG) and
    their numbers to ``out`` with ``.csv``: one series per scenario name (one in all when the
    files share it), all smoothed over one window (:func:`curve_window` of the shortest
    series). Returns ``out``."""
    if band not in BAND_KINDS:
        raise AdaptskyError(f"--band: unknown band '{band}'; choose from "
                            f"{', '.join(BAND_KINDS)}")
    if out.suffix.lower() not in FIGURE_SUFFIXES:  # never a figure written over a .toml or .h5
        raise AdaptskyError(f"--out {out}: a figure file must end in "
                            f"{', '.join(FIGURE_SUFFIXES)}")
    groups = read_sum_rates(run_paths)
    if not groups:
        raise AdaptskyError(f"{', '.join(map(str, run_paths))}: no seed has finished an "
                            "episode yet; nothing to plot")
    window = curve_window(min(len(c) for curves in groups.values() for c in curves))
    kind = cast(BandKind, band)
    series = [curve_series(name, curves, window, kind) for name, curves in groups.items()]
    scale, unit = rate_unit([float(np.abs(s.mean).max()) for s in series])
    out.parent.mkdir(parents=True, exist_ok=True)
    title = title.replace("$", r"\$") if title else None  # literal text, not TeX math
    learning_curves(out, series, [], title=title or f"Learning curves: {', '.join(groups)}",
                    ylabel=f"R_e^tot ({unit})", scale=scale,
                    note=f"trailing mean over {window} episodes; band: {BAND_NOTES[band]}")
    write_curves_csv(out.with_suffix(".csv"), series)
    return out
