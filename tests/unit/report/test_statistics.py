"""Statistics over runs (docs/evaluation.md, "Statistics over runs") against examples worked
by hand, plain loops written from the definitions, and scipy on the same data."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from adaptsky.report.statistics import (
    Interval,
    bootstrap_interval,
    iqm,
    performance_profile,
    probability_of_improvement,
)


def test_iqm_leaves_out_the_lowest_and_highest_quarter():
    assert iqm([4.0, 1.0, 3.0, 2.0]) == 2.5                       # mean of 2 and 3
    assert iqm(np.arange(1.0, 9.0)) == 4.5                        # mean of 3, 4, 5, 6
    assert iqm([[1.0, 100.0], [2.0, 7.0], [3.0, -50.0]]) == 3.25   # 1, 2, 3, 7 of six
    data = np.random.default_rng(3).normal(size=(7, 3))
    assert iqm(data) == pytest.approx(stats.trim_mean(data, 0.25, axis=None), abs=1e-12)


def test_bootstrap_interval_is_the_plain_loops_stratified_percentiles():
    scores = np.array([[90.0, 50.0], [95.0, 60.0], [99.0, 55.0], [80.0, 70.0], [85.0, 65.0]])
    found = bootstrap_interval(scores, reps=500, seed=7)
    # the same draws by a plain loop: per resample, per task, five runs with replacement
    rng = np.random.default_rng(7)
    indices = rng.integers(5, size=(500, 5, 2))
    values = []
    for draw in indices:
        resampled = [[scores[draw[i, m], m] for m in range(2)] for i in range(5)]
        flat = sorted(v for row in resampled for v in row)
        values.append(np.mean(flat[2:8]))                          # 10 scores: cut 2 each end
    low, high = np.percentile(values, [2.5, 97.5])
    assert found == Interval(iqm(scores), low, high)
    assert found.estimate == pytest.approx(np.mean([60.0, 65.0, 70.0, 80.0, 85.0, 90.0]))
    assert found.low < found.estimate < found.high


def test_bootstrap_interval_agrees_with_scipy_on_one_task():
    scores = np.random.default_rng(11).normal(80.0, 5.0, size=12)
    ours = bootstrap_interval(scores, reps=20_000, seed=0)
    # (a statistic with an ``axis`` scipy takes vectorised: the same resamples and interval
    # as one call per resample, in a hundredth of a second rather than eight seconds)
    theirs = stats.bootstrap((scores,), lambda x, axis: stats.trim_mean(x, 0.25, axis=axis),
                             n_resamples=20_000, method="percentile",
                             random_state=np.random.default_rng(1))
    # two independent sets of 20,000 resamples: the percentiles agree to their noise
    assert ours.low == pytest.approx(theirs.confidence_interval.low, abs=0.25)
    assert ours.high == pytest.approx(theirs.confidence_interval.high, abs=0.25)


def test_probability_of_improvement_by_hand_and_as_mann_whitney():
    x, y = [1.0, 2.0, 3.0], [2.0, 2.0, 0.0]
    # pairs above: (1,0), (2,0), (3,2), (3,2), (3,0); ties (2,2) twice count a half: 6 of 9
    found = probability_of_improvement(x, y, reps=200)
    assert found.estimate == pytest.approx(6 / 9)
    u = stats.mannwhitneyu(x, y).statistic
    assert found.estimate == pytest.approx(u / 9)
    # two tasks: the mean of the tasks' probabilities; X better everywhere gives 1
    assert probability_of_improvement([[5.0, 1.0], [6.0, 2.0]],
                                      [[1.0, 1.0], [2.0, 3.0]], reps=10).estimate == \
        pytest.approx((1.0 + (0.5 + 0 + 1 + 0) / 4) / 2)
    assert probability_of_improvement([9.0, 8.0], [1.0, 2.0, 3.0], reps=100) == \
        Interval(1.0, 1.0, 1.0)
    with pytest.raises(ValueError, match="the same tasks"):
        probability_of_improvement(np.ones((3, 2)), np.ones((3, 1)))


def test_performance_profile_is_the_share_above_each_threshold():
    scores = np.array([[90.0, 40.0], [95.0, 60.0], [99.0, 80.0], [70.0, 100.0]])
    profile, low, high = performance_profile(scores, [50.0, 85.0, 99.0], reps=300, seed=2)
    # task 1: 4/4, 3/4, 0/4 above; task 2: 3/4, 1/4, 1/4 above
    np.testing.assert_allclose(profile, [(1 + 0.75) / 2, (0.75 + 0.25) / 2, (0 + 0.25) / 2])
    assert (low <= profile).all() and (profile <= high).all()
    assert low[-1] == 0.0 and high[0] == 1.0


def test_bad_scores_are_refused():
    with pytest.raises(ValueError, match="finite"):
        iqm([1.0, np.nan])
    with pytest.raises(ValueError, match="shape"):
        iqm(np.ones((2, 2, 2)))
