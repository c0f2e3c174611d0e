"""What the bounds for users that move cost (docs/model.md §6 and §9): process seconds per step
of the per-step oracle (one UAV) and of best response at every step (two and four UAVs), on
the moving-user scenarios; PASS where four UAVs take at most 1 s per step.

    .venv/bin/python benchmarks/per_step_bounds.py [--steps 20]

One BLAS thread; the first step (from SoA, several rounds) is counted with the others, as an
evaluation of ``--steps`` steps pays it. A script, not a test: no time is asserted anywhere.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from stepping import pin_one_thread  # noqa: E402

from adaptsky.rollouts.genie import per_step_oracle  # noqa: E402
from adaptsky.rollouts.step_response import per_step_response  # noqa: E402
from adaptsky.scenario import load_scenario  # noqa: E402
from adaptsky.scenario.variants import with_values  # noqa: E402
from adaptsky.sim.network import NetworkBatch  # noqa: E402

WAYPOINT = {"model": "random-waypoint", "speed_min_mps": 0.5, "speed_max_mps": 2.0,
            "pause_max_s": 30.0}
LIMIT_S = 1.0            # four UAVs, per step


def cases() -> list[tuple[str, object]]:
    four = with_values(load_scenario(ROOT / "scenarios" / "four_uavs_mmwave.toml"), "users",
                       {"mobility": WAYPOINT}, "four UAVs, random waypoint")
    return [("moving_users_sub6.toml (1 UAV, per-step oracle)",
             load_scenario(ROOT / "scenarios" / "moving_users_sub6.toml")),
            ("two_uavs_moving_mmwave.toml (2 UAVs, best response)",
             load_scenario(ROOT / "scenarios" / "two_uavs_moving_mmwave.toml")),
            ("four_uavs_mmwave.toml + random waypoint (4 UAVs, best response)", four)]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=20)
    args = parser.parse_args()
    pin_one_thread()
    print("| scenario | steps | s per step | verdict (4 UAVs <= 1 s) |")
    print("|---|---|---|---|")
    failed = False
    for name, scenario in cases():
        users_m = NetworkBatch(scenario, 1).users_m
        start = time.process_time()
        if scenario.uav.count == 1:
            per_step_oracle(scenario, users_m, args.steps)
        else:
            per_step_response(scenario, users_m, args.steps)
        seconds = (time.process_time() - start) / args.steps
        verdict = "-"
        if scenario.uav.count == 4:
            verdict = "PASS" if seconds <= LIMIT_S else "FAIL"
            failed |= verdict == "FAIL"
        print(f"| {name} | {args.steps} | {seconds:.3f} | {verdict} |", flush=True)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
