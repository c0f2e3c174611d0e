"""``adaptsky inspect``."""

import json
from pathlib import Path
from typing import Annotated

import typer

from adaptsky_cli.cli.console import out
from adaptsky_cli.cli.options import Json


def inspect(
    run: Annotated[Path, typer.Argument(help="run file or eval file (HDF5)", metavar="FILE.h5",
                                        show_default=False)],
    as_json: Json = False,
) -> None:
    """Summarise a run file or an eval file.

    A run file: seeds, episodes done, R_e^tot and J_e per seed and over seeds. An eval file:
    what it evaluated and its comparison table, as eval printed them."""
    from adaptsky.report.eval_summary import is_eval_file

    if is_eval_file(run):
        _inspect_eval(run, as_json)
    else:
        _inspect_run(run, as_json)


def _inspect_run(run: Path, as_json: bool) -> None:
    """Seeds, episodes done, R_e^tot and J_e per seed and over seeds."""
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


def _inspect_eval(path: Path, as_json: bool) -> None:
    """What the eval file evaluated and its comparison table, as ``eval`` printed them."""
    from adaptsky.report.eval_summary import eval_header_line, read_eval_file
    from adaptsky_cli.cli.eval_cmd import show_results, show_training

    header, results = read_eval_file(path)
    if as_json:
        print(json.dumps(results | {"eval_file": str(path), "header": header}, indent=2))
        return
    out.print(eval_header_line(path, header, results), markup=False, soft_wrap=True)
    show_training(results)
    show_results(results)
