"""``evaluate`` and ``baseline`` as keyword-only library functions (the CLI only forwards).

Every method is rolled out on the same layouts with the same seed of LoS draws. A policy sees
positions relative to the UAV, so a policy trained on one layout means the same on others
(docs/environment.md).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from adaptsky_cli.env.actions import ActionSet
from adaptsky_cli.env.batch import NomaUavBatch
from adaptsky_cli.env.layout import user_layouts
from adaptsky_cli.env.observation import observation_size
from adaptsky_cli.errors import AdaptskyError
from adaptsky_cli.evaluate.metrics import compare, layout_metrics, summary_row
from adaptsky_cli.evaluate.oracle import oracle
from adaptsky_cli.evaluate.rollout import Policy, Trace, greedy_policy, hold, random_policy, rollout
from adaptsky_cli.evaluate.soa import soa_configuration
from adaptsky_cli.scenario import Scenario, load_scenario, parse_scenario
from adaptsky_cli.store.run_file import RunReader

BASELINES = ("soa", "oracle", "random")


class EvaluationError(AdaptskyError):
    pass


@dataclass
class Method:
    """One evaluated method: its trace and per-layout metrics."""

    name: str
    trace: Trace
    metrics: dict[str, np.ndarray]
    details: dict[str, Any]

    @classmethod
    def of(cls, name: str, scenario: Scenario, trace: Trace,
           details: dict[str, Any] | None = None) -> Method:
        metrics = layout_metrics(trace, scenario.radio.bandwidth_hz, scenario.min_rate_bps)
        return cls(name, trace, metrics, details or {})


def eval_scenario(scenario: Scenario, layouts: int | None, layout_seed: int) -> Scenario:
    """The scenario on ``layouts`` uniform layouts (near-far pairing), or as it is."""
    if layouts is None:
        return scenario
    data = scenario.model_dump(mode="json")
    data["users"] = {"count": scenario.num_users, "placement": "uniform",
                     "layout_seed": layout_seed, "pairing": "near-far",
                     "speed_m_per_step": scenario.users.speed_m_per_step}
    return parse_scenario(data, "evaluation layouts")


def eval_layouts(scenario: Scenario, layouts: int | None) -> np.ndarray:
    """User positions (L, N, 2) of an evaluation: ``layouts`` uniform ones, or the one
    scenario layout."""
    return user_layouts(scenario, layouts or 1)


def run_baseline(scenario: Scenario, method: str, steps: int, users_m: np.ndarray,
                 seed: int = 0) -> Method:
    """SoA, the oracle or the random policy on ``users_m`` (L, N, 2)."""
    details: dict[str, Any] = {}
    if method == "soa":
        env = NomaUavBatch(scenario, num_envs=len(users_m), users_m=users_m)
        uav_m, alpha_first = soa_configuration(env)
        trace = hold(scenario, uav_m, alpha_first, steps, users_m, seed)
    elif method == "oracle":
        start = time.process_time()
        best = oracle(scenario, users_m)
        details["seconds_per_layout"] = (time.process_time() - start) / len(users_m)
        details["objective_bps"] = best.objective_bps
        trace = hold(scenario, best.uav_m, best.alpha_first, 1, users_m, seed)
    elif method == "random":
        count = ActionSet(scenario.num_clusters, scenario.uav.actions).count
        trace = rollout(scenario, random_policy(count, seed), steps, users_m, seed)
    else:
        raise EvaluationError(f"unknown method '{method}'; choose from {', '.join(BASELINES)}")
    return Method.of(method, scenario, trace, details)


def _read_run(run_path: Path, seed: int | None) -> tuple[Scenario, dict[str, Any], int]:
    """The training scenario, the checkpoint of ``seed`` (default: the first) and the seed."""
    with RunReader(run_path) as run:
        seeds = run.seeds
        chosen = seeds[0] if seed is None else seed
        if chosen not in seeds:
            raise EvaluationError(f"{run_path}: has no seed {chosen}; it has "
                                  f"{', '.join(map(str, seeds))}")
        trained = parse_scenario(run.config, f"{run_path}:/config")
        return trained, run.checkpoint(chosen), chosen


def load_policy(run_path: Path, seed: int | None, scenario: Scenario) -> Policy:
    """The greedy policy of a run's seed, checked to fit the evaluation ``scenario``."""
    trained, checkpoint, _ = _read_run(run_path, seed)
    _check_compatible(run_path, trained, scenario)
    return greedy_policy(trained, checkpoint)


def _check_compatible(run_path: Path, trained: Scenario, scenario: Scenario) -> None:
    if trained.num_users != scenario.num_users:
        raise EvaluationError(
            f"{run_path}: the policy was trained for {trained.num_users} users "
            f"({observation_size(trained.num_users)} inputs) but the evaluation scenario "
            f"'{scenario.name}' has {scenario.num_users}")
    if trained.uav.actions != scenario.uav.actions:
        raise EvaluationError(f"{run_path}: the policy's actions are '{trained.uav.actions}' "
                              f"but the evaluation scenario's are '{scenario.uav.actions}'")
    same = (trained.agent.observation, trained.area.side_m, trained.uav.max_height_m) == (
        scenario.agent.observation, scenario.area.side_m, scenario.uav.max_height_m)
    if not same:
        raise EvaluationError(f"{run_path}: the evaluation scenario scales observations "
                              "differently (agent.observation, area.side_m or "
                              "uav.max_height_m differ from the training scenario's)")


def _policy_method(name: str, scenario: Scenario, policy: Policy, steps: int,
                   users_m: np.ndarray) -> Method:
    return Method.of(name, scenario, rollout(scenario, policy, steps, users_m))


def evaluate(*, checkpoint: Path, seed: int | None = None, scenario_path: Path | None = None,
             layouts: int | None = None, layout_seed: int = 0, steps: int = 1000,
             compare_with: list[str] | None = None) -> tuple[dict[str, Any], list[Method]]:
    """Greedy rollouts of a checkpoint next to baselines and other runs; results as JSON-able
    values and the methods (policy first) with their traces."""
    trained, state, chosen = _read_run(checkpoint, seed)
    base = load_scenario(scenario_path) if scenario_path else trained
    scenario = eval_scenario(base, layouts, layout_seed)
    _check_compatible(checkpoint, trained, scenario)
    users_m = eval_layouts(scenario, layouts)
    policy = greedy_policy(trained, state)
    methods = [_policy_method("policy", scenario, policy, steps, users_m)]
    for item in compare_with or []:
        if item in BASELINES:
            methods.append(run_baseline(scenario, item, steps, users_m))
        else:
            other = Path(item)
            other_policy = load_policy(other, None, scenario)
            methods.append(_policy_method(other.name, scenario, other_policy, steps, users_m))
    results = results_json(methods, scenario, steps, layouts, layout_seed, users_m)
    results |= {"checkpoint": str(checkpoint), "seed": chosen,
                "dueling": trained.agent.dueling}
    return results, methods


def baseline(*, scenario_path: Path, method: str, layouts: int | None = None,
             layout_seed: int = 0, steps: int = 1000) -> tuple[dict[str, Any], list[Method]]:
    """One baseline on the scenario's layout or on uniform layouts."""
    scenario = eval_scenario(load_scenario(scenario_path), layouts, layout_seed)
    users_m = eval_layouts(scenario, layouts)
    result = run_baseline(scenario, method, steps, users_m)
    return results_json([result], scenario, steps, layouts, layout_seed, users_m), [result]


def results_json(methods: list[Method], scenario: Scenario, steps: int, layouts: int | None,
             layout_seed: int, users_m: np.ndarray) -> dict[str, Any]:
    results: dict[str, Any] = {
        "scenario": scenario.name, "channel_model": scenario.channel.model,
        "los": scenario.channel.los, "min_se": scenario.reward.min_se, "steps": steps,
        "layouts": layouts or 1, "layout_seed": layout_seed if layouts else None,
        "layouts_m": users_m.tolist(), "methods": {}}
    for method in methods:
        entry = {"summary": summary_row(method.metrics),
                 "layouts": {k: v.tolist() for k, v in method.metrics.items()}}
        if "seconds_per_layout" in method.details:
            entry["seconds_per_layout"] = method.details["seconds_per_layout"]
        results["methods"][method.name] = entry
    first, others = methods[0], methods[1:]
    if first.name == "policy":
        results["comparison"] = {m.name: compare(first.metrics, m.metrics) for m in others}
        oracle_method = next((m for m in others if m.name == "oracle"), None)
        if oracle_method is not None:
            ceiling = oracle_method.metrics["mean_sum_rate_bps"]
            share = np.where(ceiling > 0, first.metrics["steady_sum_rate_bps"] / np.where(
                ceiling > 0, ceiling, 1.0), np.nan)
            results["policy_steady_pct_of_oracle"] = {
                "mean": float(100 * np.nanmean(share)), "median": float(100 * np.nanmedian(share)),
                "layouts": (100 * share).tolist()}
    return results
