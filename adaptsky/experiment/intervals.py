"""report.md's statistics over runs (docs/evaluation.md, "Statistics over runs"): for every
claim and measured policy with at least :data:`MIN_RUNS` runs, the interquartile mean with
its stratified bootstrap 95% interval, and the probability that a run of one policy scores
above a run of another, with its interval, for every pair of policies measured on the claim
that the report compares: of other groups, of the same kind (last or best) and panel."""

from __future__ import annotations

import math
from collections.abc import Callable
from itertools import permutations

from adaptsky.experiment.analysis import Analysis
from adaptsky.experiment.claims import format_quantity
from adaptsky.experiment.models import Claim
from adaptsky.report.statistics import bootstrap_interval, probability_of_improvement

MIN_RUNS = 3  # fewer: an interquartile mean is the median or the mean, and no interval


def _runs(analysis: Analysis, row: str, quantity: str) -> list[float]:
    values = analysis.quantities.get(row, {}).get(quantity, [])
    return [v for v in values if math.isfinite(v)]


def statistics_lines(claims: list[Claim], analysis: Analysis,
                     compared: Callable[[str, str], bool] = lambda a, b: True) -> list[str]:
    """The section's markdown lines (none where no policy has :data:`MIN_RUNS` runs);
    ``compared(row, other)``: whether the row's probability of improvement over ``other`` is
    given."""
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
                      for this, other in permutations(measured, 2)
                      if this == row and compared(row, other)
                      for p in [probability_of_improvement(runs, measured[other])]]
            rows.append(f"| {claim.text if index == 0 else ''} | {row} | {len(runs)} | {iqm} | "
                        f"{'; '.join(better) or '-'} |")
    if len(rows) == 2:
        return []
    return ["Statistics over runs (Agarwal et al. 2021): the interquartile mean (the mean of "
            "the middle half of the runs) with its 95% percentile bootstrap interval (10,000 "
            "resamples of the runs, seed 0), and the probability that a run of the row's policy "
            "scores above a run of another group's policy of the same kind (last or best; in a "
            "figure of panels, of the same panel), ties counting a half, with its interval.",
            "", *rows, ""]
