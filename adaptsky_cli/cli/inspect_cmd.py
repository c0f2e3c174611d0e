"""``adaptsky inspect``."""

import json
from pathlib import Path
from typing import Annotated

import typer

from adaptsky_cli.cli.console import out
from adaptsky_cli.cli.options import Json


def inspect(
    run: Annotated[Path, typer.Argument(help="run file (HDF5)", show_default=False)],
    as_json: Json = False,
) -> None:
    """Summarise a run file: seeds, episodes done, R_e^tot and J_e per seed and over seeds."""
    from adaptsky.report.summary import curve_tables, summarize, summary_table
    summary = summarize(run)
    if as_json:
        print(json.dumps(summary, indent=2))
        return
    out.print(f"{summary['file']}: adaptsky {summary['adaptsky_version']}, format "
              f"{summary['format_version']}, created {summary['created_utc']}", markup=False)
    if summary["overrides"]:
        out.print("--set " + " --set ".join(summary["overrides"]), markup=False)
    out.print(summary_table(summary))
    for table in curve_tables(summary):
        out.print(table)
