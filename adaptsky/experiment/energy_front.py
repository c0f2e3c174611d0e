"""E5's analysis: the front of sum rate against energy efficiency over the reward weight w_e."""

from __future__ import annotations

from typing import Any

import numpy as np

from adaptsky.experiment.analysis import (
    Analysis,
    Outputs,
    done_runs,
    figure_title,
    row_label,
    write_csv,
)
from adaptsky.experiment.evaluation import Evaluations
from adaptsky.experiment.plan import Plan, RunSpec
from adaptsky.report.curves import band
from adaptsky.report.energy_figure import FrontPoint, draw_energy_front
from adaptsky.scenario import parse_scenario
from adaptsky.sim.energy import efficiency_bound_bpj


def _steady(evaluations: Evaluations, run: RunSpec, metric: str) -> float | None:
    metrics = evaluations.runs.get(run.name)
    return None if metrics is None or metric not in metrics else float(metrics[metric][0])


def energy_front(plan: Plan, evaluations: Evaluations, out: Outputs) -> Analysis:
    """E5 (ours): per reward weight w_e and evaluated policy (last, best), each run's greedy
    steady state on the training layout: sum rate, energy efficiency, both against the same
    seed's run at w_e = 0, and how it flies (the share of moves that stay in place and that
    change height); the front of sum rate against energy efficiency, the hovering baselines,
    and the most energy efficiency any policy can reach (docs/model.md §10)."""
    experiment, analysis = plan.experiment, Analysis()
    spec = experiment.evaluation
    group = experiment.group(spec.policy)
    values = sorted({run.sweep_value for run in plan.group_runs(group.name)})
    by_value = {value: done_runs([r for r in plan.group_runs(group.name)
                                   if r.sweep_value == value]) for value in values}
    first = spec.policies[0]
    points, rows = [], []
    unweighted = {run.seed: run for run in by_value.get(0, [])}  # w_e = 0 (0.0 alike)
    for policy in spec.policies:
        measured = evaluations.of(policy)
        for value in values:
            row = f"{row_label(group.title, policy, spec.policies)}, w_e = {value:g}"
            rates, effs = [], []
            for run in by_value[value]:
                measurement = _measure_run(measured, analysis, row, run,
                                           unweighted.get(run.seed))
                if measurement is not None:
                    rates.append(measurement[0])
                    effs.append(measurement[1])
            if not rates:
                continue
            rate_band = band(np.array(rates)[:, None], experiment.figure.band)
            ee_band = band(np.array(effs)[:, None], experiment.figure.band)
            rate3 = (float(rate_band[0][0]), float(rate_band[1][0]), float(rate_band[2][0]))
            ee3 = (float(ee_band[0][0]), float(ee_band[1][0]), float(ee_band[2][0]))
            rows.append([value, policy, len(rates), *rate3, *ee3])
            if policy == first:
                points.append(FrontPoint(f"$w_e$ = {value:g}", ee3, rate3, len(rates)))
    references, bound = _references(plan, evaluations, values, by_value, rows)
    if not points:
        analysis.notes.append("no run has finished: nothing to draw")
        return analysis
    figure = draw_energy_front(points, references, bound, title=figure_title(plan))
    write_csv(out.csv,
              ["w_energy", "policy", "runs", "sum_rate_mean_bps", "sum_rate_low_bps",
               "sum_rate_high_bps", "ee_mean_bpj", "ee_low_bpj", "ee_high_bpj"], rows)
    if bound is not None:
        for row in analysis.rows:
            analysis.bounds.setdefault(row, {})["energy_efficiency_bpj"] = [bound]
        analysis.notes.append(
            f"the most energy efficiency any policy can reach on this layout is "
            f"{bound / 1e6:.1f} Mbit/J: no step carries more than the oracle's sum rate, nor "
            "costs less than the least power of one step (docs/model.md §10)")
    analysis.notes.append(
        "each run's greedy policy is measured over the last 100 of "
        f"{spec.steps} steps on the training layout; ratios and percentages pair each run "
        "with the run of the same seed at w_e = 0; 'still': moves that keep the UAV's "
        "horizontal position, 'vertical': moves that change its height")
    analysis.files += out.save(figure)
    return analysis


def _measure_run(measured: Evaluations, analysis: Analysis, row: str, run: RunSpec,
                 base: RunSpec | None) -> tuple[float, float] | None:
    """``run``'s steady state as ``measured`` (its last or best policy) into ``analysis``:
    sum rate, energy efficiency, how it flies, and both against ``base`` (the same seed's
    run at w_e = 0); its sum rate and energy efficiency, or None if not measured."""
    rate = _steady(measured, run, "steady_sum_rate_bps")
    eff = _steady(measured, run, "steady_energy_efficiency_bpj")
    if rate is None or eff is None:
        return None
    analysis.add(row, "sum_rate_bps", rate)
    analysis.add(row, "energy_efficiency_bpj", eff)
    for name in ("still", "vertical"):
        share = _steady(measured, run, f"steady_{name}_share")
        if share is not None:
            analysis.add(row, f"{name}_share_pct", 100 * share)
    base_rate = None if base is None else _steady(measured, base, "steady_sum_rate_bps")
    base_eff = None if base is None else _steady(measured, base, "steady_energy_efficiency_bpj")
    if base_rate and base_eff:  # paired by seed
        analysis.add(row, "ee_ratio_vs_unweighted", eff / base_eff)
        analysis.add(row, "sum_rate_pct_of_unweighted", 100 * rate / base_rate)
    return rate, eff


def _references(plan: Plan, evaluations: Evaluations, values: list[Any],
                by_value: dict[Any, list[RunSpec]], rows: list[list[Any]]
                ) -> tuple[dict[str, tuple[float, float]], float | None]:
    """The hovering baselines (oracle, SoA) at the first weight: their (energy efficiency,
    sum rate) by label, each appended to the CSV ``rows``, and the most energy efficiency any
    policy can reach (from the oracle's sum rate), or None without the oracle."""
    group = plan.experiment.group(plan.experiment.evaluation.policy)
    references: dict[str, tuple[float, float]] = {}
    bound = None
    for name, label in (("oracle", "oracle (hovers)"), ("soa", "SoA (hovers)")):
        metrics = evaluations.baselines.get((name, values[0] if values else None))
        if metrics is not None and "steady_energy_efficiency_bpj" in metrics:
            references[label] = (float(metrics["steady_energy_efficiency_bpj"][0]),
                                 float(metrics["steady_sum_rate_bps"][0]))
            rows.append([values[0], name, 1, references[label][1], references[label][1],
                         references[label][1], references[label][0], references[label][0],
                         references[label][0]])
            if name == "oracle":
                run = next(iter(by_value.get(values[0], [])), None) or plan.group_runs(
                    group.name)[0]
                scenario = parse_scenario(run.config, run.name)
                bound = efficiency_bound_bpj(scenario, references[label][1])
    return references, bound
