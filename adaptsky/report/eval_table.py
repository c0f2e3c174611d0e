"""Rich tables of evaluation and baseline results."""

from __future__ import annotations

from typing import Any

from rich import box
from rich.table import Table

from adaptsky.units import rate_unit


def _pct(value: float | None) -> str:
    return "-" if value is None or value != value else f"{value:+.1f}"


def methods_table(results: dict[str, Any]) -> Table:
    """One row per method: rates over the layouts and, against the policy, who wins."""
    layouts, seed = results["layouts"], results["layout_seed"]
    where = "the scenario's layout" if layouts == 1 and seed is None else (
        f"{layouts} uniform layouts (layout seed {seed})")
    title = (f"{results['scenario']} on {where}: {results['steps']} steps, "
             f"LoS {results['los']}, min SE {results['min_se']} bit/s/Hz")
    comparison = results.get("comparison")
    summaries = {name: entry["summary"] for name, entry in results["methods"].items()}
    scale, unit = rate_unit([s["mean_sum_rate_bps"] for s in summaries.values()])
    columns = ["method", "mean", "median", "steady", "Jain", "sat."]
    caption = ("sum rates in {unit}: mean and median over layouts of the mean over steps; "
               "steady: the last 100 steps; sat.: steps with every user at min SE or above")
    if comparison is not None:
        columns += ["wins", "gain%", "med%", "max%"]
        caption += ("; wins: layouts where the policy's mean sum rate is higher; gain%: the "
                    "policy's improvement over the method, mean, median and max over layouts, "
                    "of the mean over steps (the policy's flight from its start counted)")
    table = Table(*columns, title=title, caption=caption.format(unit=unit), box=box.SIMPLE_HEAD,
                  pad_edge=False, collapse_padding=True)
    # numbers are never cut; a long label (a run file's path) folds onto more lines instead
    # of being cut to an ellipsis, where two runs' labels would read the same
    table.columns[0].overflow = "fold"
    for column in table.columns[1:]:
        column.no_wrap = True
    for name, s in summaries.items():
        row = [name] + [f"{s[key] / scale:.2f}" for key in (
            "mean_sum_rate_bps", "median_sum_rate_bps", "steady_sum_rate_bps")] + [
            f"{s['fairness']:.3f}", f"{100 * s['satisfied_share']:.0f}%"]
        if comparison is not None:
            versus = comparison.get(name)
            row += ["-"] * 4 if versus is None else [
                f"{100 * versus['beats_share']:.0f}%",
                *(_pct(versus[f"{k}_improvement_pct"]) for k in ("mean", "median", "max"))]
        table.add_row(*row)
    return table


def note_lines(results: dict[str, Any]) -> list[str]:
    """One line per method whose results say what it is where that is not obvious (best
    response and OMA under sampled LoS: searched on the expected gains)."""
    return [f"{name}: {entry['note']}" for name, entry in results["methods"].items()
            if entry.get("note")]


def search_time(entry: dict[str, Any]) -> str | None:
    """'0.26 s per step' (the per-step searches, users that move) or '2.10 s per layout' of a
    method's results, or None where they hold no time."""
    for key, unit in (("seconds_per_step", "step"), ("seconds_per_layout", "layout")):
        seconds = entry.get(key)
        if seconds is not None and seconds == seconds:
            return f"{seconds:.2f} s per {unit}"
    return None


def search_lines(results: dict[str, Any]) -> list[str]:
    """One line per search with rounds (best response, OMA): its rounds, the layouts where it
    converged (its last round gained less than 1e-9 relative) and its time."""
    lines = []
    for name, entry in results["methods"].items():
        search = entry.get("search")
        if search is None:
            continue
        rounds, converged = search["rounds"], search["converged"]
        seconds = search_time(entry)
        lines.append(f"{name}: {sum(rounds) / len(rounds):.1f} rounds per layout on average "
                     f"(at most {max(rounds)}), converged on {sum(converged)} of "
                     f"{len(converged)} layouts" + (f"; {seconds}" if seconds else ""))
    return lines


def energy_lines(results: dict[str, Any]) -> list[str]:
    """One line per method with its energy (docs/model.md §10): the energy efficiency and
    mean power of all UAVs over the last 100 steps, and the share of moves that stay in
    place and that change height (methods measured before the energy: none)."""
    lines = []
    for name, entry in results["methods"].items():
        s = entry["summary"]
        if "steady_energy_efficiency_bpj" not in s:
            continue
        lines.append(f"{name}: {s['steady_energy_efficiency_bpj'] / 1e6:.1f} Mbit/J, "
                     f"{s['steady_power_w']:.1f} W; moves: {100 * s['steady_still_share']:.0f}% "
                     f"stay, {100 * s['steady_vertical_share']:.0f}% change height "
                     "(last 100 steps)")
    return lines


def service_lines(results: dict[str, Any]) -> list[str]:
    """One line per method with its service metrics (docs/model.md §14): the share of
    user-steps in outage, the mean least user rate and the 5th percentile of the user rates
    (methods measured before them: none)."""
    lines = []
    for name, entry in results["methods"].items():
        s = entry["summary"]
        if "outage_share" not in s:
            continue
        lines.append(f"{name}: outage {100 * s['outage_share']:.1f}% of user-steps, least "
                     f"user rate {s['mean_least_rate_bps'] / 1e6:.2f} Mbit/s, 5th percentile "
                     f"{s['p5_rate_bps'] / 1e6:.2f} Mbit/s")
    return lines


REFERENCES = {"oracle": "the oracle", "best-response": "best response"}
"""What the policy's steady state is a share of, as the results key it: the oracle (one UAV),
else best response (several UAVs' reference)."""


def oracle_line(results: dict[str, Any]) -> str | None:
    """The policy's steady-state sum rate as a share of the oracle's, or of best response's
    without the oracle, if it was compared."""
    for method, words in REFERENCES.items():
        share = results.get(f"policy_steady_pct_of_{method.replace('-', '_')}")
        if share is None:
            continue
        seconds = search_time(results["methods"][method])
        return (f"policy steady state: {share['mean']:.1f}% of {words} on average "
                f"(median {share['median']:.1f}%)"
                + (f"; {method} search {seconds}" if seconds else ""))
    return None
