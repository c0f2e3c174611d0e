"""Experiment files -> the plan: every run (one seed, one file) and every evaluation.

A run is the unit of work and its file is its state: ``DIR/runs/<run>.h5`` holds one seed of
one group at one sweep value. Shrinking options (``--seeds``, ``--episodes``, ``--steps``)
and ``--set`` become overrides of each run's scenario, recorded in its file.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from adaptsky.errors import ScenarioError
from adaptsky.experiment.models import Experiment, Group
from adaptsky.scenario.loading import _error_lines, parse_toml, read_scenario_text
from adaptsky.scenario.toml_writer import toml_value
from adaptsky.shipped_files import shipped_folder
from adaptsky.training.api import load_with_overrides
from adaptsky.training.resources import check_fits


def shipped_experiments() -> dict[str, Path]:
    """Shipped experiment ids and their files."""
    folder = shipped_folder("experiments")
    return {} if folder is None else {path.stem: path for path in sorted(folder.glob("*.toml"))}


def experiment_path(name: str) -> Path:
    """A shipped id (``e3``) or the path of an experiment file."""
    shipped = shipped_experiments()
    if name in shipped:
        return shipped[name]
    path = Path(name)
    if path.suffix != ".toml" and not path.exists():
        known = ", ".join(shipped) or "none found"
        raise ScenarioError([f"{name}: no such experiment; give a shipped id ({known}) or the "
                             "path of an experiment file (.toml)"])
    return path


def load_experiment(name: str) -> tuple[Experiment, Path]:
    """The validated experiment and its file; every problem is one ``file: key: message``
    line."""
    path = experiment_path(name)
    data = parse_toml(read_scenario_text(path, "experiment file"), str(path))
    try:
        experiment = Experiment.model_validate(data)
    except ValidationError as error:
        raise ScenarioError(_error_lines(str(path), error)) from None
    for group in experiment.groups:
        scenario_file = path.parent / group.scenario
        if not scenario_file.is_file():
            raise ScenarioError([f"{path}: groups.{group.name}.scenario: no such file "
                                 f"{scenario_file}"])
    return experiment, path


@dataclass(frozen=True)
class RunSpec:
    """One run: a seed of a group (at a sweep value), its overrides and resolved scenario."""

    name: str
    group: str
    seed: int
    sweep_value: Any
    path: Path
    scenario_path: Path
    set_values: tuple[str, ...]
    config: dict[str, Any] = field(compare=False, hash=False)

    @property
    def episodes(self) -> int:
        return int(self.config["train"]["episodes"])


@dataclass
class Plan:
    experiment: Experiment
    experiment_path: Path
    out: Path
    runs: list[RunSpec]
    set_values: list[str]
    shrink: dict[str, int | None]

    def group_runs(self, group: str) -> list[RunSpec]:
        return [run for run in self.runs if run.group == group]

    def run(self, group: str, seed: int, sweep_value: Any = None) -> RunSpec | None:
        return next((r for r in self.runs if (r.group, r.seed, r.sweep_value)
                     == (group, seed, sweep_value)), None)

    def record(self) -> dict[str, Any]:
        """The plan as JSON-able values (written to DIR/plan.json)."""
        return {"experiment": self.experiment.id, "file": str(self.experiment_path),
                "set": self.set_values, "shrink": self.shrink,
                "runs": [{"name": r.name, "group": r.group, "seed": r.seed,
                          "sweep_value": r.sweep_value, "file": str(r.path),
                          "scenario": str(r.scenario_path), "set": list(r.set_values)}
                         for r in self.runs]}


def _value_label(value: Any) -> str:
    return f"{value:g}" if isinstance(value, float) else str(value)


def _group_runs(group: Group, experiment_file: Path, out: Path, runs: int,
                common: list[str]) -> list[RunSpec]:
    scenario_path = experiment_file.parent / group.scenario
    points: list[tuple[Any, list[str], str]] = [(None, [], "")]
    if group.sweep is not None:
        short = group.sweep.key.rsplit(".", 1)[-1]
        points = [(value, [f"{group.sweep.key}={toml_value(value)}"],
                   f"-{short}-{_value_label(value)}") for value in group.sweep.values]
    specs = []
    for value, sweep_set, label in points:
        for seed in range(runs):
            items = (*group.set, *sweep_set, *common, f"train.seeds=[{seed}]")
            scenario, _ = load_with_overrides(scenario_path, list(items))
            name = f"{group.name}{label}-seed{seed}"
            check_fits(scenario, f"{experiment_file}: run {name}", workers=1)
            specs.append(RunSpec(name, group.name, seed, value, out / "runs" / f"{name}.h5",
                                 scenario_path, items, scenario.model_dump(mode="json")))
    return specs


def plan_experiment(experiment: Experiment, experiment_file: Path, out: Path, *,
                    seeds: int | None = None, episodes: int | None = None,
                    steps: int | None = None, set_values: list[str] | None = None) -> Plan:
    """Every run of the experiment, shrunk to ``seeds`` runs per group and point and to
    ``episodes`` x ``steps`` where given."""
    common = list(set_values or [])
    common += [f"train.episodes={episodes}"] if episodes is not None else []
    common += [f"train.steps={steps}"] if steps is not None else []
    runs = []
    for group in experiment.groups:
        count = min(group.runs, seeds) if seeds is not None else group.runs
        runs += _group_runs(group, experiment_file, out, count, common)
    return Plan(experiment, experiment_file, out, runs, list(set_values or []),
                {"seeds": seeds, "episodes": episodes, "steps": steps})


def scenario_text(spec: RunSpec) -> str:
    return read_scenario_text(spec.scenario_path)
