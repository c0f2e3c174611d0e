"""The search space of ``adaptsky tune`` (docs/tuning.md): a TOML file naming scenario keys as
``--set`` does, each with a range or a list of choices, and the study's settings.

.. code-block:: toml

    [space]
    "agent.lr" = { low = 1e-4, high = 3e-3, log = true }       # a float, log-uniform
    "agent.batch_size" = { choices = [64, 128, 256] }          # one of these
    "agent.hidden_sizes" = { choices = [[64, 64], [256, 256]] }
    "agent.update_epochs" = { low = 2, high = 10 }             # integers where both ends are
    "agent.gamma" = { low = 0.9, high = 0.999, step = 0.003 }  # a float on a grid

    [study]                     # optional; these are the defaults
    objective = "last"          # the last greedy evaluation's score, or "best" (the best's)
    pruner = "median"           # or "none"
    startup_trials = 5          # random trials before TPE models the space; none pruned
    warmup_evaluations = 2      # greedy evaluations of a trial before it may be pruned
    seed = 0                    # the sampler's

Every bound and choice is checked against the scenario as an override would be, so a bad
space gets one line before any trial runs.
"""

from __future__ import annotations

import json
import math
import tomllib
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, Literal

from adaptsky.errors import AdaptskyError, ScenarioError
from adaptsky.scenario.loading import parse_with_overrides, read_scenario_text
from adaptsky.scenario.overrides import parse_value
from adaptsky.scenario.toml_writer import toml_value

RANGE_FIELDS = {"low", "high", "log", "step"}
STUDY_FIELDS = {"objective": ("last", "best"), "pruner": ("median", "none")}
STUDY_INTS = {"startup_trials": 5, "warmup_evaluations": 2, "seed": 0}
# chosen by tune's own options or fixed by the trial's run file, never searched
NOT_SEARCHED = {"train.seeds": "a trial's seeds are the scenario's (set them with --set)",
                "train.episodes": "give --episodes", "train.steps": "give --steps",
                "name": "a trial's name is the scenario's"}


class SpaceError(AdaptskyError):
    """A search space that cannot be used: one line naming the file, the key and why."""


def compact(value: Any) -> str:
    """``value`` as TOML on one line (``[64, 64]``, ``0.0012``), as ``--set`` reads it."""
    if isinstance(value, list):
        return "[" + ", ".join(compact(item) for item in value) + "]"
    return toml_value(value)


def shown(value: Any) -> str:
    """A sampled value for people: floats to 4 significant digits."""
    return f"{value:.4g}" if isinstance(value, float) else str(value)


@dataclass(frozen=True)
class Parameter:
    """One searched key: a range (``low``..``high``, ``log`` or ``step``; integers where both
    ends are) or ``choices`` (kept as their TOML text, so lists can be chosen too)."""

    key: str
    low: float | None = None
    high: float | None = None
    log: bool = False
    step: float | None = None
    integer: bool = False
    choices: tuple[str, ...] = ()

    def value_of(self, sampled: Any) -> Any:
        """The scenario value of an Optuna sample of this parameter."""
        return parse_value(sampled) if self.choices else sampled

    def override(self, sampled: Any) -> str:
        """The ``--set`` text of a sample: ``agent.lr=0.0012``."""
        return f"{self.key}={compact(self.value_of(sampled))}"


@dataclass(frozen=True)
class StudySettings:
    objective: Literal["last", "best"] = "last"
    pruner: Literal["median", "none"] = "median"
    startup_trials: int = 5
    warmup_evaluations: int = 2
    seed: int = 0


@dataclass(frozen=True)
class Space:
    parameters: tuple[Parameter, ...]
    study: StudySettings

    def to_json(self) -> str:
        """The space as a study remembers it (running it again must search the same)."""
        return json.dumps({"parameters": [asdict(p) for p in self.parameters],
                           "study": asdict(self.study)}, sort_keys=True)

    def distributions(self) -> dict[str, Any]:
        """Optuna's distribution of every parameter, by key."""
        from optuna.distributions import (
            CategoricalDistribution,
            FloatDistribution,
            IntDistribution,
        )

        out: dict[str, Any] = {}
        for p in self.parameters:
            if p.choices:
                out[p.key] = CategoricalDistribution(p.choices)
            elif p.integer:
                out[p.key] = IntDistribution(int(p.low), int(p.high), log=p.log,  # type: ignore[arg-type]
                                             step=int(p.step or 1))
            else:
                out[p.key] = FloatDistribution(p.low, p.high, log=p.log, step=p.step)  # type: ignore[arg-type]
        return out

    def suggest(self, trial: Any) -> dict[str, Any]:
        """The trial's value of every parameter: those it holds, and the ones a process killed
        while Optuna was still writing them drawn now (Optuna's ``suggest_*`` return a value
        the trial has and sample one it lacks)."""
        values: dict[str, Any] = {}
        for p in self.parameters:
            if p.choices:
                values[p.key] = trial.suggest_categorical(p.key, list(p.choices))
            elif p.integer:
                values[p.key] = trial.suggest_int(p.key, int(p.low), int(p.high),  # type: ignore[arg-type]
                                                  step=int(p.step or 1), log=p.log)
            else:
                values[p.key] = trial.suggest_float(p.key, p.low, p.high, step=p.step,  # type: ignore[arg-type]
                                                    log=p.log)
        return values

    def overrides(self, params: dict[str, Any]) -> list[str]:
        """The ``--set`` texts of a trial's sampled ``params``, in the space's order."""
        return [p.override(params[p.key]) for p in self.parameters]


def _number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def _parameter(key: str, spec: Any, where: str) -> Parameter:
    """One ``[space]`` entry, checked for its own shape (not yet against the scenario)."""
    if key in NOT_SEARCHED:
        raise SpaceError(f"{where}: cannot be searched: {NOT_SEARCHED[key]}")
    if "." not in key and key != "name":
        raise SpaceError(f"{where}: expected a scenario key as --set names it, "
                         "e.g. \"agent.lr\" or \"reward.w_rate\"")
    if not isinstance(spec, dict):
        raise SpaceError(f"{where}: expected a table, {{ low = .., high = .. }} or "
                         "{ choices = [..] }")
    if "choices" in spec:
        extra = sorted(set(spec) - {"choices"})
        if extra:
            raise SpaceError(f"{where}: '{extra[0]}' does not go with choices "
                             "(a key has either choices or low and high)")
        choices = spec["choices"]
        if not isinstance(choices, list) or not choices:
            raise SpaceError(f"{where}.choices: expected a non-empty list of values")
        if any(isinstance(choice, dict) for choice in choices):
            raise SpaceError(f"{where}.choices: a choice is a table; choose values or lists")
        texts = tuple(compact(choice) for choice in choices)
        if len(set(texts)) != len(texts):
            raise SpaceError(f"{where}.choices: a choice is given twice")
        return Parameter(key, choices=texts)
    unknown = sorted(set(spec) - RANGE_FIELDS)
    if unknown:
        raise SpaceError(f"{where}: unknown field '{unknown[0]}'; allowed: choices, or low, "
                         "high, log and step")
    if "low" not in spec or "high" not in spec:
        raise SpaceError(f"{where}: needs low and high (or choices)")
    low, high, log, step = spec["low"], spec["high"], spec.get("log", False), spec.get("step")
    if not _number(low) or not _number(high):
        raise SpaceError(f"{where}: low and high must be finite numbers")
    if low >= high:
        raise SpaceError(f"{where}: low ({low}) must be below high ({high})")
    if not isinstance(log, bool):
        raise SpaceError(f"{where}.log: expected true or false")
    if log and low <= 0:
        raise SpaceError(f"{where}: log = true needs low > 0 (low is {low})")
    if step is not None and (not _number(step) or step <= 0):
        raise SpaceError(f"{where}.step: expected a positive number")
    if log and step is not None:
        raise SpaceError(f"{where}: log and step exclude each other")
    integer = all(isinstance(v, int) for v in (low, high)) and (step is None
                                                               or isinstance(step, int))
    return Parameter(key, float(low), float(high), log, None if step is None else float(step),
                     integer)


def _study(table: Any, source: str) -> StudySettings:
    if not isinstance(table, dict):
        raise SpaceError(f"{source}: study: expected a table")
    values: dict[str, Any] = {}
    for name, value in table.items():
        where = f"{source}: study.{name}"
        if name in STUDY_FIELDS:
            if value not in STUDY_FIELDS[name]:
                raise SpaceError(f"{where}: {value!r} is not allowed; allowed: "
                                 f"{', '.join(STUDY_FIELDS[name])}")
        elif name in STUDY_INTS:
            if not isinstance(value, int) or isinstance(value, bool) or value < 0:
                raise SpaceError(f"{where}: expected a whole number >= 0")
        else:
            raise SpaceError(f"{where}: unknown setting; allowed: "
                             f"{', '.join([*STUDY_FIELDS, *STUDY_INTS])}")
        values[name] = value
    return StudySettings(**values)


def load_space(path: Path) -> Space:
    """The space file at ``path``, its own shape checked (:func:`check_against` checks it
    against a scenario)."""
    text = read_scenario_text(path, "space file")
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:
        raise SpaceError(f"{path}: not valid TOML: {error}") from None
    unknown = sorted(set(data) - {"space", "study"})
    if unknown:
        raise SpaceError(f"{path}: unknown table '{unknown[0]}'; allowed: space, study")
    table = data.get("space")
    if not isinstance(table, dict) or not table:
        raise SpaceError(f"{path}: space: expected a [space] table naming at least one "
                         "scenario key, e.g. \"agent.lr\" = { low = 1e-4, high = 3e-3, "
                         "log = true }")
    parameters = tuple(_parameter(key, spec, f"{path}: space.\"{key}\"")
                       for key, spec in table.items())
    return Space(parameters, _study(data.get("study", {}), str(path)))


def check_against(space: Space, space_path: Path, scenario_path: Path,
                  set_values: list[str]) -> None:
    """Every bound and choice of ``space`` applied to the scenario (after ``set_values``) must
    give a valid scenario; the first that does not, in one line."""
    text = read_scenario_text(scenario_path)
    for p in space.parameters:
        values = ([parse_value(c) for c in p.choices] if p.choices else
                  [int(v) if p.integer else v for v in (p.low, p.high)])
        for value in values:
            override = f"{p.key}={compact(value)}"
            try:
                parse_with_overrides(text, scenario_path, [*set_values, override])
            except ScenarioError as error:
                reason = error.lines[0].split(": ", 1)[-1] if error.lines else str(error)
                raise SpaceError(f"{space_path}: space.\"{p.key}\": {compact(value)} is not "
                                 f"a valid value in {scenario_path}: {reason}") from None
