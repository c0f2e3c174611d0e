"""Figures, CSVs and ``report.md`` of a reproduced experiment: pure functions of its run and
eval files (reporting never trains), one analysis per figure kind.

Each analysis gives the figure's series, the CSV rows of what is plotted, and the measured
quantities that claims name, each as a list of per-run values (mean and spread over runs in
the report) or a single value.
"""

from __future__ import annotations

import csv
import io
import math
import os
import platform
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from adaptsky import __version__
from adaptsky.experiment.calls import read_calls
from adaptsky.experiment.evaluation import Evaluations, Metrics
from adaptsky.experiment.models import PER_GROUP_KINDS, Claim, Group
from adaptsky.experiment.plan import (
    Plan,
    RunSpec,
    point_title,
    shipped_experiments,
    sweep_label,
)
from adaptsky.report import figures
from adaptsky.report.curves import LAST_EPISODES, band, curve_window
from adaptsky.report.energy_figure import FrontPoint, draw_energy_front
from adaptsky.report.figure_files import save_figure
from adaptsky.report.plot_runs import BAND_NOTES, curve_series, write_curves_csv
from adaptsky.rollouts.metrics import compare
from adaptsky.scenario import parse_scenario
from adaptsky.sim.energy import efficiency_bound_bpj
from adaptsky.store.atomic import utc_timestamp, write_text_atomic
from adaptsky.store.run_file import RunReader
from adaptsky.units import format_duration, format_rate, plural, rate_unit


@dataclass
class Analysis:
    """What one figure kind measured. Per row (a group's last or best policy: ``rows`` keeps
    their order) and quantity: a list of per-run values (or one value), the same quantity for
    the oracle (``bounds``: the most any policy can reach), and details replacing the per-run
    list; notes for the report, and the files written."""

    rows: list[str] = field(default_factory=list)
    quantities: dict[str, dict[str, list[float]]] = field(default_factory=dict)
    bounds: dict[str, dict[str, list[float]]] = field(default_factory=dict)
    details: dict[str, dict[str, str]] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    files: list[Path] = field(default_factory=list)

    def add(self, row: str, quantity: str, value: float, bound: float | None = None) -> None:
        """One run's ``value`` (and the oracle's ``bound`` for the same run) in ``row``."""
        if row not in self.rows:
            self.rows.append(row)
        self.quantities.setdefault(row, {}).setdefault(quantity, []).append(value)
        if bound is not None:
            self.bounds.setdefault(row, {}).setdefault(quantity, []).append(bound)


@dataclass(frozen=True)
class Outputs:
    """Where an analysis writes: ``folder/<name>.<figure_format>`` (png, pdf or svg) and the
    plotted numbers in ``folder/<name>.csv``."""

    folder: Path
    name: str
    figure_format: str = "png"

    @property
    def figure(self) -> Path:
        return self.folder / f"{self.name}.{self.figure_format}"

    @property
    def csv(self) -> Path:
        return self.folder / f"{self.name}.csv"

    def save(self, figure: Figure) -> list[Path]:
        """Write ``figure``; the figure and CSV paths, for ``Analysis.files``."""
        save_figure(figure, self.figure)
        return [self.figure, self.csv]


def row_label(title: str, policy: str, policies: list[str]) -> str:
    """'AdaptSky, last policy': the policy named where the experiment evaluates several."""
    return f"{title}, {policy} policy" if len(policies) > 1 else title


def _done_runs(runs: list[RunSpec]) -> list[RunSpec]:
    from adaptsky.experiment.runs import run_state  # imports torch: only when reporting

    return [run for run in runs if run_state(run).status == "done"]


def _curves(run: RunSpec) -> dict[str, np.ndarray]:
    with RunReader(run.path, needs="curves") as reader:
        return reader.episodes(run.seed)


def _last_mean(values: np.ndarray) -> float:
    """R_e^tot or J_e: the mean of the last 100 episodes' values (all, for shorter runs)."""
    return float(np.mean(values[-LAST_EPISODES:]))


def _window(episodes: int) -> str:
    """"100 episodes'" or, for a shorter run, all of them: "20 episodes'"."""
    count = min(LAST_EPISODES, episodes)
    return plural(count, "episode") + ("'s" if count == 1 else "'")


def _write_csv(path: Path, header: list[str], rows: list[list[Any]]) -> None:
    text = io.StringIO()
    writer = csv.writer(text, lineterminator="\n")
    writer.writerow(header)
    writer.writerows(rows)
    write_text_atomic(path, text.getvalue())


def _baseline(evaluations: Evaluations, name: str, value: Any, metric: str) -> float | None:
    metrics = evaluations.baselines.get((name, value))
    return None if metrics is None else float(np.mean(metrics[metric]))


def learning_curves(plan: Plan, evaluations: Evaluations, out: Outputs) -> Analysis:
    """Fig. 2: R_e^tot against the episode for the policy's group, the SoA level, the oracle
    ceiling and J_e; a swept group gives each sweep value its own curve, levels, rows (mean
    and spread over that value's runs) and notes."""
    experiment, analysis = plan.experiment, Analysis()
    group = experiment.group(experiment.evaluation.policy)
    swept = group.sweep is not None
    done = {value: _done_runs(plan.point_runs(group.name, value))
            for value in plan.sweep_values(group.name)}
    if not any(done.values()):
        analysis.notes.append(f"no run of '{group.name}' has finished: nothing to draw")
        return analysis
    curves = {value: [_curves(run) for run in runs] for value, runs in done.items() if runs}
    window = curve_window(min(len(c["sum_rate_bps"]) for point in curves.values()
                              for c in point))
    series: list[figures.Series] = []
    levels: list[figures.Level] = []
    fairness_notes: list[str] = []
    for value, runs in done.items():
        if not runs:
            analysis.notes.append(f"no run of '{group.name}' at {_point(group, value)} has "
                                  "finished: no curve")
    for index, (value, point) in enumerate(curves.items()):
        row = point_title(group, value)
        series.append(curve_series(row, [c["sum_rate_bps"] for c in point], window,
                                   experiment.figure.band))
        soa = _baseline(evaluations, "soa", value, "mean_sum_rate_bps")
        soa_j = _baseline(evaluations, "soa", value, "fairness")
        oracle = _baseline(evaluations, "oracle", value, "mean_sum_rate_bps")
        for curve in point:
            r_e, j_e = _last_mean(curve["sum_rate_bps"]), _last_mean(curve["fairness"])
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
                 tuple(f"{name}, {_point(group, value, short=True)}" for name in ("SoA",
                                                                             "oracle")))
        color = f"C{index}" if swept else None
        levels += [figures.Level(name, level, style, color) for name, level, style in
                   zip(names, (soa, oracle), ("--", ":"), strict=True) if level is not None]
        j_last = [float(np.mean(c["fairness"][-window:])) for c in point]
        fairness = f"{np.mean(j_last):.3f} ± {np.std(j_last):.3f}"
        if swept:  # a line per value: 'reward.min_se = 2: 0.761 ± 0.022, SoA 0.500'
            fairness_notes.append(f"\n{_point(group, value)}: {fairness}" + (
                f", SoA {soa_j:.3f}" if soa_j is not None else ""))
        else:
            fairness_notes.append(fairness + (f"; SoA {soa_j:.3f}" if soa_j is not None
                                              else ""))
        where = f" at {_point(group, value)}" if swept else ""
        if soa is not None:
            analysis.notes.append(f"SoA on the training layout{where}: {format_rate(soa)}, "
                                  f"J = {soa_j:.3f} (evaluated over "
                                  f"{experiment.evaluation.steps} steps)")
        if oracle is not None:
            analysis.notes.append(f"oracle (best sum rate over every reachable position and "
                                  f"power split){where}: {format_rate(oracle)}")
    scale, unit = rate_unit([max(float(s.high.max()) for s in series),
                             *(lv.value for lv in levels)])
    note = (f"$J_e$ at the last episode: {''.join(fairness_notes)}"
            f"\ntrailing mean over {plural(window, 'episode')}; band: "
            f"{BAND_NOTES[experiment.figure.band]}")
    figure = figures.learning_curves(series, levels, title=_title(plan),
                                     ylabel=f"{figures.RATE_LABEL} ({unit})", scale=scale,
                                     note=note, legend_columns=2 if swept else 3)
    write_curves_csv(out.csv, series)
    analysis.files += out.save(figure)
    return analysis


def _point(group: Group, value: Any, short: bool = False) -> str:
    """'users.speed_m_per_step = 2' (``short``: 'speed_m_per_step = 2', as run files name
    it): a swept group's point, as labels name it."""
    assert group.sweep is not None, "only a swept group has points"
    key = group.sweep.key.rsplit(".", 1)[-1] if short else group.sweep.key
    return sweep_label(key, value)


def _highest_served(values: list[Any], served: list[bool]) -> float | None:
    below = [v for v, ok in zip(values, served, strict=True) if ok]
    return max(below) if below else None


def _serves(evaluations: Evaluations, name: str, share: float) -> bool | None:
    metrics = evaluations.runs.get(name)
    return None if metrics is None else float(metrics["steady_satisfied_share"][0]) >= share


def min_se_sweep(plan: Plan, evaluations: Evaluations, out: Outputs) -> Analysis:
    """Fig. 3: R_e^tot against the required minimum SE for the policy and SoA, and the
    highest threshold each serves for every user (the policy's per evaluated policy: last,
    best), beside the oracle's."""
    experiment, analysis = plan.experiment, Analysis()
    spec = experiment.evaluation
    group = experiment.group(spec.policy)
    assert group.sweep is not None, "a min-se-sweep figure needs a swept group"
    values = sorted({run.sweep_value for run in plan.group_runs(group.name)})
    means, lows, highs, counts, xs = [], [], [], [], []
    served_runs: dict[str, list[int]] = {policy: [] for policy in spec.policies}
    soa_rates, soa_served, oracle_rates, oracle_served, rows = [], [], [], [], []
    for value in values:
        runs = _done_runs([r for r in plan.group_runs(group.name) if r.sweep_value == value])
        if not runs:
            continue
        r_e = np.array([[_last_mean(_curves(run)["sum_rate_bps"])] for run in runs])
        mean, low, high = band(r_e, experiment.figure.band)
        for policy in spec.policies:
            serves = [_serves(evaluations.of(policy), run.name, spec.served_share)
                      for run in runs]
            served_runs[policy].append(sum(ok for ok in serves if ok))
        soa = _baseline(evaluations, "soa", value, "mean_sum_rate_bps")
        soa_share = _baseline(evaluations, "soa", value, "steady_satisfied_share")
        oracle = _baseline(evaluations, "oracle", value, "mean_sum_rate_bps")
        oracle_share = _baseline(evaluations, "oracle", value, "steady_satisfied_share")
        xs.append(float(value))
        means.append(mean[0])
        lows.append(low[0])
        highs.append(high[0])
        counts.append(len(runs))
        soa_rates.append(soa)
        soa_served.append(soa_share is not None and soa_share >= spec.served_share)
        oracle_rates.append(oracle)
        oracle_served.append(oracle_share is not None and oracle_share >= spec.served_share)
        rows.append([value, mean[0], low[0], high[0], len(runs), served_runs[spec.policies[0]][-1],
                     soa, soa_served[-1], oracle])
    if not xs:
        analysis.notes.append("no run has finished: nothing to draw")
        return analysis
    served = {policy: _highest_served(xs, [2 * s >= c for s, c in zip(runs_served, counts,
                                                                     strict=True)])
              for policy, runs_served in served_runs.items()}
    soa_max = _highest_served(xs, soa_served)
    oracle_max = _highest_served(xs, oracle_served) if all(
        v is not None for v in oracle_rates) else None
    first = spec.policies[0]
    x = np.array(xs)
    series = [figures.Series(f"{group.title}", x, np.array(means), np.array(lows),
                             np.array(highs), min(counts))]
    if all(v is not None for v in soa_rates):
        flat = np.array(soa_rates, dtype=float)
        series.append(figures.Series("SoA", x, flat, flat, flat, 1))
    if all(v is not None for v in oracle_rates):
        flat = np.array(oracle_rates, dtype=float)
        series.append(figures.Series("oracle", x, flat, flat, flat, 1))
    scale, unit = rate_unit([float(np.max(s.high)) for s in series])
    figure = figures.min_se_sweep(series, {series[0].label: served[first],
                                           **({"SoA": soa_max} if len(series) > 1 else {})},
                                  title=_title(plan), ylabel=f"{figures.RATE_LABEL} ({unit})",
                                  scale=scale)
    _write_csv(out.csv,
               ["min_se", "policy_mean_bps", "policy_low_bps", "policy_high_bps", "runs",
                "runs_serving", "soa_bps", "soa_serves", "oracle_bps"], rows)
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
                f"{v:g}: {s}/{c}" for v, s, c in zip(xs, served_runs[policy], counts,
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


GAIN_QUANTITIES = (("beats_share", "beats_share_pct", 100), ("mean_improvement_pct",
                   "mean_gain_pct", 1), ("median_improvement_pct", "median_gain_pct", 1),
                   ("max_improvement_pct", "max_gain_pct", 1))


def _gain_pct(mine: Metrics, theirs: Metrics) -> np.ndarray:
    rate = theirs["mean_sum_rate_bps"]
    positive = rate > 0
    return 100 * (mine["mean_sum_rate_bps"][positive] - rate[positive]) / rate[positive]


def layout_gains(plan: Plan, evaluations: Evaluations, out: Outputs) -> Analysis:
    """Fig. 4: per-layout sum rate of the policy as a gain over each baseline and compared
    group (paired by seed), for every evaluated policy (last, best) and every group measured
    as the policy is (``evaluation.also``); the oracle's gain over the same methods is the
    reachable bound. A swept group gives each sweep value its own rows and curves, against
    the baselines at that value (and the compared group's run of the same seed and value,
    or of the same seed where the compared group has no sweep)."""
    experiment, analysis = plan.experiment, Analysis()
    spec = experiment.evaluation
    pooled: dict[str, list[np.ndarray]] = {}
    methods: dict[str, str] = {}  # the method of each of the policy's pooled labels
    rows: list[dict[str, Any]] = []
    baselines = [m for m in spec.baselines if m != "oracle"]
    labels = {m: f"vs {experiment.group(m).title if m in spec.compare_groups else NAMES[m]}"
              for m in (*baselines, *spec.compare_groups)}
    evaluated = [experiment.group(name) for name in (spec.policy, *spec.also)]
    key = next((g.sweep.key for g in evaluated if g.sweep is not None), None)
    for group in evaluated:
        others = [*baselines, *(spec.compare_groups if group.name == spec.policy else [])]
        for value in plan.sweep_values(group.name):
            oracle = evaluations.baselines.get(("oracle", value))
            at = "" if value is None else f", {_point(group, value)}"
            for policy in spec.policies:
                row = row_label(point_title(group, value), policy, spec.policies)
                measured = evaluations.of(policy)
                for run in plan.point_runs(group.name, value):
                    mine = measured.runs.get(run.name)
                    if mine is None:
                        continue
                    columns: dict[str, np.ndarray] = {"policy": mine["mean_sum_rate_bps"]}
                    for method in others:
                        if method in spec.compare_groups:
                            partner = plan.run(method, run.seed, run.sweep_value if
                                               experiment.group(method).sweep else None)
                            theirs = measured.runs.get(partner.name) if partner else None
                        else:
                            theirs = evaluations.baselines.get((method, value))
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
                            methods[labels[method] + at] = method
                            pooled.setdefault(labels[method] + at, []).append(
                                _gain_pct(mine, theirs))
                        elif method == "soa":
                            pooled.setdefault(f"{point_title(group, value)} vs SoA",
                                              []).append(_gain_pct(mine, theirs))
                    if oracle is not None:
                        ceiling = oracle["mean_sum_rate_bps"]
                        share = (mine["steady_sum_rate_bps"][ceiling > 0]
                                 / ceiling[ceiling > 0])
                        analysis.add(row, "steady_pct_of_oracle", float(100 * share.mean()),
                                     100.0)
                        columns["oracle"] = ceiling
                    point = {} if key is None else {key: "" if value is None else value}
                    for layout in range(len(mine["mean_sum_rate_bps"])):
                        rows.append({"group": group.name, **point, "policy": policy,
                                     "seed": run.seed, "layout": layout,
                                     **{f"{name}_bps": float(c[layout])
                                        for name, c in columns.items()}})
    if not pooled:
        analysis.notes.append("no policy run has been evaluated: nothing to draw")
        return analysis
    policy_group = experiment.group(spec.policy)
    for value in plan.sweep_values(spec.policy):
        soa = evaluations.baselines.get(("soa", value))
        oracle = evaluations.baselines.get(("oracle", value))
        if oracle is not None and soa is not None:
            at = "" if value is None else f", {_point(policy_group, value)}"
            pooled[f"oracle vs SoA (the reachable bound){at}"] = [_gain_pct(oracle, soa)]
    gains = {label: np.concatenate(g) for label, g in pooled.items()}
    summaries = {m: _paper_summary(plan, m) for m in labels}
    paper = {label: summaries[m] for label, m in methods.items() if summaries[m]}
    figure = figures.layout_gains(gains, title=_title(plan), paper=paper or None)
    header = list(dict.fromkeys(key for row in rows for key in row))
    _write_csv(out.csv, header,
               [[row.get(key, "") for key in header] for row in rows])
    values = plan.sweep_values(spec.policy)
    runs = max((len(plan.point_runs(spec.policy, v)) for v in values), default=0)
    per = "per group and sweep value" if policy_group.sweep is not None else "per group"
    analysis.notes.append(f"gains over {spec.layouts or 1} layout(s) for each of up to {runs} "
                          f"run(s) {per}; each run is compared with the compared group's run "
                          "of the same seed (and the same policy, last or best) and with the "
                          "baselines; the figure pools the runs' layouts of the last policies")
    analysis.files += out.save(figure)
    return analysis


UAV_COUNT_METHODS = (("soa", "SoA per UAV"), ("best-response", "best response"),
                     ("oma", "OMA (best found)"))


def _search_summary(metrics: Metrics) -> str:
    """'3 rounds, converged, 61.2 s per layout' of a search's eval metrics."""
    rounds, converged = metrics.get("search_rounds"), metrics.get("search_converged")
    seconds = metrics.get("search_seconds_per_layout")
    if rounds is None or converged is None:
        return "(no search record)"
    state = "converged" if bool(np.all(converged)) else (
        f"converged on {int(np.sum(converged))} of {len(converged)} layouts")
    text = f"{plural(int(np.max(rounds)), 'round')}, {state}"
    return text + (f", {float(seconds):.3g} s per layout (process time)" if seconds is not None
                   else "")


def uav_count(plan: Plan, evaluations: Evaluations, out: Outputs) -> Analysis:
    """E4: the greedy steady state of each group's policies (last, best; one group per number
    of UAVs U, on its own training layout) against SoA per UAV, best response and OMA, sum
    rate and fairness against U; the policy's share of best response, its gain over SoA,
    and NOMA's gain over OMA (best response over the best OMA configuration)."""
    experiment, analysis = plan.experiment, Analysis()
    spec = experiment.evaluation
    points: list[tuple[int, str]] = []
    for group in (spec.policy, *spec.also):
        runs = plan.group_runs(group)
        if runs:
            points.append((int(runs[0].config["uav"]["count"]), group))
    points.sort()
    bands = experiment.figure.band
    lines: dict[str, dict[str, list[tuple[float, float, float, int]]]] = {}
    xs: dict[str, list[float]] = {}
    csv_rows: list[list[Any]] = []

    def point(label: str, count: int, metric: str, values: list[float]) -> None:
        mean, low, high = band(np.array([[v] for v in values]), bands)
        lines.setdefault(label, {}).setdefault(metric, []).append(
            (float(mean[0]), float(low[0]), float(high[0]), len(values)))
        if metric == "sum_rate_bps":
            xs.setdefault(label, []).append(float(count))
        csv_rows.append([count, label, metric, float(mean[0]), float(low[0]), float(high[0]),
                         len(values)])

    for count, group in points:
        title = experiment.group(group).title
        base = {name: evaluations.baselines.get((name, group)) for name, _ in UAV_COUNT_METHODS}
        reference = base["best-response"]
        best_bps = float(np.mean(reference["mean_sum_rate_bps"])) if reference else None
        soa_bps = float(np.mean(base["soa"]["mean_sum_rate_bps"])) if base["soa"] else None
        for policy in spec.policies:
            measured = evaluations.of(policy)
            row = row_label(title, policy, spec.policies)
            rates, fairness = [], []
            for run in plan.group_runs(group):
                mine = measured.runs.get(run.name)
                if mine is None:
                    continue
                steady = float(np.mean(mine["steady_sum_rate_bps"]))
                rates.append(steady)
                fairness.append(float(np.mean(mine["fairness"])))
                analysis.add(row, "sum_rate_bps", steady, best_bps)
                analysis.add(row, "fairness", fairness[-1])
                if best_bps:
                    analysis.add(row, "pct_of_best_response", 100 * steady / best_bps, 100.0)
                if soa_bps:
                    analysis.add(row, "gain_vs_soa_pct", 100 * (steady - soa_bps) / soa_bps,
                                 100 * (best_bps - soa_bps) / soa_bps if best_bps else None)
            if rates:
                label = f"{experiment.group(spec.policy).title.split(',')[0]}, {policy} policy"
                point(label, count, "sum_rate_bps", rates)
                point(label, count, "fairness", fairness)
        for name, label in UAV_COUNT_METHODS:
            metrics = base[name]
            if metrics is None:
                continue
            point(label, count, "sum_rate_bps", [float(np.mean(metrics["mean_sum_rate_bps"]))])
            point(label, count, "fairness", [float(np.mean(metrics["fairness"]))])
        oma = base["oma"]
        if best_bps and oma is not None:
            oma_bps = float(np.mean(oma["mean_sum_rate_bps"]))
            row = f"best response, {plural(count, 'UAV')}"
            analysis.add(row, "noma_over_oma_pct", 100 * (best_bps - oma_bps) / oma_bps)
            analysis.add(row, "sum_rate_bps", best_bps)
        searches = [f"{label} {_search_summary(base[name])}"
                    for name, label in UAV_COUNT_METHODS[1:] if base[name] is not None]
        if searches:
            analysis.notes.append(f"{plural(count, 'UAV')}: " + "; ".join(searches))
    if not lines:
        analysis.notes.append("nothing has been evaluated: nothing to draw")
        return analysis
    series = {metric: [figures.Series(label, np.array(xs[label]),
                                      *(np.array([p[i] for p in values[metric]])
                                        for i in range(3)),
                                      min(p[3] for p in values[metric]))
                       for label, values in lines.items()]
              for metric in ("sum_rate_bps", "fairness")}
    scale, unit = rate_unit([float(np.max(line.high)) for line in series["sum_rate_bps"]])
    figure = figures.uav_count(series["sum_rate_bps"], series["fairness"], title=_title(plan),
                               ylabel=f"sum rate ({unit})", scale=scale)
    _write_csv(out.csv,
               ["uavs", "method", "metric", "mean", "low", "high", "runs"], csv_rows)
    analysis.notes.append(
        f"each group is one number of UAVs on its own training layout; a policy's value is the "
        f"mean of the last {min(100, spec.steps)} of {spec.steps} greedy steps (mean ± "
        "population standard "
        "deviation over its runs), the baselines hold their configuration; best response is "
        "our reference (each UAV in turn takes its best lattice point and power split with the "
        "others fixed, docs/model.md §9), not an optimum; its column 'reachable' is best "
        "response's own value")
    analysis.files += out.save(figure)
    return analysis


NAMES = {"soa": "SoA", "random": "random", "oracle": "oracle",
         "best-response": "best response", "oma": "OMA"}
PAPER_WORDS = {"beats_share_pct": "beats on", "mean_gain_pct": "mean",
               "median_gain_pct": "median", "max_gain_pct": "max"}


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
    by_value = {value: _done_runs([r for r in plan.group_runs(group.name)
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
                rate = _steady(measured, run, "steady_sum_rate_bps")
                eff = _steady(measured, run, "steady_energy_efficiency_bpj")
                if rate is None or eff is None:
                    continue
                rates.append(rate)
                effs.append(eff)
                analysis.add(row, "sum_rate_bps", rate)
                analysis.add(row, "energy_efficiency_bpj", eff)
                for name in ("still", "vertical"):
                    share = _steady(measured, run, f"steady_{name}_share")
                    if share is not None:
                        analysis.add(row, f"{name}_share_pct", 100 * share)
                base = unweighted.get(run.seed)
                base_rate = None if base is None else _steady(measured, base,
                                                              "steady_sum_rate_bps")
                base_eff = None if base is None else _steady(
                    measured, base, "steady_energy_efficiency_bpj")
                if base_rate and base_eff:  # paired by seed
                    analysis.add(row, "ee_ratio_vs_unweighted", eff / base_eff)
                    analysis.add(row, "sum_rate_pct_of_unweighted", 100 * rate / base_rate)
            if not rates:
                continue
            rate_band = band(np.array(rates)[:, None], experiment.figure.band)
            ee_band = band(np.array(effs)[:, None], experiment.figure.band)
            rate3 = (float(rate_band[0][0]), float(rate_band[1][0]), float(rate_band[2][0]))
            ee3 = (float(ee_band[0][0]), float(ee_band[1][0]), float(ee_band[2][0]))
            rows.append([value, policy, len(rates), *rate3, *ee3])
            if policy == first:
                points.append(FrontPoint(f"$w_e$ = {value:g}", ee3, rate3, len(rates)))
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
    if not points:
        analysis.notes.append("no run has finished: nothing to draw")
        return analysis
    figure = draw_energy_front(points, references, bound, title=_title(plan))
    _write_csv(out.csv,
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


def _paper_summary(plan: Plan, method: str) -> str:
    """'paper: beats on 67%, mean +39.11%, max +275.4%' from the claims about ``method``."""
    texts = [f"{PAPER_WORDS[c.quantity.removesuffix(f'_vs_{method}')]} {c.paper_text}"
             for c in plan.experiment.claims
             if c.quantity.endswith(f"_vs_{method}") and c.paper_text]
    return f"paper: {', '.join(texts)}" if texts else ""


ANALYSES: dict[str, Callable[[Plan, Evaluations, Outputs], Analysis]] = {
    "learning-curves": learning_curves, "min-se-sweep": min_se_sweep,
    "layout-gains": layout_gains, "uav-count": uav_count, "energy-front": energy_front}


def _title(plan: Plan) -> str:
    return plan.experiment.figure.title or plan.experiment.title


def _format(quantity: str, value: float) -> str:
    if quantity == "sum_rate_bps":
        return format_rate(value)
    if quantity == "fairness":
        return f"{value:.3f}"
    if "min_se" in quantity:
        return f"{value:g} bit/s/Hz"
    if quantity == "noma_over_oma_pct":
        return f"{value:+.1f}%"
    if quantity == "fairness_minus_soa":
        return f"{value:+.1f} points"
    if quantity.endswith("_bpj"):
        return f"{value / 1e6:.1f} Mbit/J"
    if "ratio" in quantity:
        return f"{value:.3f}x"
    if "gain" in quantity:
        return f"{value:+.1f}%"
    return f"{value:.1f}%"


def _ours(quantity: str, values: list[float]) -> tuple[str, str]:
    """'mean ± std (n = N)' and the per-run values."""
    finite = [v for v in values if math.isfinite(v)]
    if not finite:
        return "not measured", ""
    if len(finite) == 1:
        return _format(quantity, finite[0]), ""
    mean, std = float(np.mean(finite)), float(np.std(finite))
    if quantity == "sum_rate_bps":  # in the mean's unit: never '± 0.0 bit/s'
        scale, unit = rate_unit([mean])
        spread = f"{std / scale:.2f} {unit}"
    else:
        spread = _format(quantity, std).lstrip("+")
    per_run = ", ".join(_format(quantity, v) for v in finite)
    return f"{_format(quantity, mean)} ± {spread} (n = {len(finite)})", per_run


def command_line(plan: Plan) -> str:
    shipped = shipped_experiments()
    resolved = plan.experiment_path.resolve()
    name = next((key for key, path in shipped.items() if path.resolve() == resolved),
                str(plan.experiment_path))
    parts = ["adaptsky reproduce", name, "--out", str(plan.out)]
    for option in ("runs", "seeds", "episodes", "steps"):
        value = plan.shrink.get(option)
        if value is not None:
            parts += [f"--{option}", ",".join(map(str, value)) if isinstance(value, list)
                      else str(value)]
    for item in plan.set_values:
        parts += ["--set", item]
    return " ".join(parts)


def claims_table(claims: list[Claim], analysis: Analysis, reference: str = "oracle"
                 ) -> list[str]:
    """The rows of report.md's table: every claim, one row per measured policy (its group's
    last or best), the paper's number, ours, the ``reference``'s (the oracle's: the most any
    policy reaches; best response's for several UAVs)."""
    lines = [f"| claim | paper | policy | ours | reachable ({reference}) | per run |",
             "|---|---|---|---|---|---|"]
    for claim in claims:
        paper = claim.paper_text or (_format(claim.quantity, claim.paper)
                                     if claim.paper is not None else "-")
        rows = [row for row in analysis.rows
                if claim.quantity in analysis.quantities.get(row, {})] or ["-"]
        for index, row in enumerate(rows):
            values = analysis.quantities.get(row, {}).get(claim.quantity, [])
            ours, per_run = _ours(claim.quantity, values)
            per_run = analysis.details.get(row, {}).get(claim.quantity, per_run)
            bound = analysis.bounds.get(row, {}).get(claim.quantity, [])
            reachable = ("-" if not bound else _format(claim.quantity, bound[0])
                         if len(set(bound)) == 1 else _ours(claim.quantity, bound)[0])
            first = index == 0
            lines.append(f"| {claim.text if first else ''} | {paper if first else ''} | {row} | "
                         f"{ours} | {reachable} | {per_run or '-'} |")
    return lines


def beyond_reach(claims: list[Claim], analysis: Analysis, groups: dict[str, str]
                 ) -> list[str]:
    """A sentence for each claim whose paper number is above what the oracle reaches (every
    claimed quantity is better when higher); ``groups``: the compared groups' titles by id,
    for a bound that holds against our runs of that group."""
    notes = []
    for claim in claims:
        bounds = [v for row in analysis.rows[:1]
                  for v in analysis.bounds.get(row, {}).get(claim.quantity, [])]
        if claim.paper is None or not bounds:
            continue
        bound = float(np.mean(bounds))
        if claim.paper > bound + 1e-9:
            paper = claim.paper_text or _format(claim.quantity, claim.paper)
            against = next((title for name, title in groups.items()
                            if claim.quantity.endswith(f"_vs_{name}")), None)
            where = (f"against our runs of {against} (mean over the pairs)" if against
                     else "under this model")
            notes.append(f"{claim.text}: the paper's {paper} lies beyond the oracle's "
                         f"{_format(claim.quantity, bound)}, the most any policy reaches "
                         f"{where}; no policy can match it")
    return notes


@dataclass(frozen=True)
class WrittenReport:
    """report.md, every file written with it, and its claims table (for the index)."""

    path: Path
    files: list[Path]
    table: list[str]


def write_report(plan: Plan, evaluations: Evaluations, wall_s: float | None = None,
                 trained_in_calls: int = 0, figure_format: str = "png") -> WrittenReport:
    """Draw the figure (as ``figure_format``: png, pdf or svg), write its CSV and
    ``report.md`` into the plan's folder; ``wall_s``: the experiment's wall time so far (every
    call of ``reproduce`` on the folder), which trained ``trained_in_calls`` runs."""
    out, experiment = plan.out, plan.experiment
    analysis = ANALYSES[experiment.figure.kind](
        plan, evaluations, Outputs(out, experiment.id, figure_format))
    runs = plan.runs
    done = _done_runs(runs)
    first = runs[0].config["train"]
    lines = [f"# {experiment.title}", ""]
    if experiment.paper_figure:
        lines += [f"The paper's {experiment.paper_figure}, reproduced by adaptsky "
                  f"{__version__} on {utc_timestamp()}.", ""]
    lines += [f"- command: `{command_line(plan)}`",
              f"- runs: {len(done)} of {len(runs)} done, {first['episodes']} episodes x "
              f"{first['steps']} steps each; groups: " + ", ".join(
                  f"{g.title} ({len(plan.group_runs(g.name))})" for g in experiment.groups)]
    if wall_s is not None:
        calls = read_calls(out).rows
        untracked = len(done) - trained_in_calls
        lines.append(f"- wall time: {format_duration(wall_s)}, training, evaluation and "
                     f"report over {plural(len(calls) + 1, 'call')} of reproduce "
                     f"(`calls.json`), on {_machine(calls)}" + (
                         f"; {plural(untracked, 'run')} trained by calls not recorded there "
                         "(by an earlier version, or by train)" if untracked > 0 else ""))
    if experiment.scenario_note:
        lines.append(f"- scenario: {experiment.scenario_note}")
    lines.append("")
    if analysis.files:
        lines += [f"![{experiment.id}]({analysis.files[0].name})", "",
                  f"Plotted numbers: [{analysis.files[1].name}]({analysis.files[1].name}).", ""]
    per_group = experiment.figure.kind in PER_GROUP_KINDS
    table = claims_table(experiment.claims, analysis,
                         "best response" if per_group else "oracle")
    lines += [*table, ""]
    compared = {name: experiment.group(name).title
                for name in experiment.evaluation.compare_groups}
    notes = [*beyond_reach(experiment.claims, analysis, compared), *analysis.notes]
    notes += [f"left out: {name} ({why})" for name, why in evaluations.missing.items()]
    if evaluations.no_best:
        notes.append(f"best policy: {plural(len(evaluations.no_best), 'run')} had no greedy "
                     "evaluation during training (train.eval_every), so their best policy is "
                     f"their last: {', '.join(evaluations.no_best)}")
    if notes:
        lines += ["Notes:", "", *(f"- {note}" for note in notes), ""]
    lines += ["Runs are in `runs/` (one HDF5 run file each), evaluations in `evals/`. "
              f"R_e^tot and J_e are the means of the last {_window(first['episodes'])} "
              "per-episode means (docs/model.md, section 5); ours: mean ± population "
              "standard deviation (ddof = 0) over the runs; reachable: the same quantity "
              + ("for best response, our reference of several UAVs (docs/model.md, section "
                 "9)." if per_group else
                 "for the oracle, the best sum rate over every reachable position and power "
                 "split (docs/model.md, section 6)."), ""]
    report = out / "report.md"
    write_text_atomic(report, "\n".join(lines))
    return WrittenReport(report, [*analysis.files, report], table)


def _machine(calls: list[dict[str, Any]]) -> str:
    """This machine (the call being made), and how many others the earlier calls ran on."""
    here = f"{os.cpu_count()} cores ({platform.machine()})"
    others = {(c.get("platform"), c.get("cpu_count")) for c in calls} - {
        (platform.platform(), os.cpu_count())}
    return here + (f" and {plural(len(others), 'other machine')}" if others else "")


def write_index(folder: Path, results: list[Any], wall_s: float) -> Path:
    """``folder/report.md`` of ``reproduce all``: each experiment's report linked, its claims
    table, its wall time in this call and the total."""
    lines = ["# adaptsky reproduce all", "",
             f"Every shipped experiment, reproduced by adaptsky {__version__} on "
             f"{utc_timestamp()} on {os.cpu_count()} cores ({platform.platform()}).", "",
             f"- wall time of this call: {format_duration(wall_s)} in all", "",
             "| experiment | paper | runs done | wall time (this call) | report |",
             "|---|---|---|---|---|"]
    for result in results:
        plan = result.plan
        done = len(_done_runs(plan.runs))
        link = f"{plan.out.name}/report.md"
        lines.append(f"| {plan.experiment.title} | {plan.experiment.paper_figure or '-'} | "
                     f"{done}/{len(plan.runs)} | {format_duration(result.wall_s)} | "
                     f"[{link}]({link}) |")
    for result in results:
        lines += ["", f"## {result.plan.experiment.title}", "", *result.table]
    path = folder / "report.md"
    write_text_atomic(path, "\n".join(lines) + "\n")
    return path
