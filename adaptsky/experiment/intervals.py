"""report.md's statistics over runs (docs/evaluation.md, "Statistics over runs"): for every
claim and measured policy with at least :data:`MIN_RUNS` runs, the interquartile mean with
its stratified bootstrap 95% interval, and the probability that a run of one policy scores
above a run of another, with its interval, for every pair of policies measured on the claim."""

from __future__ import annotations

import math
from itertools import permutations

from adaptsky.experiment.analysis import Analysis
from adaptsky.experiment.claims import format_quantity
from adaptsky.experiment.models import Claim
from adaptsky.report.statistics import bootstrap_interval, probability_of_improvement

MIN_RUNS = 3  # fewer: an interquartile mean is the median or the mean, and no interval


def _runs(analysis: Analysis, row: str, quantity: str) -> list[float]:
    values = analysis.quantities.get(row, {}).get(quantity, [])
    return [v for v in values if math.isfinite(v)]


def statistics_lines(claims: list[Claim], analysis: Analysis) -> list[str]:
    """The section's markdown lines (none where no policy has :data:`MIN_RUNS` runs)."""
    rows = ["| claim | policy | runs | IQM [95% interval] | P(above another policy) "
            "[95% interval] |", "|---|---|---|---|---|"]
    for claim in claims:
        measured = {row: _runs(analysis, row, claim.quantity) for row in analysis.rows}
        measured = {row: runs for row, runs in measured.items() if len(runs) >= MIN_RUNS}
        for index, (row, runs) in enumerate(measured.items()):
            interval = bootstrap_interval(runs)
            iqm = (f"{format_quantity(claim.quantity, interval.estimate)} "
                   f"[{format_quantity(claim.quantity, interval.low)}, "
                   f"{format_quantity(claim.quantity, interval.high)}]")
            better = [f"{other}: {p.estimate:.2f} [{p.low:.2f}, {p.high:.2f}]"
                      for this, other in permutations(measured, 2) if this == row
                      for p in [probability_of_improvement(runs, measured[other])]]
            rows.append(f"| {claim.text if index == 0 else ''} | {row} | {len(runs)} | {iqm} | "
                        f"{'; '.join(better) or '-'} |")
    if len(rows) == 2:
        return []
    return ["Statistics over runs (Agarwal et al. 2021): the interquartile mean (the mean of "
            "the middle half of the runs) with its 95% percentile bootstrap interval (10,000 "
            "resamples of the runs, seed 0), and for each pair of policies the probability that "
            "a run of the row's policy scores above a run of the other (ties count a half), "
            "with its interval. Rows of one group (its last and best policy) come from the same "
            "runs: their probability compares two policies of each run, not independent "
            "methods.", "", *rows, ""]
