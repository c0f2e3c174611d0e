"""SoA, random and the oracle on a scenario's training layout with adaptsky's Euclidean
UAV-user distance and with the released code's |dx| + |dy| + h (docs/model.md, section 7),
the elevation kept: how much of a gap between the paper's numbers and ours the distance
convention can explain (REPRODUCTION.md, why the numbers differ).

    python scripts/released_code_distance.py scenarios/sub6_al_hourani_released_code.toml

A one-off measurement: it replaces the geometry's distance inside this process only.
"""

from __future__ import annotations

import argparse

import numpy as np

from adaptsky.channels import contract
from adaptsky.evaluation.api import eval_layouts, run_baseline
from adaptsky.scenario.loading import load_scenario

EUCLIDEAN = contract.LinkGeometry._from_offsets.__func__


def released_code_distance(cls, dx_m, dy_m, height_m, user_height_m, *rest):
    """The geometry with the released code's distance |dx| + |dy| + (h - h_UT)."""
    geometry = EUCLIDEAN(cls, dx_m, dy_m, height_m, user_height_m, *rest)
    above = height_m - user_height_m
    geometry.__dict__["distance_m"] = np.abs(dx_m) + np.abs(dy_m) + np.abs(above)
    return geometry


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenario")
    parser.add_argument("--steps", type=int, default=1000)
    args = parser.parse_args()
    scenario = load_scenario(args.scenario)
    users_m = eval_layouts(scenario, None)
    print(f"{'distance':<14} {'method':<7} {'sum rate':>14} {'Jain':>6}")
    for label in ("euclidean", "released code"):
        if label == "released code":
            contract.LinkGeometry._from_offsets = classmethod(released_code_distance)
        for method in ("soa", "random", "oracle"):
            metrics = run_baseline(scenario, method, args.steps, users_m).metrics
            rate = float(np.mean(metrics["mean_sum_rate_bps"])) / 1e6
            print(f"{label:<14} {method:<7} {rate:>9.2f} Mbit/s "
                  f"{float(np.mean(metrics['fairness'])):>6.3f}")


if __name__ == "__main__":
    main()
