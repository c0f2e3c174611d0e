"""Plausibility warnings of the scenarios a command reads (``adaptsky.scenario.plausibility``:
values far outside what UAV networks use, most often a wrong unit), printed to stderr as
``adaptsky: warning: FILE: key = value ...``, each line once per process, and the notes of a
``--set`` that changed a model (``adaptsky: note: FILE with --set: dropped ...``). The one
place every command that reads a scenario file goes through; neither changes the exit code."""

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


def print_notes(lines: Iterable[str]) -> None:
    """``adaptsky: note: LINE`` on stderr for each line not printed before."""
    for line in lines:
        if line not in _printed:
            _printed.add(line)
            err.print(f"adaptsky: note: {line}", markup=False, soft_wrap=True)


def warn_scenario_file(path: Path | None, set_values: list[str] | None = None,
                       run: Path | None = None) -> None:
    """The warnings of the scenario file ``path`` with its ``--set`` overrides, and a note
    for the keys an override that changes a model dropped (``adaptsky.scenario.switches``);
    without a file, the notes of the overrides of ``run``'s scenario (None: nothing to say).
    A file that does not load says nothing here: the command reports it in its own words."""
    from adaptsky.scenario.loading import (
        load_scenario_with_overrides,
        parse_toml,
        read_scenario_text,
    )
    from adaptsky.scenario.overrides import override_notes
    if path is None:
        if run is not None and set_values:
            _note_run_overrides(run, set_values)
        return
    try:
        scenario, source = load_scenario_with_overrides(path, set_values)
        if set_values:
            print_notes(override_notes(parse_toml(read_scenario_text(path), str(path)),
                                       set_values, source))
    except AdaptskyError:
        return
    warn_scenario(scenario, source)


def _note_run_overrides(run: Path, set_values: list[str]) -> None:
    """The notes of ``--set`` on the scenario a run trained on (as ``evaluate`` applies it)."""
    from adaptsky.scenario.overrides import override_notes
    from adaptsky.store.run_file import RunReader
    try:
        with RunReader(run, needs="curves") as reader:
            data = reader.scenario.model_dump(mode="json")
        # the source evaluation.api.evaluation_base names
        print_notes(override_notes(data, set_values, "the run's scenario with --set"))
    except AdaptskyError:
        return


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
