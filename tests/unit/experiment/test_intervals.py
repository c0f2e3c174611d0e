"""report.md's statistics over runs: interquartile means, intervals and probabilities of
improvement worked by hand."""

from adaptsky.experiment.analysis import Analysis
from adaptsky.experiment.intervals import statistics_lines
from adaptsky.experiment.models import Claim


def _analysis(rows: dict[str, list[float]]) -> Analysis:
    analysis = Analysis()
    for row, values in rows.items():
        for value in values:
            analysis.add(row, "pct_of_bound", value)
    return analysis


CLAIM = [Claim(text="share of the oracle", quantity="pct_of_bound")]


def test_iqm_and_probability_of_improvement_by_hand():
    # A = 1, 2, 3, 4: the middle half 2, 3 -> IQM 2.5. B = 0, 0, 0, 5 -> IQM 0.
    # P(A > B): of the 16 pairs, every a beats the three zeros (12) and none beats 5 -> 0.75;
    # P(B > A): the 5 beats all four a (4 of 16) -> 0.25.
    lines = statistics_lines(CLAIM, _analysis({"A": [1, 2, 3, 4], "B": [0, 0, 0, 5]}))
    table = [line for line in lines if line.startswith("| share")
             or line.startswith("|  | B")]
    first, second = table
    assert first.startswith("| share of the oracle | A | 4 | 2.5% [")
    assert "B: 0.75 [" in first
    assert second.startswith("|  | B | 4 | 0.0% [") and "A: 0.25 [" in second


def test_interval_brackets_the_estimate_and_few_runs_are_left_out():
    lines = statistics_lines(CLAIM, _analysis({"A": [90.0, 95.0, 97.0, 99.0, 99.5, 100.0],
                                               "B": [80.0, 81.0]}))
    (row,) = [line for line in lines if line.startswith("| share")]
    cells = [cell.strip() for cell in row.split("|")]
    estimate, interval = cells[4].split(" [")
    low, high = (float(v.rstrip("%]")) for v in interval.split(", "))
    # IQM of six: floor(6 / 4) = 1 left out each side -> mean(95, 97, 99, 99.5) = 97.625
    assert estimate == "97.6%" and low <= 97.625 <= high and high <= 100.0
    assert cells[5] == "-"  # B has two runs: no comparison, no row
    assert statistics_lines(CLAIM, _analysis({"B": [80.0, 81.0]})) == []
