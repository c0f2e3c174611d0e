"""What buildings cost a step (docs/model.md §12): environment steps per second at B = 256 of
two and four UAVs (scenarios/two_uavs_mmwave.toml, four_uavs_mmwave.toml) in a generated
urban city with geometric LoS, against the same scenario without buildings; PASS where the
step with buildings costs at most 2x the step without (steps/s with >= 0.5 x without).

    .venv/bin/python benchmarks/city_step.py [--seconds 1] [--rounds 3] [--envs 256]

Both sides run in this process, their timed blocks alternated (without, with, with, without,
...), so that drift in the machine's speed hits both alike; every figure is the best of
``--rounds`` blocks of CPU time (``time.process_time``, one BLAS and torch thread), random
dense actions, per-environment seeds. Exits 1 where a verdict is FAIL. A script, not a test:
no time is asserted anywhere.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from stepping import pin_one_thread  # noqa: E402

from adaptsky.scenario import load_scenario  # noqa: E402
from adaptsky.sim.network import NetworkBatch  # noqa: E402

SCENARIOS = (ROOT / "scenarios" / "two_uavs_mmwave.toml",
             ROOT / "scenarios" / "four_uavs_mmwave.toml")
THRESHOLD = 0.5          # steps/s with buildings over steps/s without
CITY = {"buildings": "generated", "city": "urban"}


def environments(path: Path, num_envs: int, city: bool) -> NetworkBatch:
    """B environments of the scenario at ``path`` (endless episodes), with or without the
    urban city and geometric LoS."""
    scenario = load_scenario(path)
    update = {"train": scenario.train.model_copy(update={"steps": 10**9})}
    if city:
        update["world"] = scenario.world.model_validate(CITY)
        update["channel"] = scenario.channel.model_copy(update={"los": "geometric"})
    scenario = scenario.model_copy(update=update)
    env = NetworkBatch(scenario, num_envs,
                       seed=[np.random.SeedSequence([s, 0]) for s in range(num_envs)])
    env.reset()
    return env


def block(env: NetworkBatch, actions: np.ndarray, seconds: float) -> float:
    """Batched steps per CPU second over one block of about ``seconds``."""
    count, start = 0, time.process_time()
    while (elapsed := time.process_time() - start) < seconds:
        env.step(actions[count % len(actions)])
        count += 1
    return count / elapsed


def measure(path: Path, num_envs: int, seconds: float, rounds: int) -> tuple[float, float]:
    """The best steps/s without and with buildings."""
    sides = [environments(path, num_envs, city) for city in (False, True)]
    assert sides[0].actions is not None
    actions = np.random.default_rng(0).integers(0, sides[0].actions.count, size=(64, num_envs))
    best = [0.0, 0.0]
    for round_ in range(rounds):
        order = (0, 1) if round_ % 2 == 0 else (1, 0)
        for side in order:
            best[side] = max(best[side], block(sides[side], actions, seconds))
    return best[0], best[1]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=1.0)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--envs", type=int, default=256)
    args = parser.parse_args()
    pin_one_thread()
    print(f"load average before: {os.getloadavg()[0]:.2f}")
    print("| scenario | B | steps/s without buildings | steps/s urban city, geometric LoS | "
          "with / without | verdict (>= 0.5) |")
    print("|---|---|---|---|---|---|")
    failed = False
    for path in SCENARIOS:
        without, with_city = measure(path, args.envs, args.seconds, args.rounds)
        ratio = with_city / without
        verdict = "PASS" if ratio >= THRESHOLD else "FAIL"
        failed |= verdict == "FAIL"
        print(f"| {path.name} | {args.envs} | {without:.1f} | {with_city:.1f} | {ratio:.3f} | "
              f"{verdict} |")
    print(f"load average after: {os.getloadavg()[0]:.2f}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
