"""A figure of conditions (ours, E6): each group one condition (a city, fading, a SIC
residual: its own scenario and layouts), its policies against SoA, the bound and OMA, as
grouped bars in panels (``groups.panel``), with where NOMA stops paying over OMA."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from adaptsky.experiment.analysis import (
    Analysis,
    Outputs,
    add_against,
    figure_title,
    row_label,
    steady_states,
    write_csv,
)
from adaptsky.experiment.evaluation import Evaluations, Metrics
from adaptsky.experiment.plan import Plan
from adaptsky.references.registry import REFERENCE_ORDER, title_of
from adaptsky.report import figures
from adaptsky.report.curves import band
from adaptsky.scenario import parse_scenario
from adaptsky.sim.state import users_move
from adaptsky.units import rate_unit

BOUNDS = tuple((name, title_of(name)) for name in REFERENCE_ORDER)
"""The bound of a condition, the first evaluated: the oracle (one UAV), else best response
(several UAVs: a reference, docs/model.md §9)."""
BASELINES = tuple((name, title_of(name)) for name in ("soa", "tracking", *REFERENCE_ORDER,
                                                      "oma"))


@dataclass
class _Panel:
    """One panel's conditions (group titles) and, per method label, (mean, low, high, runs)
    at the conditions it has a value for (by their index in ``names``)."""

    names: list[str] = field(default_factory=list)
    values: dict[str, dict[int, tuple[float, float, float, int]]] = field(
        default_factory=dict)

    def add(self, label: str, point: tuple[float, float, float, int]) -> None:
        """``label``'s point at the last condition named."""
        self.values.setdefault(label, {})[len(self.names) - 1] = point

    def bars(self) -> list[figures.Bars]:
        """A bar per label over every condition (NaN where it has no value)."""
        out = []
        for label, points in self.values.items():
            arrays = [np.array([points[c][i] if c in points else np.nan
                                for c in range(len(self.names))]) for i in range(3)]
            out.append(figures.Bars(label, *arrays, max(p[3] for p in points.values())))
        return out


def _mean(metrics: Metrics | None, key: str = "mean_sum_rate_bps") -> float | None:
    return None if metrics is None else float(np.mean(metrics[key]))


def baseline_key(plan: Plan, group: str) -> str:
    """What a baseline of ``group`` is valued by: the mean over every step of the evaluation
    (a held configuration, or fading that is stationary: the same in expectation as the
    policies' last steps, with less noise), or where the users move the policies' own window,
    the last 100 steps (the users drift from their layout: the early steps are another
    distribution of positions than the last ones)."""
    runs = plan.group_runs(group)
    moving = bool(runs) and users_move(parse_scenario(runs[0].config, runs[0].name))
    return "steady_sum_rate_bps" if moving else "mean_sum_rate_bps"


def conditions(plan: Plan, evaluations: Evaluations, out: Outputs) -> Analysis:
    """Each evaluated group (``evaluation.policy`` and ``also``) as one condition: the greedy
    steady state of its policies (last, best) against SoA, its bound (the oracle, or best
    response for several UAVs) and OMA on its own layouts; the share of the bound, the gain
    over SoA, NOMA's gain over OMA for the policy and for the bound, and per panel the first
    condition where NOMA no longer beats OMA."""
    experiment, analysis = plan.experiment, Analysis()
    spec = experiment.evaluation
    panels: dict[str, _Panel] = {}
    csv_rows: list[list[Any]] = []
    noma_over_oma: dict[str, list[tuple[str, float, float | None]]] = {}
    for name in (spec.policy, *spec.also):
        group = experiment.group(name)
        if not plan.group_runs(name):
            continue
        panel = panels.setdefault(group.panel, _Panel())
        panel.names.append(group.title)
        base = {method: evaluations.baselines.get((method, name)) for method, _ in BASELINES}
        bound_name, bound_label = next(((m, label) for m, label in BOUNDS if base[m]),
                                       (None, None))
        key = baseline_key(plan, name)
        bound = _mean(base[bound_name], key) if bound_name else None
        soa, oma = _mean(base["soa"], key), _mean(base["oma"], key)
        policy_mean = None
        tracking = _mean(base["tracking"], key)
        for policy in spec.policies:
            rates = _policy_rates(plan, evaluations.of(policy), analysis, name, policy,
                                  bound, soa, oma, tracking)
            if not rates:
                continue
            mean, low, high = (float(v[0]) for v in band(np.array([[r] for r in rates]),
                                                          experiment.figure.band))
            label = f"agent, {policy} policy"
            panel.add(label, (mean, low, high, len(rates)))
            csv_rows.append([group.panel, group.title, label, mean, low, high, len(rates)])
            policy_mean = mean if policy_mean is None else policy_mean
        for method, label in BASELINES:
            value = _mean(base[method], key)
            if value is not None:
                panel.add(label, (value, value, value, 1))
                csv_rows.append([group.panel, group.title, label, value, value, value, 1])
        if bound is not None and oma:
            analysis.add(f"{bound_label}, {group.title}", "bound_over_oma_pct",
                         100 * (bound - oma) / oma)
        if oma:
            noma_over_oma.setdefault(group.panel, []).append(
                (group.title, np.nan if policy_mean is None else (policy_mean - oma) / oma,
                 None if bound is None else (bound - oma) / oma))
    for name, crossings in noma_over_oma.items():
        analysis.notes.append(_crossover(name, crossings))
    if not any(panel.values for panel in panels.values()):
        analysis.notes.append("nothing has been evaluated: nothing to draw")
        return analysis
    drawn = [(name or "conditions", panel.names, panel.bars())
             for name, panel in panels.items() if panel.values]
    scale, unit = rate_unit([float(np.nanmax(bar.high)) for _, _, bars in drawn
                             for bar in bars])
    figure = figures.conditions(drawn, title=figure_title(plan), ylabel=f"sum rate ({unit})",
                                scale=scale)
    write_csv(out.csv, ["panel", "condition", "method", "mean", "low", "high", "runs"],
              csv_rows)
    analysis.notes.append(
        f"each group is one condition on its own layouts; a policy's value is the mean of the "
        f"last {min(100, spec.steps)} of {spec.steps} greedy steps (mean and spread over its "
        "runs), the baselines hold their configuration (the mean over every step; where the "
        "users move, the same last steps as the policies'); the bound is the oracle for one UAV "
        "and best response (a reference, not an optimum) for several, and under fading what "
        "each label of the eval files says")
    analysis.files += out.save(figure)
    return analysis


def _crossover(panel: str, points: list[tuple[str, float, float | None]]) -> str:
    """'sic residual: NOMA over OMA, policy +26.5%, ... ; the policy stops beating OMA at
    eps = 0.1, the bound at ...' for one panel's conditions in order."""
    parts = []
    for title, policy, bound in points:
        text = f"{title}: policy {100 * policy:+.1f}%" if np.isfinite(policy) else title
        parts.append(text + ("" if bound is None else f", bound {100 * bound:+.1f}%"))
    stops = [next((title for title, value, _ in points if np.isfinite(value) and value <= 0),
                  None),
             next((title for title, _, value in points if value is not None and value <= 0),
                  None)]
    verdict = "; ".join(
        f"the {who} no longer beats OMA from {where} on" if where else
        f"the {who} beats OMA in every condition"
        for who, where in zip(("policy", "bound"), stops, strict=True))
    return f"{panel or 'conditions'}: NOMA over OMA: " + "; ".join(parts) + f". {verdict}"


def _policy_rates(plan: Plan, measured: Evaluations, analysis: Analysis, group: str,
                  policy: str, bound: float | None, soa: float | None, oma: float | None,
                  tracking: float | None = None) -> list[float]:
    """Each run of ``group`` as ``measured`` into ``analysis``: steady sum rate and fairness,
    its share of the bound, its gain over SoA, over tracking and over OMA, and its service
    metrics (docs/model.md §14: outage, the mean least user rate); the runs' sum rates."""
    spec = plan.experiment.evaluation
    row = row_label(plan.experiment.group(group).title, policy, spec.policies)
    rates = []
    for steady, fairness in steady_states(plan, measured, group):
        rates.append(steady)
        add_against(analysis, row, steady, fairness, bound, soa, "pct_of_bound")
        if oma:
            analysis.add(row, "noma_over_oma_pct", 100 * (steady - oma) / oma,
                         100 * (bound - oma) / oma if bound else None)
        if tracking:
            analysis.add(row, "gain_vs_tracking_pct", 100 * (steady - tracking) / tracking,
                         100 * (bound - tracking) / tracking if bound else None)
    for run in plan.group_runs(group):
        mine = measured.runs.get(run.name)
        if mine is not None and "outage_share" in mine:
            analysis.add(row, "outage_pct", 100 * float(np.mean(mine["outage_share"])))
            analysis.add(row, "least_rate_bps", float(np.mean(mine["mean_least_rate_bps"])))
    return rates
