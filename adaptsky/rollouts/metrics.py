"""Per-layout metrics of a trace, and the comparison of a policy with other methods."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from adaptsky.rollouts.rollout import Trace
from adaptsky.scenario.models import DEFAULT_OUTAGE_SE, Scenario
from adaptsky.sim.energy import energy_efficiency_bpj
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


def motion_shares(uav_m: NDArray[np.float64]) -> dict[str, NDArray[np.float64]]:
    """Per layout, over the last 100 moves of every UAV (positions (T, L, 3) or (T, L, U,
    3)): the share in which a UAV stayed where it was horizontally, and the share in which
    it changed its height (how a policy flies; docs/model.md §10). A trace of one step is a
    held configuration (the baselines): it stays, always."""
    moves = np.diff(uav_m[-STEADY_STEPS - 1:], axis=0)          # (T', L, [U,] 3)
    if not len(moves):
        layouts = uav_m.shape[1]
        return {"steady_still_share": np.ones(layouts),
                "steady_vertical_share": np.zeros(layouts)}
    still = (moves[..., 0] == 0) & (moves[..., 1] == 0)
    vertical = moves[..., 2] != 0
    axes = (0, 2) if moves.ndim == 4 else 0                      # steps (and UAVs)
    return {"steady_still_share": still.mean(axis=axes),
            "steady_vertical_share": vertical.mean(axis=axes)}


def energy_metrics(trace: Trace, step_s: float) -> dict[str, NDArray[np.float64]]:
    """Per layout (L,): the energy of all steps and UAVs (J), the mean power over the last
    100 steps (W, all UAVs), the energy efficiency over all steps and over the last 100
    (bit/J) and :func:`motion_shares`; for several UAVs also each UAV's energy (L, U)."""
    per_uav = trace.energy_j
    energy = per_uav if per_uav.ndim == 2 else per_uav.sum(axis=-1)        # (T, L)
    sum_rate = trace.sum_rate_bps
    metrics = {
        "energy_j": energy.sum(axis=0),
        "steady_power_w": energy[-STEADY_STEPS:].mean(axis=0) / step_s,
        "energy_efficiency_bpj": energy_efficiency_bpj(sum_rate, energy, step_s),
        "steady_energy_efficiency_bpj": energy_efficiency_bpj(
            sum_rate[-STEADY_STEPS:], energy[-STEADY_STEPS:], step_s),
    } | motion_shares(trace.uav_m)
    if per_uav.ndim == 3:
        metrics["uav_energy_j"] = per_uav.sum(axis=0)
    return metrics


SERVICE_PERCENTILE = 5.0
"""The low percentile of the user rates the service metrics report (docs/model.md §14)."""


def service_metrics(rate_bps: NDArray[np.float64], bandwidth_hz: float, outage_se: float
                    ) -> dict[str, NDArray[np.float64]]:
    """Per layout (L,) from the rates (T, L, N) (docs/model.md §14): the share of user-steps
    whose spectral efficiency R / W lies below ``outage_se`` (outage), the mean over the
    steps of the least user rate, and the 5th percentile of the user rates over the
    user-steps (numpy's linear interpolation between order statistics)."""
    rates = np.asarray(rate_bps, dtype=np.float64)
    user_steps = np.moveaxis(rates, 1, 0).reshape(rates.shape[1], -1)     # (L, T N)
    return {"outage_share": (rates / bandwidth_hz < outage_se).mean(axis=(0, 2)),
            "mean_least_rate_bps": rates.min(axis=2).mean(axis=0),
            "p5_rate_bps": np.percentile(user_steps, SERVICE_PERCENTILE, axis=1)}


def layout_metrics(trace: Trace, bandwidth_hz: float, min_rate_bps: float,
                   step_s: float = 1.0, outage_se: float = DEFAULT_OUTAGE_SE
                   ) -> dict[str, NDArray[np.float64]]:
    """Per layout (L,): mean sum rate over the steps, over the last 100 steps (steady
    state), mean Jain index, the smallest user's mean spectral efficiency, the share of steps
    with every user at or above R_min (over all steps, and over the last 100); each user's
    steady-state rate (L, N); the final UAV position (L, 3), or every UAV's (L, U, 3) for
    several UAVs; the energy of :func:`energy_metrics` with steps of ``step_s`` seconds; and
    the service metrics of :func:`service_metrics` (outage below ``outage_se``)."""
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
    } | energy_metrics(trace, step_s) | service_metrics(trace.rate_bps, bandwidth_hz, outage_se)


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


ENERGY_SUMMARY = ("energy_j", "steady_power_w", "energy_efficiency_bpj",
                  "steady_energy_efficiency_bpj", "steady_still_share", "steady_vertical_share")
"""The energy metrics a summary row averages over layouts (where the metrics have them)."""
SERVICE_SUMMARY = ("outage_share", "mean_least_rate_bps", "p5_rate_bps")
"""The service metrics a summary row averages over layouts (where the metrics have them:
eval files before them lack them)."""


def summary_row(metrics: dict[str, NDArray]) -> dict[str, Any]:
    """Mean and median over layouts of the rates, mean of the rest (and of the energy
    metrics, where measured: eval files before the energy lack them)."""
    rate = metrics["mean_sum_rate_bps"]
    row = {"mean_sum_rate_bps": float(rate.mean()), "median_sum_rate_bps": float(np.median(rate)),
           "steady_sum_rate_bps": float(metrics["steady_sum_rate_bps"].mean()),
           "fairness": float(metrics["fairness"].mean()),
           "min_user_se": float(metrics["min_user_se"].mean()),
           "satisfied_share": float(metrics["satisfied_share"].mean())}
    return row | {key: float(np.mean(metrics[key])) for key in (*ENERGY_SUMMARY, *SERVICE_SUMMARY)
                  if key in metrics}


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
        metrics = layout_metrics(trace, scenario.radio.bandwidth_hz, scenario.min_rate_bps,
                                 scenario.uav.step_s, scenario.metrics.outage_se)
        return cls(name, trace, metrics, details or {})
