"""The analyses of training curves: Fig. 2's learning curves and Fig. 3's sum rate against the
required minimum SE."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from adaptsky.experiment.analysis import (
    Analysis,
    Outputs,
    baseline_mean,
    done_runs,
    figure_title,
    last_mean,
    row_label,
    run_curves,
    sweep_point,
    write_csv,
)
from adaptsky.experiment.evaluation import Evaluations
from adaptsky.experiment.plan import Plan, point_title
from adaptsky.report import figures
from adaptsky.report.curves import band, curve_window
from adaptsky.report.plot_runs import BAND_NOTES, curve_series, write_curves_csv
from adaptsky.units import format_rate, plural, rate_unit


def learning_curves(plan: Plan, evaluations: Evaluations, out: Outputs) -> Analysis:
    """Fig. 2: R_e^tot against the episode for the policy's group, the SoA level, the oracle
    ceiling and J_e; a swept group gives each sweep value its own curve, levels, rows (mean
    and spread over that value's runs) and notes."""
    experiment, analysis = plan.experiment, Analysis()
    group = experiment.group(experiment.evaluation.policy)
    swept = group.sweep is not None
    done = {value: done_runs(plan.point_runs(group.name, value))
            for value in plan.sweep_values(group.name)}
    if not any(done.values()):
        analysis.notes.append(f"no run of '{group.name}' has finished: nothing to draw")
        return analysis
    curves = {value: [run_curves(run) for run in runs] for value, runs in done.items() if runs}
    window = curve_window(min(len(c["sum_rate_bps"]) for point in curves.values()
                              for c in point))
    series: list[figures.Series] = []
    levels: list[figures.Level] = []
    fairness_notes: list[str] = []
    for value, runs in done.items():
        if not runs:
            analysis.notes.append(f"no run of '{group.name}' at {sweep_point(group, value)} has "
                                  "finished: no curve")
    for index, (value, point) in enumerate(curves.items()):
        series.append(curve_series(point_title(group, value),
                                   [c["sum_rate_bps"] for c in point], window,
                                   experiment.figure.band))
        point_levels, fairness = _measure_point(plan, evaluations, analysis, value, point,
                                                window, index)
        levels += point_levels
        fairness_notes.append(fairness)
    scale, unit = rate_unit([max(float(s.high.max()) for s in series),
                             *(lv.value for lv in levels)])
    note = (f"$J_e$ at the last episode: {''.join(fairness_notes)}"
            f"\ntrailing mean over {plural(window, 'episode')}; band: "
            f"{BAND_NOTES[experiment.figure.band]}")
    figure = figures.learning_curves(series, levels, title=figure_title(plan),
                                     ylabel=f"{figures.RATE_LABEL} ({unit})", scale=scale,
                                     note=note, legend_columns=2 if swept else 3)
    write_curves_csv(out.csv, series)
    analysis.files += out.save(figure)
    return analysis


def _measure_point(plan: Plan, evaluations: Evaluations, analysis: Analysis, value: Any,
                   point: list[dict[str, np.ndarray]], window: int, index: int
                   ) -> tuple[list[figures.Level], str]:
    """One sweep value's runs (``point``: their curves) into ``analysis``: each run's R_e and
    J_e against SoA and the oracle, and the notes of these levels; the levels to draw (in
    the curve's colour where the group is swept) and the J_e note of the figure."""
    experiment = plan.experiment
    group = experiment.group(experiment.evaluation.policy)
    swept = group.sweep is not None
    row = point_title(group, value)
    soa = baseline_mean(evaluations, "soa", value, "mean_sum_rate_bps")
    soa_j = baseline_mean(evaluations, "soa", value, "fairness")
    oracle = baseline_mean(evaluations, "oracle", value, "mean_sum_rate_bps")
    for curve in point:
        r_e, j_e = last_mean(curve["sum_rate_bps"]), last_mean(curve["fairness"])
        analysis.add(row, "sum_rate_bps", r_e, oracle)
        analysis.add(row, "fairness", j_e)
        if soa:
            analysis.add(row, "gain_vs_soa_pct", 100 * (r_e - soa) / soa,
                         100 * (oracle - soa) / soa if oracle else None)
        if soa_j is not None:
            analysis.add(row, "fairness_minus_soa", 100 * (j_e - soa_j))
        if oracle:
            analysis.add(row, "pct_of_oracle", 100 * r_e / oracle, 100.0)
    # a value's levels in its curve's colour, named short: 'oracle, speed_m_per_step = 2'
    names = (("SoA", "oracle (best reachable)") if not swept else
             tuple(f"{name}, {sweep_point(group, value, short=True)}"
                   for name in ("SoA", "oracle")))
    color = f"C{index}" if swept else None
    levels = [figures.Level(name, level, style, color) for name, level, style in
              zip(names, (soa, oracle), ("--", ":"), strict=True) if level is not None]
    j_last = [float(np.mean(c["fairness"][-window:])) for c in point]
    fairness = f"{np.mean(j_last):.3f} ± {np.std(j_last):.3f}"
    if swept:  # a line per value: 'reward.min_se = 2: 0.761 ± 0.022, SoA 0.500'
        fairness_note = f"\n{sweep_point(group, value)}: {fairness}" + (
            f", SoA {soa_j:.3f}" if soa_j is not None else "")
    else:
        fairness_note = fairness + (f"; SoA {soa_j:.3f}" if soa_j is not None else "")
    where = f" at {sweep_point(group, value)}" if swept else ""
    if soa is not None:
        analysis.notes.append(f"SoA on the training layout{where}: {format_rate(soa)}, "
                              f"J = {soa_j:.3f} (evaluated over "
                              f"{experiment.evaluation.steps} steps)")
    if oracle is not None:
        analysis.notes.append(f"oracle (best sum rate over every reachable position and "
                              f"power split){where}: {format_rate(oracle)}")
    return levels, fairness_note


def _highest_served(values: list[Any], served: list[bool]) -> float | None:
    below = [v for v, ok in zip(values, served, strict=True) if ok]
    return max(below) if below else None


def _serves(evaluations: Evaluations, name: str, share: float) -> bool | None:
    metrics = evaluations.runs.get(name)
    return None if metrics is None else float(metrics["steady_satisfied_share"][0]) >= share


@dataclass(frozen=True)
class _Threshold:
    """One required minimum SE (``value``, as the sweep names it): the band of the policy's
    R_e^tot over its finished runs, how many runs of each evaluated policy serve it, and the
    sum rate of SoA and of the oracle and whether each serves it."""

    value: Any
    mean: float
    low: float
    high: float
    runs: int
    serving: dict[str, int]
    soa_bps: float | None
    soa_serves: bool
    oracle_bps: float | None
    oracle_serves: bool


def _threshold(plan: Plan, evaluations: Evaluations, value: Any) -> _Threshold | None:
    """What was measured at the required minimum SE ``value``; None before a run finished."""
    experiment = plan.experiment
    spec = experiment.evaluation
    group = experiment.group(spec.policy)
    runs = done_runs([r for r in plan.group_runs(group.name) if r.sweep_value == value])
    if not runs:
        return None
    r_e = np.array([[last_mean(run_curves(run)["sum_rate_bps"])] for run in runs])
    mean, low, high = band(r_e, experiment.figure.band)
    serving = {}
    for policy in spec.policies:
        serves = [_serves(evaluations.of(policy), run.name, spec.served_share) for run in runs]
        serving[policy] = sum(ok for ok in serves if ok)
    soa_share = baseline_mean(evaluations, "soa", value, "steady_satisfied_share")
    oracle_share = baseline_mean(evaluations, "oracle", value, "steady_satisfied_share")
    return _Threshold(
        value, mean[0], low[0], high[0], len(runs), serving,
        baseline_mean(evaluations, "soa", value, "mean_sum_rate_bps"),
        soa_share is not None and soa_share >= spec.served_share,
        baseline_mean(evaluations, "oracle", value, "mean_sum_rate_bps"),
        oracle_share is not None and oracle_share >= spec.served_share)


def min_se_sweep(plan: Plan, evaluations: Evaluations, out: Outputs) -> Analysis:
    """Fig. 3: R_e^tot against the required minimum SE for the policy and SoA, and the
    highest threshold each serves for every user (the policy's per evaluated policy: last,
    best), beside the oracle's."""
    experiment, analysis = plan.experiment, Analysis()
    spec = experiment.evaluation
    group = experiment.group(spec.policy)
    assert group.sweep is not None, "a min-se-sweep figure needs a swept group"
    values = sorted({run.sweep_value for run in plan.group_runs(group.name)})
    measured = [_threshold(plan, evaluations, value) for value in values]
    thresholds = [threshold for threshold in measured if threshold is not None]
    if not thresholds:
        analysis.notes.append("no run has finished: nothing to draw")
        return analysis
    xs = [float(t.value) for t in thresholds]
    served = {policy: _highest_served(xs, [2 * t.serving[policy] >= t.runs for t in thresholds])
              for policy in spec.policies}
    soa_max = _highest_served(xs, [t.soa_serves for t in thresholds])
    oracle_max = _highest_served(xs, [t.oracle_serves for t in thresholds]) if all(
        t.oracle_bps is not None for t in thresholds) else None
    first = spec.policies[0]
    series = _min_se_series(group.title, thresholds)
    scale, unit = rate_unit([float(np.max(s.high)) for s in series])
    figure = figures.min_se_sweep(series, {series[0].label: served[first],
                                           **({"SoA": soa_max} if len(series) > 1 else {})},
                                  title=figure_title(plan),
                                  ylabel=f"{figures.RATE_LABEL} ({unit})", scale=scale)
    write_csv(out.csv,
              ["min_se", "policy_mean_bps", "policy_low_bps", "policy_high_bps", "runs",
               "runs_serving", "soa_bps", "soa_serves", "oracle_bps"],
              [[t.value, t.mean, t.low, t.high, t.runs, t.serving[first], t.soa_bps,
                t.soa_serves, t.oracle_bps] for t in thresholds])
    for policy in spec.policies:
        row = row_label(group.title, policy, spec.policies)
        if row not in analysis.rows:
            analysis.rows.append(row)
        mine = analysis.quantities.setdefault(row, {})
        mine["max_min_se_served"] = [] if served[policy] is None else [served[policy]]
        if oracle_max is not None:
            analysis.bounds.setdefault(row, {})["max_min_se_served"] = [oracle_max]
        analysis.details.setdefault(row, {})["max_min_se_served"] = (
            "runs serving each threshold: " + ", ".join(
                f"{x:g}: {t.serving[policy]}/{t.runs}" for x, t in zip(xs, thresholds,
                                                                      strict=True)))
    analysis.rows.append("SoA")
    analysis.quantities["SoA"] = {"soa_max_min_se_served": [] if soa_max is None else [soa_max]}
    analysis.notes.append(
        f"a run serves a threshold when its greedy policy ({spec.steps} steps on the training "
        f"layout) keeps every user at or above R_min in at least "
        f"{100 * spec.served_share:.0f}% of its last 100 steps; the policy serves it when at "
        "least half of its runs do; the oracle's highest threshold is the reachable bound")
    analysis.files += out.save(figure)
    return analysis


def _min_se_series(title: str, thresholds: list[_Threshold]) -> list[figures.Series]:
    """The policy's band against the threshold, and SoA's and the oracle's sum rate where
    every threshold has it."""
    x = np.array([float(t.value) for t in thresholds])
    series = [figures.Series(f"{title}", x, np.array([t.mean for t in thresholds]),
                             np.array([t.low for t in thresholds]),
                             np.array([t.high for t in thresholds]),
                             min(t.runs for t in thresholds))]
    for label, rates in (("SoA", [t.soa_bps for t in thresholds]),
                         ("oracle", [t.oracle_bps for t in thresholds])):
        if all(v is not None for v in rates):
            flat = np.array(rates, dtype=float)
            series.append(figures.Series(label, x, flat, flat, flat, 1))
    return series
