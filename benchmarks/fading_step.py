"""What the built-in small-scale fading costs a step (issue 37, docs/model.md §11): environment
steps per second with ``channel.fading`` rician (and ``correlation = 0.9``) against the same
scenario without fading, at B = 256 and B = 1024 batched environments, for one UAV
(scenarios/nyc_mmwave.toml) and two UAVs (scenarios/two_uavs_mmwave.toml). PASS where a step
with fading takes at most 1.3 x the time of one without (time ratio <= 1.3).

    .venv/bin/python benchmarks/fading_step.py [--seconds 1] [--rounds 5] [--envs 256,1024]

As benchmarks/one_simulator.py: per-environment seeds (as training makes them), random dense
actions, one BLAS and one torch thread, every figure the best of ``--rounds`` blocks of CPU
time (``time.process_time``) of about ``--seconds`` each, the two sides' blocks alternating
(without, with, with, without, ...) so that drift in the machine's speed hits both alike.
Prints the load average before and after; exits 1 where a verdict is FAIL. A script, not a
test: no time is asserted anywhere.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))   # benchmarks/stepping.py
from stepping import pin_one_thread, random_steps

ROOT = Path(__file__).resolve().parents[1]
SCENARIOS = {"one UAV (nyc_mmwave)": ROOT / "scenarios" / "nyc_mmwave.toml",
             "two UAVs (two_uavs_mmwave)": ROOT / "scenarios" / "two_uavs_mmwave.toml"}
FADING = {"model": "rician", "correlation": 0.9}
THRESHOLD = 1.3          # time of a step with fading over one without, at most


def stepper(path: Path, num_envs: int, fading: dict[str, object] | None
            ) -> tuple[Callable[[int], None], float]:
    """``step(count)`` of ``num_envs`` environments of the scenario at ``path`` (with
    ``channel.fading`` set to ``fading`` where given, and no time limit), warmed up, and its
    calibrated steps per CPU second."""
    from adaptsky.scenario import load_scenario
    from adaptsky.sim.network import NetworkBatch

    scenario = load_scenario(path)
    updates: dict[str, object] = {"train": scenario.train.model_copy(update={"steps": 10**9})}
    if fading is not None:
        data = scenario.model_dump()
        data["channel"]["fading"] = fading
        scenario = type(scenario).model_validate(data)
        updates["train"] = scenario.train.model_copy(update={"steps": 10**9})
    scenario = scenario.model_copy(update=updates)
    env = NetworkBatch(scenario, num_envs,
                       seed=[np.random.SeedSequence([s, 0]) for s in range(num_envs)])
    assert env.actions is not None
    return random_steps(env, num_envs)


def block(step: Callable[[int], None], count: int) -> float:
    """Seconds of CPU time per batched step over ``count`` steps."""
    start = time.process_time()
    step(count)
    return (time.process_time() - start) / count


def measure(path: Path, num_envs: int, seconds: float, rounds: int
            ) -> tuple[float, float, float]:
    """(steps/s without fading, steps/s with, time ratio with/without): each the best of
    ``rounds`` alternating blocks."""
    without, rate = stepper(path, num_envs, None)
    with_fading, _ = stepper(path, num_envs, FADING)
    count = max(1, round(rate * seconds))
    times: dict[str, list[float]] = {"without": [], "with": []}
    for index in range(rounds):
        order = (("without", without), ("with", with_fading))
        for name, step in order if index % 2 == 0 else order[::-1]:
            times[name].append(block(step, count))
    best_without, best_with = min(times["without"]), min(times["with"])
    return 1 / best_without, 1 / best_with, best_with / best_without


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=1.0)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--envs", default="256,1024")
    args = parser.parse_args(argv)
    pin_one_thread()
    print(f"load average before: {os.getloadavg()[0]:.2f}; fading {FADING}, PASS: time ratio "
          f"<= {THRESHOLD}; best of {args.rounds} blocks of about {args.seconds:g} s CPU")
    print(f"{'scenario':<28} {'B':>5} {'steps/s none':>13} {'steps/s fading':>15} "
          f"{'ratio':>6}  verdict")
    failed = False
    for label, path in SCENARIOS.items():
        for num_envs in (int(value) for value in args.envs.split(",")):
            plain, faded, ratio = measure(path, num_envs, args.seconds, args.rounds)
            verdict = "PASS" if ratio <= THRESHOLD else "FAIL"
            failed |= verdict == "FAIL"
            print(f"{label:<28} {num_envs:>5} {plain:>13.1f} {faded:>15.1f} {ratio:>6.3f}  "
                  f"{verdict}", flush=True)
    print(f"load average after: {os.getloadavg()[0]:.2f}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
