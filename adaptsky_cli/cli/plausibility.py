"""Plausibility warnings of the scenarios a command reads (``adaptsky.scenario.plausibility``:
values far outside what UAV networks use, most often a wrong unit), printed to stderr as
``adaptsky: warning: FILE: key = value ...``, each line once per process. The one place every
command that reads a scenario file goes through; a warning never changes the exit code."""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING

from adaptsky.errors import AdaptskyError
from adaptsky_cli.cli.console import err

if TYPE_CHECKING:  # commands start without pydantic and numpy
    from adaptsky.scenario.models import Scenario

_printed: set[str] = set()


def print_warnings(lines: Iterable[str]) -> None:
    """``adaptsky: warning: LINE`` on stderr for each line not printed before."""
    for line in lines:
        if line not in _printed:
            _printed.add(line)
            err.print(f"adaptsky: warning: {line}")


def warn_scenario(scenario: Scenario, source: str) -> None:
    """The warnings of a loaded scenario, its lines naming ``source``."""
    from adaptsky.scenario.plausibility import plausibility_warnings
    print_warnings(plausibility_warnings(scenario, source))


def warn_scenario_file(path: Path | None, set_values: list[str] | None = None) -> None:
    """The warnings of the scenario file ``path`` with its ``--set`` overrides (None: no
    file, nothing to say). A file that does not load says nothing here: the command reports
    it in its own words."""
    from adaptsky.scenario.loading import load_scenario_with_overrides
    if path is None:
        return
    try:
        scenario, source = load_scenario_with_overrides(path, set_values)
    except AdaptskyError:
        return
    warn_scenario(scenario, source)


def warn_experiment(name: str, set_values: list[str] | None = None) -> None:
    """The warnings of every scenario an experiment (a shipped id, ``all`` or a file) trains:
    each group's file with its overrides, at every sweep value, and ``--set`` on top."""
    from adaptsky.experiment.plan import load_experiment, paper_experiments
    from adaptsky.scenario.toml_writer import toml_value
    for experiment_name in paper_experiments() if name == "all" else [name]:
        try:
            experiment, path = load_experiment(experiment_name)
        except AdaptskyError:
            continue  # the command says why
        for group in experiment.groups:
            points: list[list[str]] = [[]] if group.sweep is None else [
                [f"{group.sweep.key}={toml_value(value)}"] for value in group.sweep.values]
            for point in points:
                warn_scenario_file(path.parent / group.scenario,
                                   [*group.set, *point, *(set_values or [])])
