"""``reproduce`` as a keyword-only library function: plan, run what is missing, evaluate,
report. Every step reads and writes files in the output folder, so a second call on a
finished folder only redraws, and an interrupted one continues where the files stand.
"""

from __future__ import annotations

import json
import os
import time
from dataclasses import dataclass
from pathlib import Path

from rich.console import Console

from adaptsky_cli.experiment.executors import make_executor
from adaptsky_cli.experiment.plan import Plan, load_experiment, plan_experiment
from adaptsky_cli.experiment.runs import run_state
from adaptsky_cli.experiment.sweep import SweepOutcome, run_sweep
from adaptsky_cli.store.atomic import write_text_atomic


@dataclass
class ReproduceResult:
    plan: Plan
    sweep: SweepOutcome | None
    report: Path | None
    files: list[Path]

    @property
    def interrupted(self) -> bool:
        return self.sweep is not None and self.sweep.interrupted


def default_out(experiment_id: str) -> Path:
    return Path("reproduce") / experiment_id


def reproduce(*, experiment: str, out: Path | None = None, seeds: int | None = None,
              episodes: int | None = None, steps: int | None = None,
              workers: int | None = None, scheduler: str | None = None,
              set_values: list[str] | None = None, runs_only: bool = False,
              report_only: bool = False, quiet: bool = False,
              console: Console | None = None) -> ReproduceResult:
    """Run, evaluate and report an experiment into ``out`` (default reproduce/<id>).

    ``runs_only`` stops after training; ``report_only`` trains nothing and reports the runs
    that are finished (for a look while the runs go on elsewhere)."""
    console = console or Console(stderr=True, highlight=False)
    spec, path = load_experiment(experiment)
    out = out if out is not None else default_out(spec.id)
    plan = plan_experiment(spec, path, out, seeds=seeds, episodes=episodes, steps=steps,
                           set_values=set_values)
    states = [(run, run_state(run)) for run in plan.runs]  # refuses conflicting files first
    out.mkdir(parents=True, exist_ok=True)
    write_text_atomic(out / "plan.json", json.dumps(plan.record(), indent=1))
    todo = [(run, state) for run, state in states if state.status != "done"]
    sweep = None
    if todo and not report_only:
        executor = make_executor(workers or max(1, min(len(todo), os.cpu_count() or 1)),
                                 scheduler)
        sweep = run_sweep(todo, executor, console, quiet, len(plan.runs))
        if sweep.interrupted:
            return ReproduceResult(plan, sweep, None, [])
    if runs_only:
        return ReproduceResult(plan, sweep, None, [])
    from adaptsky_cli.experiment.evaluation import evaluate_plan
    from adaptsky_cli.report.reproduction import write_report

    start = time.monotonic()
    evaluations = evaluate_plan(plan, console, quiet)
    report, files = write_report(plan, evaluations)
    if not quiet:
        console.print(f"evaluated and reported in {time.monotonic() - start:.1f} s",
                      markup=False)
    return ReproduceResult(plan, sweep, report, files)
