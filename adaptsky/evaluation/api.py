"""``evaluate`` and ``baseline`` as keyword-only library functions (the CLI only forwards).

Every method is rolled out on the same layouts with the same seed of LoS draws. A policy sees
positions relative to the UAV, so a policy trained on one layout means the same on others
(docs/environment.md).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from adaptsky.algos.registry import algorithm_of
from adaptsky.algos.shared.shapes import observation_size_of
from adaptsky.arrays import Tree
from adaptsky.errors import AdaptskyError
from adaptsky.evaluation.labels import distinct_labels
from adaptsky.progress import Reporter, Silent, WorkProgress
from adaptsky.references.registry import NAMES, REFERENCE_ORDER, resolve
from adaptsky.references.registry import run_baseline as run_baseline  # (the library's name)
from adaptsky.report.evaluations import curve_json, score_kind
from adaptsky.rollouts.metrics import Method, compare, percent_of, summary_row
from adaptsky.rollouts.rollout import Policy, greedy_policy, rollout
from adaptsky.scenario import Scenario
from adaptsky.scenario.loading import load_scenario_with_overrides, parse_scenario
from adaptsky.scenario.overrides import apply_overrides
from adaptsky.scenario.toml_writer import dumps
from adaptsky.scenario.variants import eval_scenario
from adaptsky.sim.layout import user_layouts
from adaptsky.store.run_file import RunReader

POLICY = "policy"
BASELINES = NAMES
"""The methods ``--compare`` and ``baseline --method`` take (the references' registry)."""
SEARCH_KEYS = ("objective_bps", "rounds", "converged")
"""What ``results_json`` keeps of best response and OMA, per layout, under ``search``."""
SEARCH_SECONDS = ("seconds_per_layout", "seconds_per_step")
"""A search's process time: per layout, or per step for the per-step searches (users that
move)."""
# what a policy's inputs are and are scaled by: they must match between training and
# evaluation
OBSERVATION_SCALING = ("agent.observation", "agent.user_order", "agent.observe",
                       "agent.raster_cells", "agent.raster_cell_m", "area.side_m",
                       "uav.max_height_m")


class EvaluationError(AdaptskyError):
    pass


def eval_layouts(scenario: Scenario, layouts: int | None) -> np.ndarray:
    """User positions (L, N, 2) of an evaluation: ``layouts`` uniform ones, or the one
    scenario layout."""
    return user_layouts(scenario, layouts or 1)


# float64 numbers a rollout keeps per step, layout and user (the states it records: gains,
# rates, shares, LoS, positions...), and per step and layout; measured shapes, rounded up;
# each UAV past the first adds its position
STATE_FLOATS_PER_USER, STATE_FLOATS_PER_LAYOUT, STATE_FLOATS_PER_UAV = 12, 16, 3


def check_rollout_memory(scenario: Scenario, steps: int, layouts: int, methods: int,
                         source: str) -> None:
    """Refuse, before any work, rollouts whose recorded states this machine cannot hold."""
    from adaptsky.training.resources import available_bytes, format_bytes

    per_step = layouts * (STATE_FLOATS_PER_USER * scenario.num_users + STATE_FLOATS_PER_LAYOUT
                          + STATE_FLOATS_PER_UAV * (scenario.uav.count - 1))
    needed = 8 * per_step * steps * methods
    available = available_bytes()
    if available is not None and needed > available:
        raise AdaptskyError(f"{source}: {methods} rollout(s) of {steps} steps on {layouts} "
                            f"layouts need about {format_bytes(needed)} of memory, this machine "
                            f"has {format_bytes(available)} available; lower --steps or "
                            "--layouts")


@dataclass(frozen=True)
class Compared:
    """One ``--compare`` item: a baseline, or another run file (its first seed's policy)."""

    label: str
    baseline: str | None = None
    run: Path | None = None


def compared_methods(items: list[str]) -> list[Compared]:
    """The ``--compare`` items with unique labels: baselines by name, run files by their
    shortest distinguishing path. Unknown names and items given twice are refused in one
    line (the run files themselves are opened, and checked, before any work too)."""
    seen: dict[str, str] = {}
    for item in items:
        if item in BASELINES:
            key = item
        else:
            path = Path(item)
            if not path.exists() and path.suffix == "" and len(path.parts) == 1:
                raise EvaluationError(f"--compare: unknown method '{item}'; choose from "
                                      f"{', '.join(BASELINES)} or a run file (.h5)")
            key = str(path.resolve())
        if key in seen:
            same = "" if seen[key] == item else f" (as '{seen[key]}')"
            raise EvaluationError(f"--compare: '{item}' is given twice{same}; name each method "
                                  "once")
        seen[key] = item
    runs = [Path(item) for item in items if item not in BASELINES]
    labels = iter(distinct_labels(runs, taken={POLICY, *BASELINES}))
    return [Compared(item, baseline=item) if item in BASELINES else
            Compared(next(labels), run=Path(item)) for item in items]


POLICIES = ("best", "last")


class TrainedPolicy(NamedTuple):
    """What an evaluation reads of a run: the training scenario, the arrays of the policy
    asked for, the seed, which policy that is (:func:`policy_record`), and the seed's greedy
    evaluations during training."""

    scenario: Scenario
    policy: Tree
    seed: int
    record: dict[str, Any]
    evaluations: dict[str, np.ndarray]


def read_trained(run_path: Path, seed: int | None, policy: str = "best") -> TrainedPolicy:
    """:class:`TrainedPolicy` of ``seed`` (default: the run's first) in one reading."""
    if policy not in POLICIES:
        raise EvaluationError(f"--policy: unknown policy '{policy}'; choose best or last")
    with RunReader(run_path) as run:
        seeds = run.seeds
        chosen = seeds[0] if seed is None else seed
        if chosen not in seeds:
            raise EvaluationError(f"{run_path}: has no seed {chosen}; it has "
                                  f"{', '.join(map(str, seeds))}")
        checkpoint = run.checkpoint(chosen)  # (validated on opening)
        best = run.best(chosen) if policy == "best" else None
        return TrainedPolicy(run.scenario, with_policy(run.scenario, checkpoint, best), chosen,
                             policy_record(run_path, chosen, checkpoint, policy, best),
                             run.evaluations(chosen))


def with_policy(scenario: Scenario, checkpoint: Tree, best: Tree | None) -> Tree:
    """The arrays of the best policy, or of the checkpoint's last one without a best policy
    (``scenario``'s algorithm says where they are)."""
    if best is None:
        return algorithm_of(scenario).policy_of(checkpoint)
    return best["policy"]


def policy_record(run_path: Path, seed: int, checkpoint: Tree, asked: str,
                  best: Tree | None) -> dict[str, Any]:
    """Which policy an evaluation used: the run file's absolute path, the seed, the policy
    asked for and the one used (``best`` falls back to ``last`` in a run with no greedy
    evaluation yet), the episode whose weights they are, and the last checkpoint's episode."""
    last = int(checkpoint.get("episode", -1))
    record = {"path": str(run_path.resolve()), "seed": seed, "policy_asked": asked,
              "policy": "best" if best is not None else "last",
              "episode": int(best["episode"]) if best is not None else last,
              "last_episode": last,
              "global_step": int(checkpoint.get("global_step", -1))}
    if best is not None:
        record["best_score"] = float(best["score"])
    return record


def load_policy(run_path: Path, seed: int | None, scenario: Scenario, policy: str = "best"
                ) -> tuple[Policy, dict[str, Any]]:
    """The greedy policy (``best`` or ``last``) of a run's seed, checked to fit the
    evaluation ``scenario``, and which policy it is."""
    trained, arrays, _, record, _ = read_trained(run_path, seed, policy)
    _check_compatible(run_path, trained, scenario)
    return greedy_policy(trained, arrays), record


def _setting(scenario: Scenario, key: str) -> Any:
    value: Any = scenario
    for part in key.split("."):
        value = getattr(value, part)
    return value


def _uavs(count: int) -> str:
    return "one UAV" if count == 1 else f"{count} UAVs"


def _check_compatible(run_path: Path, trained: Scenario, scenario: Scenario) -> None:
    if trained.uav.count != scenario.uav.count:
        raise EvaluationError(
            f"{run_path}: the policy was trained for {_uavs(trained.uav.count)} but the "
            f"evaluation scenario '{scenario.name}' has {scenario.uav.count}")
    if trained.num_users != scenario.num_users:
        raise EvaluationError(
            f"{run_path}: the policy was trained for {trained.num_users} users "
            f"({observation_size_of(trained)} inputs) but the evaluation scenario "
            f"'{scenario.name}' has {scenario.num_users}")
    if trained.uav.actions != scenario.uav.actions:
        raise EvaluationError(f"{run_path}: the policy's actions are '{trained.uav.actions}' "
                              f"but the evaluation scenario's are '{scenario.uav.actions}'")
    keys = OBSERVATION_SCALING
    if "velocity" in trained.agent.observe:    # the users' velocities in UAV steps
        keys = (*keys, "uav.step_m", "uav.step_s")
    for key in keys:
        was, now = _setting(trained, key), _setting(scenario, key)
        if was != now:
            raise EvaluationError(
                f"{run_path}: the evaluation scenario observes differently: {key} "
                f"is {now!r}, the policy was trained with {was!r}; evaluate on a scenario "
                f"with the same {', '.join(keys)}")


def _policy_method(name: str, scenario: Scenario, policy: Policy, steps: int,
                   users_m: np.ndarray, progress: WorkProgress) -> Method:
    with progress.stage(name, steps, "step") as tick:
        return Method.of(name, scenario, rollout(scenario, policy, steps, users_m,
                                                 on_step=tick))


def _baseline_method(scenario: Scenario, name: str, steps: int, users_m: np.ndarray,
                     progress: WorkProgress) -> Method:
    reference = resolve(name, scenario)
    with progress.stage(name, *reference.work(scenario, steps, users_m)) as tick:
        return reference.run(scenario, steps, users_m, on_progress=tick)


def checked_compared(scenario: Scenario, compared: list[Compared], policy: str
                     ) -> dict[str, tuple[Policy, dict[str, Any]]]:
    """Refuse a compared baseline the evaluation ``scenario`` cannot have; the greedy policy
    (``best`` or ``last``) of every compared run file, checked to fit it, by label."""
    for item in compared:
        if item.baseline is not None:
            resolve(item.baseline, scenario, "--compare")
    return {item.label: load_policy(item.run, None, scenario, policy)
            for item in compared if item.run is not None}


def rollouts(scenario: Scenario, policy: Policy, compared: list[Compared],
             others: dict[str, tuple[Policy, dict[str, Any]]], steps: int,
             users_m: np.ndarray, progress: Reporter | None) -> list[Method]:
    """The evaluated ``policy``'s rollout, then every compared method's, on the layouts
    ``users_m`` with the same draws; ``progress`` shows each (default: nothing)."""
    with WorkProgress(progress or Silent()) as work:
        methods = [_policy_method(POLICY, scenario, policy, steps, users_m, work)]
        for item in compared:
            if item.baseline is not None:
                methods.append(_baseline_method(scenario, item.baseline, steps, users_m, work))
            else:
                methods.append(_policy_method(item.label, scenario, others[item.label][0],
                                              steps, users_m, work))
    return methods


def evaluation_base(scenario_path: Path | None, trained: Scenario | None,
                    set_values: list[str] | None) -> Scenario:
    """The scenario an evaluation starts from: the file ``scenario_path``, else the
    ``trained`` one, with the ``--set section.key=value`` overrides ``set_values`` applied and
    validated as a file is (as ``train --set`` does)."""
    if scenario_path is not None:   # overridden in the file's own keys, as train does
        return load_scenario_with_overrides(scenario_path, set_values)[0]
    assert trained is not None, "an evaluation needs a scenario"
    if not set_values:
        return trained
    source = "the run's scenario with --set"
    return parse_scenario(apply_overrides(trained.model_dump(mode="json"), set_values, source),
                          source)


def evaluate(*, checkpoint: Path, seed: int | None = None, scenario_path: Path | None = None,
             layouts: int | None = None, layout_seed: int = 0, steps: int = 1000,
             compare_with: list[str] | None = None, progress: Reporter | None = None,
             policy: str = "best", set_values: list[str] | None = None
             ) -> tuple[dict[str, Any], list[Method]]:
    """Greedy rollouts of a checkpoint's ``policy`` (``best``: the best greedy evaluation
    during training, ``last``: the last checkpoint) next to baselines and other runs (their
    policy alike); results as JSON-able values and the methods (policy first) with their
    traces. The evaluation scenario is ``scenario_path`` or the training scenario, with the
    ``set_values`` overrides (``section.key=value``). Every input is checked before the
    first rollout; ``progress`` shows the rollouts and the oracle's search (default:
    nothing)."""
    compared = compared_methods(compare_with or [])
    trained, arrays, chosen, used, curve = read_trained(checkpoint, seed, policy)
    base = evaluation_base(scenario_path, trained, set_values)
    scenario = eval_scenario(base, layouts, layout_seed)
    _check_compatible(checkpoint, trained, scenario)
    others = checked_compared(scenario, compared, policy)
    check_rollout_memory(scenario, steps, layouts or 1, 1 + len(compared), str(checkpoint))
    users_m = eval_layouts(scenario, layouts)
    methods = rollouts(scenario, greedy_policy(trained, arrays), compared, others, steps,
                       users_m, progress)
    results = results_json(methods, scenario, steps, layouts, layout_seed, users_m)
    used["score_kind"] = score_kind(trained)
    results |= {"checkpoint": used["path"], "seed": chosen, "checkpoint_episode":
                used["episode"], "policy": used, "training_evaluations": curve_json(curve),
                "dueling": getattr(trained.agent, "dueling", True),  # BDQ: dueling branches
                "scenario_file": str(scenario_path.resolve()) if scenario_path else None,
                "scenario_toml": dumps(scenario.model_dump(mode="json")),
                "compared_runs": {label: record for label, (_, record) in others.items()}}
    return results, methods


def baseline(*, scenario_path: Path, method: str, layouts: int | None = None,
             layout_seed: int = 0, steps: int = 1000, progress: Reporter | None = None,
             set_values: list[str] | None = None) -> tuple[dict[str, Any], list[Method]]:
    """One baseline on the scenario's layout or on uniform layouts, the scenario with the
    ``set_values`` overrides; ``progress`` shows its work (default: nothing)."""
    scenario = eval_scenario(evaluation_base(scenario_path, None, set_values), layouts,
                             layout_seed)
    if method not in BASELINES:
        raise EvaluationError(f"--method: unknown method '{method}'; choose from "
                              f"{', '.join(BASELINES)}")
    resolve(method, scenario, "--method")
    check_rollout_memory(scenario, steps, layouts or 1, 1, str(scenario_path))
    users_m = eval_layouts(scenario, layouts)
    with WorkProgress(progress or Silent()) as work:
        result = _baseline_method(scenario, method, steps, users_m, work)
    return results_json([result], scenario, steps, layouts, layout_seed, users_m), [result]


def results_json(methods: list[Method], scenario: Scenario, steps: int, layouts: int | None,
                 layout_seed: int, users_m: np.ndarray) -> dict[str, Any]:
    """Summaries, per-layout metrics and comparisons of ``methods`` as JSON-able values."""
    results: dict[str, Any] = {
        "scenario": scenario.name, "channel_model": scenario.channel.model,
        "los": scenario.channel.los, "min_se": scenario.reward.min_se, "steps": steps,
        "layouts": layouts or 1, "layout_seed": layout_seed if layouts else None,
        "layouts_m": users_m.tolist(), "methods": {}}
    if scenario.uav.count > 1:  # (one UAV's results are as they always were)
        results["uavs"] = scenario.uav.count
    for method in methods:
        entry = {"summary": summary_row(method.metrics),
                 "layouts": {k: v.tolist() for k, v in method.metrics.items()}}
        for key in SEARCH_SECONDS:   # a search's process time, per layout or per step
            if key in method.details:
                entry[key] = float(method.details[key])
        if "rounds" in method.details:  # best response and OMA
            entry["search"] = {key: np.asarray(method.details[key]).tolist()
                               for key in SEARCH_KEYS}
        if "note" in method.details:    # what a method is where that is not obvious
            entry["note"] = method.details["note"]
        results["methods"][method.name] = entry
    first, others = methods[0], methods[1:]
    if first.name == POLICY:
        results["comparison"] = {m.name: compare(first.metrics, m.metrics) for m in others}
        reference = next((m for name in REFERENCE_ORDER for m in others if m.name == name), None)
        if reference is not None:
            pct = percent_of(first.metrics["steady_sum_rate_bps"],
                             reference.metrics["mean_sum_rate_bps"])
            results[pct_key(reference.name)] = {
                "mean": float(np.nanmean(pct)), "median": float(np.nanmedian(pct)),
                "layouts": pct.tolist()}
    return results


def pct_key(reference: str) -> str:
    """The results' key of the policy's steady state as a percentage of ``reference`` (the
    oracle's as it always was)."""
    return f"policy_steady_pct_of_{reference.replace('-', '_')}"
