"""Experiment files -> the plan: every run (one seed, one file) and every evaluation.

A run is the unit of work and its file is its state: ``DIR/runs/<run>.h5`` holds one seed of
one group at one sweep value. Shrinking options (``--runs``, ``--seeds``, ``--episodes``,
``--steps``) choose runs or become overrides of each run's scenario, recorded in its file, as
``--set`` does.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from adaptsky.errors import ScenarioError
from adaptsky.experiment.models import Experiment, Group
from adaptsky.scenario.loading import parse_toml, read_scenario_text, validation_error_lines
from adaptsky.scenario.toml_writer import toml_value
from adaptsky.shipped_files import shipped_folder
from adaptsky.training.api import load_with_overrides
from adaptsky.training.resources import check_fits


def shipped_experiments() -> dict[str, Path]:
    """Shipped experiment ids and their files."""
    folder = shipped_folder("experiments")
    return {} if folder is None else {path.stem: path for path in sorted(folder.glob("*.toml"))}


def paper_experiments() -> list[str]:
    """The shipped experiments of the paper (those with a ``paper_figure``), in id order:
    what ``reproduce all`` runs."""
    return [name for name in shipped_experiments() if load_experiment(name)[0].paper_figure]


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
        raise ScenarioError(validation_error_lines(str(path), error, model=Experiment)) from None
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
    shrink: dict[str, Any]

    def group_runs(self, group: str) -> list[RunSpec]:
        return [run for run in self.runs if run.group == group]

    def sweep_values(self, group: str) -> list[Any]:
        """The sweep values of ``group``'s planned runs, in the file's order (``[None]`` for a
        group without a sweep, ``[]`` for one without runs)."""
        return list(dict.fromkeys(run.sweep_value for run in self.group_runs(group)))

    def point_runs(self, group: str, sweep_value: Any) -> list[RunSpec]:
        """The runs of ``group`` at one sweep value (None: a group without a sweep)."""
        return [run for run in self.group_runs(group) if run.sweep_value == sweep_value]

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


def sweep_label(key: str, value: Any) -> str:
    """A sweep point as figures and tables name it: 'users.speed_m_per_step = 2' (a float as
    ``:g`` writes it, a bool as TOML does)."""
    text = str(value).lower() if isinstance(value, bool) else _value_label(value)
    return f"{key} = {text}"


def point_title(group: Group, value: Any) -> str:
    """A group's title at one sweep point: 'bdq, users.speed_m_per_step = 2' (its title alone
    for a group without a sweep)."""
    if group.sweep is None or value is None:
        return group.title
    return f"{group.title}, {sweep_label(group.sweep.key, value)}"


def _group_runs(group: Group, experiment_file: Path, out: Path, seeds: list[int],
                common: list[str]) -> list[RunSpec]:
    scenario_path = experiment_file.parent / group.scenario
    points: list[tuple[Any, list[str], str]] = [(None, [], "")]
    if group.sweep is not None:
        short = group.sweep.key.rsplit(".", 1)[-1]
        points = [(value, [f"{group.sweep.key}={toml_value(value)}"],
                   f"-{short}-{_value_label(value)}") for value in group.sweep.values]
    specs = []
    for value, sweep_set, label in points:
        for seed in seeds:
            items = (*group.set, *sweep_set, *common, f"train.seeds=[{seed}]")
            scenario, _ = load_with_overrides(scenario_path, list(items))
            name = f"{group.name}{label}-seed{seed}"
            check_fits(scenario, f"{experiment_file}: run {name}", workers=1)
            specs.append(RunSpec(name, group.name, seed, value, out / "runs" / f"{name}.h5",
                                 scenario_path, items, scenario.model_dump(mode="json")))
    return specs


def planned_seeds(group: Group, runs: int | None, seeds: list[int] | None) -> list[int]:
    """A group's seeds: 0 .. ``group.runs`` - 1, at most ``runs`` of them, only ``seeds``
    among them where given."""
    planned = range(min(group.runs, runs) if runs is not None else group.runs)
    return [seed for seed in planned if seeds is None or seed in seeds]


def _check_seeds(experiment: Experiment, experiment_file: Path, runs: int | None,
                 seeds: list[int] | None) -> None:
    """Refuse ``--seeds`` that no group plans (every seed given must be one of them)."""
    planned = {seed for group in experiment.groups for seed in planned_seeds(group, runs, None)}
    missing = [seed for seed in seeds or [] if seed not in planned]
    if missing:
        top = max(planned)
        within = f" with --runs {runs}" if runs is not None else ""
        raise ScenarioError([f"{experiment_file}: --seeds: {', '.join(map(str, missing))} "
                             f"not planned; the experiment's seeds{within} are 0-{top}"])


def plan_experiment(experiment: Experiment, experiment_file: Path, out: Path, *,
                    runs: int | None = None, seeds: list[int] | None = None,
                    episodes: int | None = None, steps: int | None = None,
                    set_values: list[str] | None = None) -> Plan:
    """Every run of the experiment, shrunk to ``runs`` runs per group and point (seeds 0 ..
    runs - 1), to the planned ``seeds`` among them and to ``episodes`` x ``steps`` where
    given."""
    _check_seeds(experiment, experiment_file, runs, seeds)
    common = list(set_values or [])
    common += [f"train.episodes={episodes}"] if episodes is not None else []
    common += [f"train.steps={steps}"] if steps is not None else []
    specs = []
    for group in experiment.groups:
        specs += _group_runs(group, experiment_file, out, planned_seeds(group, runs, seeds),
                             common)
    return Plan(experiment, experiment_file, out, specs, list(set_values or []),
                {"runs": runs, "seeds": seeds, "episodes": episodes, "steps": steps})


def scenario_text(spec: RunSpec) -> str:
    return read_scenario_text(spec.scenario_path)
