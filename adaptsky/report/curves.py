"""Learning-curve numbers for the figures: trailing means over episodes and bands over runs
(pure numpy, no I/O)."""

from __future__ import annotations

from typing import Literal

import numpy as np

LAST_EPISODES = 100

BandKind = Literal["std", "bootstrap"]
BAND_KINDS: tuple[BandKind, ...] = ("std", "bootstrap")


def curve_window(episodes: int) -> int:
    """Episodes in the trailing window of a plotted R_e^tot curve.

    The paper's R_e^tot (sec. V-C) is the mean over the last 100 of 1000 episodes, so a run of
    1000 episodes or more is smoothed over 100. A shorter run (a quick trial, a test) keeps the
    same one-tenth ratio, at least one episode, so its curve still has points to draw.
    """
    return min(LAST_EPISODES, max(1, episodes // 10))


def trailing_mean(values: np.ndarray, window: int) -> np.ndarray:
    """(..., E) -> (..., E - window + 1): entry e - window is the mean of episodes
    e - window + 1 .. e (1-based), for e = window .. E; float64 throughout."""
    values = np.asarray(values, dtype=np.float64)
    episodes = values.shape[-1]
    if not 1 <= window <= episodes:
        raise ValueError(f"window {window} is not within 1..{episodes} episodes")
    sums = np.cumsum(values, axis=-1)
    sums = np.concatenate([np.zeros((*values.shape[:-1], 1)), sums], axis=-1)
    return (sums[..., window:] - sums[..., :-window]) / window


def band(curves: np.ndarray, kind: BandKind, *, resamples: int = 2000,
         seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(R, X) curves of R runs -> (mean, low, high), each (X,).

    ``"std"``: the mean ± one standard deviation over runs (ddof = 0, the paper's band; zero
    width for one run). ``"bootstrap"``: the 95% percentile bootstrap interval of the mean over
    runs, from ``resamples`` resamplings of the runs with replacement drawn by
    ``numpy.random.default_rng(seed)``.
    """
    curves = np.asarray(curves, dtype=np.float64)
    if curves.ndim != 2:
        raise ValueError(f"curves must be (runs, points), not {curves.shape}")
    runs = curves.shape[0]
    if runs == 0:
        raise ValueError("no runs to draw a band over")
    mean = curves.mean(axis=0)
    if kind == "std":
        spread = curves.std(axis=0)
        return mean, mean - spread, mean + spread
    if kind == "bootstrap":
        rng = np.random.default_rng(seed)
        # how often each run is drawn in each resampling: the same law as drawing with
        # replacement, without a (resamples, R, X) array
        counts = rng.multinomial(runs, np.full(runs, 1.0 / runs), size=resamples)
        means = counts @ curves / runs
        low, high = np.percentile(means, [2.5, 97.5], axis=0)
        return mean, low, high
    raise ValueError(f"unknown band '{kind}'; choose from {', '.join(BAND_KINDS)}")


def gain_stats(gains_pct: np.ndarray) -> dict[str, float]:
    """Per-layout gains in % -> share of layouts with a gain > 0 (0..1), median and max gain
    in %."""
    gains_pct = np.asarray(gains_pct, dtype=np.float64)
    if gains_pct.size == 0:
        raise ValueError("no layouts")
    return {"share_positive": float(np.mean(gains_pct > 0)),
            "median_pct": float(np.median(gains_pct)), "max_pct": float(gains_pct.max())}
