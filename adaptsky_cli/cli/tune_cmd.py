"""``adaptsky tune``."""

import math
from pathlib import Path
from typing import Annotated

import typer
from rich.table import Table

from adaptsky_cli.cli.console import err, out
from adaptsky_cli.cli.options import Episodes, SetValues, Steps
from adaptsky_cli.cli.values import study_value

TABLE_ROWS = 10


def tune(
    scenario: Annotated[Path, typer.Argument(help="scenario file (TOML)", show_default=False,
                                             metavar="SCENARIO.toml")],
    space: Annotated[Path, typer.Option(
        "--space", metavar="SPACE.toml", show_default=False,
        help="the search space: scenario keys with ranges or choices (docs/tuning.md)")],
    trials: Annotated[int, typer.Option(
        min=1, metavar="N", help="end when the study has N trials finished or pruned")],
    storage: Annotated[str | None, typer.Option(
        metavar="URL", show_default=False,
        help="Optuna storage, any SQLAlchemy URL (default: sqlite:///OUT/study.db)")] = None,
    study: Annotated[str | None, typer.Option(
        metavar="NAME", show_default=False, callback=study_value,
        help="the study's name (default: the scenario file's name)")] = None,
    out_dir: Annotated[Path | None, typer.Option(
        "--out", metavar="DIR", show_default=False,
        help="folder of the trials' run files and best.toml (default: tune/<study>)")] = None,
    workers: Annotated[int, typer.Option(
        min=1, metavar="W", help="processes running trials at once (one trial each)")] = 1,
    episodes: Episodes = None,
    steps: Steps = None,
    set_values: SetValues = None,
    quiet: Annotated[bool, typer.Option("--quiet", help="print only the final table")] = False,
) -> None:
    """Tune hyperparameters with Optuna; the same command again continues the study.

    TPE proposes the space's values, each trial trains them into a run file, and a median
    pruner ends trials whose greedy evaluations trail (docs/tuning.md)."""
    from adaptsky.tuning.api import tune as run_tune
    from adaptsky.tuning.space import shown
    from adaptsky_cli.cli.progress_display import RichReporter

    outcome = run_tune(scenario_path=scenario, space_path=space, trials=trials,
                       storage=storage, study=study, out=out_dir, workers=workers,
                       episodes=episodes, steps=steps, set_values=set_values, quiet=quiet,
                       progress=RichReporter(err, quiet=quiet))
    c = outcome.counts
    table = Table(title=f"study {outcome.study}: {c.complete} finished, {c.pruned} pruned "
                        f"(best {TABLE_ROWS} shown)")
    for column in ("trial", "state", "objective", "parameters"):
        table.add_column(column, justify="right" if column != "parameters" else "left")
    for row in outcome.trials[:TABLE_ROWS]:
        state = (row["state"] if row["pruned_at"] is None
                 else f"pruned at {row['pruned_at']}")
        value = f"{row['value']:.2f}" if math.isfinite(row["value"]) else "-"
        params = ", ".join(f"{k}={shown(v)}" for k, v in row["params"].items())
        table.add_row(str(row["number"]), state, value, params)
    out.print(table)
    if outcome.best_path is not None:
        err.print(f"best trial as a scenario: {outcome.best_path}")
    if not quiet:
        err.print(f"watch it: optuna-dashboard {outcome.storage}", markup=False,
                  highlight=False)
    if outcome.interrupted:
        err.print("interrupted; run the same command again to continue the study")
        raise typer.Exit(130)
