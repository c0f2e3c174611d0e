"""``adaptsky reproduce``."""

from pathlib import Path
from typing import Annotated

import typer

from adaptsky_cli.cli.console import err
from adaptsky_cli.cli.options import SEEDS_HELP, Device, Episodes, Steps, parse_seeds, seeds_option
from adaptsky_cli.cli.plausibility import warn_experiment
from adaptsky_cli.cli.values import conflict, format_value, set_value


def reproduce(
    experiment: Annotated[str, typer.Argument(
        metavar="EXPERIMENT", show_default=False,
        help="a shipped experiment id (the paper's e1a, e1b, e2, e3; ours e4, e5, e6, e7, e9, bdq, "
        "ppo, sac, mappo; suite, the benchmark), 'all' (the paper's), or an experiment "
        "file (TOML)")],
    out: Annotated[Path | None, typer.Option(
        metavar="DIR", show_default=False,
        help="output folder: runs/, evals/, figures, CSVs, report.md (default: "
        "reproduce/<id>); with 'all', the folder of one subfolder per experiment")] = None,
    runs: Annotated[int | None, typer.Option(
        min=1, metavar="N", show_default=False,
        help="at most N runs per group and sweep point (seeds 0 .. N-1), for a quick "
        "look")] = None,
    seeds: Annotated[list[str] | None, seeds_option(
        f"only these of the experiment's planned seeds; {SEEDS_HELP}")] = None,
    episodes: Episodes = None,
    steps: Steps = None,
    workers: Annotated[int | None, typer.Option(
        min=1, metavar="N", show_default=False,
        help="parallel local processes (default: one per core)")] = None,
    scheduler: Annotated[str | None, typer.Option(
        metavar="tcp://HOST:PORT", show_default=False,
        help="address of a Dask scheduler; DIR must be on storage every worker shares")] = None,
    set_values: Annotated[list[str] | None, typer.Option(
        "--set", metavar="KEY=VALUE", show_default=False, callback=set_value,
        help="override a key of every run's scenario, section.key=value (repeatable)")] = None,
    runs_only: Annotated[bool, typer.Option(
        "--runs-only", help="train the missing runs, then stop before evaluating and "
        "reporting")] = False,
    report_only: Annotated[bool, typer.Option(
        "--report-only", help="train nothing: evaluate and report the runs that are "
        "finished")] = False,
    device: Device = "cpu",
    figure_format: Annotated[str | None, typer.Option(
        "--format", metavar="png|pdf|svg", show_default=False, callback=format_value,
        help="the format of the experiments' figures, which report.md links (default: "
        "png)")] = None,
    quiet: Annotated[bool, typer.Option("--quiet", help="no progress, only the final "
                                        "lines")] = False,
) -> None:
    """Reproduce a paper experiment: train, evaluate, report.

    Runs what is missing, resumes what was interrupted, skips what is done, evaluates, and
    writes figures, CSVs and report.md."""
    if runs_only and report_only:
        raise conflict("--runs-only and --report-only exclude each other")
    if runs_only and figure_format is not None:
        raise conflict(f"--format {figure_format}: --runs-only draws no figure; leave out "
                       "one of them")
    # training and evaluation import torch: only when the command runs, not for --help
    from adaptsky.experiment.reproduce import reproduce as run_experiment
    from adaptsky.experiment.reproduce import reproduce_all
    from adaptsky_cli.cli.progress_display import RichReporter

    options = dict(runs=runs, seeds=parse_seeds(seeds), episodes=episodes, steps=steps,
                   workers=workers, scheduler=scheduler, set_values=set_values, runs_only=runs_only,
                   report_only=report_only, device=device, quiet=quiet,
                   progress=RichReporter(err, quiet=quiet), figure_format=figure_format or "png")
    if not report_only:  # what is trained: the scenarios of the experiment's runs
        warn_experiment(experiment, set_values)
    if experiment == "all":
        results, index = reproduce_all(out=out, **options)
    else:
        results, index = [run_experiment(experiment=experiment, out=out, **options)], None
    if any(result.interrupted for result in results):
        folders = ", ".join(str(result.plan.out) for result in results if result.interrupted)
        err.print(f"interrupted; every run keeps its last checkpoint. Continue with the same "
                  f"command (output folder {folders})")
        raise typer.Exit(130)
    for result in results:
        if result.report is not None:
            err.print(f"report: {result.report}")
        else:
            err.print(f"runs are in {result.plan.out / 'runs'}")
    if index is not None:
        err.print(f"index of every report: {index}")
