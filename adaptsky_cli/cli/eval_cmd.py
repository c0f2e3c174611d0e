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
from adaptsky_cli.cli.options import Json, ScenarioFile, command_line

Layouts = Annotated[int | None, typer.Option(min=1, help="evaluate on this many uniform "
                                             "layouts (default: the scenario's layout)")]
LayoutSeed = Annotated[int, typer.Option(min=0, help="seed of the uniform layouts")]
Steps = Annotated[int, typer.Option(min=1, help="steps per layout")]


def _writable_new_file(path: Path) -> None:
    """Refuse, before any work, an eval file that exists or whose folder does not exist or
    cannot be written."""
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


def _show(results: dict[str, Any]) -> None:
    from adaptsky.report.eval_table import methods_table, oracle_line
    out.print(methods_table(results))
    line = oracle_line(results)
    if line:
        out.print(line, markup=False)


def evaluate(
    ctx: typer.Context,
    checkpoint: Annotated[Path, typer.Option(help="run file (HDF5) with the policy",
                                             show_default=False)],
    seed: Annotated[int | None, typer.Option(help="which seed's policy (default: the "
                                             "first)")] = None,
    scenario: Annotated[Path | None, typer.Option(help="evaluate on this scenario (default: "
                                                  "the training scenario)")] = None,
    layouts: Layouts = None,
    layout_seed: LayoutSeed = 0,
    steps: Steps = 1000,
    compare: Annotated[str, typer.Option(help="comma-separated: soa, oracle, random, or "
                                         "other run files")] = "soa,random",
    out_file: Annotated[Path | None, typer.Option("--out", help="eval file to write "
                                                  "(default: next to the run file)")] = None,
    policy: Annotated[str, typer.Option(help="best: the policy of the best greedy evaluation "
                                        "during training (the last where a run has none); "
                                        "last: the last checkpoint")] = "best",
    as_json: Json = False,
) -> None:
    """Greedy rollouts of a trained policy, compared with baselines and other runs."""
    from adaptsky.evaluation import api
    from adaptsky.store.atomic import fresh_path
    from adaptsky.store.eval_file import write_eval
    from adaptsky_cli.cli.progress_display import RichReporter
    start = time.monotonic()
    path = out_file if out_file is not None else fresh_path(checkpoint.parent,
                                                            f"{checkpoint.stem}-eval")
    if out_file is not None or path.parent.is_dir():  # else the run file is missing: said next
        _writable_new_file(path)
    methods = [item.strip() for item in compare.split(",") if item.strip()]
    results, traces = api.evaluate(checkpoint=checkpoint, seed=seed, scenario_path=scenario,
                                   layouts=layouts, layout_seed=layout_seed, steps=steps,
                                   compare_with=methods, progress=RichReporter(err),
                                   policy=policy)
    write_eval(path, results, traces, provenance={
        "command_line": json.dumps(command_line(ctx)), "wall_time_s": time.monotonic() - start})
    if as_json:
        print(json.dumps(results | {"eval_file": str(path)}))
        return
    _show_training(results)
    _show(results)
    err.print(f"eval file: {path}")


def _show_training(results: dict[str, Any]) -> None:
    """Which policy was evaluated, and the greedy evaluations during training."""
    from adaptsky.report.evaluations import curve_arrays, curve_table, policy_line

    used = results["policy"]
    out.print(policy_line(used, used["score_kind"]), markup=False)
    curve = curve_arrays(results["training_evaluations"])
    if len(curve["episode"]):
        best = used["episode"] if used["policy"] == "best" else None
        out.print(curve_table(results["seed"], curve, best, limit=6))


def baseline(
    scenario: ScenarioFile,
    method: Annotated[str, typer.Option(help="soa, oracle or random")],
    layouts: Layouts = None,
    layout_seed: LayoutSeed = 0,
    steps: Steps = 1000,
    as_json: Json = False,
) -> None:
    """Run one baseline on a scenario; the oracle also reports its optimum."""
    from adaptsky.evaluation import api
    from adaptsky.units import format_rate
    from adaptsky_cli.cli.progress_display import RichReporter
    if method not in api.BASELINES:
        raise AdaptskyError(f"--method: unknown method '{method}'; choose from "
                            f"{', '.join(api.BASELINES)}")
    results, (result,) = api.baseline(scenario_path=scenario, method=method, layouts=layouts,
                                      layout_seed=layout_seed, steps=steps,
                                      progress=RichReporter(err))
    if method == "oracle":
        results["optimum"] = [
            {"uav_m": result.trace.uav_m[-1, i].tolist(),
             "alpha": result.trace.alpha[-1, i].tolist(),
             "rate_bps": result.trace.rate_bps[-1, i].tolist()}
            for i in range(results["layouts"])]
    if as_json:
        print(json.dumps(results))
        return
    _show(results)
    if method == "oracle":
        for i, best in enumerate(results["optimum"][:10]):
            rates = ", ".join(format_rate(r) for r in best["rate_bps"])
            out.print(f"layout {i}: UAV at {best['uav_m']}, alpha "
                      f"{[round(a, 4) for a in best['alpha']]}, rates {rates}", markup=False)
        if results["layouts"] > 10:
            out.print(f"... {results['layouts'] - 10} more layouts (--json lists them all)")
