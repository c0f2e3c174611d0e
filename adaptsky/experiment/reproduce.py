"""``reproduce`` as a keyword-only library function: plan, run what is missing, evaluate,
report. Every step reads and writes files in the output folder, so a second call on a
finished folder only redraws, and an interrupted one continues where the files stand.
"""

from __future__ import annotations

import json
import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from adaptsky.errors import AdaptskyError
from adaptsky.experiment.calls import read_calls, record_call
from adaptsky.experiment.executors import make_executor, stacks
from adaptsky.experiment.plan import Plan, load_experiment, paper_experiments, plan_experiment
from adaptsky.experiment.runs import run_state
from adaptsky.experiment.sweep import SweepOutcome, run_sweep
from adaptsky.progress import LogLines, Reporter
from adaptsky.report.figure_files import check_format
from adaptsky.store.atomic import utc_timestamp, write_text_atomic
from adaptsky.training.api import training_device


@dataclass
class ReproduceResult:
    """One experiment's outcome: its plan, the training sweep (none when nothing was left to
    train), report.md and the files written, the claims table and this call's wall time."""

    plan: Plan
    sweep: SweepOutcome | None
    report: Path | None
    files: list[Path]
    table: list[str] = field(default_factory=list)
    wall_s: float = 0.0

    @property
    def interrupted(self) -> bool:
        return self.sweep is not None and self.sweep.interrupted


def default_out(experiment_id: str) -> Path:
    return Path("reproduce") / experiment_id


def reproduce(*, experiment: str, out: Path | None = None, runs: int | None = None,
              seeds: list[int] | None = None, episodes: int | None = None, steps: int | None = None,
              workers: int | None = None, scheduler: str | None = None,
              set_values: list[str] | None = None, runs_only: bool = False,
              report_only: bool = False, device: str = "cpu", quiet: bool = False,
              progress: Reporter | None = None, figure_format: str = "png") -> ReproduceResult:
    """Run, evaluate and report an experiment into ``out`` (default reproduce/<id>).

    ``runs`` keeps at most so many runs per group and sweep point (seeds 0 .. runs - 1),
    ``seeds`` only those of the planned seeds. ``runs_only`` stops after training;
    ``report_only`` trains nothing and reports the runs that are finished (for a look while
    the runs go on elsewhere). ``progress`` hears of the work
    (default: timestamped lines on standard error, none but interrupts with ``quiet``).
    ``figure_format`` (png, pdf or svg) is the figure's, checked before any work.
    Every call is recorded in ``DIR/calls.json``; the report gives their summed wall time.
    """
    start, started_utc = time.monotonic(), utc_timestamp()
    figure_format = check_format(figure_format)
    progress = progress or LogLines(quiet=quiet)
    torch_device = training_device(device)
    spec, path = load_experiment(experiment)
    plan = plan_experiment(spec, path, out if out is not None else default_out(spec.id),
                           runs=runs, seeds=seeds, episodes=episodes, steps=steps,
                           set_values=set_values)
    states = [(run, run_state(run)) for run in plan.runs]  # refuses conflicting files first
    if plan.out.exists() and not plan.out.is_dir():
        raise AdaptskyError(f"{plan.out}: is a file; --out names the folder the "
                            "experiment's runs, evaluations and report go to")
    plan.out.mkdir(parents=True, exist_ok=True)
    write_text_atomic(plan.out / "plan.json", json.dumps(plan.record(), indent=1))
    todo = [(run, state) for run, state in states if state.status != "done"]

    def finish(result: ReproduceResult) -> ReproduceResult:
        result.wall_s = time.monotonic() - start
        record_call(plan.out, started_utc=started_utc, wall_s=result.wall_s,
                    trained=len(todo) if result.sweep is not None else 0,
                    interrupted=result.interrupted, device=str(torch_device))
        return result

    sweep = None
    if todo and not report_only:
        on_gpu = torch_device.type != "cpu"
        units = len(stacks([run for run, _ in todo])) if on_gpu else len(todo)
        default_workers = min(units, os.cpu_count() or 1)
        executor = make_executor(workers or max(1, default_workers), scheduler, torch_device)
        sweep = run_sweep(todo, executor, progress, len(plan.runs))
    if runs_only or (sweep is not None and sweep.interrupted):
        return finish(ReproduceResult(plan, sweep, None, []))
    from adaptsky.experiment.evaluation import evaluate_plan
    from adaptsky.experiment.report import write_report

    evaluated = time.monotonic()
    evaluations = evaluate_plan(plan, progress)
    calls = read_calls(plan.out)
    trained = sum(int(row.get("runs_trained", 0)) for row in calls.rows)
    written = write_report(plan, evaluations, wall_s=calls.wall_s + time.monotonic() - start,
                           trained_in_calls=trained + (len(todo) if sweep is not None else 0),
                           figure_format=figure_format)
    progress.say(f"{plan.experiment.id}: evaluated and reported in "
                 f"{time.monotonic() - evaluated:.1f} s")
    return finish(ReproduceResult(plan, sweep, written.path, written.files, written.table))


def reproduce_all(*, out: Path | None = None, **options: Any) -> tuple[list[ReproduceResult],
                                                                      Path | None]:
    """:func:`reproduce` for every shipped experiment of the paper (those with a
    ``paper_figure``; ours, such as E4, run by name), one after the other into
    ``out/<id>`` (default reproduce/), then ``out/report.md``: an index linking each report,
    with every claims table, each experiment's wall time and the total. Stops after an
    interrupted experiment (the same call continues); no index with ``runs_only``."""
    from adaptsky.experiment.report import write_index

    start = time.monotonic()
    check_format(options.get("figure_format", "png"))  # before the first experiment's work
    folder = out if out is not None else Path("reproduce")
    results = []
    for name in paper_experiments():
        result = reproduce(experiment=name, out=folder / name, **options)
        results.append(result)
        if result.interrupted:
            return results, None
    if options.get("runs_only"):
        return results, None
    return results, write_index(folder, results, time.monotonic() - start)
