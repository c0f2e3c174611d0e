"""The benchmark table of the suite (issue 40, docs/results/benchmark.md): from a finished
``adaptsky reproduce suite --out DIR``, each task's learners as a share of the task's bound,
the interquartile mean over the runs with its stratified bootstrap 95% interval, for the last
and the best policies; the runs, the wall time and the machine from the folder.

    .venv/bin/python scripts/benchmark_table.py DIR [--experiment experiments/suite.toml]
        [--write docs/results/benchmark.md --figure suite/suite.png]
        [--runs N --episodes E --steps T]

(``--runs``, ``--episodes`` and ``--steps`` as given to that reproduce, if any.)

Reads the runs' and baselines' eval files the reproduce wrote (``evaluate_plan`` finds them
cached: nothing is rolled out again where they are complete). The groups of the experiment
are named ``<task>-<learner>``, labelled ``<learner>, <task>``, and panelled by task.
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from adaptsky.experiment.analysis import Outputs  # noqa: E402
from adaptsky.experiment.calls import read_calls  # noqa: E402
from adaptsky.experiment.conditions import conditions  # noqa: E402
from adaptsky.experiment.evaluation import evaluate_plan  # noqa: E402
from adaptsky.experiment.plan import load_experiment, plan_experiment  # noqa: E402
from adaptsky.progress import Silent  # noqa: E402
from adaptsky.report.statistics import bootstrap_interval  # noqa: E402
from adaptsky.units import format_duration, plural  # noqa: E402

LEARNERS = ("dueling DQN", "BDQ", "PPO", "SAC", "MAPPO")
BOUNDS = {  # each task's bound (docs/evaluation.md#baselines), by the groups' task prefix
    "paper": "the oracle of the training layout (exhaustive search of the lattice)",
    "any": "the oracle of each of 20 unseen uniform layouts",
    "u2": "best response (a reference for several UAVs, not an optimum)",
    "u4": "best response (a reference for several UAVs, not an optimum)",
    "moving-fading": ("the per-step oracle that knows each step's positions and fading "
                      "draws (an upper bound on any policy of one UAV)"),
    "city": ("the static ceiling: the best fixed position and shares over the policy's own "
             "fading draws (a ceiling for static policies only)"),
}


def header(title: str, spec_note: str, tasks: dict[str, str], figure: str | None) -> list[str]:
    """The document's title, what it measures, each task's bound and the figure."""
    lines = [f"# {title}", "",
             "Written by `scripts/benchmark_table.py` from a finished `adaptsky reproduce "
             "suite` (docs/reproduce.md#the-benchmark-suite). " + spec_note, "",
             "Each cell is the greedy steady state (the mean sum rate over the last 100 of "
             "1000 greedy steps, on the task's evaluation layouts) as a share of the task's "
             "bound, for the five runs of the cell: their interquartile mean with its "
             "stratified bootstrap 95% interval (docs/evaluation.md#statistics).", "",
             "| task | bound |", "|---|---|"]
    lines += [f"| {panel} | {bound} |" for panel, bound in tasks.items()]
    if figure is not None:
        lines += ["", f"![the suite: sum rates per task, learners beside their bounds]({figure})"]
    return [*lines, ""]


def cell(values: list[float]) -> str:
    finite = [v for v in values if math.isfinite(v)]
    if not finite:
        return "-"
    if len(finite) < 3:
        return ", ".join(f"{v:.1f}" for v in finite) + f" (n = {len(finite)})"
    interval = bootstrap_interval(finite)
    return (f"{interval.estimate:.1f} [{interval.low:.1f}, {interval.high:.1f}] "
            f"(n = {len(finite)})")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", type=Path)
    parser.add_argument("--experiment", default=str(ROOT / "experiments" / "suite.toml"))
    parser.add_argument("--write", type=Path, default=None)
    parser.add_argument("--figure", default=None,
                        help="the suite's figure, as linked from the written file")
    for option in ("--runs", "--episodes", "--steps"):
        parser.add_argument(option, type=int, default=None)
    args = parser.parse_args()
    spec, path = load_experiment(args.experiment)
    plan = plan_experiment(spec, path, args.folder, runs=args.runs, episodes=args.episodes,
                           steps=args.steps)
    evaluations = evaluate_plan(plan, Silent())
    with tempfile.TemporaryDirectory() as scratch:
        analysis = conditions(plan, evaluations, Outputs(Path(scratch), spec.id, "png"))
    tasks: dict[str, dict[str, dict[str, list[float]]]] = {}
    bounds: dict[str, str] = {}
    for group in spec.groups:
        bounds[group.panel] = BOUNDS.get(group.name.rsplit("-", 1)[0], "-")
        learner, _, _ = group.title.partition(", ")
        for policy in spec.evaluation.policies:
            row = f"{group.title}, {policy} policy"
            values = analysis.quantities.get(row, {}).get("pct_of_bound", [])
            tasks.setdefault(group.panel, {}).setdefault(policy, {})[learner] = values
    learners = [name for name in LEARNERS
                if any(name in by for t in tasks.values() for by in t.values())]
    lines = header(spec.title, " ".join(spec.scenario_note.split()), bounds, args.figure)
    for policy in spec.evaluation.policies:
        lines += [f"**{policy.capitalize()} policies**: greedy steady state, % of the task's "
                  "bound, interquartile mean [95% bootstrap interval] (runs):", "",
                  "| task | " + " | ".join(learners) + " |",
                  "|---|" + "---|" * len(learners)]
        for task, by_policy in tasks.items():
            found = by_policy.get(policy, {})
            lines.append(f"| {task} | " + " | ".join(
                cell(found[name]) if name in found else "n/a" for name in learners) + " |")
        lines.append("")
    calls = read_calls(args.folder)
    runs = len(plan.runs)
    lines.append("n/a: a learner that does not fit the task (SAC and the dueling DQN act for "
                 "one UAV, MAPPO for several); -: no finished run.")
    lines.append("")
    machines = sorted({f"{row.get('cpu_count', '?')} cores ({row.get('platform', '?')}), "
                       f"{row.get('device', '?')}, torch {row.get('torch_version', '?')}"
                       for row in calls.rows})
    lines.append(f"{runs} runs ({len(spec.groups)} cells), trained, evaluated and reported in "
                 f"{format_duration(calls.wall_s)} over {plural(len(calls.rows), 'call')} of "
                 f"reproduce (`calls.json`), on {'; '.join(machines) or 'an unrecorded machine'}.")
    text = "\n".join(lines) + "\n"
    if args.write is not None:
        args.write.write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
