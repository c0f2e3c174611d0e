"""Summary of a run file: per seed R_e^tot and J_e (sec. V-C: means over the last 100
episodes), and their mean and standard deviation over seeds."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from rich.table import Table

from adaptsky_cli.report.units import format_rate
from adaptsky_cli.store.run_file import RunReader

LAST_EPISODES = 100


def summarize(path: Path) -> dict[str, Any]:
    """Everything ``adaptsky inspect`` shows, as JSON-able values."""
    with RunReader(path) as run:
        attrs, config, plugins, overrides = run.attrs, run.config, run.plugins, run.overrides
        seeds = []
        for seed in run.seeds:
            run.require_checkpoint(seed)
            curves = run.episodes(seed)
            sizes = run.seed_attrs(seed)
            rates = curves["sum_rate_bps"][-LAST_EPISODES:]
            fairness = curves["fairness"][-LAST_EPISODES:]
            seeds.append({
                "seed": seed, "episodes_done": sizes["episodes_done"],
                "episodes_planned": sizes["episodes_planned"],
                "sum_rate_bps": float(rates.mean()) if len(rates) else None,
                "fairness": float(fairness.mean()) if len(fairness) else None,
                "episodes_averaged": len(rates)})
    summary: dict[str, Any] = {
        "file": str(path), "scenario": config["name"], "format_version": attrs["format_version"],
        "adaptsky_version": attrs["adaptsky_version"], "created_utc": attrs["created_utc"],
        "channel_model": config["channel"]["model"], "plugins": plugins, "overrides": overrides,
        "steps_per_episode": config["train"]["steps"], "seeds": seeds}
    for key in ("sum_rate_bps", "fairness"):
        values = [s[key] for s in seeds if s[key] is not None]
        summary[key] = ({"mean": float(np.mean(values)), "std": float(np.std(values)),
                         "seeds": len(values)} if values else None)
    return summary


def summary_table(summary: dict[str, Any]) -> Table:
    """A Rich table of :func:`summarize`'s result."""
    table = Table("seed", "episodes", "R_e^tot (last 100)", "J_e (last 100)",
                  title=f"{summary['scenario']} ({summary['channel_model']}, "
                        f"{summary['steps_per_episode']} steps/episode)")
    for s in summary["seeds"]:
        table.add_row(str(s["seed"]), f"{s['episodes_done']}/{s['episodes_planned']}",
                      format_rate(s["sum_rate_bps"]) if s["sum_rate_bps"] is not None else "-",
                      f"{s['fairness']:.3f}" if s["fairness"] is not None else "-")
    rate, fairness = summary["sum_rate_bps"], summary["fairness"]
    if rate is not None and fairness is not None:
        table.add_section()
        table.add_row("all", f"{rate['seeds']} seeds",
                      f"{format_rate(rate['mean'])} ± {format_rate(rate['std'])}",
                      f"{fairness['mean']:.3f} ± {fairness['std']:.3f}")
    return table
