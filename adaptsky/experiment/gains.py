"""Fig. 4's analysis: per-layout gains of the policy over the baselines and compared groups."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from adaptsky.experiment.analysis import (
    Analysis,
    Outputs,
    figure_title,
    row_label,
    sweep_point,
    write_csv,
)
from adaptsky.experiment.evaluation import Evaluations, Metrics
from adaptsky.experiment.models import Group
from adaptsky.experiment.plan import Plan, RunSpec, point_title
from adaptsky.report import figures
from adaptsky.rollouts.metrics import compare

GAIN_QUANTITIES = (("beats_share", "beats_share_pct", 100), ("mean_improvement_pct",
                   "mean_gain_pct", 1), ("median_improvement_pct", "median_gain_pct", 1),
                   ("max_improvement_pct", "max_gain_pct", 1))


def _gain_pct(mine: Metrics, theirs: Metrics) -> np.ndarray:
    rate = theirs["mean_sum_rate_bps"]
    positive = rate > 0
    return 100 * (mine["mean_sum_rate_bps"][positive] - rate[positive]) / rate[positive]


@dataclass
class _Pooled:
    """What ``layout_gains`` gathers over the runs: per-layout gains by figure label (the
    policy's over each method, another group's over SoA), the method of each of the policy's
    labels, and the CSV rows (a layout of a run each); ``labels``: 'vs SoA' by method, and
    ``key``: the swept key the rows name, if a group is swept."""

    labels: dict[str, str]
    key: str | None
    gains: dict[str, list[np.ndarray]] = field(default_factory=dict)
    methods: dict[str, str] = field(default_factory=dict)
    rows: list[dict[str, Any]] = field(default_factory=list)


def layout_gains(plan: Plan, evaluations: Evaluations, out: Outputs) -> Analysis:
    """Fig. 4: per-layout sum rate of the policy as a gain over each baseline and compared
    group (paired by seed), for every evaluated policy (last, best) and every group measured
    as the policy is (``evaluation.also``); the oracle's gain over the same methods is the
    reachable bound. A swept group gives each sweep value its own rows and curves, against
    the baselines at that value (and the compared group's run of the same seed and value,
    or of the same seed where the compared group has no sweep)."""
    experiment, analysis = plan.experiment, Analysis()
    spec = experiment.evaluation
    baselines = [m for m in spec.baselines if m != "oracle"]
    evaluated = [experiment.group(name) for name in (spec.policy, *spec.also)]
    pooled = _Pooled(
        labels={m: f"vs {experiment.group(m).title if m in spec.compare_groups else NAMES[m]}"
                for m in (*baselines, *spec.compare_groups)},
        key=next((g.sweep.key for g in evaluated if g.sweep is not None), None))
    for group in evaluated:
        for value in plan.sweep_values(group.name):
            for policy in spec.policies:
                for run in plan.point_runs(group.name, value):
                    _compare_run(plan, evaluations, analysis, pooled, group, value, policy, run)
    if not pooled.gains:
        analysis.notes.append("no policy run has been evaluated: nothing to draw")
        return analysis
    policy_group = experiment.group(spec.policy)
    gains = {label: np.concatenate(g)
             for label, g in (pooled.gains | _reachable_gains(plan, evaluations)).items()}
    summaries = {m: _paper_summary(plan, m) for m in pooled.labels}
    paper = {label: summaries[m] for label, m in pooled.methods.items() if summaries[m]}
    figure = figures.layout_gains(gains, title=figure_title(plan), paper=paper or None)
    header = list(dict.fromkeys(key for row in pooled.rows for key in row))
    write_csv(out.csv, header, [[row.get(key, "") for key in header] for row in pooled.rows])
    values = plan.sweep_values(spec.policy)
    runs = max((len(plan.point_runs(spec.policy, v)) for v in values), default=0)
    per = "per group and sweep value" if policy_group.sweep is not None else "per group"
    analysis.notes.append(f"gains over {spec.layouts or 1} layout(s) for each of up to {runs} "
                          f"run(s) {per}; each run is compared with the compared group's run "
                          "of the same seed (and the same policy, last or best) and with the "
                          "baselines; the figure pools the runs' layouts of the last policies")
    analysis.files += out.save(figure)
    return analysis


def _compare_run(plan: Plan, evaluations: Evaluations, analysis: Analysis, pooled: _Pooled,
                 group: Group, value: Any, policy: str, run: RunSpec) -> None:
    """``run``'s ``policy`` (last or best) at sweep value ``value`` against each baseline and
    compared group, and against the oracle: the gains and their bounds into ``analysis``,
    the last policy's per-layout gains and every layout's sum rates into ``pooled``."""
    spec = plan.experiment.evaluation
    measured = evaluations.of(policy)
    mine = measured.runs.get(run.name)
    if mine is None:
        return
    row = row_label(point_title(group, value), policy, spec.policies)
    oracle = evaluations.baselines.get(("oracle", value))
    at = "" if value is None else f", {sweep_point(group, value)}"
    others = [m for m in spec.baselines if m != "oracle"]
    others += spec.compare_groups if group.name == spec.policy else []
    columns: dict[str, np.ndarray] = {"policy": mine["mean_sum_rate_bps"]}
    for method in others:
        theirs = _against(plan, evaluations, measured, method, run, value)
        if theirs is None:
            continue
        columns[method] = theirs["mean_sum_rate_bps"]
        result = compare(mine, theirs)
        reachable = compare(oracle, theirs) if oracle is not None else {}
        for source, stat, scale in GAIN_QUANTITIES:
            analysis.add(row, f"{stat}_vs_{method}", scale * result[source],
                         scale * reachable[source] if reachable else None)
        if policy != spec.policies[0]:
            continue
        if group.name == spec.policy:
            pooled.methods[pooled.labels[method] + at] = method
            pooled.gains.setdefault(pooled.labels[method] + at, []).append(
                _gain_pct(mine, theirs))
        elif method == "soa":
            pooled.gains.setdefault(f"{point_title(group, value)} vs SoA", []).append(
                _gain_pct(mine, theirs))
    if oracle is not None:
        ceiling = oracle["mean_sum_rate_bps"]
        share = mine["steady_sum_rate_bps"][ceiling > 0] / ceiling[ceiling > 0]
        analysis.add(row, "steady_pct_of_oracle", float(100 * share.mean()), 100.0)
        columns["oracle"] = ceiling
    point = {} if pooled.key is None else {pooled.key: "" if value is None else value}
    pooled.rows += [{"group": group.name, **point, "policy": policy, "seed": run.seed,
                     "layout": layout, **{f"{name}_bps": float(c[layout])
                                          for name, c in columns.items()}}
                    for layout in range(len(mine["mean_sum_rate_bps"]))]


def _against(plan: Plan, evaluations: Evaluations, measured: Evaluations, method: str,
             run: RunSpec, value: Any) -> Metrics | None:
    """What ``run`` is compared with: the baseline ``method`` at its sweep value, or the
    compared group's run of the same seed (and value, where that group is swept), as
    ``measured`` (its last or best policy)."""
    if method not in plan.experiment.evaluation.compare_groups:
        return evaluations.baselines.get((method, value))
    partner = plan.run(method, run.seed,
                       run.sweep_value if plan.experiment.group(method).sweep else None)
    return measured.runs.get(partner.name) if partner else None


def _reachable_gains(plan: Plan, evaluations: Evaluations) -> dict[str, list[np.ndarray]]:
    """The oracle's gains over SoA at each sweep value of the policy's group: the bound."""
    group = plan.experiment.group(plan.experiment.evaluation.policy)
    pooled = {}
    for value in plan.sweep_values(group.name):
        soa = evaluations.baselines.get(("soa", value))
        oracle = evaluations.baselines.get(("oracle", value))
        if oracle is not None and soa is not None:
            at = "" if value is None else f", {sweep_point(group, value)}"
            pooled[f"oracle vs SoA (the reachable bound){at}"] = [_gain_pct(oracle, soa)]
    return pooled


NAMES = {"soa": "SoA", "random": "random", "oracle": "oracle",
         "best-response": "best response", "oma": "OMA"}


PAPER_WORDS = {"beats_share_pct": "beats on", "mean_gain_pct": "mean",
               "median_gain_pct": "median", "max_gain_pct": "max"}


def _paper_summary(plan: Plan, method: str) -> str:
    """'paper: beats on 67%, mean +39.11%, max +275.4%' from the claims about ``method``."""
    texts = [f"{PAPER_WORDS[c.quantity.removesuffix(f'_vs_{method}')]} {c.paper_text}"
             for c in plan.experiment.claims
             if c.quantity.endswith(f"_vs_{method}") and c.paper_text]
    return f"paper: {', '.join(texts)}" if texts else ""
