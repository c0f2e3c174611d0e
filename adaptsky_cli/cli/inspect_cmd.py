"""``adaptsky inspect``."""

import json
from pathlib import Path
from typing import Annotated

import typer

from adaptsky.errors import AdaptskyError
from adaptsky_cli.cli.console import err, out
from adaptsky_cli.cli.options import CsvFile, Json, Layout


def inspect(
    run: Annotated[Path, typer.Argument(help="run file or eval file (HDF5)", metavar="FILE.h5",
                                        show_default=False)],
    layout: Layout = None,
    csv_file: CsvFile = None,
    as_json: Json = False,
) -> None:
    """Summarise a run file or an eval file.

    A run file: seeds, episodes done, R_e^tot and J_e per seed and over seeds, each user's rate
    in each seed's last episode. An eval file: what it evaluated, its comparison table and each
    user's rate, as eval printed them (--csv: every layout's numbers to a CSV)."""
    from adaptsky.report.eval_summary import is_eval_file

    if is_eval_file(run):
        _inspect_eval(run, layout, csv_file, as_json)
        return
    for option, value in (("--layout", layout), ("--csv", csv_file)):
        if value is not None:
            raise AdaptskyError(f"{option} {value}: {run} is not an eval file; {option} "
                                "applies to eval files (adaptsky eval writes them)")
    _inspect_run(run, as_json)


def _inspect_run(run: Path, as_json: bool) -> None:
    """Seeds, episodes done, R_e^tot and J_e per seed and over seeds, per-user rates."""
    from adaptsky.report.summary import (
        curve_tables,
        energy_line,
        service_line,
        summarize,
        summary_table,
    )
    from adaptsky.report.user_rates import run_user_table
    summary = summarize(run)
    if as_json:
        print(json.dumps(summary, indent=2))
        return
    out.print(f"{summary['file']}: adaptsky {summary['adaptsky_version']}, format "
              f"{summary['format_version']}, created {summary['created_utc']}", markup=False)
    if summary["overrides"]:
        out.print("--set " + " --set ".join(summary["overrides"]), markup=False)
    out.print(summary_table(summary))
    for line in (energy_line(summary), service_line(summary)):
        if line:
            out.print(line, markup=False)
    users = run_user_table(summary)
    if users is not None:
        out.print(users)
    for table in curve_tables(summary):
        out.print(table)


def _inspect_eval(path: Path, layout: int | None, csv_file: Path | None,
                  as_json: bool) -> None:
    """What the eval file evaluated, its comparison table and per-user rates, as ``eval``
    printed them; its per-layout numbers to ``csv_file``."""
    from adaptsky.report.eval_csv import write_eval_csv
    from adaptsky.report.eval_summary import (
        eval_header_line,
        outside_policy_line,
        read_eval_file,
    )
    from adaptsky_cli.cli.eval_cmd import check_tables, show_results, show_training

    header, results = read_eval_file(path)
    check_tables(layout, int(results["layouts"]), csv_file, as_json)
    written = {} if csv_file is None else {"csv_file": str(write_eval_csv(csv_file, results))}
    if as_json:
        print(json.dumps(results | {"eval_file": str(path), "header": header} | written,
                         indent=2))
        return
    out.print(eval_header_line(path, header, results), markup=False, soft_wrap=True)
    outside = outside_policy_line(results)  # a policy from outside: no run, no curve
    if outside is not None:
        out.print(outside, markup=False, soft_wrap=True)
    else:
        show_training(results)
    show_results(results, layout or 0)
    if csv_file is not None:
        err.print(f"CSV: {csv_file}")
