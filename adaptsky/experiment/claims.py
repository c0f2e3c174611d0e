"""The claims table of report.md: the paper's number, ours and the reachable bound per claim
and measured policy, and the claims no policy can match."""

from __future__ import annotations

import math

import numpy as np

from adaptsky.experiment.analysis import Analysis
from adaptsky.experiment.models import Claim
from adaptsky.units import format_rate, rate_unit


def format_quantity(quantity: str, value: float) -> str:
    """``value`` of ``quantity`` as report.md writes it: '12.34 Gbit/s', '+12.5%', '0.871'."""
    if quantity in ("sum_rate_bps", "least_rate_bps"):
        return format_rate(value)
    if quantity == "fairness":
        return f"{value:.3f}"
    if "min_se" in quantity:
        return f"{value:g} bit/s/Hz"
    if quantity in ("noma_over_oma_pct", "bound_over_oma_pct"):
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
        return format_quantity(quantity, finite[0]), ""
    mean, std = float(np.mean(finite)), float(np.std(finite))
    if quantity == "sum_rate_bps":  # in the mean's unit: never '± 0.0 bit/s'
        scale, unit = rate_unit([mean])
        spread = f"{std / scale:.2f} {unit}"
    else:
        spread = format_quantity(quantity, std).lstrip("+")
    per_run = ", ".join(format_quantity(quantity, v) for v in finite)
    return f"{format_quantity(quantity, mean)} ± {spread} (n = {len(finite)})", per_run


def claims_table(claims: list[Claim], analysis: Analysis, reference: str = "oracle"
                 ) -> list[str]:
    """The rows of report.md's table: every claim, one row per measured policy (its group's
    last or best), the paper's number, ours, the ``reference``'s (the oracle's: the most any
    policy reaches; best response's for several UAVs)."""
    lines = [f"| claim | paper | policy | ours | reachable ({reference}) | per run |",
             "|---|---|---|---|---|---|"]
    for claim in claims:
        paper = claim.paper_text or (format_quantity(claim.quantity, claim.paper)
                                     if claim.paper is not None else "-")
        rows = [row for row in analysis.rows
                if claim.quantity in analysis.quantities.get(row, {})] or ["-"]
        for index, row in enumerate(rows):
            values = analysis.quantities.get(row, {}).get(claim.quantity, [])
            ours, per_run = _ours(claim.quantity, values)
            per_run = analysis.details.get(row, {}).get(claim.quantity, per_run)
            bound = analysis.bounds.get(row, {}).get(claim.quantity, [])
            reachable = ("-" if not bound else format_quantity(claim.quantity, bound[0])
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
            paper = claim.paper_text or format_quantity(claim.quantity, claim.paper)
            against = next((title for name, title in groups.items()
                            if claim.quantity.endswith(f"_vs_{name}")), None)
            where = (f"against our runs of {against} (mean over the pairs)" if against
                     else "under this model")
            notes.append(f"{claim.text}: the paper's {paper} lies beyond the oracle's "
                         f"{format_quantity(claim.quantity, bound)}, the most any policy reaches "
                         f"{where}; no policy can match it")
    return notes
