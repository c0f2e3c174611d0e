"""``adaptsky train``."""

from pathlib import Path
from typing import Annotated

import typer

from adaptsky_cli.cli.console import err, out
from adaptsky_cli.cli.options import (
    SEEDS_HELP,
    Device,
    Episodes,
    SetValues,
    Steps,
    parse_seeds,
    seeds_option,
)
from adaptsky_cli.cli.plausibility import warn_scenario_file
from adaptsky_cli.cli.usage import click_errors
from adaptsky_cli.cli.values import conflict, log_value, split_list


def train(
    ctx: typer.Context,
    scenario: Annotated[Path | None, typer.Argument(help="scenario file (TOML)",
                                                    show_default=False,
                                                    metavar="SCENARIO.toml")] = None,
    out_file: Annotated[Path | None, typer.Option(
        "--out", metavar="FILE.h5", show_default=False,
        help="run file to write (default: runs/<scenario>-<time>.h5)")] = None,
    seeds: Annotated[list[str] | None, seeds_option(
        f"{SEEDS_HELP}; one run file holds them all (default: the scenario's)")] = None,
    episodes: Episodes = None,
    steps: Steps = None,
    workers: Annotated[int | None, typer.Option(
        min=1, metavar="N", show_default=False,
        help="parallel processes (default: one per seed, at most the cores)")] = None,
    checkpoint_every: Annotated[int | None, typer.Option(
        min=1, metavar="N", show_default=False, help="episodes between checkpoints")] = None,
    set_values: SetValues = None,
    resume: Annotated[Path | None, typer.Option(
        metavar="RUN.h5", show_default=False,
        help="continue this run file from its last checkpoints")] = None,
    device: Device = "cpu",
    log: Annotated[list[str] | None, typer.Option(
        "--log", metavar="tensorboard|csv", show_default=False, callback=log_value,
        help="also log every episode's scalars beside the run file, in RUN.logs/: "
        "TensorBoard event files, a CSV or both (tensorboard,csv or the option repeated; "
        "--resume continues the run's logs)")
    ] = None,
    quiet: Annotated[bool, typer.Option("--quiet", help="print only the final table")] = False,
) -> None:
    """Train the scenario's agent (agent.algorithm: dqn, bdq, ppo, sac, mappo or ippo).

    On a CPU one process per core, its seeds as one stack; on a GPU every seed in one stack."""
    from adaptsky.report.summary import summarize, summary_table
    from adaptsky.training import api
    from adaptsky_cli.cli.progress_display import RichReporter
    progress = RichReporter(err, quiet=quiet)
    if resume is not None:
        if scenario is not None or seeds or steps or checkpoint_every or out_file or set_values:
            raise conflict("--resume continues a run as it was configured: give only "
                           "--episodes, --workers, --device, --log and --quiet with it")
        path, outcome = api.resume(run_path=resume, episodes=episodes, workers=workers,
                                   device=device, quiet=quiet, progress=progress,
                                   logs=split_list(log) if log else None)
    elif scenario is None:
        raise click_errors.UsageError("missing argument SCENARIO.toml (or --resume RUN.h5 to "
                                      "continue a run)", ctx)
    else:
        warn_scenario_file(scenario, set_values)
        path, outcome = api.train(scenario_path=scenario, out=out_file, seeds=parse_seeds(seeds),
                                  episodes=episodes, steps=steps, workers=workers,
                                  checkpoint_every=checkpoint_every, set_values=set_values,
                                  device=device, quiet=quiet, progress=progress,
                                  logs=split_list(log))
    out.print(summary_table(summarize(path)))
    if outcome.interrupted:
        err.print(f"interrupted; checkpoints saved. Continue with: adaptsky train --resume {path}")
        raise typer.Exit(130)
    if outcome.complete:
        done = max(outcome.episodes_done.values())
        err.print(f"{path}: already complete ({done} episodes per seed), nothing trained; to "
                  f"train it further give --episodes with more than {done}")
    elif not quiet:
        err.print(f"run file: {path}")
