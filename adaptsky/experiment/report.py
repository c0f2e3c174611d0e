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
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from adaptsky import __version__
from adaptsky.experiment.evaluation import Evaluations
from adaptsky.experiment.plan import Plan, RunSpec, shipped_experiments
from adaptsky.report import figures
from adaptsky.report.curves import LAST_EPISODES, band, curve_window
from adaptsky.report.plot_runs import BAND_NOTES, curve_series, write_curves_csv
from adaptsky.rollouts.metrics import compare
from adaptsky.store.atomic import utc_timestamp, write_text_atomic
from adaptsky.store.run_file import RunReader
from adaptsky.units import format_rate, rate_unit


@dataclass
class Analysis:
    """What one figure kind measured: per quantity a list of per-run values (or one value),
    notes for the report, and the files written."""

    quantities: dict[str, list[float]] = field(default_factory=dict)
    details: dict[str, str] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    files: list[Path] = field(default_factory=list)


def _done_runs(runs: list[RunSpec]) -> list[RunSpec]:
    from adaptsky.experiment.runs import run_state  # imports torch: only when reporting

    return [run for run in runs if run_state(run).status == "done"]


def _curves(run: RunSpec) -> dict[str, np.ndarray]:
    with RunReader(run.path, needs="curves") as reader:
        return reader.episodes(run.seed)


def _last_mean(values: np.ndarray) -> float:
    """R_e^tot or J_e: the mean of the last 100 episodes' values (all, for shorter runs)."""
    return float(np.mean(values[-LAST_EPISODES:]))


def _write_csv(path: Path, header: list[str], rows: list[list[Any]]) -> None:
    text = io.StringIO()
    writer = csv.writer(text, lineterminator="\n")
    writer.writerow(header)
    writer.writerows(rows)
    write_text_atomic(path, text.getvalue())


def _baseline(evaluations: Evaluations, name: str, value: Any, metric: str) -> float | None:
    metrics = evaluations.baselines.get((name, value))
    return None if metrics is None else float(np.mean(metrics[metric]))


def learning_curves(plan: Plan, evaluations: Evaluations, out: Path) -> Analysis:
    """Fig. 2: R_e^tot against the episode per group, SoA level, oracle ceiling, J_e."""
    experiment, analysis = plan.experiment, Analysis()
    group = experiment.evaluation.policy
    runs = _done_runs(plan.group_runs(group))
    if not runs:
        analysis.notes.append(f"no run of '{group}' has finished: nothing to draw")
        return analysis
    curves = [_curves(run) for run in runs]
    rates = [c["sum_rate_bps"] for c in curves]
    window = curve_window(min(len(r) for r in rates))
    series = curve_series(experiment.group(group).title, rates, window, experiment.figure.band)
    soa = _baseline(evaluations, "soa", None, "mean_sum_rate_bps")
    soa_j = _baseline(evaluations, "soa", None, "fairness")
    oracle = _baseline(evaluations, "oracle", None, "mean_sum_rate_bps")
    r_e = [_last_mean(r) for r in rates]
    j_e = [_last_mean(c["fairness"]) for c in curves]
    analysis.quantities["sum_rate_bps"] = r_e
    analysis.quantities["fairness"] = j_e
    if soa:
        analysis.quantities["gain_vs_soa_pct"] = [100 * (r - soa) / soa for r in r_e]
    if soa_j is not None:
        analysis.quantities["fairness_minus_soa"] = [100 * (j - soa_j) for j in j_e]
    if oracle:
        analysis.quantities["pct_of_oracle"] = [100 * r / oracle for r in r_e]
    levels = [figures.Level(label, value, style) for label, value, style in
              (("SoA", soa, "--"), ("oracle (best reachable)", oracle, ":"))
              if value is not None]
    scale, unit = rate_unit([float(series.high.max()), *(lv.value for lv in levels)])
    j_last = [float(np.mean(c["fairness"][-window:])) for c in curves]
    note = (f"J_e at the last episode: {np.mean(j_last):.3f} ± {np.std(j_last):.3f}"
            + (f"; SoA {soa_j:.3f}" if soa_j is not None else "")
            + f"\ntrailing mean over {window} episodes; band: "
            f"{BAND_NOTES[experiment.figure.band]}")
    png = out / f"{experiment.id}.png"
    figures.learning_curves(png, [series], levels, title=_title(plan),
                            ylabel=f"R_e^tot ({unit})", scale=scale, note=note)
    write_curves_csv(out / f"{experiment.id}.csv", [series])
    if soa is not None:
        analysis.notes.append(f"SoA on the training layout: {format_rate(soa)}, J = "
                              f"{soa_j:.3f} (evaluated over {experiment.evaluation.steps} steps)")
    if oracle is not None:
        analysis.notes.append(f"oracle (best sum rate over every reachable position and "
                              f"power split): {format_rate(oracle)}")
    analysis.files += [png, out / f"{experiment.id}.csv"]
    return analysis


def _highest_served(values: list[Any], served: list[bool]) -> float | None:
    below = [v for v, ok in zip(values, served, strict=True) if ok]
    return max(below) if below else None


def min_se_sweep(plan: Plan, evaluations: Evaluations, out: Path) -> Analysis:
    """Fig. 3: R_e^tot against the required minimum SE for the policy and SoA, and the
    highest threshold each serves for every user."""
    experiment, analysis = plan.experiment, Analysis()
    spec = experiment.evaluation
    group = experiment.group(spec.policy)
    assert group.sweep is not None, "a min-se-sweep figure needs a swept group"
    values = sorted({run.sweep_value for run in plan.group_runs(group.name)})
    means, lows, highs, counts, served_runs, xs = [], [], [], [], [], []
    per_seed: dict[int, list[bool]] = {}
    soa_rates, soa_served, oracle_rates, rows = [], [], [], []
    for value in values:
        runs = _done_runs([r for r in plan.group_runs(group.name) if r.sweep_value == value])
        if not runs:
            continue
        r_e = np.array([[_last_mean(_curves(run)["sum_rate_bps"])] for run in runs])
        mean, low, high = band(r_e, experiment.figure.band)
        serves = [float(evaluations.runs[run.name]["steady_satisfied_share"][0])
                  >= spec.served_share for run in runs if run.name in evaluations.runs]
        for run, ok in zip(runs, serves, strict=False):
            per_seed.setdefault(run.seed, []).append(ok)
        soa = _baseline(evaluations, "soa", value, "mean_sum_rate_bps")
        soa_share = _baseline(evaluations, "soa", value, "steady_satisfied_share")
        oracle = _baseline(evaluations, "oracle", value, "mean_sum_rate_bps")
        xs.append(float(value))
        means.append(mean[0])
        lows.append(low[0])
        highs.append(high[0])
        counts.append(len(runs))
        served_runs.append(sum(serves))
        soa_rates.append(soa)
        soa_served.append(soa_share is not None and soa_share >= spec.served_share)
        oracle_rates.append(oracle)
        rows.append([value, mean[0], low[0], high[0], len(runs), sum(serves), soa,
                     soa_served[-1], oracle])
    if not xs:
        analysis.notes.append("no run has finished: nothing to draw")
        return analysis
    policy_served = _highest_served(xs, [2 * s >= c for s, c in zip(served_runs, counts,
                                                                     strict=True)])
    soa_max = _highest_served(xs, soa_served)
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
    png = out / f"{experiment.id}.png"
    figures.min_se_sweep(png, series, {series[0].label: policy_served,
                                       **({"SoA": soa_max} if len(series) > 1 else {})},
                         title=_title(plan), ylabel=f"R_e^tot ({unit})", scale=scale)
    _write_csv(out / f"{experiment.id}.csv",
               ["min_se", "policy_mean_bps", "policy_low_bps", "policy_high_bps", "runs",
                "runs_serving", "soa_bps", "soa_serves", "oracle_bps"], rows)
    analysis.quantities["max_min_se_served"] = [] if policy_served is None else [policy_served]
    analysis.quantities["soa_max_min_se_served"] = [] if soa_max is None else [soa_max]
    analysis.details["max_min_se_served"] = "runs serving each threshold: " + ", ".join(
        f"{v:g}: {s}/{c}" for v, s, c in zip(xs, served_runs, counts, strict=True))
    analysis.notes.append(
        f"a run serves a threshold when its greedy policy (1000 steps on the training layout) "
        f"keeps every user at or above R_min in at least {100 * spec.served_share:.0f}% of "
        "its last 100 steps; the policy serves it when at least half of its runs do")
    analysis.files += [png, out / f"{experiment.id}.csv"]
    return analysis


def layout_gains(plan: Plan, evaluations: Evaluations, out: Path) -> Analysis:
    """Fig. 4: per-layout sum rate of the policy as a gain over each baseline and compared
    group (paired by seed)."""
    experiment, analysis = plan.experiment, Analysis()
    spec = experiment.evaluation
    gains: dict[str, list[np.ndarray]] = {}
    rows: list[list[Any]] = []
    others = [m for m in (*spec.baselines, *spec.compare_groups) if m != "oracle"]
    oracle = evaluations.baselines.get(("oracle", None))
    for run in plan.group_runs(spec.policy):
        mine = evaluations.runs.get(run.name)
        if mine is None:
            continue
        columns: dict[str, np.ndarray] = {"policy": mine["mean_sum_rate_bps"]}
        for method in others:
            if method in spec.compare_groups:
                partner = plan.run(method, run.seed, run.sweep_value)
                theirs = evaluations.runs.get(partner.name) if partner else None
            else:
                theirs = evaluations.baselines.get((method, None))
            if theirs is None:
                continue
            rate = theirs["mean_sum_rate_bps"]
            columns[method] = rate
            result = compare(mine, theirs)
            for key, name in (("beats_share", "beats_share_pct"),
                              ("mean_improvement_pct", "mean_gain_pct"),
                              ("median_improvement_pct", "median_gain_pct"),
                              ("max_improvement_pct", "max_gain_pct")):
                scale = 100 if key == "beats_share" else 1
                analysis.quantities.setdefault(f"{name}_vs_{method}", []).append(
                    scale * result[key])
            positive = rate > 0
            gains.setdefault(method, []).append(
                100 * (mine["mean_sum_rate_bps"][positive] - rate[positive]) / rate[positive])
        if oracle is not None:
            ceiling = oracle["mean_sum_rate_bps"]
            share = mine["steady_sum_rate_bps"][ceiling > 0] / ceiling[ceiling > 0]
            analysis.quantities.setdefault("steady_pct_of_oracle", []).append(
                float(100 * share.mean()))
            columns["oracle"] = ceiling
        for layout in range(len(mine["mean_sum_rate_bps"])):
            rows.append([run.seed, layout, *(float(c[layout]) for c in columns.values())])
        header = ["seed", "layout", *(f"{name}_bps" for name in columns)]
    if not gains:
        analysis.notes.append("no policy run has been evaluated: nothing to draw")
        return analysis
    labels = {m: f"vs {experiment.group(m).title if m in spec.compare_groups else NAMES[m]}"
              for m in gains}
    pooled = {labels[m]: np.concatenate(g) for m, g in gains.items()}
    paper = {labels[m]: text for m in gains if (text := _paper_summary(plan, m))}
    png = out / f"{experiment.id}.png"
    figures.layout_gains(png, pooled, title=_title(plan), paper=paper or None)
    _write_csv(out / f"{experiment.id}.csv", header, rows)
    runs = len(next(iter(gains.values())))
    analysis.notes.append(f"gains pooled over {runs} policy run(s) x "
                          f"{spec.layouts or 1} layout(s); each run is compared with the "
                          "compared group's run of the same seed")
    analysis.files += [png, out / f"{experiment.id}.csv"]
    return analysis


NAMES = {"soa": "SoA", "random": "random", "oracle": "oracle"}
PAPER_WORDS = {"beats_share_pct": "beats on", "mean_gain_pct": "mean",
               "median_gain_pct": "median", "max_gain_pct": "max"}


def _paper_summary(plan: Plan, method: str) -> str:
    """'paper: beats on 67%, mean +39.11%, max +275.4%' from the claims about ``method``."""
    texts = [f"{PAPER_WORDS[c.quantity.removesuffix(f'_vs_{method}')]} {c.paper_text}"
             for c in plan.experiment.claims
             if c.quantity.endswith(f"_vs_{method}") and c.paper_text]
    return f"paper: {', '.join(texts)}" if texts else ""


ANALYSES: dict[str, Callable[[Plan, Evaluations, Path], Analysis]] = {
    "learning-curves": learning_curves, "min-se-sweep": min_se_sweep,
    "layout-gains": layout_gains}


def _title(plan: Plan) -> str:
    return plan.experiment.figure.title or plan.experiment.title


def _format(quantity: str, value: float) -> str:
    if quantity == "sum_rate_bps":
        return format_rate(value)
    if quantity == "fairness":
        return f"{value:.3f}"
    if "min_se" in quantity:
        return f"{value:g} bit/s/Hz"
    if quantity == "fairness_minus_soa":
        return f"{value:+.1f} points"
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
    for option in ("seeds", "episodes", "steps"):
        if plan.shrink.get(option) is not None:
            parts += [f"--{option}", str(plan.shrink[option])]
    for item in plan.set_values:
        parts += ["--set", item]
    return " ".join(parts)


def write_report(plan: Plan, evaluations: Evaluations) -> tuple[Path, list[Path]]:
    """Draw the figure, write its CSV and ``report.md`` into the plan's folder."""
    out, experiment = plan.out, plan.experiment
    analysis = ANALYSES[experiment.figure.kind](plan, evaluations, out)
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
    if experiment.scenario_note:
        lines.append(f"- scenario: {experiment.scenario_note}")
    lines.append("")
    if analysis.files:
        lines += [f"![{experiment.id}]({analysis.files[0].name})", "",
                  f"Plotted numbers: [{analysis.files[1].name}]({analysis.files[1].name}).", ""]
    lines += ["| claim | paper | ours | per run |", "|---|---|---|---|"]
    for claim in experiment.claims:
        values = analysis.quantities.get(claim.quantity, [])
        ours, per_run = _ours(claim.quantity, values)
        per_run = analysis.details.get(claim.quantity, per_run)
        paper = claim.paper_text or (_format(claim.quantity, claim.paper)
                                     if claim.paper is not None else "-")
        lines.append(f"| {claim.text} | {paper} | {ours} | {per_run or '-'} |")
    lines.append("")
    notes = list(analysis.notes)
    notes += [f"left out: {name} ({why})" for name, why in evaluations.missing.items()]
    if notes:
        lines += ["Notes:", "", *(f"- {note}" for note in notes), ""]
    lines += ["Runs are in `runs/` (one HDF5 run file each), evaluations in `evals/`. "
              "R_e^tot and J_e are the means of the last 100 episodes' per-episode means "
              "(docs/model.md, section 5); ours: mean ± population standard deviation "
              "(ddof = 0) over the runs.", ""]
    report = out / "report.md"
    write_text_atomic(report, "\n".join(lines))
    return report, [*analysis.files, report]
