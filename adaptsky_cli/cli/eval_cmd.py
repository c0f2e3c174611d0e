"""``adaptsky eval`` and ``adaptsky baseline``."""

from __future__ import annotations

import json
import os
import time
from pathlib import Path
from typing import Annotated, Any

import typer

from adaptsky.errors import AdaptskyError
from adaptsky_cli.cli.console import err, out
from adaptsky_cli.cli.options import CsvFile, Json, Layout, ScenarioFile, command_line
from adaptsky_cli.cli.plausibility import warn_scenario_file
from adaptsky_cli.cli.usage import click_errors
from adaptsky_cli.cli.values import (
    conflict,
    method_value,
    policy_value,
    set_value,
    split_list,
)

Layouts = Annotated[int | None, typer.Option(min=1, metavar="N", show_default=False,
                                             help="evaluate on this many uniform layouts "
                                             "(default: the scenario's layout)")]
LayoutSeed = Annotated[int, typer.Option(min=0, metavar="SEED",
                                         help="seed of the uniform layouts")]
Steps = Annotated[int, typer.Option(min=1, metavar="N", help="steps per layout")]
EvalSetValues = Annotated[list[str] | None, typer.Option(
    "--set", metavar="KEY=VALUE", show_default=False, callback=set_value,
    help="override a key of the evaluation scenario, section.key=value (repeatable), e.g. "
    "--set channel.los=expected; recorded in the eval file")]
PROBE_BYTES = 64 * 1024
"""The trial write before the rollouts: a full disk refuses it as it would the eval file."""


def _trial_write(path: Path) -> None:
    """Write and remove a small file beside ``path``, so that a full disk (a quota, a size
    limit) is one line before the rollouts, as it is for ``train``, not after them."""
    from adaptsky.store.atomic import StorageError, write_bytes_atomic

    probe = path.with_name(f".{path.name}.probe")
    try:
        write_bytes_atomic(probe, bytes(PROBE_BYTES))
    except StorageError as error:
        raise StorageError(path, error.action, error.reason, error.advice, error.code) from None
    probe.unlink(missing_ok=True)


def _writable_new_file(path: Path) -> None:
    """Refuse, before any work, an eval file that exists or whose folder does not exist or
    cannot be written, or whose disk is full."""
    if path.exists():
        raise AdaptskyError(f"{path}: exists; choose another --out")
    if not path.parent.is_dir():
        raise AdaptskyError(f"{path}: the folder {path.parent} does not exist; create it or "
                            "choose another --out")
    if not os.access(path.parent, os.W_OK | os.X_OK):
        read_only = bool(os.statvfs(path.parent).f_flag & os.ST_RDONLY)
        reason = "read-only file system" if read_only else "permission denied"
        raise AdaptskyError(f"{path}: cannot write in {path.parent} ({reason}); "
                            "choose another --out")
    _trial_write(path)


def show_results(results: dict[str, Any], layout: int | None = None) -> None:
    """The comparison table of an evaluation or a baseline, and the policy's share of the
    oracle (of best response for several UAVs); with ``layout``, each user's rate on it."""
    from adaptsky.report.eval_table import (
        energy_lines,
        methods_table,
        note_lines,
        oracle_line,
        search_lines,
        service_lines,
    )
    from adaptsky.report.user_rates import eval_user_table
    out.print(methods_table(results))
    for line in (*note_lines(results), *search_lines(results), *energy_lines(results),
                 *service_lines(results)):
        out.print(line, markup=False)
    line = oracle_line(results)
    if line:
        out.print(line, markup=False)
    if layout is not None:
        out.print(eval_user_table(results, layout))


def check_tables(layout: int | None, layouts: int, csv_file: Path | None,
                 as_json: bool) -> None:
    """Refuse, before any work, a ``--layout`` the evaluation lacks or that ``--json`` would
    not show, and a ``--csv`` path that cannot be written."""
    from adaptsky.report.eval_csv import check_csv_path
    from adaptsky.report.user_rates import check_layout

    if layout is not None:
        if as_json:
            raise conflict(f"--layout {layout}: picks the layout of the per-user table, "
                           "which --json does not print (its steady_user_rate_bps holds "
                           "every layout); leave out one of them")
        check_layout(layout, layouts)
    if csv_file is not None:
        check_csv_path(csv_file)


def _run_file(run: Path | None, checkpoint: Path | None, ctx: typer.Context) -> Path:
    """The run file, given as the argument or as ``--checkpoint`` (once)."""
    if run is not None and checkpoint is not None:
        raise click_errors.UsageError(f"the run file is given twice ({run} and --checkpoint "
                                      f"{checkpoint}); give it once, as RUN.h5", ctx)
    if run is None and checkpoint is None:
        raise click_errors.UsageError("missing argument RUN.h5, the run file with the policy",
                                      ctx)
    return run if run is not None else checkpoint  # type: ignore[return-value]


def evaluate(
    ctx: typer.Context,
    run: Annotated[Path | None, typer.Argument(help="run file (HDF5) with the policy",
                                               metavar="RUN.h5", show_default=False)] = None,
    checkpoint: Annotated[Path | None, typer.Option(
        metavar="RUN.h5", show_default=False,
        help="the run file, as an option (the same as the argument)")] = None,
    seed: Annotated[int | None, typer.Option(
        min=0, metavar="SEED", show_default=False,
        help="which seed's policy (default: the first)")] = None,
    scenario: Annotated[Path | None, typer.Option(
        metavar="SCENARIO.toml", show_default=False,
        help="evaluate on this scenario (default: the training scenario)")] = None,
    layouts: Layouts = None,
    layout_seed: LayoutSeed = 0,
    steps: Steps = 1000,
    compare: Annotated[list[str], typer.Option(
        metavar="METHODS",
        help="comma-separated or the option repeated: soa, tracking, oracle (one UAV), "
        "best-response, oma, random, centroid, or other run files")] = ["soa,random"],  # noqa: B006
    out_file: Annotated[Path | None, typer.Option(
        "--out", metavar="FILE.h5", show_default=False,
        help="eval file to write (default: next to the run file)")] = None,
    policy: Annotated[str, typer.Option(
        metavar="best|last", callback=policy_value,
        help="best: the policy of the best greedy evaluation during training (the last "
        "where a run has none); last: the last checkpoint")] = "best",
    layout: Layout = None,
    csv_file: CsvFile = None,
    as_json: Json = False,
    set_values: EvalSetValues = None,
) -> None:
    """Evaluate a trained policy against baselines and other runs.

    Greedy rollouts of one seed's policy and of the methods compared, on the same layouts;
    prints a table and each user's rate, and writes an eval file (and a CSV with --csv)."""
    from adaptsky.evaluation import api
    from adaptsky.store.atomic import fresh_path
    from adaptsky.store.eval_file import write_eval
    from adaptsky_cli.cli.progress_display import RichReporter
    checkpoint = _run_file(run, checkpoint, ctx)
    start = time.monotonic()
    path = out_file if out_file is not None else fresh_path(checkpoint.parent,
                                                            f"{checkpoint.stem}-eval")
    if out_file is not None or path.parent.is_dir():  # else the run file is missing: said next
        _writable_new_file(path)
    check_tables(layout, layouts or 1, csv_file, as_json)
    methods = [item for item in split_list(compare) if item]
    warn_scenario_file(scenario, set_values, run=checkpoint)
    results, traces = api.evaluate(checkpoint=checkpoint, seed=seed, scenario_path=scenario,
                                   layouts=layouts, layout_seed=layout_seed, steps=steps,
                                   compare_with=methods, progress=RichReporter(err),
                                   policy=policy, set_values=set_values)
    write_eval(path, results, traces, provenance={
        "command_line": json.dumps(command_line(ctx)), "wall_time_s": time.monotonic() - start})
    written = {"eval_file": str(path)}
    if csv_file is not None:
        from adaptsky.report.eval_csv import write_eval_csv
        written["csv_file"] = str(write_eval_csv(csv_file, results))
    if as_json:
        print(json.dumps(results | written))
        return
    show_training(results)
    show_results(results, layout or 0)
    err.print(f"eval file: {path}")
    if csv_file is not None:
        err.print(f"CSV: {csv_file}")


def show_training(results: dict[str, Any]) -> None:
    """Which policy was evaluated, and the greedy evaluations during training (an evaluation
    of baselines alone has neither)."""
    from adaptsky.report.evaluations import curve_arrays, curve_table, policy_line

    used = results.get("policy")
    if used is None:
        return
    out.print(policy_line(used, used["score_kind"]), markup=False)
    curve = curve_arrays(results.get("training_evaluations") or {"episode": []})
    if len(curve["episode"]):
        best = used["episode"] if used["policy"] == "best" else None
        out.print(curve_table(results["seed"], curve, best, limit=6))


def baseline(
    scenario: ScenarioFile,
    method: Annotated[str, typer.Option(
        metavar="soa|tracking|oracle|best-response|oma|random|centroid",
        show_default=False,
        callback=method_value,
        help="the baseline to run (oracle: one UAV only)")],
    layouts: Layouts = None,
    layout_seed: LayoutSeed = 0,
    steps: Steps = 1000,
    as_json: Json = False,
    set_values: EvalSetValues = None,
) -> None:
    """Run one baseline on a scenario.

    The oracle also reports its optimum per layout; best response and OMA what they found,
    with their rounds."""
    from adaptsky.evaluation import api
    from adaptsky_cli.cli.progress_display import RichReporter
    warn_scenario_file(scenario, set_values)
    results, (result,) = api.baseline(scenario_path=scenario, method=method, layouts=layouts,
                                      layout_seed=layout_seed, steps=steps,
                                      progress=RichReporter(err), set_values=set_values)
    if method == "oracle":
        results["optimum"] = [
            {"uav_m": result.trace.uav_m[-1, i].tolist(),
             "alpha": result.trace.alpha[-1, i].tolist(),
             "rate_bps": result.trace.rate_bps[-1, i].tolist()}
            for i in range(results["layouts"])]
    elif method in ("best-response", "oma"):
        search = results["methods"][method]["search"]
        results["found"] = [
            {"uav_m": result.trace.uav_m[-1, i].tolist(),
             "alpha": result.trace.alpha[-1, i].tolist(),
             "rate_bps": result.trace.rate_bps[-1, i].tolist(),
             "rounds": search["rounds"][i], "converged": search["converged"][i]}
            for i in range(results["layouts"])]
    if as_json:
        print(json.dumps(results))
        return
    show_results(results)
    found = results.get("optimum") or results.get("found") or []
    for i, best in enumerate(found[:10]):
        out.print(f"layout {i}: {_configuration(method, best)}", markup=False)
    if len(found) > 10:
        out.print(f"... {results['layouts'] - 10} more layouts (--json lists them all)")


def _oma_words(cluster_size: int) -> str:
    """OMA's split in words, for clusters of ``cluster_size`` users (OMA's share 1/M each)."""
    if cluster_size == 2:
        return "OMA (half the band and half the power each)"
    part = {3: "a third", 4: "a quarter"}.get(cluster_size, f"1/{cluster_size}")
    return f"OMA ({part} of the band and {part} of the power each)"


def _configuration(method: str, best: dict[str, Any]) -> str:
    """What a search found on one layout, in words: the UAV or UAVs, the power shares (OMA
    splits no power), the users' rates and, for best response and OMA, the rounds."""
    import numpy as np

    from adaptsky.units import format_rate

    rates = ", ".join(format_rate(r) for r in best["rate_bps"])
    if method == "oracle":  # (as it always was)
        return (f"UAV at {best['uav_m']}, alpha {[round(a, 4) for a in best['alpha']]}, "
                f"rates {rates}")
    uav_m = np.round(best["uav_m"], 3).tolist()
    where = f"UAVs at {uav_m}" if np.ndim(uav_m) == 2 else f"UAV at {uav_m}"
    shares = (_oma_words(round(1 / best["alpha"][0])) if method == "oma" else
              f"alpha {[round(a, 4) for a in best['alpha']]}")
    rounds = best["rounds"]
    return (f"{where}, {shares}, rates {rates}; {rounds} round{'s' if rounds != 1 else ''}, "
            f"{'converged' if best['converged'] else 'not converged'}")
