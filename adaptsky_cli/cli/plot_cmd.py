"""``adaptsky plot``."""

from __future__ import annotations

from enum import StrEnum
from pathlib import Path
from typing import Annotated

import typer

from adaptsky.errors import AdaptskyError
from adaptsky_cli.cli.console import err
from adaptsky_cli.cli.values import conflict, metric_value, profile_value, split_list


class Band(StrEnum):
    """The --band choices (adaptsky.report.curves.BAND_KINDS)."""

    std = "std"
    bootstrap = "bootstrap"


def plot(
    runs: Annotated[list[Path], typer.Argument(help="run files (HDF5); eval files among them "
                                               "are skipped", metavar="RUN.h5...",
                                               show_default=False)],
    out_file: Annotated[Path | None, typer.Option(
        "--out", metavar="FIG.png|.pdf|.svg",
        help="figure to write, in the format its suffix names (.png, .pdf or .svg), with the "
        "plotted numbers in a .csv beside it (default: <first run file>-curves.png beside it)",
        show_default=False)] = None,
    metric: Annotated[list[str], typer.Option(
        metavar="METRICS", callback=metric_value,
        help="what to draw: sum-rate (R_e^tot), fairness (J_e), greedy "
        "(the greedy evaluations' score), energy-efficiency (bit/J per episode), reward (the "
        "episode's return), height (mean UAV height), epsilon (exploration rate), loss (mean "
        "TD loss), energy (J per episode), outage (share of user-steps), least-rate (mean "
        "least user rate) or p5-rate (5th percentile of the user rates); several "
        "(comma-separated or the option repeated) draw a panel each, e.g. "
        "sum-rate,fairness")] = ["sum-rate"],  # noqa: B006
    band: Annotated[Band, typer.Option(
        metavar="std|bootstrap", help="shaded band: mean ± 1 std over seeds, or a 95% "
        "bootstrap interval of the mean")] = Band.std,
    title: Annotated[str | None, typer.Option(metavar="TEXT", help="figure title",
                                              show_default=False)] = None,
    profile: Annotated[str | None, typer.Option(
        metavar="last|best", show_default=False, callback=profile_value,
        help="draw performance profiles instead of curves: per scenario, the share of seeds "
        "whose last (or best) greedy evaluation score is above each threshold, with 95% "
        "stratified bootstrap bands (default --out: <first run file>-profile.png)")] = None,
) -> None:
    """Draw the learning curves of run files.

    R_e^tot (a trailing mean), J_e, the greedy evaluations or any other per-episode series
    of every seed, with a band over seeds, as a PNG, PDF or SVG and a CSV."""
    from adaptsky.report.eval_summary import split_eval_files
    from adaptsky.report.plot_runs import default_figure_path, plot_runs  # matplotlib

    runs, evals = split_eval_files(runs)
    if not runs:
        raise AdaptskyError(f"no run file to plot: {', '.join(map(str, evals))} "
                            f"{'is an eval file' if len(evals) == 1 else 'are eval files'}; "
                            "give the run files (RUN.h5) that eval read")
    for path in evals:
        err.print(f"{path}: an eval file, not a run file: skipped (adaptsky inspect {path} "
                  "shows it)")
    if profile is not None:
        from adaptsky.report.profile_plot import plot_profiles

        if split_list(metric) != ["sum-rate"] or band != Band.std:
            raise conflict("--profile draws the greedy evaluations' scores: give it "
                           "without --metric and --band")
        path = plot_profiles(run_paths=runs, policy=profile, title=title,
                             out=out_file or runs[0].with_name(f"{runs[0].stem}-profile.png"))
        err.print(f"figure: {path}")
        return
    path = plot_runs(run_paths=runs, out=out_file or default_figure_path(runs[0]),
                     band=band.value, title=title, metric=",".join(split_list(metric)))
    err.print(f"figure: {path}")
