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

from adaptsky.errors import AdaptskyError
from adaptsky.experiment.executors import make_executor, stacks
from adaptsky.experiment.plan import Plan, load_experiment, plan_experiment
from adaptsky.experiment.runs import run_state
from adaptsky.experiment.sweep import SweepOutcome, run_sweep
from adaptsky.progress import LogLines, Reporter
from adaptsky.store.atomic import write_text_atomic
from adaptsky.training.api import training_device


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
              report_only: bool = False, device: str = "cpu", quiet: bool = False,
              progress: Reporter | None = None) -> ReproduceResult:
    """Run, evaluate and report an experiment into ``out`` (default reproduce/<id>).

    ``runs_only`` stops after training; ``report_only`` trains nothing and reports the runs
    that are finished (for a look while the runs go on elsewhere). ``progress`` hears of the
    work (default: timestamped lines on standard error, none but interrupts with ``quiet``).
    """
    return reproduce_many(experiments=[experiment], outs=[out], seeds=seeds, episodes=episodes,
                          steps=steps, workers=workers, scheduler=scheduler,
                          set_values=set_values, runs_only=runs_only, report_only=report_only,
                          device=device, quiet=quiet, progress=progress)[0]


def reproduce_many(*, experiments: list[str], outs: list[Path | None],
                   seeds: int | None = None, episodes: int | None = None,
                   steps: int | None = None, workers: int | None = None,
                   scheduler: str | None = None, set_values: list[str] | None = None,
                   runs_only: bool = False, report_only: bool = False, device: str = "cpu",
                   quiet: bool = False, progress: Reporter | None = None
                   ) -> list[ReproduceResult]:
    """:func:`reproduce` for several experiments whose runs train in one sweep (side by side
    on the executor), then are evaluated and reported one experiment at a time."""
    progress = progress or LogLines(quiet=quiet)
    torch_device = training_device(device)
    plans = []
    for experiment, out in zip(experiments, outs, strict=True):
        spec, path = load_experiment(experiment)
        plans.append(plan_experiment(spec, path, out if out is not None else default_out(spec.id),
                                     seeds=seeds, episodes=episodes, steps=steps,
                                     set_values=set_values))
    todo = []
    for plan in plans:
        states = [(run, run_state(run)) for run in plan.runs]  # refuses conflicting files first
        if plan.out.exists() and not plan.out.is_dir():
            raise AdaptskyError(f"{plan.out}: is a file; --out names the folder the "
                                "experiment's runs, evaluations and report go to")
        plan.out.mkdir(parents=True, exist_ok=True)
        write_text_atomic(plan.out / "plan.json", json.dumps(plan.record(), indent=1))
        todo += [(run, state) for run, state in states if state.status != "done"]
    sweep = None
    if todo and not report_only:
        on_gpu = torch_device.type != "cpu"
        units = len(stacks([run for run, _ in todo])) if on_gpu else len(todo)
        default_workers = min(units, os.cpu_count() or 1)
        executor = make_executor(workers or max(1, default_workers), scheduler, torch_device)
        sweep = run_sweep(todo, executor, progress, sum(len(p.runs) for p in plans))
        if sweep.interrupted or runs_only:
            return [ReproduceResult(plan, sweep, None, []) for plan in plans]
    if runs_only:
        return [ReproduceResult(plan, sweep, None, []) for plan in plans]
    from adaptsky.experiment.evaluation import evaluate_plan
    from adaptsky.experiment.report import write_report

    results = []
    for plan in plans:
        start = time.monotonic()
        evaluations = evaluate_plan(plan, progress)
        report, files = write_report(plan, evaluations)
        progress.say(f"{plan.experiment.id}: evaluated and reported in "
                     f"{time.monotonic() - start:.1f} s")
        results.append(ReproduceResult(plan, sweep, report, files))
    return results
