"""Summary of a run file: per seed R_e^tot and J_e (sec. V-C: means over the last 100
episodes, or over every episode of a shorter run) and, from format 3, the episodes' energy
and energy efficiency (docs/model.md §10), and their mean and population standard deviation
(ddof = 0) over seeds; per seed, each user's mean rate in its last stored episode."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from rich.table import Table

from adaptsky.report.evaluations import (
    curve_arrays,
    curve_json,
    curve_table,
    format_score,
    score_kind,
)
from adaptsky.store.run_file import RunReader
from adaptsky.units import format_rate, format_rate_spread, plural

LAST_EPISODES = 100
# per episode, J and bit/J (run files of format 3; None in older ones)
ENERGY_KEYS = ("energy_j", "energy_efficiency_bpj")
# per episode, the service metrics (format 4; None in older ones; docs/model.md §14)
SERVICE_KEYS = ("outage_share", "mean_least_rate_bps", "p5_rate_bps")


def summarize(path: Path) -> dict[str, Any]:
    """Everything ``adaptsky inspect`` shows, as JSON-able values."""
    with RunReader(path) as run:
        attrs, config, plugins, overrides = run.attrs, run.config, run.plugins, run.overrides
        seeds = []
        kind = score_kind(run.scenario)
        for seed in run.seeds:
            curves = run.episodes(seed)
            sizes = run.seed_attrs(seed)
            rates = curves["sum_rate_bps"][-LAST_EPISODES:]
            users = curves["mean_rate_bps"]
            fairness = curves["fairness"][-LAST_EPISODES:]
            energy = {key: float(curves[key][-LAST_EPISODES:].mean())
                      if key in curves and len(rates) else None
                      for key in (*ENERGY_KEYS, *SERVICE_KEYS)}
            best = run.best(seed) if run.has_checkpoint(seed) else None
            seeds.append({
                "seed": seed, "episodes_done": sizes["episodes_done"],
                "episodes_planned": sizes["episodes_planned"],
                "sum_rate_bps": float(rates.mean()) if len(rates) else None,
                "fairness": float(fairness.mean()) if len(fairness) else None,
                "episodes_averaged": len(rates), **energy,
                "last_episode_user_rate_bps": users[-1].tolist() if len(users) else None,
                "best": None if best is None else {"episode": int(best["episode"]),
                                                   "score": float(best["score"])},
                "evaluations": curve_json(run.evaluations(seed))})
    summary: dict[str, Any] = {
        "file": str(path), "scenario": config["name"], "format_version": attrs["format_version"],
        "adaptsky_version": attrs["adaptsky_version"], "created_utc": attrs["created_utc"],
        "channel_model": config["channel"]["model"], "plugins": plugins, "overrides": overrides,
        "steps_per_episode": config["train"]["steps"], "score_kind": kind, "seeds": seeds}
    for key in ("sum_rate_bps", "fairness", *ENERGY_KEYS, *SERVICE_KEYS):
        values = [s[key] for s in seeds if s[key] is not None]
        summary[key] = ({"mean": float(np.mean(values)), "std": float(np.std(values)),
                         "std_ddof": 0, "seeds": len(values)} if values else None)
    return summary


def _window(seeds: list[dict[str, Any]]) -> str:
    """Which episodes the per-seed means are over: 'last 100', 'last 7', 'last 7-100'."""
    counts = sorted({s["episodes_averaged"] for s in seeds if s["episodes_averaged"]})
    if not counts:
        return f"last {LAST_EPISODES}"
    return f"last {counts[0]}" if len(counts) == 1 else f"last {counts[0]}-{counts[-1]}"


def summary_table(summary: dict[str, Any]) -> Table:
    """A Rich table of :func:`summarize`'s result."""
    rate, fairness = summary["sum_rate_bps"], summary["fairness"]
    window = _window(summary["seeds"])
    caption = None
    if rate is not None and fairness is not None:
        caption = (f"per seed: means over its {window} episodes; all: mean ± population "
                   f"standard deviation over {plural(rate['seeds'], 'seed')}")
    greedy = any(s["best"] is not None for s in summary["seeds"])
    columns = ["seed", "episodes", f"R_e^tot ({window})", f"J_e ({window})"]
    if greedy:
        columns.append("best greedy (episode)")
        caption = (caption or "") + ("; best greedy: the best greedy evaluation during "
                                     "training, the policy eval uses by default")
    table = Table(*columns, title=f"{summary['scenario']} ({summary['channel_model']}, "
                                  f"{summary['steps_per_episode']} steps/episode)",
                  caption=caption)
    for s in summary["seeds"]:
        row = [str(s["seed"]), f"{s['episodes_done']}/{s['episodes_planned']}",
               format_rate(s["sum_rate_bps"]) if s["sum_rate_bps"] is not None else "-",
               f"{s['fairness']:.3f}" if s["fairness"] is not None else "-"]
        if greedy:
            best = s["best"]
            row.append("-" if best is None else
                       f"{format_score(best['score'], summary['score_kind'])} "
                       f"({best['episode']})")
        table.add_row(*row)
    if rate is not None and fairness is not None:
        table.add_section()
        table.add_row("all", plural(rate["seeds"], "seed"),
                      format_rate_spread(rate["mean"], rate["std"]),
                      f"{fairness['mean']:.3f} ± {fairness['std']:.3f}")
    return table


def energy_line(summary: dict[str, Any]) -> str | None:
    """The seeds' energy efficiency over their last episodes, bits over the UAVs' propulsion
    and transmit energy (docs/model.md §10), and its mean ± std over seeds; None for run
    files made before the energy."""
    efficiency = summary.get("energy_efficiency_bpj")
    if efficiency is None:
        return None
    seeds = ", ".join(f"seed {s['seed']} {s['energy_efficiency_bpj'] / 1e6:.1f}"
                      for s in summary["seeds"] if s.get("energy_efficiency_bpj") is not None)
    return (f"energy efficiency ({_window(summary['seeds'])} episodes), Mbit/J: {seeds}; "
            f"all {efficiency['mean'] / 1e6:.1f} ± {efficiency['std'] / 1e6:.1f}")


def service_line(summary: dict[str, Any]) -> str | None:
    """The service metrics over the seeds' last episodes (docs/model.md §14): mean ± std
    over seeds of the outage, the least user rate and the 5th percentile; None for run files
    made before them."""
    outage = summary.get("outage_share")
    if outage is None:
        return None
    least, low = summary["mean_least_rate_bps"], summary["p5_rate_bps"]
    return (f"service ({_window(summary['seeds'])} episodes, all seeds): outage "
            f"{100 * outage['mean']:.1f}% ± {100 * outage['std']:.1f}% of user-steps, least "
            f"user rate {format_rate_spread(least['mean'], least['std'])}, 5th percentile "
            f"{format_rate_spread(low['mean'], low['std'])}")


def curve_tables(summary: dict[str, Any], limit: int = 8) -> list[Table]:
    """Each seed's greedy evaluations during training (seeds without any: none)."""
    tables = []
    for s in summary["seeds"]:
        curve = curve_arrays(s["evaluations"])
        if len(curve["episode"]):
            best = s["best"]["episode"] if s["best"] is not None else None
            tables.append(curve_table(s["seed"], curve, best, limit))
    return tables
