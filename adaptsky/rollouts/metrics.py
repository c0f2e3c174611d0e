"""Per-layout metrics of a trace, and the comparison of a policy with other methods."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from adaptsky.rollouts.rollout import Trace
from adaptsky.scenario.models import Scenario
from adaptsky.sim.noma import jain_fairness

STEADY_STEPS = 100
# SoA gives a weak user exactly R_min; in floating point that lands within an ulp either side
MIN_RATE_TOLERANCE = 1e-9


def meets_min_rate(rate_bps: NDArray[np.float64], min_rate_bps: float) -> NDArray[np.bool_]:
    """Whether each rate meets R_min, up to a relative 1e-9 (rounding of exact ties)."""
    return rate_bps >= min_rate_bps * (1 - MIN_RATE_TOLERANCE)


def steady_user_rates(rate_bps: NDArray[np.float64]) -> NDArray[np.float64]:
    """(T, L, N) rates of every step, layout and user -> (L, N): each user's mean rate over the
    last 100 steps (the steady state; every step of a shorter rollout)."""
    return np.asarray(rate_bps)[-STEADY_STEPS:].mean(axis=0)


def layout_metrics(trace: Trace, bandwidth_hz: float, min_rate_bps: float
                   ) -> dict[str, NDArray[np.float64]]:
    """Per layout (L,): mean sum rate over the steps, over the last 100 steps (steady
    state), mean Jain index, the smallest user's mean spectral efficiency, the share of steps
    with every user at or above R_min (over all steps, and over the last 100); each user's
    steady-state rate (L, N); and the final UAV position (L, 3), or every UAV's (L, U, 3) for
    several UAVs."""
    sum_rate = trace.sum_rate_bps
    all_met = meets_min_rate(trace.rate_bps, min_rate_bps).all(axis=-1)
    return {
        "mean_sum_rate_bps": sum_rate.mean(axis=0),
        "steady_sum_rate_bps": sum_rate[-STEADY_STEPS:].mean(axis=0),
        "fairness": jain_fairness(trace.rate_bps).mean(axis=0),
        "min_user_se": (trace.rate_bps.mean(axis=0) / bandwidth_hz).min(axis=-1),
        "satisfied_share": all_met.mean(axis=0),
        "steady_satisfied_share": all_met[-STEADY_STEPS:].mean(axis=0),
        "steady_user_rate_bps": steady_user_rates(trace.rate_bps),
        "final_uav_m": trace.uav_m[-1],
    }


def percent_of(steady_bps: NDArray[np.float64], reference_bps: NDArray[np.float64]
               ) -> NDArray[np.float64]:
    """100 steady / reference per layout, NaN where the reference (the oracle for one UAV,
    best response for several) is NaN or 0 (no point meets R_min)."""
    positive = reference_bps > 0
    return np.where(positive, 100 * steady_bps / np.where(positive, reference_bps, 1.0),
                    np.nan)


def compare(policy: dict[str, NDArray], other: dict[str, NDArray]) -> dict[str, float]:
    """How the policy's mean sum rate compares with another method's over the layouts.

    improvement_pct = 100 (policy - other) / other per layout (layouts where the other
    method's rate is 0 are left out of the percentages).
    """
    mine, theirs = policy["mean_sum_rate_bps"], other["mean_sum_rate_bps"]
    positive = theirs > 0
    improvement = 100 * (mine[positive] - theirs[positive]) / theirs[positive]
    summary = {"beats_share": float(np.mean(mine > theirs))}
    for name, reduce in (("mean", np.mean), ("median", np.median), ("max", np.max)):
        summary[f"{name}_improvement_pct"] = float(reduce(improvement)) if len(improvement) \
            else float("nan")
    return summary


def summary_row(metrics: dict[str, NDArray]) -> dict[str, Any]:
    """Mean and median over layouts of the rates, mean of the rest."""
    rate = metrics["mean_sum_rate_bps"]
    return {"mean_sum_rate_bps": float(rate.mean()), "median_sum_rate_bps": float(np.median(rate)),
            "steady_sum_rate_bps": float(metrics["steady_sum_rate_bps"].mean()),
            "fairness": float(metrics["fairness"].mean()),
            "min_user_se": float(metrics["min_user_se"].mean()),
            "satisfied_share": float(metrics["satisfied_share"].mean())}


@dataclass
class Method:
    """One evaluated method: its trace and per-layout metrics."""

    name: str
    trace: Trace
    metrics: dict[str, np.ndarray]
    details: dict[str, Any]

    @classmethod
    def of(cls, name: str, scenario: Scenario, trace: Trace,
           details: dict[str, Any] | None = None) -> Method:
        metrics = layout_metrics(trace, scenario.radio.bandwidth_hz, scenario.min_rate_bps)
        return cls(name, trace, metrics, details or {})
