"""Evaluating a plan: greedy rollouts of every run of the evaluated groups (its last policy,
and its best one where the experiment asks) and the baselines on the same layouts, one eval
file each in ``DIR/evals/`` (``<run>.h5``, ``<run>-best.h5``, ``<baseline>[-<value>].h5``).

An eval file records what it evaluated (scenario, layouts, steps and, for a policy, the
episodes its run had done); a later call reuses it when that record matches, so a finished
folder is not evaluated twice.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from adaptsky.errors import AdaptskyError
from adaptsky.evaluation.api import eval_layouts, results_json, with_policy
from adaptsky.experiment.models import PER_GROUP_KINDS
from adaptsky.experiment.plan import Plan, RunSpec
from adaptsky.progress import Reporter, WorkProgress
from adaptsky.references.registry import resolve
from adaptsky.rollouts.metrics import Method
from adaptsky.rollouts.rollout import greedy_policy, rollout
from adaptsky.scenario import Scenario, parse_scenario
from adaptsky.scenario.variants import eval_scenario
from adaptsky.store.eval_file import read_eval_metrics, write_eval
from adaptsky.store.run_file import RunReader
from adaptsky.units import plural

Metrics = dict[str, np.ndarray]


@dataclass
class Evaluations:
    """Per-layout metrics of every evaluated run's last policy (``runs``) and best policy
    (``best``), by run name, and of every baseline (by method and sweep value, or by method
    and group for a figure whose groups are x points, ``PER_GROUP_KINDS``); ``missing``
    says what could not be evaluated and why; ``no_best`` names the runs without a greedy
    evaluation during training, whose best policy is their last."""

    runs: dict[str, Metrics] = field(default_factory=dict)
    baselines: dict[tuple[str, Any], Metrics] = field(default_factory=dict)
    missing: dict[str, str] = field(default_factory=dict)
    best: dict[str, Metrics] = field(default_factory=dict)
    no_best: list[str] = field(default_factory=list)

    def of(self, policy: str) -> Evaluations:
        """The same evaluations with ``policy``'s ("last" or "best") metrics as ``runs``."""
        return self if policy == "last" else replace(self, runs=self.best)


def _cached(path: Path, record: dict[str, Any]) -> Metrics | None:
    if not path.exists():
        return None
    try:
        stored, methods = read_eval_metrics(path)
    except AdaptskyError:
        return None  # damaged: evaluate again
    if stored != json.loads(json.dumps(record)) or len(methods) != 1:
        return None
    return next(iter(methods.values()))


def _store(path: Path, scenario: Scenario, method: Method, record: dict[str, Any],
           steps: int, layouts: int | None, layout_seed: int, users_m: np.ndarray) -> Metrics:
    results = results_json([method], scenario, steps, layouts, layout_seed, users_m)
    results["record"] = record
    path.parent.mkdir(parents=True, exist_ok=True)
    write_eval(path, results, [method])
    # as the file holds them (with a search's record): what a later call reads back
    return next(iter(read_eval_metrics(path)[1].values()))


def _label(value: Any) -> str:
    return "" if value is None else f"-{value:g}" if isinstance(value, float) else f"-{value}"


def evaluate_plan(plan: Plan, reporter: Reporter) -> Evaluations:
    """Evaluate every finished run of the evaluated groups and every baseline, with progress
    (a bar per stage where ``reporter`` draws live, else timestamped lines)."""
    with WorkProgress(reporter) as progress:
        return _evaluate_plan(plan, progress)


def _evaluate_plan(plan: Plan, progress: WorkProgress) -> Evaluations:
    from adaptsky.experiment.runs import run_state  # imports torch: only when evaluating

    spec = plan.experiment.evaluation
    per_group = plan.experiment.figure.kind in PER_GROUP_KINDS
    evaluations = Evaluations()
    folder = plan.out / "evals"
    points: dict[Any, RunSpec] = {}
    layouts: dict[Any, np.ndarray] = {}
    def layouts_of(group: str) -> int | None:
        """How many uniform layouts ``group`` is evaluated on (None: its own layout)."""
        own = plan.experiment.group(group).eval_layouts if per_group else None
        return own if own is not None else spec.layouts

    for group in (spec.policy, *spec.compare_groups, *spec.also):
        count = layouts_of(group)
        for run in plan.group_runs(group):
            state = run_state(run)
            if state.status != "done":
                evaluations.missing[run.name] = (f"{state.episodes_done}/{run.episodes} "
                                                 "episodes")
                continue
            trained = parse_scenario(run.config, run.name)
            scenario = eval_scenario(trained, count, spec.layout_seed)
            users_m = eval_layouts(scenario, count)
            point = group if per_group else run.sweep_value
            first = layouts.setdefault(point, users_m)
            if not np.array_equal(first, users_m):
                raise AdaptskyError(f"{plan.experiment_path}: group '{group}' is evaluated on "
                                    f"other layouts than group '{spec.policy}' (another area "
                                    "or number of users); the groups of one experiment share "
                                    "its layouts")
            record = {"kind": "policy", "run": run.name, "episodes_done": state.episodes_done,
                      "scenario": scenario.model_dump(mode="json"), "steps": spec.steps,
                      "layouts": count, "layout_seed": spec.layout_seed}
            for which in spec.policies:
                # the last policy's record is the one eval files have always had
                mine = record if which == "last" else {**record, "policy": which}
                suffix = "" if which == "last" else f"-{which}"
                path = folder / f"{run.name}{suffix}.h5"
                best = None
                if which == "best":
                    with RunReader(run.path) as reader:
                        best = reader.best(run.seed)
                    if best is None:
                        evaluations.no_best.append(run.name)
                metrics = _cached(path, mine)
                if metrics is None:
                    with RunReader(run.path) as reader:
                        checkpoint = reader.checkpoint(run.seed)
                    policy = greedy_policy(trained, with_policy(trained, checkpoint, best))
                    stage = (f"evaluating {run.name}{suffix} on "
                             f"{plural(len(users_m), 'layout')}")
                    with progress.stage(stage, spec.steps, "step") as tick:
                        method = Method.of("policy", scenario, rollout(
                            scenario, policy, spec.steps, users_m, on_step=tick))
                    metrics = _store(path, scenario, method, mine, spec.steps, count,
                                     spec.layout_seed, users_m)
                (evaluations.runs if which == "last" else evaluations.best)[run.name] = metrics
            if group == spec.policy or per_group:
                points.setdefault(point, run)
    if per_group:   # a group's baselines need no finished run: its scenario is planned
        for group in (spec.policy, *spec.also):
            planned = plan.group_runs(group)
            if planned and group not in points:
                points[group] = planned[0]
    # a baseline measures the network, not the learner: points whose scenarios differ only in
    # [agent], [train], name or description share it (a conditions figure's learners on one task)
    shared: dict[str, Metrics] = {}
    for value, run in points.items():
        count = layouts_of(value) if per_group else spec.layouts
        scenario = eval_scenario(parse_scenario(run.config, run.name), count,
                                 spec.layout_seed)
        users_m = eval_layouts(scenario, count)
        own = plan.experiment.group(value).baselines if per_group else None
        for name in spec.baselines if own is None else own:
            record = {"kind": name, "scenario": scenario.model_dump(mode="json"),
                      "steps": spec.steps, "layouts": count,
                      "layout_seed": spec.layout_seed}
            path = folder / f"{name}{_label(value)}.h5"
            network = json.dumps({**record, "scenario": {
                key: part for key, part in record["scenario"].items()
                if key not in ("agent", "train", "name", "description")}}, sort_keys=True)
            metrics = shared.get(network) or _cached(path, record)
            if metrics is None:
                try:
                    reference = resolve(name, scenario)
                    total, unit = reference.work(scenario, spec.steps, users_m)
                    stage = f"evaluating {name}{_label(value)}" + (
                        "" if unit == "layout" else f" on {plural(len(users_m), 'layout')}")
                    with progress.stage(stage, total, unit) as tick:
                        method = reference.run(scenario, spec.steps, users_m,
                                               on_progress=tick)
                except AdaptskyError as error:
                    evaluations.missing[f"{name}{_label(value)}"] = str(error)
                    continue
                metrics = _store(path, scenario, method, record, spec.steps, count,
                                 spec.layout_seed, users_m)
            shared[network] = metrics
            evaluations.baselines[(name, value)] = metrics
    return evaluations
