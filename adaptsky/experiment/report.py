"""``report.md`` of a reproduced experiment and the index of ``reproduce all``: the figure
kind's analysis (one module each), its claims table and notes, written beside its figure and
CSV. Pure functions of run and eval files: reporting never trains.
"""

from __future__ import annotations

import os
import platform
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from adaptsky import __version__
from adaptsky.experiment.analysis import Analysis, Outputs, done_runs, row_label
from adaptsky.experiment.calls import read_calls
from adaptsky.experiment.claims import beyond_reach, claims_table
from adaptsky.experiment.conditions import conditions
from adaptsky.experiment.curves import learning_curves, min_se_sweep
from adaptsky.experiment.energy_front import energy_front
from adaptsky.experiment.evaluation import Evaluations
from adaptsky.experiment.gains import layout_gains
from adaptsky.experiment.intervals import statistics_lines
from adaptsky.experiment.models import PER_GROUP_KINDS
from adaptsky.experiment.plan import Plan, shipped_experiments
from adaptsky.experiment.uav_count import uav_count
from adaptsky.report.curves import LAST_EPISODES
from adaptsky.store.atomic import utc_timestamp, write_text_atomic
from adaptsky.units import format_duration, plural


def _window(episodes: int) -> str:
    """"100 episodes'" or, for a shorter run, all of them: "20 episodes'"."""
    count = min(LAST_EPISODES, episodes)
    return plural(count, "episode") + ("'s" if count == 1 else "'")


ANALYSES: dict[str, Callable[[Plan, Evaluations, Outputs], Analysis]] = {
    "learning-curves": learning_curves, "min-se-sweep": min_se_sweep,
    "layout-gains": layout_gains, "uav-count": uav_count, "energy-front": energy_front,
    "conditions": conditions}


REACHABLE: dict[str, tuple[str, str]] = {
    "learning-curves": ("oracle", "the same quantity for the oracle, the best sum rate over "
                        "every reachable position and power split (docs/model.md, section 6)."),
    "uav-count": ("best response", "the same quantity for best response, our reference of "
                  "several UAVs (docs/model.md, section 9)."),
    "conditions": ("bound", "the same quantity for each condition's bound: the oracle for one "
                   "UAV (docs/model.md, section 6), best response for several (section 9)."),
}
"""The reachable column of a figure kind's claims table: its header and what the report says
of it (a kind not listed: the uav-count one where its groups are x points, else the
oracle)."""


def command_line(plan: Plan) -> str:
    shipped = shipped_experiments()
    resolved = plan.experiment_path.resolve()
    name = next((key for key, path in shipped.items() if path.resolve() == resolved),
                str(plan.experiment_path))
    parts = ["adaptsky reproduce", name, "--out", str(plan.out)]
    for option in ("runs", "seeds", "episodes", "steps"):
        value = plan.shrink.get(option)
        if value is not None:
            parts += [f"--{option}", ",".join(map(str, value)) if isinstance(value, list)
                      else str(value)]
    for item in plan.set_values:
        parts += ["--set", item]
    return " ".join(parts)


@dataclass(frozen=True)
class WrittenReport:
    """report.md, every file written with it, and its claims table (for the index)."""

    path: Path
    files: list[Path]
    table: list[str]


def write_report(plan: Plan, evaluations: Evaluations, wall_s: float | None = None,
                 trained_in_calls: int = 0, figure_format: str = "png") -> WrittenReport:
    """Draw the figure (as ``figure_format``: png, pdf or svg), write its CSV and
    ``report.md`` into the plan's folder; ``wall_s``: the experiment's wall time so far (every
    call of ``reproduce`` on the folder), which trained ``trained_in_calls`` runs."""
    out, experiment = plan.out, plan.experiment
    analysis = ANALYSES[experiment.figure.kind](
        plan, evaluations, Outputs(out, experiment.id, figure_format))
    first = plan.runs[0].config["train"]
    lines = _header(plan, wall_s, trained_in_calls)
    if analysis.files:
        lines += [f"![{experiment.id}]({analysis.files[0].name})", "",
                  f"Plotted numbers: [{analysis.files[1].name}]({analysis.files[1].name}).", ""]
    per_group = experiment.figure.kind in PER_GROUP_KINDS
    reference, reach = REACHABLE.get(experiment.figure.kind, REACHABLE["uav-count"]
                                     if per_group else REACHABLE["learning-curves"])
    table = claims_table(experiment.claims, analysis, reference)
    lines += [*table, "", *statistics_lines(experiment.claims, analysis, _compared(plan))]
    notes = _notes(plan, evaluations, analysis)
    if notes:
        lines += ["Notes:", "", *(f"- {note}" for note in notes), ""]
    lines += ["Runs are in `runs/` (one HDF5 run file each), evaluations in `evals/`. "
              f"R_e^tot and J_e are the means of the last {_window(first['episodes'])} "
              "per-episode means (docs/model.md, section 5); ours: mean ± population "
              f"standard deviation (ddof = 0) over the runs; reachable: {reach}", ""]
    report = out / "report.md"
    write_text_atomic(report, "\n".join(lines))
    return WrittenReport(report, [*analysis.files, report], table)


def _compared(plan: Plan) -> Callable[[str, str], bool]:
    """Which rows' probabilities of improvement report.md gives: another group's policy of the
    same kind (last or best) and panel."""
    policies = plan.experiment.evaluation.policies
    kinds = {row_label(group.title, policy, policies): (group.name, group.panel, policy)
             for group in plan.experiment.groups for policy in policies}

    def compared(row: str, other: str) -> bool:
        a, b = kinds.get(row), kinds.get(other)
        return a is not None and b is not None and a[0] != b[0] and a[1:] == b[1:]
    return compared


def _header(plan: Plan, wall_s: float | None, trained_in_calls: int) -> list[str]:
    """report.md's title, where its numbers come from (version, command, runs, wall time and
    machine) and the scenario's note."""
    out, experiment, runs = plan.out, plan.experiment, plan.runs
    done = done_runs(runs)
    first = runs[0].config["train"]
    lines = [f"# {experiment.title}", ""]
    if experiment.paper_figure:
        lines += [f"The paper's {experiment.paper_figure}, reproduced by adaptsky "
                  f"{__version__} on {utc_timestamp()}.", ""]
    lines += [f"- command: `{command_line(plan)}`",
              f"- runs: {len(done)} of {len(runs)} done, {first['episodes']} episodes x "
              f"{first['steps']} steps each; groups: " + ", ".join(
                  f"{g.title} ({len(plan.group_runs(g.name))})" for g in experiment.groups)]
    if wall_s is not None:
        calls = read_calls(out).rows
        untracked = len(done) - trained_in_calls
        lines.append(f"- wall time: {format_duration(wall_s)}, training, evaluation and "
                     f"report over {plural(len(calls) + 1, 'call')} of reproduce "
                     f"(`calls.json`), on {_machine(calls)}" + (
                         f"; {plural(untracked, 'run')} trained by calls not recorded there "
                         "(by an earlier version, or by train)" if untracked > 0 else ""))
    if experiment.scenario_note:
        lines.append(f"- scenario: {experiment.scenario_note}")
    lines.append("")
    return lines


def _notes(plan: Plan, evaluations: Evaluations, analysis: Analysis) -> list[str]:
    """The claims no policy can match, the analysis's notes, and what was left out."""
    experiment = plan.experiment
    compared = {name: experiment.group(name).title
                for name in experiment.evaluation.compare_groups}
    notes = [*beyond_reach(experiment.claims, analysis, compared), *analysis.notes]
    notes += [f"left out: {name} ({why})" for name, why in evaluations.missing.items()]
    if evaluations.no_best:
        notes.append(f"best policy: {plural(len(evaluations.no_best), 'run')} had no greedy "
                     "evaluation during training (train.eval_every), so their best policy is "
                     f"their last: {', '.join(evaluations.no_best)}")
    return notes


def _machine(calls: list[dict[str, Any]]) -> str:
    """This machine (the call being made), and how many others the earlier calls ran on."""
    here = f"{os.cpu_count()} cores ({platform.machine()})"
    others = {(c.get("platform"), c.get("cpu_count")) for c in calls} - {
        (platform.platform(), os.cpu_count())}
    return here + (f" and {plural(len(others), 'other machine')}" if others else "")


def write_index(folder: Path, results: list[Any], wall_s: float) -> Path:
    """``folder/report.md`` of ``reproduce all``: each experiment's report linked, its claims
    table, its wall time in this call and the total."""
    lines = ["# adaptsky reproduce all", "",
             f"Every shipped experiment, reproduced by adaptsky {__version__} on "
             f"{utc_timestamp()} on {os.cpu_count()} cores ({platform.platform()}).", "",
             f"- wall time of this call: {format_duration(wall_s)} in all", "",
             "| experiment | paper | runs done | wall time (this call) | report |",
             "|---|---|---|---|---|"]
    for result in results:
        plan = result.plan
        done = len(done_runs(plan.runs))
        link = f"{plan.out.name}/report.md"
        lines.append(f"| {plan.experiment.title} | {plan.experiment.paper_figure or '-'} | "
                     f"{done}/{len(plan.runs)} | {format_duration(result.wall_s)} | "
                     f"[{link}]({link}) |")
    for result in results:
        lines += ["", f"## {result.plan.experiment.title}", "", *result.table]
    path = folder / "report.md"
    write_text_atomic(path, "\n".join(lines) + "\n")
    return path
