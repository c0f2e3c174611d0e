"""Statistics of results over runs (Agarwal, Schwarzer, Castro, Courville and Bellemare, "Deep
reinforcement learning at the edge of the statistical precipice", NeurIPS 2021;
docs/evaluation.md, "Statistics over runs"): the interquartile mean, stratified bootstrap
intervals, the probability of improvement and performance profiles.

Scores are arrays (runs, tasks): run i's normalised score on task m (a share of the task's
bound, in %, for adaptsky's results). One task is an array (runs,) or (runs, 1). A stratified
bootstrap resamples the runs of every task on its own, with replacement, as many as it has;
the intervals are the percentile ones. Every resample is drawn by one ``numpy`` generator
from ``seed``, so an interval is the same on every call.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

FloatArray = NDArray[np.float64]
REPS = 10_000        # bootstrap resamples
CONFIDENCE = 0.95


@dataclass(frozen=True)
class Interval:
    """An estimate and its percentile bootstrap interval [low, high]."""

    estimate: float
    low: float
    high: float


def as_scores(scores: ArrayLike) -> FloatArray:
    """``scores`` as (runs, tasks) floats; (runs,) is one task. A ValueError for an empty or
    non-finite array."""
    array = np.asarray(scores, dtype=np.float64)
    if array.ndim == 1:
        array = array[:, None]
    if array.ndim != 2 or array.size == 0:
        raise ValueError(f"scores must be (runs, tasks) or (runs,), got shape {array.shape}")
    if not np.isfinite(array).all():
        raise ValueError("scores must be finite")
    return array


def iqm(scores: ArrayLike) -> float:
    """The interquartile mean of every score: the mean of the middle half after sorting, the
    lowest and the highest quarter (floor(n / 4) scores each) left out, as
    ``scipy.stats.trim_mean(x, 0.25)``."""
    flat = np.sort(as_scores(scores), axis=None)
    cut = len(flat) // 4
    return float(flat[cut:len(flat) - cut].mean())


def resample_indices(runs: int, tasks: int, reps: int, rng: np.random.Generator
                     ) -> NDArray[np.int64]:
    """(reps, runs, tasks) run indices: for every resample and task, ``runs`` draws with
    replacement from that task's runs (stratified by task)."""
    return rng.integers(runs, size=(reps, runs, tasks))


def _resampled(scores: FloatArray, indices: NDArray[np.int64]) -> FloatArray:
    """The scores of every resample, (reps, runs, tasks)."""
    return np.take_along_axis(scores[None], indices, axis=1)


def _percentiles(values: FloatArray, confidence: float) -> tuple[float, float]:
    tail = 100 * (1 - confidence) / 2
    low, high = np.percentile(values, [tail, 100 - tail], axis=0)
    return float(low), float(high)


def bootstrap_interval(scores: ArrayLike, statistic: Callable[[FloatArray], float] = iqm,
                       reps: int = REPS, seed: int = 0, confidence: float = CONFIDENCE
                       ) -> Interval:
    """``statistic`` of the scores and its stratified bootstrap percentile interval."""
    array = as_scores(scores)
    rng = np.random.default_rng(seed)
    draws = _resampled(array, resample_indices(*array.shape, reps, rng))
    values = np.array([statistic(draw) for draw in draws])
    return Interval(float(statistic(array)), *_percentiles(values, confidence))


def _improvement(x: FloatArray, y: FloatArray) -> float:
    """P(X > Y): for each task the share of pairs (x_i, y_j) with x_i > y_j, ties counting a
    half (the Mann-Whitney U over N K), averaged over the tasks."""
    greater = (x[:, None, :] > y[None, :, :]).mean(axis=(0, 1))
    equal = (x[:, None, :] == y[None, :, :]).mean(axis=(0, 1))
    return float((greater + 0.5 * equal).mean())


def probability_of_improvement(x: ArrayLike, y: ArrayLike, reps: int = REPS, seed: int = 0,
                               confidence: float = CONFIDENCE) -> Interval:
    """The probability that a run of method X scores above a run of method Y on a task drawn
    uniformly, with its interval (the runs of X and of Y resampled per task, each on its own).
    X and Y need the same tasks, not the same number of runs."""
    a, b = as_scores(x), as_scores(y)
    if a.shape[1] != b.shape[1]:
        raise ValueError(f"X has {a.shape[1]} tasks and Y {b.shape[1]}: the same tasks needed")
    rng = np.random.default_rng(seed)
    xs = _resampled(a, resample_indices(*a.shape, reps, rng))
    ys = _resampled(b, resample_indices(*b.shape, reps, rng))
    values = np.array([_improvement(xr, yr) for xr, yr in zip(xs, ys, strict=True)])
    return Interval(_improvement(a, b), *_percentiles(values, confidence))


def _profile(scores: FloatArray, taus: FloatArray) -> FloatArray:
    """For each tau, the share of runs scoring above it, averaged over the tasks."""
    return (scores[None, :, :] > taus[:, None, None]).mean(axis=1).mean(axis=1)


def performance_profile(scores: ArrayLike, taus: ArrayLike, reps: int = REPS, seed: int = 0,
                        confidence: float = CONFIDENCE
                        ) -> tuple[FloatArray, FloatArray, FloatArray]:
    """The score distribution's tail (a performance profile): for every threshold tau the
    share of runs scoring above it (averaged over the tasks), with its pointwise interval;
    (profile, low, high), each shaped as ``taus``."""
    array, thresholds = as_scores(scores), np.asarray(taus, dtype=np.float64)
    rng = np.random.default_rng(seed)
    draws = _resampled(array, resample_indices(*array.shape, reps, rng))
    values = np.array([_profile(draw, thresholds) for draw in draws])
    tail = 100 * (1 - confidence) / 2
    low, high = np.percentile(values, [tail, 100 - tail], axis=0)
    return _profile(array, thresholds), low, high
