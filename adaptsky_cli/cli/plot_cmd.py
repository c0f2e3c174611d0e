"""``adaptsky plot``."""

from __future__ import annotations

from enum import StrEnum
from pathlib import Path
from typing import Annotated

import typer

from adaptsky_cli.cli.console import err


class Band(StrEnum):
    """The --band choices (adaptsky.report.curves.BAND_KINDS)."""

    std = "std"
    bootstrap = "bootstrap"


def plot(
    runs: Annotated[list[Path], typer.Argument(help="run files (HDF5)", show_default=False)],
    out_file: Annotated[Path | None, typer.Option(
        "--out", help="PNG to write (its name ends in .png), with the plotted numbers in a .csv "
        "beside it (default: <first run file>-curves.png beside it)", show_default=False)] = None,
    band: Annotated[Band, typer.Option(help="shaded band: mean ± 1 std over seeds, or a 95% "
                                       "bootstrap interval of the mean")] = Band.std,
    title: Annotated[str | None, typer.Option(help="figure title", show_default=False)] = None,
) -> None:
    """Draw the learning curves (R_e^tot, a trailing mean) of every seed of the run files."""
    from adaptsky.report.plot_runs import default_figure_path, plot_runs  # matplotlib

    path = plot_runs(run_paths=runs, out=out_file or default_figure_path(runs[0]),
                     band=band.value, title=title)
    err.print(f"figure: {path}")
