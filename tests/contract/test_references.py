"""Contract tests of every reference in the registry (docs/evaluation.md#references): each
applies and refuses on the shipped scenarios as the docs' table says, a refusal is one line,
and a bound is at least every policy compared with it. A new reference gets them by its
registry line."""

from __future__ import annotations

import re
from pathlib import Path
from typing import get_args

import numpy as np
import pytest

from adaptsky.errors import AdaptskyError
from adaptsky.evaluation.api import eval_layouts
from adaptsky.experiment.models import Baseline
from adaptsky.references.registry import (
    NAMES,
    REGISTRY,
    reference_for,
    refusal,
    resolve,
)
from adaptsky.rollouts.rollout import random_controls_policy, rollout
from adaptsky.scenario.loading import load_scenario
from adaptsky.scenario.variants import eval_scenario, with_values
from adaptsky.sim.controls import controls_of

ROOT = Path(__file__).resolve().parents[2]
SCENARIOS = sorted(ROOT.glob("scenarios/*.toml"))
DOCS = ROOT / "docs" / "evaluation.md"
TABLE = re.compile(r"<!-- references-by-scenario: begin -->\n(.*?)<!-- references-by-scenario: "
                   r"end -->", re.S)
KINDS = {"Oracle": "oracle", "PerStepOracle": "per-step oracle",
         "StaticCeiling": "static ceiling", "BestResponse": "best response",
         "StepResponse": "best response at every step", "Oma": "OMA"}


def _cell(name: str, scenario) -> str:
    """What runs for ``name`` on ``scenario``, as the docs' table says it."""
    if refusal(name, scenario) is not None:
        return "refused"
    found = resolve(name, scenario)
    return f"{KINDS[type(found).__name__]} ({found.label(scenario)})"


def scenario_rows() -> str:
    """The docs' table of the shipped scenarios, from the registry."""
    rows = []
    for path in SCENARIOS:
        scenario = load_scenario(path)
        found = reference_for(scenario)
        percent = ("none: sum rates" if found is None or not found.per_layout(scenario)
                   else found.name)
        cells = [_cell(name, scenario) for name in ("oracle", "best-response", "oma")]
        rows.append(f"| `{path.name}` | {' | '.join(cells)} | {percent} |")
    return "\n".join(rows)


def test_the_docs_table_is_what_the_registry_says():
    block = TABLE.search(DOCS.read_text()).group(1)
    assert block.strip().splitlines()[2:] == scenario_rows().splitlines()


@pytest.mark.parametrize("path", SCENARIOS, ids=lambda path: path.stem)
def test_every_refusal_is_one_line_and_resolve_raises_it(path):
    scenario = load_scenario(path)
    for name in NAMES:
        reason = refusal(name, scenario)
        if reason is None:
            assert resolve(name, scenario).applies(scenario) is None
            continue
        assert reason and "\n" not in reason
        with pytest.raises(AdaptskyError) as caught:
            resolve(name, scenario, "--compare")
        text = str(caught.value)
        assert text.endswith(reason) and "\n" not in text
        assert text.startswith("--compare: ") or text.startswith(f"scenario '{scenario.name}'")


def test_unknown_names_list_every_choice():
    with pytest.raises(AdaptskyError, match="unknown method 'oracel'; choose from soa, "
                                            "tracking, oracle, best-response, oma, random, "
                                            "centroid"):
        resolve("oracel", load_scenario(SCENARIOS[0]))


def test_experiments_take_every_name():
    assert set(get_args(Baseline)) == set(NAMES)


def test_every_entry_says_what_it_is():
    scenario = load_scenario(ROOT / "scenarios" / "nyc_mmwave.toml")
    for entry in REGISTRY:
        assert entry.name in NAMES and entry.title and entry.what
        assert entry.label(scenario) in ("bound", "reference", "baseline")


BOUNDED = [("nyc_mmwave.toml", "oracle"), ("nyc_mmwave.toml", "best-response"),
           ("moving_users_sub6.toml", "oracle"), ("moving_users_fading_sub6.toml", "oracle")]


@pytest.mark.parametrize(("file", "name"), BOUNDED)
def test_a_bound_is_at_least_every_policy_at_every_step(file, name):
    """Random-control policies of three seeds on two layouts, step by step, under the same
    draws: none has a larger sum rate than the bound (R_min = 0, where the objective is the
    sum rate)."""
    base = load_scenario(ROOT / "scenarios" / file)
    coarse = with_values(with_values(base, "reward", {"min_se": 0.0}, base.name), "uav",
                         {"step_m": [5.0, 5.0, 5.0], "power_step": 0.05}, base.name)
    scenario = eval_scenario(coarse, 2, 0)   # (a coarse lattice: the same search, faster)
    found = resolve(name, scenario)
    assert found.label(scenario) == "bound"
    users_m, steps = eval_layouts(scenario, 2), 6
    bound = found.run(scenario, steps, users_m).trace.rate_bps.sum(axis=-1)   # (T, L)
    for seed in range(3):
        policy = random_controls_policy(controls_of(scenario, 2), seed)
        rates = rollout(scenario, policy, steps, users_m).rate_bps.sum(axis=-1)
        assert np.all(rates <= bound[-1] * (1 + 1e-9) if len(bound) == 1 else
                      rates <= bound * (1 + 1e-9))
        assert rates.max() > 0.2 * bound.max()   # (a real policy, not an empty one)
